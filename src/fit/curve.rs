//! `fit_curve`: one call from data points and a chain layout to a fitted chain, by any method
//! and metric, with the offsets and the solver's effort (what the CLI's `fit` reports).

use crate::bezier::Vector;
use crate::chain::{ChainLayout, CurveChain};
use crate::closest::FootOptions;
use crate::error::{Error, Result};
use crate::optim::bfgs::{bfgs, BfgsOptions};
use crate::optim::evo::{EvoHooks, EvoOptions};
use crate::optim::hybrid::{evolve_then_polish, EvoSummary, Stage};
use crate::optim::lsq::{lsq, pick, Guard, HasReport, LsqFit, LsqHooks, LsqOptions, Start};
use crate::optim::method::Method;
use crate::optim::nelder_mead::{nelder_mead, NelderMeadOptions};
use crate::optim::report::SolveReport;
use crate::problem::offset::{
    corresponding_stats, exponent_params, offset_stats, span_ratio, Metric, OffsetStats,
};
use crate::problem::CurveProblem;
use glam::DVec2;
use std::time::Instant;

/// Everything `fit_curve` needs besides the data and the layout.
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// The method, one of [`Method::CURVE`]. Default least squares.
    pub method: Method,
    /// The offset metric minimised and reported. Default closest point.
    pub metric: Metric,
    /// Anchor the first and last data points at the chain's ends (`t = 0` and `t = 1`) in
    /// the objective, so the chain spans the data instead of running past it (see
    /// [`FitProblem`](crate::problem::FitProblem)). Reported offsets are true closest-point offsets
    /// either way. Default true.
    pub anchor_ends: bool,
    /// The least-squares method starts from a linear solve at each of these
    /// parameterisations of the data: exponents `alpha` of [`exponent_params`] (1 chord
    /// length, 0.5 centripetal, 0 uniform). For the closest-point metric it also starts from
    /// the paper's start (design points picked from the data). The closest-point objective has
    /// many local minima and each start reaches one; the starts run in parallel. Default
    /// `[1.0, 0.5, 0.25]`.
    pub parametrizations: &'static [f64],
    /// Of the least-squares starts, those whose chain has a [`span_ratio`] at most this
    /// compete on the sum of squares; a chain above it has a stretch that loops away from the
    /// data or folds back (if every start has one, the lowest ratio wins). Default 3.
    pub max_span_ratio: f64,
    /// Foot-point search during the fit. Defaults: 32 samples per segment, 40 Newton steps.
    pub foot: FootOptions,
    /// Options of the least-squares method.
    pub lsq: LsqOptions,
    /// Options of Nelder-Mead.
    pub nelder_mead: NelderMeadOptions,
    /// Options of BFGS.
    pub bfgs: BfgsOptions,
    /// Options of the GA and CMA-ES (population, generations, seed, backend, ...).
    pub evo: EvoOptions,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            method: Method::default(),
            metric: Metric::default(),
            anchor_ends: true,
            parametrizations: &[1.0, 0.5, 0.25],
            max_span_ratio: 3.0,
            foot: FootOptions::default(),
            lsq: LsqOptions::default(),
            nelder_mead: NelderMeadOptions::default(),
            bfgs: BfgsOptions::default(),
            evo: EvoOptions::default(),
        }
    }
}

/// A fitted chain with its offsets and the effort it took.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveFit<P: Vector> {
    /// The fitted chain (design and expanded control points).
    pub chain: CurveChain<P>,
    /// Offsets under the fit's metric.
    pub offset: OffsetStats<P>,
    /// Closest-point offsets (the same as `offset` for the closest metric), measured afresh
    /// with 48 samples per segment and Newton's method.
    pub closest: OffsetStats<P>,
    /// The method used.
    pub method: Method,
    /// The metric minimised.
    pub metric: Metric,
    /// [`span_ratio`] of the chain at the data's foot points (the ends anchored as in the fit):
    /// near 1 when the chain follows the data, far above it when a stretch of chain loops away
    /// or folds back.
    pub span_ratio: f64,
    /// Iterations and evaluations of the solver; `seconds` covers the whole fit, from the
    /// data to the final offsets. For the evolutionary methods `iterations` counts
    /// generations and `evaluations` individuals (plus the polish's, for `ga+lsq` and
    /// `cmaes+lsq`).
    pub report: SolveReport,
    /// The evolutionary run and the stages, for `ga`, `cmaes`, `ga+lsq` and `cmaes+lsq`.
    pub evolution: Option<EvoSummary>,
}

impl<P: Vector> CurveFit<P> {
    /// The cap that cut the fit short (`"evaluation cap"`, `"iteration cap"`): the solver's, or
    /// an evolutionary method's polish's (a generation limit is the evolutionary stage's own
    /// end, not a cap); `None` when it stopped on its own.
    #[must_use]
    pub fn stopped(&self) -> Option<&'static str> {
        match &self.evolution {
            Some(evo) => evo.stages[1..].iter().find_map(|s| s.report.cap()),
            None => self.report.cap(),
        }
    }
}

/// Fit a chain with `layout` to `points` (ordered along the curve, e.g. a Selig contour).
///
/// `lsq` starts from each of `opts.parametrizations` with a linear solve and from the paper's
/// start, and keeps the best loop-free fit (see [`FitOptions::max_span_ratio`]). `nelder-mead` and
/// `bfgs` start as the paper does, from design points picked from the data at an even increment
/// ([`crate::problem::increment_start`]), and minimise the metric's sum of squares over the
/// flattened design points `x0, y0, x1, y1, …`. With `anchor_ends` (the default) all three minimise
/// the closest-point sum with the first and last data points tied to the chain's ends; the reported
/// offsets are always true closest-point offsets.
pub fn fit_curve<P: Vector>(points: &[P], layout: ChainLayout, opts: &FitOptions) -> Result<CurveFit<P>> {
    fit_curve_with(points, layout, opts, &mut EvoHooks::default())
}

/// [`fit_curve`] with hooks into the evolutionary methods' runs (a per-generation callback for
/// progress and checkpoints, a checkpoint to resume from); the other methods ignore them.
///
/// `ga` and `cmaes` minimise the closest-point sum of squares on the population evaluator
/// (see [`crate::optim::evo`]), with the first and last data points tied to the chain's ends when
/// `anchor_ends` is set, and start from the paper's start (the GA: a population spread around
/// it). They fit plane points only, and the closest-point metric only.
pub fn fit_curve_with<P: Vector>(
    points: &[P],
    layout: ChainLayout,
    opts: &FitOptions,
    hooks: &mut EvoHooks<'_>,
) -> Result<CurveFit<P>> {
    let clock = Instant::now();
    let problem = CurveProblem::curve_with(layout.clone(), points, opts.metric, opts.foot, opts.anchor_ends)?;
    let mut evolution = None;
    // Keep every least-squares run free of folds once it is: the closest-point objective
    // cannot see a stretch of chain that doubles back where the data are nearly straight, and
    // with uniform breaks such folds can lower the sum of squares (a fold moves a join).
    let limit = opts.max_span_ratio;
    let guard = |design: &[P], params: &[[f64; 1]]| -> bool {
        problem.chain(design).is_ok_and(|chain| {
            let t: Vec<f64> = params.iter().map(|t| t[0]).collect();
            span_ratio(&chain, points, &t) <= limit
        })
    };
    let (design, mut report) = match opts.method {
        Method::GaCmaes => {
            return Err(Error::invalid(format!(
                "{} is not a method of curve fits",
                opts.method
            )))
        }
        Method::Ga | Method::Cmaes | Method::GaLsq | Method::CmaesLsq => {
            let Some((algorithm, polish_after)) = opts.method.evolutionary() else {
                return Err(Error::invalid(format!(
                    "{} is not an evolutionary method",
                    opts.method
                )));
            };
            if P::DIM != 2 {
                return Err(Error::invalid(format!(
                    "{} fits plane curves: these points have {} coordinates",
                    opts.method,
                    P::DIM
                )));
            }
            if opts.metric != Metric::Closest {
                return Err(Error::invalid(format!(
                    "{} minimises closest-point offsets; the corresponding-point metric is for lsq, \
                     nelder-mead and bfgs",
                    opts.method
                )));
            }
            // The population evaluator takes plane points: the same problem over them.
            let plane: Vec<DVec2> = points
                .iter()
                .map(|p| DVec2::new(p.coord(0), p.coord(1)))
                .collect();
            let evo =
                CurveProblem::<DVec2>::curve_with(layout, &plane, opts.metric, opts.foot, opts.anchor_ends)?
                    .with_bounds(opts.evo.margin)?;
            let (mut design, mut report, mut summary) = evolve_then_polish(
                &evo, &problem, algorithm, false, &opts.evo, &opts.lsq, None, hooks,
            )?;
            if polish_after {
                // The polish is the least-squares method with the evolved design as one more
                // start (the first, so it wins ties): the hybrid ends at the better of the
                // basin the evolution found and the ones lsq's own starts reach.
                let polish_clock = Instant::now();
                let feet: Vec<[f64; 1]> = problem.feet(&design, None).iter().map(|f| f.t).collect();
                let best = best_lsq(&problem, points, opts, &guard, Some(Start::Design(design, feet)))?;
                let mut r = best.fit.report;
                r.seconds = polish_clock.elapsed().as_secs_f64();
                summary.stages.push(Stage {
                    method: "lsq".to_string(),
                    report: r,
                });
                summary.polish_from_evolved = Some(best.start == 0);
                report.iterations += r.iterations;
                report.evaluations += r.evaluations;
                report.stop = r.stop;
                design = best.fit.design;
            }
            evolution = Some(summary);
            (design, report)
        }
        Method::Lsq => {
            let best = best_lsq(&problem, points, opts, &guard, None)?;
            (best.fit.design, best.fit.report)
        }
        Method::NelderMead => {
            let x0 = CurveProblem::<P>::to_flat(&problem.increment_start()?);
            let m = nelder_mead(&mut problem.objective_fn(), &x0, &opts.nelder_mead);
            (CurveProblem::<P>::from_flat(&m.x), m.report)
        }
        Method::Bfgs => {
            let x0 = CurveProblem::<P>::to_flat(&problem.increment_start()?);
            let m = bfgs(&mut problem.objective_fn(), &x0, &opts.bfgs);
            (CurveProblem::<P>::from_flat(&m.x), m.report)
        }
    };
    if design.iter().any(|p| !p.is_finite_point()) {
        return Err(Error::Numerical(format!(
            "{} produced non-finite design points",
            opts.method
        )));
    }
    let chain = problem.chain(&design)?;
    let closest = offset_stats(&chain, points)?;
    let feet = problem.feet(&design, None);
    let span = span_ratio(&chain, points, &feet.iter().map(|f| f.t[0]).collect::<Vec<f64>>());
    let offset = match opts.metric {
        Metric::Closest => closest,
        Metric::Corresponding => corresponding_stats(&chain, points)?,
    };
    report.seconds = clock.elapsed().as_secs_f64();
    Ok(CurveFit {
        chain,
        offset,
        closest,
        method: opts.method,
        metric: opts.metric,
        span_ratio: span,
        report,
        evolution,
    })
}

/// The least-squares method: a linear solve at each of `opts.parametrizations` and (closest
/// metric) the paper's start, each followed by guarded Levenberg-Marquardt, plus `extra` as the
/// first start when given; the best fold-free fit wins (the lowest span ratio if none is).
fn best_lsq<P: Vector>(
    problem: &CurveProblem<'_, P>,
    points: &[P],
    opts: &FitOptions,
    guard: Guard<'_, P, 1>,
    extra: Option<Start<P, 1>>,
) -> Result<Scored<P>> {
    let mut starts: Vec<Start<P, 1>> = extra.into_iter().collect();
    for &alpha in opts.parametrizations {
        starts.push(Start::Params(
            exponent_params(points, alpha)?.into_iter().map(|t| [t]).collect(),
        ));
    }
    if opts.metric == Metric::Closest {
        starts.push(Start::Design(
            problem.increment_start()?,
            problem.params().to_vec(),
        ));
    }
    let hooks = LsqHooks {
        guard: Some(guard),
        observe: None,
    };
    let fits = lsq(problem, &starts, &opts.lsq, hooks)?;
    // Rank by (has a loop, sum of squares), loops by their span ratio.
    let scored = fits
        .into_iter()
        .enumerate()
        .map(|(start, fit)| {
            let chain = problem.chain(&fit.design)?;
            let t: Vec<f64> = fit.params.iter().map(|t| t[0]).collect();
            let ratio = span_ratio(&chain, points, &t);
            Ok(Scored { fit, ratio, start })
        })
        .collect::<Result<Vec<_>>>()?;
    let limit = opts.max_span_ratio;
    pick(scored, |a, b| match (a.ratio <= limit, b.ratio <= limit) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => a.fit.sum_sq < b.fit.sum_sq,
        (false, false) => a.ratio < b.ratio,
    })
    .ok_or_else(|| Error::Numerical("lsq: no start produced a fit".into()))
}

/// A least-squares fit with its chain's span ratio and the index of its start.
struct Scored<P> {
    fit: LsqFit<P, 1>,
    ratio: f64,
    start: usize,
}

impl<P> HasReport for Scored<P> {
    fn report(&self) -> &SolveReport {
        &self.fit.report
    }
    fn report_mut(&mut self) -> &mut SolveReport {
        &mut self.fit.report
    }
}
