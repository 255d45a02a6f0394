//! The fits of the adaptive search: a candidate parameterisation (a layout and how x is
//! stored) is fitted through the library's one least-squares solver ([`crate::optim::lsq`]) on
//! the one fitting problem ([`FitProblem`]: ends anchored, the aerofoil rule a linear
//! constraint on x), with the search's effort limits as an observer, and an optional
//! minimax polish by Lawson's reweighting (the problem's weights).
//!
//! The search fits hundreds of candidate layouts, so each fit is single-start, warm-started
//! and checks no other foot points than the local ones: its distances come from a local
//! Newton search from each point's previous foot point, each the distance to *some* point of
//! the curve, so never below the true closest distance, and a tolerance met by them is met
//! by the true offsets. The design a search returns is re-measured with the global
//! closest-point search ([`crate::problem::offset_stats`]) before it is reported.

use crate::chain::{ChainLayout, CurveShape};
use crate::closest::FootOptions;
use crate::error::{Error, Result};
use crate::optim::{lsq, DampingScale, LsqHooks, LsqIterate, LsqOptions, Start};
use crate::problem::{Constraint, CoordRule, FitProblem, Metric};
use glam::DVec2;

/// How the x coordinates of the design points are stored.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum XRule {
    /// Both coordinates of every design point are free.
    Free,
    /// Aerofoil rule: `x(t) = x_le + (x_te,1 - x_le) (1 - 2t)²` for `t <= 1/2` and
    /// `x_le + (x_te,2 - x_le) (2t - 1)²` after, so only the numbers `θ = (x_le, x_te,1,
    /// x_te,2)` (or `(x_le, x_te)` when both surfaces end at the same x) and the y of every
    /// design point are stored. Row `i` of `rows` holds the weights of `(x_le, x_te,1, x_te,2)`
    /// in design point `i`'s x.
    Aerofoil {
        /// The weights.
        rows: Vec<[f64; 3]>,
        /// One trailing-edge x for both surfaces.
        shared_te: bool,
    },
}

/// A candidate parameterisation: the spline layout and how x is stored.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Model {
    pub layout: ChainLayout,
    pub rule: XRule,
    /// The rule as a constraint on the design points (`None` for free x).
    constraint: Option<Constraint>,
}

/// The break of the leading edge in the aerofoil rule.
pub(crate) const LE_BREAK: f64 = 0.5;

impl Model {
    /// A model with free x.
    pub fn free(layout: ChainLayout) -> Self {
        Model {
            layout,
            rule: XRule::Free,
            constraint: None,
        }
    }

    /// A model with the aerofoil rule (one trailing-edge x for both surfaces with
    /// `shared_te`); the layout must have a C1 (or C0) break at 1/2 and degree 2 or more.
    pub fn aerofoil(layout: ChainLayout, shared_te: bool) -> Result<Self> {
        let d = layout.degree();
        let le = layout.breaks().iter().position(|&b| b == LE_BREAK);
        match le {
            Some(i) if d >= 2 && layout.orders()[i - 1] <= 1 => {}
            _ => {
                return Err(Error::invalid(
                    "the aerofoil rule needs degree 2 or more and a C1 break at t = 1/2",
                ))
            }
        }
        let rows = rule_rows(&layout);
        let constraint = Some(rule_constraint(&rows, shared_te));
        Ok(Model {
            layout,
            rule: XRule::Aerofoil { rows, shared_te },
            constraint,
        })
    }

    /// Number of x unknowns.
    pub fn x_unknowns(&self) -> usize {
        match &self.rule {
            XRule::Free => self.layout.design_count(),
            XRule::Aerofoil { shared_te, .. } => 3 - usize::from(*shared_te),
        }
    }

    /// The design points (B-spline coefficients) from the unknowns.
    pub fn coeffs(&self, z: &[f64]) -> Vec<DVec2> {
        let mx = self.x_unknowns();
        let n = self.layout.design_count();
        (0..n)
            .map(|i| {
                let x = match &self.rule {
                    XRule::Free => z[i],
                    XRule::Aerofoil { rows: r, shared_te } => {
                        if *shared_te {
                            r[i][0] * z[0] + (r[i][1] + r[i][2]) * z[1]
                        } else {
                            r[i][0] * z[0] + r[i][1] * z[1] + r[i][2] * z[2]
                        }
                    }
                };
                DVec2::new(x, z[mx + i])
            })
            .collect()
    }

    /// The unknowns of design points that follow the model (x from the rule is not checked).
    pub fn unknowns_of(&self, coeffs: &[DVec2], theta: Option<&[f64]>) -> Vec<f64> {
        let mut z = match (&self.rule, theta) {
            (XRule::Aerofoil { .. }, Some(t)) => t.to_vec(),
            _ => coeffs.iter().map(|p| p.x).collect(),
        };
        z.extend(coeffs.iter().map(|p| p.y));
        z
    }

    /// The aerofoil rule's numbers `θ` of design points that follow the model (`None` for
    /// free x).
    pub fn theta(&self, coeffs: &[DVec2]) -> Option<Vec<f64>> {
        let z = self.constraint.as_ref()?.unknowns_of(coeffs)?;
        Some(z[..self.x_unknowns()].to_vec())
    }

    /// Which design points the data at `params` leave undetermined: those whose basis
    /// function's squares summed over the data fall below [`UNDETERMINED`] of the largest such
    /// sum (a segment holding no data point, or one only at a C2 join where the segment's own
    /// basis functions are flat to rounding).
    pub fn undetermined(&self, params: &[f64]) -> Vec<bool> {
        let d = self.layout.degree();
        let mut reach = vec![0.0_f64; self.layout.design_count()];
        for &t in params {
            let b = self.layout.basis(t, 0);
            for a in 0..=d {
                reach[b.first + a] += b.value[a] * b.value[a];
            }
        }
        let top = reach.iter().fold(0.0_f64, |m, &r| m.max(r));
        reach
            .iter()
            .map(|&r| r.is_nan() || r <= UNDETERMINED * top)
            .collect()
    }

    /// This model's constraint with the design points `held` kept where they start: their y
    /// (and x, where x is free) take no step; x under the aerofoil rule stays on the rule.
    fn holding(&self, held: &[bool]) -> Constraint {
        // The rule's θ are the first unknowns; every coordinate not held gets the next one.
        let mut next = match &self.rule {
            XRule::Free => 0,
            XRule::Aerofoil { .. } => self.x_unknowns(),
        };
        let mut own = |h: bool| {
            if h {
                Vec::new()
            } else {
                next += 1;
                vec![(next - 1, 1.0)]
            }
        };
        let x_rows: Vec<Vec<(usize, f64)>> = match &self.rule {
            XRule::Free => held.iter().map(|&h| own(h)).collect(),
            XRule::Aerofoil { rows, shared_te } => rows.iter().map(|w| theta_row(w, *shared_te)).collect(),
        };
        let mut rows = Vec::with_capacity(2 * held.len());
        for (x, &h) in x_rows.into_iter().zip(held) {
            rows.push(x);
            rows.push(own(h));
        }
        // The offsets never enter the fit: lsq moves the design by steps within the rows.
        let offset = vec![0.0; rows.len()];
        Constraint::coupled(rows, offset, next)
    }

    /// The fitting problem of this model on `data` from `params`: the ends anchored at 0 and
    /// 1, the rule a constraint on x. `None` when the data cannot determine the layout.
    fn problem<'a>(&self, data: &Data<'a>, params: Vec<f64>) -> Option<FitProblem<'a, CurveShape<DVec2>, 1>> {
        let extent = data
            .points
            .iter()
            .fold(0.0_f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
        let foot = FootOptions {
            max_newton: FOOT_STEPS,
            tolerance: FOOT_TOLERANCE * extent.max(f64::MIN_POSITIVE),
            ..FootOptions::default()
        };
        let n = data.points.len();
        let mut params: Vec<[f64; 1]> = params.into_iter().map(|t| [t.clamp(0.0, 1.0)]).collect();
        params[0] = [0.0];
        params[n - 1] = [1.0];
        let problem = FitProblem::new(
            CurveShape::new(self.layout.clone()),
            data.points,
            params,
            Metric::Closest,
            foot,
        )
        .ok()?;
        let mut problem = problem.with_anchors(&[0, n - 1]).ok()?;
        if let Some(c) = &self.constraint {
            problem = problem.with_constraint(c.clone()).ok()?;
        }
        Some(problem)
    }
}

/// The weights of `θ = (x_le, x_te,1, x_te,2)` in every coefficient of the layout: the
/// B-spline coefficients of the rule's three piecewise quadratics, by blossoming (the
/// coefficient of basis function `i` is the blossom of the polynomial piece at the knots
/// `τ_{i+1} … τ_{i+d}`; the pieces agree wherever the window spans the leading edge).
pub(crate) fn rule_rows(layout: &ChainLayout) -> Vec<[f64; 3]> {
    let d = layout.degree();
    let knots = layout.knots();
    let pairs = (d * (d - 1) / 2) as f64;
    (0..layout.design_count())
        .map(|i| {
            let args = &knots[i + 1..=i + d];
            // Blossom of 4 (t - 1/2)²: 4 Σ_{a<b} (x_a - 1/2)(x_b - 1/2) / C(d, 2).
            let mut s = 0.0;
            for a in 0..d {
                for b in a + 1..d {
                    s += (args[a] - LE_BREAK) * (args[b] - LE_BREAK);
                }
            }
            let q = 4.0 * s / pairs;
            let left = args.iter().any(|&x| x < LE_BREAK);
            let (up, lo) = if left { (q, 0.0) } else { (0.0, q) };
            [1.0 - up - lo, up, lo]
        })
        .collect()
}

/// The aerofoil rule as a constraint: x of design point `i` is `rows[i] · θ` (the two
/// trailing-edge numbers one with `shared_te`), y free.
fn rule_constraint(rows: &[[f64; 3]], shared_te: bool) -> Constraint {
    let x = CoordRule::linear(
        rows.iter().map(|w| theta_row(w, shared_te)).collect(),
        3 - usize::from(shared_te),
    );
    Constraint::new(vec![x, CoordRule::free(rows.len())])
}

/// The entries `(unknown, weight)` of a design point's x under the aerofoil rule, `w` its
/// weights on `θ = (x_le, x_te,1, x_te,2)`: the two trailing-edge numbers are one unknown
/// with `shared_te`.
fn theta_row(w: &[f64; 3], shared_te: bool) -> Vec<(usize, f64)> {
    if shared_te {
        vec![(0, w[0]), (1, w[1] + w[2])]
    } else {
        vec![(0, w[0]), (1, w[1]), (2, w[2])]
    }
}

/// A fitted state of a model: design points, one parameter and one distance per data point.
#[derive(Clone, Debug)]
pub(crate) struct State {
    pub coeffs: Vec<DVec2>,
    pub params: Vec<f64>,
    /// Distance of each data point to the curve at its parameter (an upper bound of the true
    /// closest distance).
    pub dist: Vec<f64>,
}

impl State {
    /// The largest distance.
    pub fn max(&self) -> f64 {
        self.dist.iter().fold(0.0, |m, &d| m.max(d))
    }

    /// Root mean square of the distances.
    pub fn rms(&self) -> f64 {
        (self.dist.iter().map(|d| d * d).sum::<f64>() / self.dist.len().max(1) as f64).sqrt()
    }
}

/// Effort limits of one fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Effort {
    /// Gauss-Newton iterations at most.
    pub iterations: usize,
    /// Stop when an iteration lowers the sum of squares by less than this fraction.
    pub ftol: f64,
    /// Lawson reweighting rounds of the minimax polish (0: none).
    pub minimax: usize,
    /// From iteration `give_up_after` on, give up when the largest distance, shrunk at the
    /// last iteration's rate over the iterations left, would stay above this (the layout
    /// cannot come near the tolerance the caller cares about); `INFINITY` never gives up.
    pub give_up: f64,
    /// See `give_up`.
    pub give_up_after: usize,
    /// Stop once the largest distance improved by less than 1% over this many iterations (the
    /// sum of squares may still creep along a valley where the design points slide along the
    /// curve, which changes the shape no more); 0 never stops for this.
    pub max_stall: usize,
}

/// The data: points in order, the first and last tied to the curve's ends.
pub(crate) struct Data<'a> {
    pub points: &'a [DVec2],
}

/// A design point whose basis function's squares, summed over the data, fall below this
/// share of the largest such sum is not determined by the data: `1e-10`, where the Cholesky
/// factors of the normal equations no longer resolve it (their diagonal spans 10 decades).
const UNDETERMINED: f64 = 1e-10;

/// Newton steps of a point's local foot-point search.
const FOOT_STEPS: usize = 16;

/// The local foot-point search stops before a step that moves the foot by less than this
/// fraction of the data's extent along the curve (`1e-10` of a unit chord: the distance it
/// reports is then exact to `1e-20` over the curvature radius, and still a distance to a
/// point of the curve).
const FOOT_TOLERANCE: f64 = 1e-10;

/// A fitted state from a design and the parameters it was fitted with (anchored ends at 0
/// and 1), the distances measured there.
fn state_at(
    problem: &FitProblem<'_, CurveShape<DVec2>, 1>,
    coeffs: Vec<DVec2>,
    params: Vec<[f64; 1]>,
) -> State {
    let dist = problem.distances(&coeffs, &params);
    State {
        coeffs,
        params: params.iter().map(|t| t[0]).collect(),
        dist,
    }
}

/// A state from design points and starting parameters, every parameter (but the anchored
/// ends) projected to its local foot point.
pub(crate) fn state(model: &Model, data: &Data<'_>, coeffs: Vec<DVec2>, params: Vec<f64>) -> State {
    let n = data.points.len();
    let mut params: Vec<[f64; 1]> = params.into_iter().map(|t| [t.clamp(0.0, 1.0)]).collect();
    params[0] = [0.0];
    params[n - 1] = [1.0];
    match model.problem(data, params.iter().map(|t| t[0]).collect()) {
        Some(problem) => {
            problem.project(&coeffs, &mut params);
            state_at(&problem, coeffs, params)
        }
        None => State {
            dist: vec![f64::INFINITY; n],
            params: params.iter().map(|t| t[0]).collect(),
            coeffs,
        },
    }
}

/// Least squares on `problem` from `start` under `effort` (its iteration, gain, give-up and
/// stall limits, judged on accepted steps as an observer of [`lsq`]).
fn descend(
    problem: &FitProblem<'_, CurveShape<DVec2>, 1>,
    start: Start<DVec2, 1>,
    effort: &Effort,
) -> Option<State> {
    let opts = LsqOptions {
        // Steps tried, accepted or not: the effort counts accepted ones.
        max_iterations: 3 * effort.iterations,
        initial_damping: INITIAL_DAMPING,
        global_checks: 0,
        // The effort's tests below replace the windowed decrease test.
        window: usize::MAX,
        // Any decrease is taken, and the damping follows it quickly: the fits are short.
        accept_ratio: 0.0,
        damping_factors: Some([4.0, 8.0]),
        damping_scale: DampingScale::Reduced,
        ..LsqOptions::default()
    };
    let (mut obj, mut accepted) = (f64::INFINITY, 0);
    let mut maxes: Vec<f64> = Vec::new();
    let mut observe = |it: &LsqIterate, _: &[DVec2], _: &[[f64; 1]]| {
        if it.iteration == 0 {
            obj = it.sum_sq;
            maxes.push(it.max);
            return true;
        }
        if !it.accepted {
            return true;
        }
        accepted += 1;
        let gain = (obj - it.sum_sq) / obj.max(f64::MIN_POSITIVE);
        obj = it.sum_sq;
        // Far from the caller's tolerance and no longer converging fast: not worth more.
        if gain < effort.ftol || accepted >= effort.iterations {
            return false;
        }
        // Give up when, at the rate of the last iteration, the remaining ones would not
        // bring the largest distance (about the square root of the sum) to the target.
        if accepted >= effort.give_up_after && effort.give_up.is_finite() {
            let rest = effort.iterations.saturating_sub(accepted) as f64;
            if it.max * (1.0 - gain).max(0.0).powf(0.5 * rest) > effort.give_up {
                return false;
            }
        }
        maxes.push(it.max);
        let k = effort.max_stall;
        !(k > 0 && maxes.len() > k && maxes[maxes.len() - 1] > 0.99 * maxes[maxes.len() - 1 - k])
    };
    let hooks = LsqHooks {
        guard: None,
        observe: Some(&mut observe),
    };
    let fit = lsq(problem, &[start], &opts, hooks).ok()?.pop()?;
    Some(state_at(problem, fit.design, fit.params))
}

/// The damping the fits start with, relative to the diagonal of the normal equations: the
/// search's fits are warm-started close to their optimum, so bold first steps pay.
const INITIAL_DAMPING: f64 = 0.1;

/// Fit `model` from design points `start` (or, when `None`, the linear fit at `params`) and
/// starting parameters: least squares on the sum of squares, then the minimax polish if
/// asked.
pub(crate) fn fit(
    model: &Model,
    data: &Data<'_>,
    start: Option<Vec<DVec2>>,
    params: Vec<f64>,
    effort: &Effort,
) -> Option<State> {
    let problem = model.problem(data, params)?;
    run(problem, start, effort)
}

/// [`fit`] from design points `start` with the design points the data at `params` leave
/// undetermined ([`Model::undetermined`]) held where `start` has them: a refit on part of the
/// data (the held-out check) otherwise lets the part no point reaches go anywhere, since
/// moving it changes no distance.
pub(crate) fn refit(
    model: &Model,
    data: &Data<'_>,
    start: Vec<DVec2>,
    params: Vec<f64>,
    effort: &Effort,
) -> Option<State> {
    let held = model.undetermined(&params);
    if !held.contains(&true) {
        return fit(model, data, Some(start), params, effort);
    }
    let problem = model
        .problem(data, params)?
        .with_constraint(model.holding(&held))
        .ok()?;
    run(problem, Some(start), effort)
}

/// Least squares on `problem` from design points `start` (or the linear fit at its
/// parameters), then the minimax polish if `effort` asks for it.
fn run(
    mut problem: FitProblem<'_, CurveShape<DVec2>, 1>,
    start: Option<Vec<DVec2>>,
    effort: &Effort,
) -> Option<State> {
    let params = problem.params().to_vec();
    let start = match start {
        Some(coeffs) => Start::Design(coeffs, params),
        None => Start::Params(params),
    };
    let s = descend(&problem, start, effort)?;
    if effort.minimax == 0 {
        return Some(s);
    }
    Some(lawson(&mut problem, s, effort))
}

/// Lawson's iteration towards the minimax fit, from `s`: see [`minimax`].
pub(crate) fn minimax(model: &Model, data: &Data<'_>, s: State, effort: &Effort) -> State {
    match model.problem(data, s.params.clone()) {
        Some(mut problem) => lawson(&mut problem, s, effort),
        None => s,
    }
}

/// Lawson's iteration towards the minimax fit: each round multiplies every point's weight by
/// its distance (normalised, floored at `1e-6` of the largest) and takes one least-squares
/// step with those weights; the state with the smallest largest distance is kept.
fn lawson(problem: &mut FitProblem<'_, CurveShape<DVec2>, 1>, s: State, effort: &Effort) -> State {
    let n = s.dist.len();
    let mut w = vec![1.0 / n as f64; n];
    let mut best = s.clone();
    let mut cur = s;
    let one = Effort {
        iterations: 1,
        ..*effort
    };
    for _ in 0..effort.minimax {
        let mut total = 0.0;
        for (wj, d) in w.iter_mut().zip(&cur.dist) {
            *wj *= d.max(1e-300);
            total += *wj;
        }
        if !(total > 0.0) || !total.is_finite() {
            break;
        }
        let top = w.iter().fold(0.0_f64, |m, &x| m.max(x)) / total;
        for wj in &mut w {
            *wj = (*wj / total).max(1e-6 * top);
        }
        if problem.set_weights(Some(w.clone())).is_err() {
            break;
        }
        let start = Start::Feet(cur.coeffs.clone(), cur.params.iter().map(|&t| [t]).collect());
        match descend(problem, start, &one) {
            Some(next) => cur = next,
            None => break,
        }
        if cur.max() < best.max() {
            best = cur.clone();
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eff() -> Effort {
        Effort {
            iterations: 50,
            ftol: 1e-12,
            minimax: 0,
            give_up: f64::INFINITY,
            give_up_after: 0,
            max_stall: 0,
        }
    }

    #[test]
    fn rule_rows_reproduce_the_quadratic_x_rule() {
        for (d, orders) in [
            (2, vec![1]),
            (3, vec![2, 1, 2]),
            (5, vec![4, 1, 3]),
            (4, vec![1, 1, 1]),
        ] {
            let breaks = match orders.len() {
                1 => vec![0.0, 0.5, 1.0],
                _ => vec![0.0, 0.2, 0.5, 0.9, 1.0],
            };
            let l = ChainLayout::with_orders(d, breaks, orders).unwrap();
            let m = Model::aerofoil(l.clone(), false).unwrap();
            let theta = [0.01, 1.02, 0.98];
            let z = m.unknowns_of(&vec![DVec2::ZERO; l.design_count()], Some(&theta));
            let c = m.coeffs(&z);
            for i in 0..=200 {
                let t = i as f64 / 200.0;
                let x = l.eval(&c, t).x;
                let expect = if t <= 0.5 {
                    theta[0] + (theta[1] - theta[0]) * (1.0 - 2.0 * t).powi(2)
                } else {
                    theta[0] + (theta[2] - theta[0]) * (2.0 * t - 1.0).powi(2)
                };
                assert!((x - expect).abs() < 1e-14, "d={d} t={t}: {x} vs {expect}");
            }
        }
        let no_le = ChainLayout::with_order(3, vec![0.0, 0.4, 1.0], 1).unwrap();
        assert!(Model::aerofoil(no_le, false).is_err());
        let c2_le = ChainLayout::with_order(3, vec![0.0, 0.5, 1.0], 2).unwrap();
        assert!(Model::aerofoil(c2_le, true).is_err());
    }

    #[test]
    fn recovers_a_curve_sampled_off_its_parameters() {
        let l = ChainLayout::with_orders(4, vec![0.0, 0.35, 0.6, 1.0], vec![3, 1]).unwrap();
        let truth: Vec<DVec2> = (0..l.design_count())
            .map(|i| DVec2::new(i as f64 * 0.2, 0.3 * (1.3 * i as f64).sin()))
            .collect();
        let pts: Vec<DVec2> = (0..150)
            .map(|i| l.eval(&truth, (i as f64 / 149.0).powf(1.3)))
            .collect();
        let data = Data { points: &pts };
        let model = Model::free(l);
        let params: Vec<f64> = (0..150).map(|i| i as f64 / 149.0).collect();
        let s = fit(&model, &data, None, params, &eff()).unwrap();
        assert!(s.max() < 1e-10, "max {}", s.max());
    }

    #[test]
    fn minimax_lowers_the_largest_distance() {
        let l = ChainLayout::with_order(3, vec![0.0, 0.5, 1.0], 2).unwrap();
        let pts: Vec<DVec2> = (0..120)
            .map(|i| {
                let a = i as f64 / 119.0 * 3.0;
                DVec2::new(a, (2.0 * a).sin() * 0.4)
            })
            .collect();
        let data = Data { points: &pts };
        let model = Model::free(l);
        let params: Vec<f64> = (0..120).map(|i| i as f64 / 119.0).collect();
        let l2 = fit(&model, &data, None, params.clone(), &eff()).unwrap();
        let mm = fit(&model, &data, None, params, &Effort { minimax: 40, ..eff() }).unwrap();
        assert!(mm.max() < 0.8 * l2.max(), "{} vs {}", mm.max(), l2.max());
    }
}
