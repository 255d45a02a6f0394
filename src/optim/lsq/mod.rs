//! The closest-point least-squares fit: Levenberg-Marquardt over the design points and every
//! data point's foot-point parameters together, the parameters eliminated blockwise.
//!
//! The unknowns are the design points `x` (`m` points, `D` coordinates) and one parameter
//! `t_j ∈ [0, 1]^K` per data point; the residuals are `r_j = C(t_j) - q_j`. Each `t_j` touches
//! only its own residual, so the damped normal equations
//!
//! ```text
//! [ Jxᵀ Jx + λ Dx    Jxᵀ Jt       ] [dx]     [Jxᵀ r]
//! [ Jtᵀ Jx           Jtᵀ Jt + λ Dt] [dt] = - [Jtᵀ r]
//! ```
//!
//! have a block-diagonal lower-right part (a `K x K` block `M_j = T_jᵀ T_j` per point, `T_j`
//! the tangents; `Dx`, `Dt` are the diagonals of `Jxᵀ Jx` and `Jtᵀ Jt`, Marquardt's scaling).
//! Eliminating it leaves an `mD x mD` system
//!
//! ```text
//! S = Σ_j (a_j a_jᵀ) ⊗ P_j + λ Dx,   b = Σ_j a_j ⊗ (P_j r_j),   P_j = I - T_j (M_j + λ Dt_j)⁻¹
//! T_jᵀ,
//! ```
//!
//! with `a_j` the basis of point `j` over the design points; then `dx = -S⁻¹ b` and
//! `dt_j = -(M_j + λ Dt_j)⁻¹ T_jᵀ (r_j + Σ_i a_ji dx_i)`. Building `S` costs `O(n)` (each
//! point adds a small block over its cell's support, `rayon` splits large point sets);
//! solving it costs `O((mD)³)`, independent of `n`. With `λ → 0`, `P_j` projects onto the
//! normal space: the step is the tangent-distance step of Wang, Pottmann and Liu (2006), which
//! converges where the alternation of a linear solve and a foot-point projection (Hoschek's
//! parameter correction, `alternate`) crawls.
//!
//! The step's `dt` only starts Newton's method for the exact local foot points on the trial
//! design: the trial is judged by the true sum of squared distances. At convergence a global
//! foot-point search checks that no data point has a closer foot point elsewhere on the
//! shape; if one has, the iteration goes on from there.
//!
//! On aerofoils the closest-point objective has long, flat, curved valleys (design points
//! can slide along the shape while the offsets barely change; the reduced system's condition
//! number reaches 1e8) and many local minima. The iteration walks such valleys in tens to
//! hundreds of steps, and stops when ten iterations together gain less than `ftol`.
//!
//! Tried and left out: the residuals' second-order terms (a Newton model of the
//! closest-point objective) and geodesic acceleration (Transtrum and Sethna 2012). On the
//! paper's cases both took about as many iterations and more often stopped in a worse local
//! minimum.

mod step;

use super::report::{SolveReport, StopReason};
use crate::bezier::Vector;
use crate::chain::shape::Shape;
use crate::closest::clamp01;
use crate::error::{Error, Result};
use crate::problem::fit_problem::FitProblem;
use crate::problem::offset::Metric;
use rayon::prelude::*;
use std::time::Instant;
use step::{assemble, solve_step, trial_starts};

/// Options of the Levenberg-Marquardt fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsqOptions {
    /// Most iterations (steps tried, accepted or not). Default 300.
    pub max_iterations: usize,
    /// Converged when the last 10 iterations together lowered the sum of squares by less
    /// than this fraction of it. Default 1e-7.
    pub ftol: f64,
    /// Converged when an accepted step moves no design coordinate by more than this fraction
    /// of the data extent. Default 1e-13.
    pub xtol: f64,
    /// Initial damping `λ`, relative to the diagonal of the normal equations (Marquardt's
    /// scaling). A large value makes the first steps short, gradient-like ones, which on the
    /// aerofoil files led to better local minima than bold first steps. Default 10.
    pub initial_damping: f64,
    /// How often a global foot-point search may restart the iteration after convergence, when
    /// it finds closer foot points elsewhere on the shape. Default 3.
    pub global_checks: usize,
    /// Iterations over which the `ftol` test measures the decrease. Default 10: on aerofoils
    /// the iteration crosses flat stretches of a valley where single steps gain little.
    pub window: usize,
    /// Smallest ratio of the actual to the predicted decrease of the sum of squares for a step
    /// to be accepted. Default 1e-4.
    pub accept_ratio: f64,
    /// `[down, up]`: the damping is divided by `down` (not below 1e-12) after an accepted step
    /// and multiplied by `up` after a rejected one; `None`, the default, is Nielsen's update
    /// (down by up to 3 as the model predicted well, up by 2, 4, 8, ... in a row).
    pub damping_factors: Option<[f64; 2]>,
    /// What the damping `λ` scales. Default [`DampingScale::Jacobian`].
    pub damping_scale: DampingScale,
    /// The method. Default [`LsqMethod::Joint`].
    pub method: LsqMethod,
}

/// Marquardt's scaling of the damping term `λ D` of the design step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DampingScale {
    /// `D` is the diagonal of `Jxᵀ W Jx`, the design points' own weight in the data (the same
    /// for every coordinate of a point). The default.
    #[default]
    Jacobian,
    /// `D` is the diagonal of the reduced normal matrix (after the parameters are eliminated),
    /// one per unknown: a direction that the data pin only along the shape is damped less.
    /// The adaptive search's short, warm-started fits converge on it as its own engine did.
    Reduced,
}

impl Default for LsqOptions {
    fn default() -> Self {
        LsqOptions {
            max_iterations: 300,
            ftol: 1e-7,
            xtol: 1e-13,
            initial_damping: 10.0,
            global_checks: 3,
            window: 10,
            accept_ratio: 1e-4,
            damping_factors: None,
            damping_scale: DampingScale::Jacobian,
            method: LsqMethod::Joint,
        }
    }
}

/// How [`lsq`] iterates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LsqMethod {
    /// Levenberg-Marquardt over the design and the parameters together (see the module docs).
    #[default]
    Joint,
    /// Hoschek's parameter correction, the baseline the joint method replaces: each iteration
    /// is a linear least-squares solve at fixed parameters, then a projection of every
    /// parameter to its local foot point. `max_iterations` rounds at most; only the observer
    /// stops it earlier.
    Alternate,
}

/// The result of a least-squares fit.
#[derive(Clone, Debug, PartialEq)]
pub struct LsqFit<P, const K: usize> {
    /// The fitted design points.
    pub design: Vec<P>,
    /// The parameter of every data point at the end (foot points for the closest-point
    /// metric, fixed parameters for anchored points and the corresponding-points metric).
    pub params: Vec<[f64; K]>,
    /// The objective `Σ_j |C(t_j) - q_j|²` at those parameters, in squared model units.
    pub sum_sq: f64,
    /// Iterations, evaluations, time, stop reason.
    pub report: SolveReport,
}

/// A test of a design and its parameters that the fit keeps true once it holds (see
/// [`LsqHooks::guard`]).
pub type Guard<'g, P, const K: usize> = &'g (dyn Fn(&[P], &[[f64; K]]) -> bool + Sync);

/// An observer of every iteration (the iterate, the current design and parameters), and of
/// the start (iteration 0); returning false stops the fit (reason
/// [`StopReason::MaxIterations`]).
pub type Observer<'o, P, const K: usize> = &'o mut dyn FnMut(&LsqIterate, &[P], &[[f64; K]]) -> bool;

/// What a caller may hook into [`lsq`].
pub struct LsqHooks<'h, P, const K: usize> {
    /// Once the guard holds, every step after which it would no longer hold is rejected (a
    /// barrier: the fit stays in the region the guard admits, e.g. chains that do not fold
    /// back on themselves). From a start where it fails, steps are taken freely until it
    /// holds. Joint method only.
    pub guard: Option<Guard<'h, P, K>>,
    /// Called after every iteration. With an observer, several starts run one after another.
    pub observe: Option<Observer<'h, P, K>>,
}

impl<P, const K: usize> Default for LsqHooks<'_, P, K> {
    fn default() -> Self {
        LsqHooks {
            guard: None,
            observe: None,
        }
    }
}

/// The state after one iteration, for progress reports and observers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsqIterate {
    /// Iterations so far (steps tried).
    pub iteration: usize,
    /// The (weighted) sum of squares at the current design, in squared model units.
    pub sum_sq: f64,
    /// The largest distance of any data point at the current design and parameters, model
    /// units.
    pub max: f64,
    /// The damping `λ` for the next step (0 for the alternating method).
    pub lambda: f64,
    /// True when this iteration's step was accepted.
    pub accepted: bool,
}

/// Where a least-squares fit starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Start<P, const K: usize> {
    /// One parameter per data point; the design is the linear least-squares fit at them.
    Params(Vec<[f64; K]>),
    /// A design, with one parameter per data point from which the local foot points are
    /// found.
    Design(Vec<P>, Vec<[f64; K]>),
    /// A design with its local foot points already found (the result of an earlier fit):
    /// taken as they are.
    Feet(Vec<P>, Vec<[f64; K]>),
}

/// The least-squares fit of `problem` from each of `starts`, one fit per start, in order
/// (several starts run in parallel unless an observer is hooked).
///
/// For the closest-point metric each start is followed by the method of `opts`:
/// Levenberg-Marquardt over the design and the parameters together ([`LsqMethod::Joint`],
/// see the module docs) or Hoschek's alternation ([`LsqMethod::Alternate`]). Anchored points
/// keep the problem's parameters whatever the start says. For the corresponding-points metric
/// the parameters are fixed and one linear solve at the problem's parameters is exact: one
/// fit, whatever the starts. [`LsqFit::best`] picks the lowest sum of squares.
pub fn lsq<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    starts: &[Start<S::Point, K>],
    opts: &LsqOptions,
    hooks: LsqHooks<'_, S::Point, K>,
) -> Result<Vec<LsqFit<S::Point, K>>> {
    let clock = Instant::now();
    if problem.metric() == Metric::Corresponding {
        let params = problem.params().to_vec();
        let design = problem.linear_fit(&params)?;
        let sum_sq = problem.sum_sq_at(&design, &params);
        return Ok(vec![LsqFit {
            design,
            params,
            sum_sq,
            report: SolveReport {
                iterations: 1,
                evaluations: 1,
                seconds: clock.elapsed().as_secs_f64(),
                stop: StopReason::Exact,
            },
        }]);
    }
    if starts.is_empty() {
        return Err(Error::invalid("lsq: at least one start is needed"));
    }
    let n = problem.points().len();
    // Anchored points keep the problem's parameters whatever the start says.
    let own = |t: &[[f64; K]]| -> Result<Vec<[f64; K]>> {
        if t.len() != n {
            return Err(Error::invalid(format!(
                "lsq: a start has {} parameters for {n} data points",
                t.len()
            )));
        }
        Ok(t.iter()
            .enumerate()
            .map(|(j, &t)| {
                if problem.is_anchored(j) {
                    problem.params()[j]
                } else {
                    clamp01(t)
                }
            })
            .collect())
    };
    let guard = hooks.guard;
    let run =
        |start: &Start<S::Point, K>, observe: Observer<'_, S::Point, K>| -> Result<LsqFit<S::Point, K>> {
            let (design, params, projected) = match start {
                Start::Params(t) => (None, own(t)?, false),
                Start::Design(x, t) => (Some(x.clone()), own(t)?, false),
                Start::Feet(x, t) => (Some(x.clone()), own(t)?, true),
            };
            match opts.method {
                LsqMethod::Joint => {
                    let design = match design {
                        Some(x) => x,
                        None => problem.linear_fit(&params)?,
                    };
                    levenberg_marquardt(problem, design, params, projected, opts, guard, observe)
                }
                LsqMethod::Alternate => alternate(problem, design, params, opts, observe),
            }
        };
    match hooks.observe {
        Some(observe) => starts.iter().map(|s| run(s, &mut *observe)).collect(),
        None if starts.len() == 1 => Ok(vec![run(&starts[0], &mut |_, _, _| true)?]),
        None => starts.par_iter().map(|s| run(s, &mut |_, _, _| true)).collect(),
    }
}

impl<P, const K: usize> LsqFit<P, K> {
    /// The fit with the least sum of squares (the first on ties), its report carrying the
    /// summed iterations and evaluations of all; `None` for no fits.
    #[must_use]
    pub fn best(fits: Vec<Self>) -> Option<Self> {
        pick(fits, |a, b| a.sum_sq < b.sum_sq)
    }
}

/// Levenberg-Marquardt on the design points and the data points' parameters together, from
/// `design` and `params` (see the module docs), under `guard`, calling `observe` after every
/// iteration.
#[allow(clippy::too_many_arguments)]
fn levenberg_marquardt<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: Vec<S::Point>,
    params: Vec<[f64; K]>,
    projected: bool,
    opts: &LsqOptions,
    guard: Option<Guard<'_, S::Point, K>>,
    observe: Observer<'_, S::Point, K>,
) -> Result<LsqFit<S::Point, K>> {
    let clock = Instant::now();
    if design.len() != problem.design_count() || params.len() != problem.points().len() {
        return Err(Error::invalid(format!(
            "levenberg_marquardt: {} design points and {} parameters given, the problem needs {} and {}",
            design.len(),
            params.len(),
            problem.design_count(),
            problem.points().len()
        )));
    }
    let (mut design, mut params) = (design, params);
    // Below this sum of squares the data lie on the shape to rounding.
    let tiny = (f64::EPSILON * problem.extent()).powi(2) * problem.points().len() as f64;
    let mut evaluations = 1;
    let mut iterations = 0;
    let (mut phi, mut max) = if projected {
        let d = problem.distances(&design, &params);
        let phi = d.iter().enumerate().map(|(j, e)| problem.weight(j) * e * e).sum();
        (phi, d.iter().fold(0.0_f64, |m, &e| m.max(e)))
    } else {
        problem.project_max(&design, &mut params)
    };
    let admits = |d: &[S::Point], t: &[[f64; K]]| guard.is_none_or(|g| g(d, t));
    let mut feasible = admits(&design, &params);
    let mut lambda = opts.initial_damping;
    let mut nu = 2.0;
    // The sum of squares after every iteration, for the windowed convergence test.
    let window = opts.window.max(1);
    let mut history = vec![phi];
    let mut checks = 0;
    // The point models at the current design and parameters, while no step has moved them.
    let mut kept = None;
    let start = LsqIterate {
        iteration: 0,
        sum_sq: phi,
        max,
        lambda,
        accepted: false,
    };
    let stop = loop {
        if iterations == 0 && !observe(&start, &design, &params) {
            break StopReason::MaxIterations;
        }
        let mut done = None;
        if phi <= tiny {
            done = Some(StopReason::Converged);
        } else if iterations >= opts.max_iterations {
            break StopReason::MaxIterations;
        } else {
            iterations += 1;
            let (normal, models) = assemble(problem, &design, &params, lambda, kept.take());
            let mut accepted = false;
            let solved = solve_step(
                problem.shape(),
                &normal,
                lambda,
                problem.constraint(),
                opts.damping_scale,
            );
            if let Some((step, damping_term)) = solved {
                let (starts, pred) = trial_starts(
                    problem,
                    &design,
                    &params,
                    &step,
                    damping_term,
                    lambda,
                    models.as_ref(),
                );
                let trial: Vec<S::Point> = design.iter().zip(&step).map(|(&x, &d)| x + d).collect();
                let mut trial_params = starts;
                let (phi_trial, max_trial) = problem.project_max(&trial, &mut trial_params);
                evaluations += 1;
                let rho = (phi - phi_trial) / pred;
                let trial_feasible = || admits(&trial, &trial_params);
                if pred > 0.0
                    && phi_trial.is_finite()
                    && rho > opts.accept_ratio
                    && (!feasible || trial_feasible())
                {
                    feasible = feasible || trial_feasible();
                    accepted = true;
                    let moved = step.iter().fold(0.0_f64, |m, d| m.max(d.max_abs()));
                    design = trial;
                    params = trial_params;
                    // Nielsen's update: shrink the damping by up to 3 when the model was good.
                    match opts.damping_factors {
                        Some([down, _]) => lambda = (lambda / down).max(1e-12),
                        None => lambda *= (1.0 - (2.0 * rho.min(1.0) - 1.0).powi(3)).max(1.0 / 3.0),
                    }
                    nu = 2.0;
                    phi = phi_trial;
                    max = max_trial;
                    if moved <= opts.xtol * problem.extent() {
                        done = Some(StopReason::Converged);
                    }
                }
            }
            if !accepted {
                kept = models;
                match opts.damping_factors {
                    Some([_, up]) => lambda *= up,
                    None => {
                        lambda *= nu;
                        nu *= 2.0;
                    }
                }
                if lambda > 1e16 {
                    done = Some(StopReason::NoProgress);
                }
            }
            history.push(phi);
            if history.len() > window && history[history.len() - 1 - window] - phi <= opts.ftol * phi {
                done = done.or(Some(StopReason::Converged));
            }
            let state = LsqIterate {
                iteration: iterations,
                sum_sq: phi,
                max,
                lambda,
                accepted,
            };
            if !observe(&state, &design, &params) && done.is_none() {
                break StopReason::MaxIterations;
            }
        }
        if let Some(reason) = done {
            if problem.metric() == Metric::Closest && checks < opts.global_checks && phi > tiny {
                let feet = problem.feet(&design, Some(&params));
                evaluations += 1;
                let phi_global: f64 = feet
                    .iter()
                    .enumerate()
                    .map(|(j, f)| problem.weight(j) * f.dist_sq)
                    .sum();
                if phi_global < phi * (1.0 - 1e-9) {
                    checks += 1;
                    params = feet.iter().map(|f| f.t).collect();
                    phi = phi_global;
                    max = feet.iter().fold(0.0_f64, |m, f| m.max(f.dist_sq)).sqrt();
                    history.clear();
                    history.push(phi);
                    lambda = opts.initial_damping;
                    nu = 2.0;
                    kept = None;
                    continue;
                }
            }
            break reason;
        }
    };
    Ok(LsqFit {
        design,
        params,
        sum_sq: phi,
        report: SolveReport {
            iterations,
            evaluations,
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    })
}

/// The fit that `better` prefers (the first on ties), its report carrying the summed
/// iterations and evaluations of all.
pub(crate) fn pick<F, T>(fits: Vec<T>, better: F) -> Option<T>
where
    F: Fn(&T, &T) -> bool,
    T: HasReport,
{
    let (mut iterations, mut evaluations) = (0, 0);
    let mut best: Option<T> = None;
    for fit in fits {
        iterations += fit.report().iterations;
        evaluations += fit.report().evaluations;
        if best.as_ref().is_none_or(|b| better(&fit, b)) {
            best = Some(fit);
        }
    }
    best.map(|mut b| {
        b.report_mut().iterations = iterations;
        b.report_mut().evaluations = evaluations;
        b
    })
}

/// Access to a result's solver report.
pub(crate) trait HasReport {
    /// The report.
    fn report(&self) -> &SolveReport;
    /// The report, to amend.
    fn report_mut(&mut self) -> &mut SolveReport;
}

impl<P, const K: usize> HasReport for LsqFit<P, K> {
    fn report(&self) -> &SolveReport {
        &self.report
    }
    fn report_mut(&mut self) -> &mut SolveReport {
        &mut self.report
    }
}

/// Hoschek's parameter correction (the baseline the joint method replaces): rounds of a
/// linear least-squares solve at fixed parameters and a projection of every parameter to its
/// local foot point, from `design` (projected first) or the linear fit at `params`, at most
/// `opts.max_iterations` rounds. Returns the last design with its foot points and sum of
/// squares.
fn alternate<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: Option<Vec<S::Point>>,
    mut params: Vec<[f64; K]>,
    opts: &LsqOptions,
    observe: Observer<'_, S::Point, K>,
) -> Result<LsqFit<S::Point, K>> {
    let clock = Instant::now();
    let rounds = opts.max_iterations.max(1);
    let (mut design, mut iterations, mut evaluations) = match design {
        Some(x) => (x, 0, 1),
        None => (problem.linear_fit(&params)?, 1, 0),
    };
    let (mut sum_sq, mut max) = problem.project_max(&design, &mut params);
    let mut stop = StopReason::MaxIterations;
    loop {
        let state = LsqIterate {
            iteration: iterations,
            sum_sq,
            max,
            lambda: 0.0,
            accepted: true,
        };
        if !observe(&state, &design, &params) {
            break;
        }
        if iterations >= rounds {
            break;
        }
        design = problem.linear_fit(&params)?;
        (sum_sq, max) = problem.project_max(&design, &mut params);
        iterations += 1;
        evaluations += 1;
        if !sum_sq.is_finite() {
            stop = StopReason::NoProgress;
            break;
        }
    }
    Ok(LsqFit {
        design,
        params,
        sum_sq,
        report: SolveReport {
            iterations,
            evaluations: evaluations.max(1),
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
    use crate::problem::CurveProblem;
    use glam::{DVec2, DVec3};

    /// A cubic C1 chain of `segments` segments whose design point `i` is `(i step, wave(i))`.
    fn wavy(segments: usize, step: f64, wave: impl Fn(f64) -> f64) -> (ChainLayout, CurveChain<DVec2>) {
        let layout = ChainLayout::uniform(3, segments, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * step, wave(i as f64)))
            .collect();
        (layout.clone(), CurveChain::new(layout, design).unwrap())
    }

    /// The fit from the problem's own parameters.
    fn own<S: Shape<K>, const K: usize>(p: &FitProblem<'_, S, K>, opts: &LsqOptions) -> LsqFit<S::Point, K> {
        lsq(
            p,
            &[Start::Params(p.params().to_vec())],
            opts,
            LsqHooks::default(),
        )
        .unwrap()
        .remove(0)
    }

    #[test]
    fn recovers_a_chain_from_points_sampled_off_its_chord_length_parameters() {
        let (layout, chain) = wavy(4, 0.2, |x| 0.3 * (1.1 * x).sin());
        // Uneven sampling, so the chord-length start is off and the parameters must move.
        let pts: Vec<DVec2> = (0..120)
            .map(|i| chain.eval((i as f64 / 119.0).powf(1.4)))
            .collect();
        let p = CurveProblem::curve(layout, &pts, Metric::Closest).unwrap();
        let fit = own(&p, &LsqOptions::default());
        assert!(fit.sum_sq < 1e-24, "sum_sq {}", fit.sum_sq);
        let (stats, _) = p.stats(&fit.design);
        assert!(stats.max < 1e-12, "max {}", stats.max);
        assert!(fit.report.converged());
        for (a, b) in fit.design.iter().zip(chain.design()) {
            assert!((*a - *b).length() < 1e-9, "{a} vs {b}");
        }
    }

    #[test]
    fn the_joint_step_beats_alternation_on_noisy_data() {
        let (layout, chain) = wavy(3, 0.25, |x| 0.4 * (0.9 * x).cos());
        let pts: Vec<DVec2> = (0..90)
            .map(|i| {
                let t = (i as f64 / 89.0).powf(0.7);
                chain.eval(t) + DVec2::new(1e-3 * (37.0 * t).sin(), 1e-3 * (23.0 * t).cos())
            })
            .collect();
        let p = CurveProblem::curve(layout, &pts, Metric::Closest).unwrap();
        let joint = own(&p, &LsqOptions::default());
        let slow = own(
            &p,
            &LsqOptions {
                method: LsqMethod::Alternate,
                max_iterations: 50,
                ..LsqOptions::default()
            },
        );
        assert_eq!(slow.report.iterations, 50);
        assert!(joint.report.converged());
        assert!(joint.sum_sq < slow.sum_sq, "{} vs {}", joint.sum_sq, slow.sum_sq);
        // The optimum is stationary: the gradient of the objective (a sum of `2 φ_i r_j`
        // terms) is tiny next to the size of its terms, `2 Σ |r_j|`.
        let mut g = vec![DVec2::ZERO; joint.design.len()];
        let mut cache = Vec::new();
        p.objective_grad(&joint.design, &mut cache, &mut g);
        let gmax = g.iter().map(|v| v.max_abs()).fold(0.0, f64::max);
        let scale = 2.0 * p.stats(&joint.design).0.sum;
        assert!(gmax < 1e-6 * scale, "gradient {gmax} against {scale}");
    }

    #[test]
    fn recovers_a_patch_grid_from_a_cloud_with_perturbed_parameters() {
        let layout = GridLayout::uniform((3, 3), (2, 2), Continuity::C1).unwrap();
        let design: Vec<DVec3> =
            layout.design_from(|a, b| DVec3::new(a, b, 0.2 * (2.5 * a).sin() * (1.5 * b + 0.3).cos()));
        let grid = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        // A 25 x 25 cloud sampled on the grid; the fit starts from parameters off by up to 0.02
        // and must recover the surface and the sampling parameters.
        let mut pts = Vec::new();
        let mut params = Vec::new();
        for i in 0..25 {
            for j in 0..25 {
                let (u, v) = (i as f64 / 24.0, j as f64 / 24.0);
                pts.push(grid.eval(u, v));
                let wobble = 0.02 * ((7 * i + 3 * j) as f64).sin();
                params.push([(u + wobble).clamp(0.0, 1.0), (v - wobble).clamp(0.0, 1.0)]);
            }
        }
        let corners = [0, 24, 600, 624];
        for &c in &corners {
            params[c] = [(c / 25) as f64 / 24.0, (c % 25) as f64 / 24.0];
        }
        let p = FitProblem::grid(layout, &pts, params, Metric::Closest)
            .unwrap()
            .with_anchors(&corners)
            .unwrap();
        let fit = own(&p, &LsqOptions::default());
        assert!(fit.sum_sq < 1e-20, "sum_sq {}", fit.sum_sq);
        let fitted = p.patch_grid(&fit.design).unwrap();
        assert!(fitted.continuity_error() < 1e-9);
        let (stats, _) = p.stats(&fit.design);
        assert!(stats.max < 1e-10, "max {}", stats.max);
    }
}
