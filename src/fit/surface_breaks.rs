//! Choosing the span breaks of a surface fit.
//!
//! Uniform breaks suit a blade badly: the paper's blade closes from a 0.08 chord to a point over
//! the last 0.3 % of its span, and a bicubic patch that must follow that collapse overshoots over
//! half the span. [`search_breaks_v`] moves the interior `v` breaks one at a time over a grid of
//! candidate positions (every candidate fitted in full, in parallel) and keeps the fit with the
//! smallest sum of squares among those that pass the [`projection_check`] (the emulation of a plain
//! outside tool's closest-point search, see [`crate::problem::checker`]). [`auto_breaks_v`] is the
//! policy of `--breaks-v auto` (when the search runs at all) and [`check_fit`] the one of the
//! projection check after a fit.

use super::surface::{fit_surface, Breaks, SurfaceFit, SurfaceLayout, SurfaceOptions, SurfaceProgress};
use crate::error::{Error, Result};
use crate::geometry::Grid;
use crate::problem::checker::{projection_check, ProjectionCheck};
use glam::DVec3;
use rayon::prelude::*;

/// One candidate of the break search.
#[derive(Clone, Debug)]
pub struct BreakCandidate {
    /// All `v` breaks, 0 to 1.
    pub breaks_v: Vec<f64>,
    /// Exact closest-point sum of squares of its fit.
    pub sum_sq: f64,
    /// Its projection check.
    pub check: ProjectionCheck,
}

/// The outcome of [`search_breaks_v`].
#[derive(Debug)]
pub struct BreakSearch {
    /// The fit kept.
    pub fit: SurfaceFit,
    /// Its projection check.
    pub check: ProjectionCheck,
    /// Every candidate fitted, in order.
    pub candidates: Vec<BreakCandidate>,
}

impl BreakSearch {
    /// What the search chose, in one line: the breaks, how many fits it made and how many of
    /// them passed the projection check, and the sum of squares kept against the uniform
    /// breaks' (the first candidate).
    #[must_use]
    pub fn describe(&self) -> String {
        describe(
            self.fit.grid.layout().v.breaks(),
            &self.candidates,
            self.fit.stats.sum_sq,
        )
    }
}

/// [`BreakSearch::describe`] of `breaks` chosen among `candidates` with `sum_sq`.
fn describe(breaks: &[f64], candidates: &[BreakCandidate], sum_sq: f64) -> String {
    let passed = candidates.iter().filter(|c| c.check.agrees).count();
    let uniform = candidates.first().map_or(f64::NAN, |c| c.sum_sq);
    format!(
        "breaks v: {} (auto: {} fits, {passed} pass the projection check; sum_sq {sum_sq:.4e}, uniform {uniform:.4e})",
        breaks
            .iter()
            .map(|b| format!("{b:.4}"))
            .collect::<Vec<_>>()
            .join(" "),
        candidates.len(),
    )
}

/// Positions tried for one break, as fractions of the interval between its neighbours.
const FRACTIONS: [f64; 11] = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98];

/// Fit `points` with `layout` (its `breaks_u` kept, its `breaks_v` replaced) for candidate
/// `v` breaks: uniform first, then each interior break in turn over `FRACTIONS` of the
/// interval between its neighbours (a position the break already has is not fitted again).
/// Keeps the smallest sum of squares among the fits that pass the [`projection_check`] (among
/// all fits when none does). Least squares only; each fit is a whole [`fit_surface`] call, so
/// the cost is at most `1 + 11 (pv - 1)` fits, run in parallel.
pub fn search_breaks_v(
    points: &[DVec3],
    grid: Option<Grid>,
    layout: &SurfaceLayout,
    opts: &SurfaceOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<BreakSearch> {
    let pv = layout.patches[1];
    if pv == 0 {
        return Err(Error::invalid("patches along v must be at least 1"));
    }
    let fit_with = |breaks: &[f64]| -> Result<(SurfaceFit, ProjectionCheck)> {
        let trial = SurfaceLayout {
            breaks_v: Breaks::Params(breaks.to_vec()),
            ..layout.clone()
        };
        let fit = fit_surface(points, grid, &trial, opts, &mut |_: SurfaceProgress| {})?;
        let check = projection_check(&fit.grid, points, fit.stats.rms, fit.stats.max);
        Ok((fit, check))
    };
    // An upper bound until each break's candidates are known.
    let mut total = 1 + FRACTIONS.len() * (pv - 1);
    let mut done = 0;
    let uniform: Vec<f64> = (0..=pv).map(|k| k as f64 / pv as f64).collect();
    let (mut fit, mut check) = fit_with(&uniform)?;
    let mut breaks = uniform.clone();
    let mut candidates = vec![BreakCandidate {
        breaks_v: uniform,
        sum_sq: fit.stats.sum_sq,
        check,
    }];
    done += 1;
    progress(done, total);
    let better = |a: (f64, bool), b: (f64, bool)| match (a.1, b.1) {
        (true, false) => true,
        (false, true) => false,
        _ => a.0 < b.0,
    };
    for k in 1..pv {
        let (lo, hi) = (breaks[k - 1], breaks[k + 1]);
        let trials: Vec<Vec<f64>> = FRACTIONS
            .iter()
            .map(|f| lo + f * (hi - lo))
            .filter(|&t| (t - breaks[k]).abs() > 1e-12)
            .map(|t| {
                let mut b = breaks.clone();
                b[k] = t;
                b
            })
            .collect();
        total -= FRACTIONS.len() - trials.len();
        let fits: Vec<Result<(SurfaceFit, ProjectionCheck)>> =
            trials.par_iter().map(|b| fit_with(b)).collect();
        for (b, result) in trials.into_iter().zip(fits) {
            done += 1;
            progress(done, total);
            let Ok((f, c)) = result else { continue };
            candidates.push(BreakCandidate {
                breaks_v: b.clone(),
                sum_sq: f.stats.sum_sq,
                check: c,
            });
            if better((f.stats.sum_sq, c.agrees), (fit.stats.sum_sq, check.agrees)) {
                (fit, check, breaks) = (f, c, b);
            }
        }
    }
    Ok(BreakSearch {
        fit,
        check,
        candidates,
    })
}

/// Clouds up to this many points get the projection check after a fit ([`check_fit`]) and the
/// automatic span-break search ([`auto_breaks_v`]): the check's sampled search costs about
/// as much as a fit's closest points, so larger clouds skip it.
pub const CHECKED_POINTS: usize = 20_000;

/// What [`auto_breaks_v`] decided.
#[derive(Debug)]
pub enum AutoBreaks {
    /// The search ran: its fit and candidates.
    Searched(Box<BreakSearch>),
    /// One patch along v: nothing to search, uniform breaks.
    SinglePatch,
    /// The cloud has more than `limit` points (the smaller of [`CHECKED_POINTS`] and the
    /// subsample size): uniform breaks.
    TooLarge {
        /// The largest cloud searched.
        limit: usize,
    },
}

/// The span breaks of `--breaks-v auto`: the [`search_breaks_v`] of a least-squares fit
/// (whatever `opts.method`) for two or more patches along v and clouds of up to
/// [`CHECKED_POINTS`] points (and up to the subsample size); uniform breaks otherwise.
pub fn auto_breaks_v(
    points: &[DVec3],
    grid: Option<Grid>,
    layout: &SurfaceLayout,
    opts: &SurfaceOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<AutoBreaks> {
    if layout.patches[1] < 2 {
        return Ok(AutoBreaks::SinglePatch);
    }
    let limit = match opts.subsample {
        0 => CHECKED_POINTS,
        s => s.min(CHECKED_POINTS),
    };
    if points.len() > limit {
        return Ok(AutoBreaks::TooLarge { limit });
    }
    let lsq = SurfaceOptions {
        method: crate::optim::method::Method::Lsq,
        ..opts.clone()
    };
    search_breaks_v(points, grid, layout, &lsq, progress).map(|s| AutoBreaks::Searched(Box::new(s)))
}

/// The projection check of a finished fit of `points` (`earlier`, the break search's check of
/// the same fit, is reused); `None` for clouds of more than [`CHECKED_POINTS`] points.
#[must_use]
pub fn check_fit(
    fit: &SurfaceFit,
    points: &[DVec3],
    earlier: Option<ProjectionCheck>,
) -> Option<ProjectionCheck> {
    (points.len() <= CHECKED_POINTS)
        .then(|| earlier.unwrap_or_else(|| projection_check(&fit.grid, points, fit.stats.rms, fit.stats.max)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The line gives the breaks to 4 places, the fits and those that pass, and the kept sum
    /// of squares against the uniform breaks' (the first candidate).
    #[test]
    fn the_search_says_what_it_chose() {
        let candidate = |sum_sq: f64, agrees: bool| BreakCandidate {
            breaks_v: vec![0.0, 0.5, 1.0],
            sum_sq,
            check: ProjectionCheck {
                rms: 0.0,
                max: 0.0,
                agrees,
            },
        };
        let line = describe(
            &[0.0, 0.25, 1.0],
            &[
                candidate(2e-3, true),
                candidate(1e-3, false),
                candidate(5e-4, true),
            ],
            5e-4,
        );
        assert_eq!(
            line,
            "breaks v: 0.0000 0.2500 1.0000 (auto: 3 fits, 2 pass the projection check; sum_sq 5.0000e-4, uniform 2.0000e-3)"
        );
    }
}
