//! The hybrid methods `ga+lsq` and `cmaes+lsq`: an evolutionary run on a population
//! objective, then the least-squares polish of its result on the fitting problem.

use super::evo::PopulationObjective;
use super::evo::{evolve, EvoHooks, EvoOptions, EvoResult};
use super::lsq::{lsq, Guard, LsqHooks, LsqOptions, Start};
use super::method::Method;
use super::report::SolveReport;
use crate::chain::shape::Shape;
use crate::error::{Error, Result};
use crate::problem::FitProblem;
use std::time::Instant;

/// One stage of a fit, for reports.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// `ga`, `cmaes` or `lsq`.
    pub method: String,
    /// Its effort.
    pub report: SolveReport,
}

/// What an evolutionary fit adds to a fit's report.
#[derive(Clone, Debug, PartialEq)]
pub struct EvoSummary {
    /// The evolutionary run.
    pub run: EvoResult,
    /// The stages: the evolutionary one, then the least-squares polish when asked for.
    pub stages: Vec<Stage>,
    /// For a curve hybrid's polish (which also tries the least-squares method's own starts):
    /// whether the fit polished from the evolved design won. `None` without a polish.
    pub polish_from_evolved: Option<bool>,
}

/// The least-squares polish: [`lsq`] on `problem` from `design` and its
/// foot points, kept where `guard` admits once it holds. Returns the polished design and the
/// solver's report.
pub fn polish<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: Vec<S::Point>,
    opts: &LsqOptions,
    guard: Option<Guard<'_, S::Point, K>>,
) -> Result<(Vec<S::Point>, SolveReport)> {
    let params: Vec<[f64; K]> = problem.feet(&design, None).iter().map(|f| f.t).collect();
    let hooks = LsqHooks { guard, observe: None };
    let fit = lsq(problem, &[Start::Design(design, params)], opts, hooks)?
        .into_iter()
        .next()
        .ok_or_else(|| Error::Numerical("lsq: the polish produced no fit".into()))?;
    Ok((fit.design, fit.report))
}

/// The evolutionary stage on `evo`, then (with `polish_after`) the least-squares polish on
/// `problem` under `guard`: the design, the combined report and the summary.
#[allow(clippy::too_many_arguments)]
pub fn evolve_then_polish<S: Shape<K>, const K: usize>(
    evo: &dyn PopulationObjective,
    problem: &FitProblem<'_, S, K>,
    algorithm: Method,
    polish_after: bool,
    options: &EvoOptions,
    lsq: &LsqOptions,
    guard: Option<Guard<'_, S::Point, K>>,
    hooks: &mut EvoHooks<'_>,
) -> Result<(Vec<S::Point>, SolveReport, EvoSummary)> {
    let run = evolve(evo, algorithm, options, hooks)?;
    let clock = Instant::now();
    let mut design = FitProblem::<S, K>::from_flat(&run.design);
    let mut stages = vec![Stage {
        method: algorithm.name().to_string(),
        report: run.report,
    }];
    let mut report = run.report;
    if polish_after {
        let (polished, r) = polish(problem, design, lsq, guard)?;
        design = polished;
        stages.push(Stage {
            method: "lsq".to_string(),
            report: r,
        });
        report.iterations += r.iterations;
        report.evaluations += r.evaluations;
        report.stop = r.stop;
    }
    // The run's seconds (with those before a checkpoint it resumed from), then the polish.
    report.seconds = run.report.seconds + clock.elapsed().as_secs_f64();
    let polish_from_evolved = polish_after.then_some(true);
    Ok((
        design,
        report,
        EvoSummary {
            run,
            stages,
            polish_from_evolved,
        },
    ))
}
