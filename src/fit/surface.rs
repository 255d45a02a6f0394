//! `fit_surface`: one call from a 3D cloud and a patch-grid layout to a fitted grid, with the
//! closest-point offsets and the solver's effort (what the CLI's `fit-surface` reports).
//!
//! The fit is the joint Levenberg-Marquardt of [`mod@super::lsq`] (design net and every point's
//! `(u, v)` together, the parameters eliminated blockwise), so each iteration costs `O(n)` in
//! the number of points plus a banded solve independent of `n`. Large clouds are fitted in two
//! stages: a random subsample of [`SurfaceOptions::subsample`] points is fitted to convergence
//! from the initial parameters (see [`mod@super::param`]); then every point is projected onto
//! that surface (Newton's method from its own initial parameters) and a few joint iterations
//! on the whole cloud ([`SurfaceOptions::polish_iterations`]) let every point count. The
//! reported offsets are true closest-point distances, found by a global search warm-started
//! from the final parameters.

use super::lsq::{levenberg_marquardt_observed, LsqIterate, LsqOptions};
use super::objective::{SolveReport, StopReason};
use super::offset::{Metric, OffsetStats};
use super::param::{blade_params, section_params, BladeParamOptions, SpanAxis};
use super::problem::GridProblem;
use crate::chain::{GridLayout, PatchGrid};
use crate::error::{Error, Result};
use crate::geometry::Grid;
use glam::DVec3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::fmt;
use std::str::FromStr;
use std::time::Instant;

/// A surface-fitting method. Only least squares exists so far; the evolutionary methods
/// (through the population evaluator) will join it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SurfaceMethod {
    /// Joint Levenberg-Marquardt over the design net and the foot points. The default.
    #[default]
    Lsq,
}

impl SurfaceMethod {
    /// The name used on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            SurfaceMethod::Lsq => "lsq",
        }
    }
}

impl fmt::Display for SurfaceMethod {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for SurfaceMethod {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "lsq" => Ok(SurfaceMethod::Lsq),
            "nelder-mead" | "bfgs" | "ga" | "cmaes" | "ga+lsq" | "cmaes+lsq" => Err(Error::invalid(format!(
                "method '{s}' is not available for surfaces yet (only lsq)"
            ))),
            _ => Err(Error::invalid(format!("unknown method '{s}' (surfaces: lsq)"))),
        }
    }
}

/// Where the initial `(u, v)` of the data points come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ParamSource {
    /// From the sections when the cloud has them, else blade-aware. The default.
    #[default]
    Auto,
    /// From the sections ([`section_params`]); an error for an unordered cloud.
    Sections,
    /// Blade-aware, ignoring any sections ([`blade_params`]).
    Blade,
}

impl ParamSource {
    /// The name used on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ParamSource::Auto => "auto",
            ParamSource::Sections => "sections",
            ParamSource::Blade => "blade",
        }
    }
}

impl FromStr for ParamSource {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(ParamSource::Auto),
            "sections" => Ok(ParamSource::Sections),
            "blade" => Ok(ParamSource::Blade),
            _ => Err(Error::invalid(format!(
                "unknown parameterisation '{s}' (expected auto, sections or blade)"
            ))),
        }
    }
}

/// Everything [`fit_surface`] needs besides the data and the layout.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceOptions {
    /// The method. Default least squares.
    pub method: SurfaceMethod,
    /// Where the initial parameters come from. Default [`ParamSource::Auto`].
    pub params: ParamSource,
    /// Options of the blade-aware parameterisation.
    pub blade: BladeParamOptions,
    /// The Levenberg-Marquardt options of the main fit (the subsample, or the whole cloud when
    /// it is small). Default: at most 100 iterations, converged when 3 iterations gain less
    /// than 1e-5 of the sum of squares, initial damping 1e-3, one global foot-point check.
    pub lsq: LsqOptions,
    /// Clouds with more points than this are fitted on a random subsample of this many first.
    /// 0 never subsamples. Default 50,000.
    pub subsample: usize,
    /// Joint iterations on the whole cloud after a subsample fit. Default 3.
    pub polish_iterations: usize,
    /// Seed of the subsample. Default 0.
    pub seed: u64,
}

impl Default for SurfaceOptions {
    fn default() -> Self {
        SurfaceOptions {
            method: SurfaceMethod::Lsq,
            params: ParamSource::Auto,
            blade: BladeParamOptions::default(),
            lsq: LsqOptions {
                max_iterations: 100,
                ftol: 1e-5,
                window: 3,
                initial_damping: 1e-3,
                global_checks: 1,
                ..LsqOptions::default()
            },
            subsample: 50_000,
            polish_iterations: 3,
            seed: 0,
        }
    }
}

/// One stage of a surface fit.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceStage {
    /// `subsample`, `full` (the whole cloud after a subsample fit) or `lsq` (the whole cloud
    /// in one stage).
    pub name: &'static str,
    /// Points the stage fitted.
    pub points: usize,
    /// The stage's solver report.
    pub report: SolveReport,
}

/// What [`fit_surface`] tells its caller while it runs (the library never prints).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SurfaceProgress {
    /// The initial parameters are ready (`source` says which method made them).
    Params {
        /// `sections` or `blade`.
        source: &'static str,
        /// Seconds spent.
        seconds: f64,
    },
    /// A stage starts.
    Stage {
        /// The stage's name (see [`SurfaceStage::name`]).
        name: &'static str,
        /// Points it fits.
        points: usize,
    },
    /// A Levenberg-Marquardt iteration ended.
    Iteration(LsqIterate),
    /// The final closest-point search over every point starts.
    Offsets {
        /// Points measured.
        points: usize,
    },
}

/// A fitted patch grid with its offsets and the effort spent.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceFit {
    /// The fitted grid.
    pub grid: PatchGrid<DVec3>,
    /// The closest-point parameters `(u, v)` of every data point.
    pub params: Vec<[f64; 2]>,
    /// True closest-point offsets of every data point, in f64.
    pub stats: OffsetStats<DVec3>,
    /// The span axis the parameters were measured along.
    pub axis: SpanAxis,
    /// `sections` or `blade`: where the initial parameters came from.
    pub param_source: &'static str,
    /// The stages, in order.
    pub stages: Vec<SurfaceStage>,
    /// Iterations and evaluations summed over the stages, wall-clock seconds of the whole fit
    /// (parameters and final offsets included).
    pub report: SolveReport,
}

/// Initial parameters of a cloud, and the name of the method that made them.
pub fn initial_params(
    points: &[DVec3],
    grid: Option<Grid>,
    opts: &SurfaceOptions,
) -> Result<(Vec<[f64; 2]>, SpanAxis, &'static str)> {
    match (opts.params, grid) {
        (ParamSource::Sections | ParamSource::Auto, Some(g)) => {
            let (p, a) = section_params(points, g, opts.blade.span)?;
            Ok((p, a, "sections"))
        }
        (ParamSource::Sections, None) => Err(Error::invalid(
            "parameters from sections need a structured cloud (CSV with section,index columns)",
        )),
        (ParamSource::Blade | ParamSource::Auto, _) => {
            let (p, a) = blade_params(points, &opts.blade)?;
            Ok((p, a, "blade"))
        }
    }
}

/// The indices of a subsample of about `count` points, sorted, without repeats: an equal
/// share of random points from every patch (by the initial parameters; a patch with fewer
/// points gives all it has, so small patches, like the blade's last span before the tip, keep
/// their data), plus the `count / 50` points with the smallest and with the largest initial
/// `u` and `v` each, so that the four edges of the surface keep theirs (a random 2% of the
/// root section leaves the edge there free to pull back).
fn subsample(params: &[[f64; 2]], layout: &GridLayout, count: usize, seed: u64) -> Vec<usize> {
    let n = params.len();
    let (pu, pv) = layout.patches();
    let mut by_cell: Vec<Vec<usize>> = vec![Vec::new(); pu * pv];
    for (j, t) in params.iter().enumerate() {
        let (a, _) = layout.u.locate(t[0]);
        let (b, _) = layout.v.locate(t[1]);
        by_cell[a * pv + b].push(j);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let quota = count.div_ceil(pu * pv).max(1);
    let mut idx = Vec::with_capacity(count + count / 10);
    for cell in &by_cell {
        if cell.len() <= quota {
            idx.extend_from_slice(cell);
        } else {
            idx.extend(
                rand::seq::index::sample(&mut rng, cell.len(), quota)
                    .into_iter()
                    .map(|k| cell[k]),
            );
        }
    }
    let edge = (count / 50).min(n / 4);
    if edge > 0 {
        let mut order: Vec<usize> = (0..n).collect();
        for k in 0..2 {
            let key = |i: &usize| params[*i][k];
            order.select_nth_unstable_by(edge, |a, b| key(a).total_cmp(&key(b)));
            idx.extend_from_slice(&order[..edge]);
            order.select_nth_unstable_by(n - 1 - edge, |a, b| key(a).total_cmp(&key(b)));
            idx.extend_from_slice(&order[n - edge..]);
        }
    }
    idx.sort_unstable();
    idx.dedup();
    idx
}

/// Fit a patch grid of `layout` to `points` (with their section structure when known) by
/// closest-point least squares; see the module docs for the stages.
pub fn fit_surface(
    points: &[DVec3],
    grid: Option<Grid>,
    layout: GridLayout,
    opts: &SurfaceOptions,
    progress: &mut dyn FnMut(SurfaceProgress),
) -> Result<SurfaceFit> {
    let clock = Instant::now();
    let (nu, nv) = layout.design_shape();
    if points.len() < nu * nv {
        return Err(Error::invalid(format!(
            "{} data points cannot determine a {nu} x {nv} design net: at least {} are needed",
            points.len(),
            nu * nv
        )));
    }
    let (mut params, axis, source) = initial_params(points, grid, opts)?;
    progress(SurfaceProgress::Params {
        source,
        seconds: clock.elapsed().as_secs_f64(),
    });
    let n = points.len();
    let sub = opts.subsample > 0 && n > opts.subsample && opts.subsample >= nu * nv;
    let mut stages = Vec::new();
    let full = GridProblem::grid(layout.clone(), points, params.clone(), Metric::Closest)?;
    let design = if sub {
        let idx = subsample(&params, &layout, opts.subsample, opts.seed);
        let sub_points: Vec<DVec3> = idx.iter().map(|&i| points[i]).collect();
        let sub_params: Vec<[f64; 2]> = idx.iter().map(|&i| params[i]).collect();
        let problem = GridProblem::grid(layout.clone(), &sub_points, sub_params, Metric::Closest)?;
        progress(SurfaceProgress::Stage {
            name: "subsample",
            points: sub_points.len(),
        });
        let start = problem.linear_fit(problem.params())?;
        let fit = levenberg_marquardt_observed(
            &problem,
            start,
            problem.params().to_vec(),
            &opts.lsq,
            &mut |it: &LsqIterate| {
                progress(SurfaceProgress::Iteration(*it));
                true
            },
        )?;
        stages.push(SurfaceStage {
            name: "subsample",
            points: sub_points.len(),
            report: fit.report,
        });
        // The whole cloud: Levenberg-Marquardt first moves every point to its own foot point on
        // the subsample's surface (Newton's method from its initial parameters).
        progress(SurfaceProgress::Stage {
            name: "full",
            points: n,
        });
        let polish = LsqOptions {
            max_iterations: opts.polish_iterations,
            global_checks: 0,
            ..opts.lsq
        };
        if opts.polish_iterations > 0 {
            let fit =
                levenberg_marquardt_observed(&full, fit.design, params, &polish, &mut |it: &LsqIterate| {
                    progress(SurfaceProgress::Iteration(*it));
                    true
                })?;
            params = fit.params;
            stages.push(SurfaceStage {
                name: "full",
                points: n,
                report: fit.report,
            });
            fit.design
        } else {
            full.project(&fit.design, &mut params);
            fit.design
        }
    } else {
        progress(SurfaceProgress::Stage {
            name: "lsq",
            points: n,
        });
        let start = full.linear_fit(full.params())?;
        let fit = levenberg_marquardt_observed(&full, start, params, &opts.lsq, &mut |it: &LsqIterate| {
            progress(SurfaceProgress::Iteration(*it));
            true
        })?;
        params = fit.params;
        stages.push(SurfaceStage {
            name: "lsq",
            points: n,
            report: fit.report,
        });
        fit.design
    };
    progress(SurfaceProgress::Offsets { points: n });
    let (stats, feet) = full.closest_stats(&design, Some(&params));
    let grid = full.patch_grid(&design)?;
    let (iterations, evaluations) = stages.iter().fold((0, 0), |(i, e), s| {
        (i + s.report.iterations, e + s.report.evaluations)
    });
    // The whole-cloud polish runs a fixed number of iterations: the main stage says whether
    // the fit converged.
    let stop = stages.first().map_or(StopReason::Converged, |s| s.report.stop);
    Ok(SurfaceFit {
        grid,
        params: feet,
        stats,
        axis,
        param_source: source,
        stages,
        report: SolveReport {
            iterations,
            evaluations: evaluations + 1,
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    })
}
