//! The fit the search runs on every candidate layout: warm-started closest-point least
//! squares with a polish, and the offsets, span maxima and fold check of its result.

use super::super::blade::{span_differences, Chordwise, ColumnFrames, SPAN_FAIRNESS};
use super::super::Norm;
use super::data::Data;
use super::{fold_check, SurfaceAdaptOptions, FOLD_SAMPLES};
use crate::chain::{ChainLayout, GridLayout, GridShape, PatchGrid};
use crate::closest::FootOptions;
use crate::error::Result;
use crate::optim::{lsq, LsqHooks, LsqIterate, LsqMethod, LsqOptions, Start};
use crate::problem::{shape_offsets, Constraint, CoordRule, FitProblem, GridProblem, Metric};
use glam::DVec3;

/// A fitted candidate: design net, point parameters and the fit's own offsets.
#[derive(Clone)]
pub(super) struct Fitted {
    pub(super) design: Vec<DVec3>,
    pub(super) u: Vec<f64>,
    pub(super) err: Vec<f64>,
    pub(super) measure: f64,
}

/// The fits of one layout pair: the library's one fitting problem ([`GridProblem`]) on the
/// points fitted, every point's span parameter `v_k` held, the span rule a constraint on the
/// design (the span coordinate of every design column fixed), solved by the one least-squares
/// solver ([`lsq`]) in its alternating method (Hoschek's parameter correction along u), the
/// search's round limits an observer; Lawson's minimax polish reweights the problem.
///
/// Every distance is from a point to the surface at its own `(u, v_k)` after a local Newton
/// correction of `u` alone: a point of the surface, so never below the true closest distance.
pub(super) struct Fitter<'p> {
    pub(super) problem: GridProblem<'p, DVec3>,
    /// `v_k` of every point fitted.
    pub(super) v: Vec<f64>,
    /// Per point fitted, the share of the tolerance it is held to ([`Data::scale_of`]): its
    /// offsets count times this in the fit's measure and in the minimax polish (the
    /// least-squares rounds weigh every point alike). `None`: 1 for all.
    scale: Option<Vec<f64>>,
}

/// Newton steps of each point's parameter correction in a round of the fit, and in a round of
/// the minimax polish. The correction takes full Newton steps only
/// ([`FootOptions::backtrack`] false): on the paper's blade, backtracking (a further-moving
/// correction) made the search end with 15-55 % more stored scalars at four of five
/// tolerances between 1.77e-4 and 1.77e-5.
pub(super) const FIT_NEWTON: usize = 8;
pub(super) const POLISH_NEWTON: usize = 4;

/// Lawson's reweighting stops after this many rounds in a row without a better max. Before,
/// it ran all its 16 rounds: stopping after 4 left every layout of the IEA blades at 1e-3 and
/// of the paper blade's sweep as it was, and took the IEA 3.4 MW's default search from 63.7
/// to 52.0 s.
pub(super) const POLISH_STALE: usize = 4;

impl<'p> Fitter<'p> {
    /// The fits of `lu` x `lv` to `points` (a subset of the data's, section `k` at `v[j]`).
    pub(super) fn new(
        data: &Data<'_>,
        lu: ChainLayout,
        lv: ChainLayout,
        points: &'p [DVec3],
        v: Vec<f64>,
        scale: Option<Vec<f64>>,
        te_ends: Option<&[(usize, f64)]>,
    ) -> Option<Self> {
        let (nu, nv) = (lu.design_count(), lv.design_count());
        let span_col: Option<Vec<f64>> = data.span.map(|r| {
            lv.greville()
                .iter()
                .map(|g| r.ends[0] + g * (r.ends[1] - r.ends[0]))
                .collect()
        });
        let mut params: Vec<[f64; 2]> = v.iter().map(|&v| [0.0, v]).collect();
        for &(p, u) in te_ends.unwrap_or_default() {
            params[p][0] = u;
        }
        let ends: Vec<usize> = te_ends.unwrap_or_default().iter().map(|e| e.0).collect();
        let (lu_c, lv_c) = (lu.clone(), lv.clone());
        let foot = FootOptions {
            max_newton: FIT_NEWTON,
            backtrack: false,
            ..FootOptions::default()
        };
        let problem = FitProblem::new(
            GridShape::new(GridLayout::new(lu, lv)),
            points,
            params,
            Metric::Closest,
            foot,
        )
        .ok()?
        .with_held([false, true]);
        // The bulk families anchor every section's end points at the ends of u:
        // without them the grid ran past a section's last point by metres (IEA 15 MW).
        let problem = problem.with_anchors(&ends).ok()?;
        let problem = match (data.span, span_col) {
            (Some(rule), Some(sc)) if data.blade.is_some() => {
                let frames = ColumnFrames::new(&lv_c, &data.v, data.blade.as_deref()?);
                let axes = [data.axes[0], data.axes[1]];
                problem
                    .with_constraint(frames.constraint(
                        &Chordwise::new(&lu_c, te_ends.is_some()),
                        axes,
                        rule.axis,
                        &sc,
                    ))
                    .ok()?
            }
            (Some(rule), Some(sc)) => {
                let m = nu * nv;
                let coords = (0..3)
                    .map(|a| {
                        if a == rule.axis {
                            CoordRule::fixed((0..m).map(|i| sc[i % nv]).collect())
                        } else {
                            CoordRule::free(m)
                        }
                    })
                    .collect();
                let con = Constraint::new(coords);
                // A bulk family has dv more design columns than sections: the fairness holds
                // the columns the sections leave free, as under the chord rule.
                let con = if te_ends.is_some() {
                    con.with_fairness(span_differences(nu, nv, |i, j| i * nv + j), SPAN_FAIRNESS)
                } else {
                    con
                };
                problem.with_constraint(con).ok()?
            }
            _ => problem,
        };
        Some(Fitter { problem, v, scale })
    }

    /// Every point's `(u, v_k)` for `u`.
    pub(super) fn params(&self, u: &[f64]) -> Vec<[f64; 2]> {
        u.iter().zip(&self.v).map(|(&u, &v)| [u, v]).collect()
    }

    /// The fitted state of a design at its (corrected) parameters.
    pub(super) fn fitted(&self, design: Vec<DVec3>, params: &[[f64; 2]], norm: Norm) -> Fitted {
        let mut err = self.problem.distances(&design, params);
        if let Some(s) = &self.scale {
            scale_by(&mut err, s);
        }
        Fitted {
            measure: norm_of(&err, norm),
            design,
            u: params.iter().map(|t| t[0]).collect(),
            err,
        }
    }

    /// Rounds of a linear least-squares solve for the design net at fixed parameters and a
    /// Newton correction of every point's `u` ([`LsqMethod::Alternate`]) from `u0`: at most 12,
    /// until a round gains less than 0.5 % of the measure; the best round is kept. Then,
    /// for the max norm and a fit within twice the tolerance, Lawson's reweighting towards
    /// the minimax fit (at most 16 rounds, until [`POLISH_STALE`] rounds gain nothing).
    pub(super) fn fit(&mut self, u0: &[f64], opts: &SurfaceAdaptOptions) -> Option<Fitted> {
        let n = u0.len();
        let rounds = LsqOptions {
            max_iterations: 12,
            method: LsqMethod::Alternate,
            ..LsqOptions::default()
        };
        // Where the points' shares of the tolerance differ, the measure takes one more pass
        // over the points.
        let problem = &self.problem;
        let scale = self.scale.as_deref();
        let measure = |it: &LsqIterate, design: &[DVec3], params: &[[f64; 2]]| match (opts.norm, scale) {
            (Norm::Max, None) => it.max,
            (Norm::Rms, None) => (it.sum_sq / n.max(1) as f64).sqrt(),
            (norm, Some(s)) => {
                let mut e = problem.distances(design, params);
                scale_by(&mut e, s);
                norm_of(&e, norm)
            }
        };
        let mut best: Option<(f64, Vec<DVec3>, Vec<[f64; 2]>)> = None;
        let mut last = f64::INFINITY;
        let mut observe = |it: &LsqIterate, design: &[DVec3], params: &[[f64; 2]]| {
            let m = measure(it, design, params);
            if best.as_ref().is_none_or(|b| m < b.0) {
                best = Some((m, design.to_vec(), params.to_vec()));
            }
            if m > last * 0.995 {
                return false;
            }
            last = m;
            true
        };
        let hooks = LsqHooks {
            guard: None,
            observe: Some(&mut observe),
        };
        lsq(&self.problem, &[Start::Params(self.params(u0))], &rounds, hooks).ok()?;
        let (_, design, params) = best?;
        let mut best = self.fitted(design, &params, opts.norm);
        if opts.minimax && opts.norm == Norm::Max && best.measure <= 2.0 * opts.tol && best.measure > opts.tol
        {
            let one = LsqOptions {
                max_iterations: 1,
                ..rounds
            };
            let polish = FootOptions {
                max_newton: POLISH_NEWTON,
                ..*self.problem.foot_options()
            };
            self.problem.set_foot_options(polish).ok()?;
            let mut w = vec![1.0; n];
            let mut params = params;
            let mut err = best.err.clone();
            let mut stale = 0;
            for _ in 0..16 {
                if stale >= POLISH_STALE {
                    break;
                }
                let mean = err.iter().zip(&w).map(|(e, w)| e * w).sum::<f64>() / n as f64;
                if !(mean > 0.0) {
                    break;
                }
                for (wi, e) in w.iter_mut().zip(&err) {
                    *wi = (*wi * (e / mean)).clamp(1e-6, 1e6);
                }
                if self.problem.set_weights(Some(w.clone())).is_err() {
                    break;
                }
                let Some(round) = lsq(&self.problem, &[Start::Params(params)], &one, LsqHooks::default())
                    .ok()
                    .and_then(|mut f| f.pop())
                else {
                    break;
                };
                params = round.params;
                let next = self.fitted(round.design, &params, opts.norm);
                err = next.err.clone();
                stale += 1;
                if next.measure < best.measure {
                    stale = 0;
                    best = next;
                    if best.measure <= opts.tol * 0.98 {
                        break;
                    }
                }
            }
        }
        Some(best)
    }
}

/// The largest offset in each span of `breaks` of the points at `(t, offset)` (a point on an
/// interior break counts in the span after it; 0 for a span without points).
pub(super) fn span_maxima(breaks: &[f64], points: impl Iterator<Item = (f64, f64)>) -> Vec<f64> {
    let inner = &breaks[1..breaks.len() - 1];
    let mut out = vec![0.0_f64; breaks.len() - 1];
    for (t, e) in points {
        let s = inner.partition_point(|&x| x <= t);
        out[s] = out[s].max(e);
    }
    out
}

/// Where `grid` folds ([`fold_check`]): the `u` of the largest turn, when it exceeds 90°.
pub(super) fn fold_at(grid: &PatchGrid<DVec3>) -> Option<f64> {
    let f = fold_check(grid, FOLD_SAMPLES);
    (!f.passes).then_some(f.at[0])
}

/// Every offset of `err` times its point's share of the tolerance ([`Data::scale_of`]).
pub(super) fn scale_by(err: &mut [f64], scale: &[f64]) {
    err.iter_mut().zip(scale).for_each(|(e, s)| *e *= s);
}

pub(super) fn norm_of(err: &[f64], norm: Norm) -> f64 {
    match norm {
        Norm::Max => err.iter().fold(0.0, |m: f64, e| m.max(*e)),
        Norm::Rms => (err.iter().map(|e| e * e).sum::<f64>() / err.len().max(1) as f64).sqrt(),
    }
}

/// The squared closest-point offsets of `points` from `grid`: every point's distance to the
/// nearest of the surface points found by the library's global search
/// ([`crate::problem::grid_offset_stats`]'s), by the checker's (`checked`, from
/// [`sampled_offsets`]) and, when given, the fit's own foot points (`own`). Each search ends
/// on a point of the surface, so each is an upper bound of the true distance and so is their
/// minimum; near a collapsed edge (a blade tip) any one of them can stop in a local minimum.
pub(super) fn closest_dist_sq(
    grid: &PatchGrid<DVec3>,
    points: &[DVec3],
    checked: &[f64],
    own: Option<&[f64]>,
) -> Result<Vec<f64>> {
    let shape = GridShape::<DVec3>::new(grid.layout().clone());
    let opts = FootOptions {
        samples: 12,
        ..FootOptions::default()
    };
    let (_, feet) = shape_offsets(&shape, grid.design(), points, &opts)?;
    let d2: Vec<f64> = feet
        .iter()
        .enumerate()
        .map(|(p, f)| {
            let mut d = f.dist_sq.min(checked[p] * checked[p]);
            if let Some(o) = own {
                d = d.min(o[p] * o[p]);
            }
            d
        })
        .collect();
    Ok(d2)
}
