//! The evolutionary methods: a real-coded genetic algorithm and CMA-ES, on the population
//! evaluator (one evaluator call per generation, on the GPU or the CPU), for curve chains and
//! patch grids alike.
//!
//! - [`PopulationObjective`]: what they optimise, a box-bounded vector with a start, scored a
//!   population at a time; the fitting problem is one ([`crate::fit::population`]: closest-
//!   point offsets on the population evaluator), any other objective can be.
//! - [`Evolution`]: one run, generation by generation ([`Evolution::step`]), with
//!   [`Evolution::checkpoint`] / [`Evolution::resume`] that continue bit-identically.
//! - [`evolve`]: a whole run with a per-generation callback;
//!   [`polish`](crate::optim::hybrid::polish) runs the least-squares fit from its result (the
//!   `ga+lsq` and `cmaes+lsq` methods); [`fit_grid_evo`](crate::fit::fit_grid_evo) does both for a
//!   patch grid (curves: [`crate::fit::fit_curve`]).
//!
//! **Reproducibility.** Random numbers come from ChaCha8 streams fixed by the seed, the
//! generation and the individual; sorting breaks ties by index; sums over individuals run in
//! fixed chunks. The same seed and backend give bit-identical runs whatever the thread count,
//! and a checkpoint holds everything else (population or strategy, parameters, counters).

pub mod checkpoint;
pub mod cmaes;
pub mod ga;
pub mod objective;
mod rng;
pub mod watch;

pub use checkpoint::Checkpoint;
pub use cmaes::{default_lambda, CmaesOptions, CmaesState};
pub use ga::GaOptions;
pub use objective::{Fnv, PopulationObjective, Score, Scorer};
pub use watch::Watched;

use self::cmaes::Cmaes;
use self::ga::{initial_population, Ga};
use self::rng::Streams;
use super::method::Method;
use super::report::{SolveReport, StopReason};
use crate::error::{Error, Result};
use crate::eval::{Backend, BackendInfo, GpuOptions};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Instant;

// The evolutionary driver's callers name its methods ([`Method::EVOLUTIONARY`]) so.
pub use super::method::Method as Algorithm;

/// Options of the evolutionary methods, for every objective they run on (chain and grid fits,
/// aerodynamic shapes): the size and length of a run, its randomness, stopping rules and
/// operators. Fields an objective has no use for (the fitting problems' projections and
/// bounds, for an aerodynamic objective) are ignored by it.
#[derive(Clone, Debug, PartialEq)]
pub struct EvoOptions {
    /// Individuals per generation (CMA-ES: `λ`), 4 to [`MAX_POPULATION`]. `None`: the
    /// objective's default ([`PopulationObjective::default_population`]; the fitting
    /// problems: 1024 for the GA, `4 + ⌊3 ln n⌋` for CMA-ES with `n` design variables).
    /// Default `None`.
    pub population: Option<usize>,
    /// Generations after the initial population, 1 to [`MAX_GENERATIONS`] (a resumed run
    /// counts the generations before its checkpoint). `None`: the objective's default
    /// ([`PopulationObjective::default_generations`]; the fitting problems: 500 for the GA,
    /// pycma's `100 + 150 (n + 3)² / √λ` for CMA-ES, which usually stops earlier, when the
    /// objective is flat). Default `None`.
    pub generations: Option<usize>,
    /// Seed of every random stream. Default 1.
    pub seed: u64,
    /// Where populations are evaluated. Default [`Backend::Auto`].
    pub backend: Backend,
    /// Foot-point Newton steps per data point and individual (0: offsets at the parameters of
    /// the last projection, a corresponding-point measure). Default 3.
    pub newton: u32,
    /// Generations between projections of the data onto the best design so far, in f64.
    /// Default 1 (every generation).
    pub reproject_every: usize,
    /// Samples per segment (per patch side for grids) of those projections. Default 16.
    pub samples: usize,
    /// Stop once the best sum of squares is at most this (model units squared); 0: no
    /// target. Default 0.
    pub target: f64,
    /// Stop when the best score has not improved by the fraction
    /// [`stall_tolerance`](Self::stall_tolerance) of its size for this many generations; 0:
    /// never. Default 0.
    pub stall_generations: usize,
    /// Relative improvement that resets the stall count. Default 1e-6.
    pub stall_tolerance: f64,
    /// Standard deviation of the initial population around the start (GA), or the initial
    /// step size `σ` (CMA-ES), as a fraction of the objective's extent
    /// ([`PopulationObjective::extent`]: the data's, an aerofoil's chord). Default 0.02.
    pub spread: f64,
    /// Box bounds: the bounding box of the data (and, for grids, of the start) grown on every
    /// side by this fraction of its largest side. Default 0.1.
    pub margin: f64,
    /// Options of the GA.
    pub ga: GaOptions,
    /// Options of CMA-ES.
    pub cmaes: CmaesOptions,
    /// GPU settings. Default [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for EvoOptions {
    fn default() -> Self {
        EvoOptions {
            population: None,
            generations: None,
            seed: 1,
            backend: Backend::Auto,
            newton: 3,
            reproject_every: 1,
            samples: 16,
            target: 0.0,
            stall_generations: 0,
            stall_tolerance: 1e-6,
            spread: 0.02,
            margin: 0.1,
            ga: GaOptions::default(),
            cmaes: CmaesOptions::default(),
            gpu: GpuOptions::default(),
        }
    }
}

/// The fitting problems' GA population.
pub const GA_POPULATION: usize = 1024;
/// The fitting problems' GA generation limit.
pub const GA_GENERATIONS: usize = 500;
/// The largest population (individuals per generation) a run may ask for.
pub const MAX_POPULATION: usize = 1 << 20;
/// The largest generation limit a run may ask for (its history keeps 40 bytes a generation:
/// 400 MB at the limit).
pub const MAX_GENERATIONS: usize = 10_000_000;
/// The most design variables one generation may hold, population × variables: 256 MiB of f32
/// a copy (a run keeps a few: parents, children, the evaluator's buffers).
pub const MAX_POPULATION_VALUES: usize = 1 << 26;

/// The fitting problems' population of `method` on `n` design variables: [`GA_POPULATION`]
/// for the GA, [`default_lambda`] for CMA-ES.
#[must_use]
pub fn default_population(method: Method, n: usize) -> usize {
    match method {
        Method::Ga => GA_POPULATION,
        _ => default_lambda(n),
    }
}

/// The fitting problems' generation limit of `method` on `n` design variables with `size`
/// individuals a generation: [`GA_GENERATIONS`] for the GA, pycma's
/// `100 + 150 (n + 3)² / √λ` for CMA-ES.
#[must_use]
pub fn default_generations(method: Method, n: usize, size: usize) -> usize {
    match method {
        Method::Ga => GA_GENERATIONS,
        _ => 100 + (150.0 * ((n + 3) as f64).powi(2) / (size as f64).sqrt()) as usize,
    }
}

/// Check that a generation of `size` individuals of `n` design variables fits in memory
/// ([`MAX_POPULATION_VALUES`]), before anything is allocated for it.
pub fn check_generation_size(size: usize, n: usize) -> Result<()> {
    if size.checked_mul(n).is_none_or(|v| v > MAX_POPULATION_VALUES) {
        return Err(Error::invalid(format!(
            "a population of {size} individuals of {n} design variables is more than the \
             {MAX_POPULATION_VALUES} values a generation may hold: at most {} individuals",
            MAX_POPULATION_VALUES / n.max(1)
        )));
    }
    Ok(())
}

impl EvoOptions {
    /// Check every field; the message names the option and its allowed range (the spread's
    /// as a fraction of the data extent, the fitting problems' extent).
    pub fn check(&self) -> Result<()> {
        self.check_with_extent("the data extent")
    }

    /// [`check`](Self::check) for a run on `problem`: the spread's message names its extent
    /// ([`PopulationObjective::extent_name`]).
    pub fn check_for(&self, problem: &dyn PopulationObjective) -> Result<()> {
        self.check_with_extent(problem.extent_name())
    }

    fn check_with_extent(&self, extent: &str) -> Result<()> {
        if let Some(p) = self.population {
            if !(4..=MAX_POPULATION).contains(&p) {
                return Err(Error::invalid(format!(
                    "the population must be between 4 and {MAX_POPULATION}, not {p}"
                )));
            }
        }
        if let Some(g) = self.generations {
            if !(1..=MAX_GENERATIONS).contains(&g) {
                return Err(Error::invalid(format!(
                    "the generations must be between 1 and {MAX_GENERATIONS}, not {g}"
                )));
            }
        }
        if self.reproject_every == 0 {
            return Err(Error::invalid(
                "the projection interval must be at least one generation",
            ));
        }
        if self.samples == 0 {
            return Err(Error::invalid(
                "the projection needs at least one sample per segment",
            ));
        }
        Error::check_non_negative("the target", self.target)?;
        Error::check_non_negative("the stall tolerance", self.stall_tolerance)?;
        if !(self.spread > 0.0) || !self.spread.is_finite() {
            return Err(Error::invalid(format!(
                "the initial spread must be a finite fraction > 0 of {extent}, not {}",
                self.spread
            )));
        }
        Error::check_non_negative("the bounds margin", self.margin)?;
        self.ga.check()?;
        self.cmaes.check()
    }

    /// Individuals per generation of `method` on `problem`: [`population`](Self::population),
    /// or the problem's default.
    #[must_use]
    pub fn size(&self, problem: &dyn PopulationObjective, method: Method) -> usize {
        self.population
            .unwrap_or_else(|| problem.default_population(method))
    }

    /// The generation limit of `method` on `problem`: [`generations`](Self::generations), or
    /// the problem's default.
    #[must_use]
    pub fn generation_limit(&self, problem: &dyn PopulationObjective, method: Method) -> usize {
        self.generations
            .unwrap_or_else(|| problem.default_generations(method, self.size(problem, method)))
    }
}

/// One generation's line of the history.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// The generation (0: the initial population).
    pub generation: u64,
    /// The best sum of squares so far (the evaluator's f32 measure plus anchors).
    pub best: f64,
    /// The mean sum of squares of this generation (finite scores only).
    pub mean: f64,
    /// Individuals evaluated so far.
    pub evaluations: u64,
    /// Wall-clock seconds so far.
    pub seconds: f64,
}

/// Why an evolutionary run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum EvoStop {
    /// The generation limit.
    Generations,
    /// The target sum of squares was reached.
    Target,
    /// No improvement for the stall limit.
    Stall,
    /// CMA-ES: the sampling spread fell below the tolerance.
    StepSize,
    /// CMA-ES: the covariance became too ill-conditioned.
    Condition,
    /// CMA-ES: the generation bests have been flat for the flatness window.
    Flat,
}

impl EvoStop {
    /// The solver-neutral reason.
    #[must_use]
    pub fn reason(self) -> StopReason {
        match self {
            EvoStop::Generations => StopReason::MaxIterations,
            EvoStop::Target | EvoStop::StepSize | EvoStop::Flat => StopReason::Converged,
            EvoStop::Stall | EvoStop::Condition => StopReason::NoProgress,
        }
    }
}

impl fmt::Display for EvoStop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            EvoStop::Generations => "generation limit",
            EvoStop::Target => "target reached",
            EvoStop::Stall => "stalled",
            EvoStop::StepSize => "step size below tolerance",
            EvoStop::Condition => "covariance ill-conditioned",
            EvoStop::Flat => "objective flat",
        })
    }
}

// One per run: the size difference does not matter.
#[allow(clippy::large_enum_variant)]
enum Engine {
    Ga(Ga),
    Cmaes(Cmaes),
}

/// One evolutionary run on a problem, advanced a generation at a time.
pub struct Evolution<'p> {
    problem: &'p dyn PopulationObjective,
    algorithm: Method,
    options: EvoOptions,
    fingerprint: u64,
    size: usize,
    streams: Streams,
    scorer: Box<dyn Scorer + 'p>,
    effort: Effort,
    engine: Engine,
    generation: u64,
    evaluations: u64,
    seconds_before: f64,
    clock: Instant,
    best: Vec<f32>,
    best_score: Score,
    stall_reference: f64,
    stall_since: u64,
    history: Vec<Progress>,
}

/// The fingerprint of a run: the problem's, the method and the options that shape the run.
fn run_fingerprint(
    problem: &dyn PopulationObjective,
    algorithm: Method,
    options: &EvoOptions,
    size: usize,
) -> u64 {
    let mut h = Fnv::new();
    h.bytes(&problem.fingerprint().to_le_bytes());
    h.bytes(algorithm.name().as_bytes());
    h.usize(size);
    h.bytes(&options.seed.to_le_bytes());
    h.usize(options.newton as usize);
    h.usize(options.reproject_every);
    h.usize(options.samples);
    h.f64s(&[options.spread]);
    match algorithm {
        Method::Cmaes => {
            h.usize(options.cmaes.resample);
        }
        _ => {
            let g = &options.ga;
            h.usize(g.tournament);
            h.f64s(&[
                g.crossover_rate,
                g.crossover_eta,
                g.mutation_rate.unwrap_or(-1.0),
                g.mutation_eta,
                g.elite_fraction,
                g.line_rate,
                g.covariance_rate,
                g.covariance_pool,
            ]);
        }
    }
    h.finish()
}

/// The mean of the scores `problem` counts as feasible (`+∞` when none is), summed in order.
fn mean_feasible(problem: &dyn PopulationObjective, scores: &[Score]) -> f64 {
    let (sum, count) = scores
        .iter()
        .filter(|s| problem.feasible(s))
        .fold((0.0, 0usize), |(s, c), x| (s + x.sum_sq, c + 1));
    if count == 0 {
        f64::INFINITY
    } else {
        sum / count as f64
    }
}

/// The best score that counts as an improvement on `reference` by the fraction `tolerance` of
/// its size (objectives may be negative; `+∞` stays `+∞`).
fn improvement_threshold(reference: f64, tolerance: f64) -> f64 {
    if reference >= 0.0 {
        reference * (1.0 - tolerance)
    } else {
        reference * (1.0 + tolerance)
    }
}

/// The population of `algorithm` on `problem` under `options`, once the options, the method
/// and the generation's memory ([`check_generation_size`]) are checked.
fn checked_size(problem: &dyn PopulationObjective, algorithm: Method, options: &EvoOptions) -> Result<usize> {
    options.check_for(problem)?;
    if !Method::EVOLUTIONARY.contains(&algorithm) {
        return Err(Error::invalid(format!(
            "{algorithm} is not an evolutionary method (ga or cmaes)"
        )));
    }
    let size = options.size(problem, algorithm);
    check_generation_size(size, problem.dim())?;
    Ok(size)
}

/// The index of the best score (ties: the first).
fn best_index(scores: &[Score]) -> usize {
    (0..scores.len())
        .min_by(|&a, &b| scores[a].before(a, &scores[b], b))
        .unwrap_or(0)
}

impl<'p> Evolution<'p> {
    /// Start a run: check the options, project the data onto the start, build the evaluator
    /// and evaluate generation 0 (the GA's initial population; CMA-ES's start point).
    pub fn new(
        problem: &'p dyn PopulationObjective,
        algorithm: Method,
        options: &EvoOptions,
    ) -> Result<Self> {
        let size = checked_size(problem, algorithm, options)?;
        let n = problem.dim();
        let streams = Streams::new(options.seed);
        let mut scorer = problem.scorer(None, options)?;
        let mut effort = Effort::default();
        let spread = options.spread * problem.extent();
        let clock = Instant::now();
        let (engine, best, best_score, evaluations) = match algorithm {
            Method::Ga => {
                let mut pop = initial_population(problem, size, spread, &streams);
                let mut scores = vec![Score::WORST; size];
                score(&mut *scorer, &mut effort, &mut pop, &mut scores)?;
                let k = best_index(&scores);
                let best = pop[k * n..(k + 1) * n].to_vec();
                let s = scores[k];
                (Engine::Ga(Ga::new(pop, scores)), best, s, size as u64)
            }
            _ => {
                let bounds = problem.bounds();
                let mut start: Vec<f32> = problem
                    .start()
                    .iter()
                    .zip(bounds)
                    .map(|(&x, &[lo, hi])| ga::to_f32(x.clamp(lo, hi), lo, hi))
                    .collect();
                let mut s = [Score::WORST];
                score(&mut *scorer, &mut effort, &mut start, &mut s)?;
                let state = CmaesState::new(problem.start(), spread);
                (Engine::Cmaes(Cmaes::new(state, size)), start, s[0], 1)
            }
        };
        let mean = match &engine {
            Engine::Ga(g) => mean_feasible(problem, &g.scores),
            Engine::Cmaes(_) => best_score.sum_sq,
        };
        let history = vec![Progress {
            generation: 0,
            best: best_score.sum_sq,
            mean,
            evaluations,
            seconds: clock.elapsed().as_secs_f64(),
        }];
        Ok(Evolution {
            problem,
            algorithm,
            fingerprint: run_fingerprint(problem, algorithm, options, size),
            options: options.clone(),
            size,
            streams,
            scorer,
            effort,
            engine,
            generation: 0,
            evaluations,
            seconds_before: 0.0,
            clock,
            best,
            best_score,
            stall_reference: best_score.sum_sq,
            stall_since: 0,
            history,
        })
    }

    /// Continue a run from a checkpoint. The problem, method and the options that shape the run
    /// (population, seed, Newton steps, projection, operators) must be those it was written with
    /// (else [`Error::Invalid`]); the generation limit, target, stall options and CMA-ES restarts
    /// may differ. On the same backend the continuation is bit-identical to a run that was never
    /// interrupted.
    pub fn resume(
        problem: &'p dyn PopulationObjective,
        algorithm: Method,
        options: &EvoOptions,
        checkpoint: &Checkpoint,
    ) -> Result<Self> {
        let size = checked_size(problem, algorithm, options)?;
        let n = problem.dim();
        let fingerprint = run_fingerprint(problem, algorithm, options, size);
        if checkpoint.algorithm != algorithm {
            return Err(Error::invalid(format!(
                "the checkpoint is of a {} run, not {algorithm}",
                checkpoint.algorithm
            )));
        }
        if checkpoint.fingerprint != fingerprint || checkpoint.dim != n || checkpoint.size != size {
            return Err(Error::invalid(format!(
                "the checkpoint was written for another problem or other settings (fingerprint {:016x}, \
                 this run {fingerprint:016x}): the data, layout, method, population, seed and optimiser \
                 options must be those of the interrupted run",
                checkpoint.fingerprint
            )));
        }
        checkpoint
            .check_values()
            .and_then(|()| checkpoint.check_bounds(problem.bounds()))
            .map_err(|e| Error::invalid(format!("the checkpoint cannot be resumed: {e}")))?;
        let scorer = problem.scorer(Some(checkpoint.params.clone()), options)?;
        let engine = match (&checkpoint.cmaes, algorithm) {
            (None, Method::Ga) => {
                Engine::Ga(Ga::new(checkpoint.population.clone(), checkpoint.scores.clone()))
            }
            (Some(state), Method::Cmaes) => {
                state.check(n)?;
                Engine::Cmaes(Cmaes::new(state.clone(), size))
            }
            _ => {
                return Err(Error::invalid(
                    "the checkpoint's strategy does not match its method",
                ))
            }
        };
        Ok(Evolution {
            problem,
            algorithm,
            fingerprint,
            options: options.clone(),
            size,
            streams: Streams::new(options.seed),
            scorer,
            effort: Effort {
                eval_seconds: checkpoint.eval_seconds,
                point_evals: checkpoint.point_evals,
            },
            engine,
            generation: checkpoint.generation,
            evaluations: checkpoint.evaluations,
            seconds_before: checkpoint.seconds,
            clock: Instant::now(),
            best: checkpoint.best.clone(),
            best_score: checkpoint.best_score,
            stall_reference: checkpoint.stall_reference,
            stall_since: checkpoint.stall_since,
            history: checkpoint.history.clone(),
        })
    }

    /// Run one generation: project the data onto the best design (when due), breed or sample
    /// the population, evaluate it in one evaluator call, update the best and the history.
    pub fn step(&mut self) -> Result<&Progress> {
        let g = self.generation + 1;
        let problem = self.problem;
        let n = problem.dim();
        if self.restart_due() {
            if let Engine::Cmaes(es) = &mut self.engine {
                let sum_sq = problem.measure(&problem.absolute(&es.state.mean), &self.options)?;
                es.state = es.state.restarted(sum_sq);
            }
            // The restarted strategy gets its own stall window.
            self.stall_reference = self.best_score.sum_sq;
            self.stall_since = self.generation;
        }
        // Anchor the evaluator where this generation will lie: at the GA's best (an elite, kept
        // in the population) and at CMA-ES's mean, around which it samples. CMA-ES's best so far
        // is a sample of some past generation that the mean may have left far behind, and the
        // evaluator scores individuals whose foot points lie beyond the reach of its reference
        // too high (the offsets are then upper bounds): anchored at a stale best, case 3 (degree
        // 5, 3 segments, P 1024) never scored a sample below it again and stopped 'flat' at
        // 1.7e-5 in f64 while its mean measured 8.6e-6. Over seeds 1-6 (CPU, P 1024) the mean
        // reaches the best minimum known 5, 5 and 6 times on cases 1, 2 and 3; the best so
        // far 2, 3 and 0 times.
        let design: Vec<f64> = match &self.engine {
            Engine::Cmaes(es) => es.state.mean.clone(),
            Engine::Ga(_) => self.best.iter().map(|&x| f64::from(x)).collect(),
        };
        self.scorer.recentre(g, &design)?;
        let (scorer, effort) = (&mut *self.scorer, &mut self.effort);
        let (pop, scores): (&[f32], &[Score]) = match &mut self.engine {
            Engine::Ga(ga) => {
                ga.breed(problem, &self.options.ga, &self.streams, g);
                score(scorer, effort, &mut ga.next, &mut ga.next_scores)?;
                ga.advance();
                (&ga.population, &ga.scores)
            }
            Engine::Cmaes(es) => {
                es.sample(problem, &self.options.cmaes, &self.streams, g);
                score(scorer, effort, &mut es.samples, &mut es.scores)?;
                es.update();
                (&es.samples, &es.scores)
            }
        };
        let k = best_index(scores);
        if scores[k].sum_sq < self.best_score.sum_sq {
            self.best_score = scores[k];
            self.best.copy_from_slice(&pop[k * n..(k + 1) * n]);
        }
        if self.best_score.sum_sq < improvement_threshold(self.stall_reference, self.options.stall_tolerance)
        {
            self.stall_reference = self.best_score.sum_sq;
            self.stall_since = g;
        }
        self.generation = g;
        self.evaluations += self.size as u64;
        self.history.push(Progress {
            generation: g,
            best: self.best_score.sum_sq,
            mean: mean_feasible(problem, scores),
            evaluations: self.evaluations,
            seconds: self.seconds(),
        });
        Ok(&self.history[self.history.len() - 1])
    }

    /// Why the run should stop now, if it should.
    #[must_use]
    pub fn stop(&self) -> Option<EvoStop> {
        let o = &self.options;
        if o.target > 0.0 && self.best_score.sum_sq <= o.target {
            return Some(EvoStop::Target);
        }
        if self.generation >= o.generation_limit(self.problem, self.algorithm) as u64 {
            return Some(EvoStop::Generations);
        }
        if o.stall_generations > 0 && self.generation - self.stall_since >= o.stall_generations as u64 {
            return Some(EvoStop::Stall);
        }
        // A converged CMA-ES run with restarts left goes on: the next step restarts it.
        self.converged().filter(|_| !self.restarts_left())
    }

    /// Why the CMA-ES strategy has converged, if it has (step size, condition, flatness);
    /// `None` for the GA.
    fn converged(&self) -> Option<EvoStop> {
        let Engine::Cmaes(es) = &self.engine else {
            return None;
        };
        let o = &self.options.cmaes;
        if es.state.spread() < o.tol_x * self.problem.extent() {
            return Some(EvoStop::StepSize);
        }
        if es.state.condition() > o.max_condition {
            return Some(EvoStop::Condition);
        }
        let last: Vec<f64> = es.scores.iter().map(|s| s.sum_sq).collect();
        let tol = |level: f64| o.tol_fun * self.scorer.resolution(level);
        es.state
            .flat(self.problem.dim(), self.size, &last, tol)
            .then_some(EvoStop::Flat)
    }

    /// True when the CMA-ES strategy has converged and has restarts left: the next
    /// [`step`](Self::step) restarts it.
    fn restart_due(&self) -> bool {
        self.restarts_left() && self.converged().is_some()
    }

    /// True when the CMA-ES strategy has restarts left ([`CmaesOptions::restarts`]); false for
    /// the GA.
    fn restarts_left(&self) -> bool {
        matches!(self.engine, Engine::Cmaes(_)) && self.restarts() < self.options.cmaes.restarts as u64
    }

    /// Restarts done by the CMA-ES strategy (0 for the GA).
    #[must_use]
    pub fn restarts(&self) -> u64 {
        match &self.engine {
            Engine::Cmaes(es) => es.state.restarts,
            Engine::Ga(_) => 0,
        }
    }

    /// Step until [`stop`](Self::stop) says why, calling `on_generation` after each step (an
    /// error from it ends the run with that error). Returns the reason.
    ///
    /// A run resumed from a checkpoint that had already stopped (its generations spent, its
    /// step size underflowed) takes no step: `on_generation` is called once on the resumed
    /// state, so that the run's outputs (history, checkpoint) are written from it.
    pub fn run(&mut self, on_generation: impl FnMut(&Evolution<'_>) -> Result<()>) -> Result<EvoStop> {
        drive(self, on_generation)
    }

    /// Continue this run with CMA-ES from its best individual (the `ga+cmaes` handover): the
    /// mean there, the step `spread × extent`, `λ` of [`EvoOptions::size`]. The generation
    /// count, evaluations, best, stall count, history and scorer carry on; from now on the run
    /// checkpoints, resumes ([`resume`](Self::resume) with [`Method::Cmaes`]) and stops as
    /// a CMA-ES run. Nothing happens when it already is one.
    pub fn switch_to_cmaes(&mut self) {
        if matches!(self.engine, Engine::Cmaes(_)) {
            return;
        }
        let problem = self.problem;
        let size = self.options.size(problem, Method::Cmaes);
        let mean: Vec<f64> = self.best.iter().map(|&x| f64::from(x)).collect();
        let state = CmaesState::new(&mean, self.options.spread * problem.extent());
        self.engine = Engine::Cmaes(Cmaes::new(state, size));
        self.algorithm = Method::Cmaes;
        self.size = size;
        self.fingerprint = run_fingerprint(problem, Method::Cmaes, &self.options, size);
    }

    /// What the scorer would hand a checkpoint now ([`Scorer::state`]).
    #[must_use]
    pub fn scorer_state(&self) -> Vec<[f64; 2]> {
        self.scorer.state()
    }

    /// Everything needed to continue this run bit-identically.
    #[must_use]
    pub fn checkpoint(&self) -> Checkpoint {
        let (population, scores, cmaes) = match &self.engine {
            Engine::Ga(ga) => (ga.population.clone(), ga.scores.clone(), None),
            Engine::Cmaes(es) => (Vec::new(), Vec::new(), Some(es.state.clone())),
        };
        Checkpoint {
            fingerprint: self.fingerprint,
            algorithm: self.algorithm,
            backend: self.scorer.info().to_string(),
            dim: self.problem.dim(),
            size: self.size,
            generation: self.generation,
            evaluations: self.evaluations,
            seconds: self.seconds(),
            eval_seconds: self.effort.eval_seconds,
            point_evals: self.effort.point_evals,
            params: self.scorer.state(),
            best: self.best.clone(),
            best_score: self.best_score,
            stall_reference: self.stall_reference,
            stall_since: self.stall_since,
            history: self.history.clone(),
            population,
            scores,
            cmaes,
        }
    }

    /// The method.
    #[must_use]
    pub fn algorithm(&self) -> Method {
        self.algorithm
    }

    /// Generations completed.
    #[must_use]
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The generation limit.
    #[must_use]
    pub fn generations(&self) -> usize {
        self.options.generation_limit(self.problem, self.algorithm)
    }

    /// Individuals per generation.
    #[must_use]
    pub fn size(&self) -> usize {
        self.size
    }

    /// The best individual so far (f32, as evaluated, in the objective's frame: see
    /// [`PopulationObjective::absolute`]) and its score.
    #[must_use]
    pub fn best(&self) -> (&[f32], Score) {
        (&self.best, self.best_score)
    }

    /// One line per generation so far (generation 0 first).
    #[must_use]
    pub fn history(&self) -> &[Progress] {
        &self.history
    }

    /// The backend and adapter that run the evaluations.
    #[must_use]
    pub fn info(&self) -> &BackendInfo {
        self.scorer.info()
    }

    /// CMA-ES's strategy (`None` for the GA).
    #[must_use]
    pub fn strategy(&self) -> Option<&CmaesState> {
        match &self.engine {
            Engine::Cmaes(es) => Some(&es.state),
            Engine::Ga(_) => None,
        }
    }

    /// Wall-clock seconds so far, including those before a checkpoint.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        self.seconds_before + self.clock.elapsed().as_secs_f64()
    }

    /// Individual × point evaluations per second of evaluator time.
    #[must_use]
    pub fn evals_per_second(&self) -> f64 {
        if self.effort.eval_seconds > 0.0 {
            self.effort.point_evals as f64 / self.effort.eval_seconds
        } else {
            0.0
        }
    }

    /// End the run: re-measure the candidates in f64 (the best individual; for CMA-ES also
    /// the mean, and the best mean an earlier run converged to when it restarted) and return
    /// the best.
    pub fn finish(self, stop: EvoStop) -> Result<EvoResult> {
        let mut candidates = vec![self.best.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>()];
        if let Engine::Cmaes(es) = &self.engine {
            candidates.push(es.state.mean.clone());
            if !es.state.kept_mean.is_empty() {
                candidates.push(es.state.kept_mean.clone());
            }
        }
        let mut best: Option<(Vec<f64>, f64)> = None;
        for c in candidates {
            let c = self.problem.absolute(&c);
            let m = self.problem.measure(&c, &self.options)?;
            if best.as_ref().is_none_or(|(_, b)| m < *b) {
                best = Some((c, m));
            }
        }
        let (design, sum_sq) = best.ok_or_else(|| Error::Numerical("no candidate design".into()))?;
        if design.iter().any(|x| !x.is_finite()) || !sum_sq.is_finite() {
            return Err(Error::Numerical(format!(
                "{} produced a non-finite design",
                self.algorithm
            )));
        }
        let seconds = self.seconds();
        Ok(EvoResult {
            design,
            sum_sq,
            score: self.best_score,
            report: SolveReport {
                iterations: self.generation as usize,
                evaluations: self.evaluations as usize,
                seconds,
                stop: stop.reason(),
            },
            stop,
            restarts: self.restarts(),
            size: self.size,
            backend: self.scorer.info().clone(),
            eval_seconds: self.effort.eval_seconds,
            point_evals: self.effort.point_evals,
            evals_per_second: self.evals_per_second(),
            history: self.history,
        })
    }
}

/// Seconds spent scoring and individual × work-unit evaluations done.
#[derive(Clone, Copy, Debug, Default)]
struct Effort {
    eval_seconds: f64,
    point_evals: u64,
}

/// Score `population` into `scores`, counting the time and the work in `effort`: the one
/// place a generation is evaluated. Under a team of processes ([`crate::team`]) rank 0's
/// population replaces every rank's, each rank measures its share of the rows, and every rank
/// absorbs the records of all of them, so every rank's run goes on from the same bits.
fn score(
    scorer: &mut dyn Scorer,
    effort: &mut Effort,
    population: &mut [f32],
    scores: &mut [Score],
) -> Result<()> {
    let clock = Instant::now();
    let n = population.len() / scores.len().max(1);
    let record = scorer.record();
    let records = crate::team::share_rows(scores.len(), record, population, |range, pop, out| {
        scorer.measure(&pop[range.start * n..range.end * n], out)
    })?;
    scorer.absorb(population, &records, scores);
    effort.eval_seconds += clock.elapsed().as_secs_f64();
    effort.point_evals += (scores.len() * scorer.work()) as u64;
    Ok(())
}

/// The outcome of an evolutionary run.
#[derive(Clone, Debug, PartialEq)]
pub struct EvoResult {
    /// The best design found, flat.
    pub design: Vec<f64>,
    /// Its objective re-measured in f64 (closest-point offsets by a global search, plus the
    /// anchored points).
    pub sum_sq: f64,
    /// The best score the evaluator gave (f32 arithmetic).
    pub score: Score,
    /// Generations (`iterations`), individuals evaluated, seconds, stop reason.
    pub report: SolveReport,
    /// The evolutionary stop reason.
    pub stop: EvoStop,
    /// CMA-ES restarts done ([`CmaesOptions::restarts`]; 0 for the GA).
    pub restarts: u64,
    /// Individuals per generation.
    pub size: usize,
    /// The backend and adapter that ran the evaluations.
    pub backend: BackendInfo,
    /// Seconds spent in the evaluator.
    pub eval_seconds: f64,
    /// Individual × point evaluations.
    pub point_evals: u64,
    /// `point_evals / eval_seconds`.
    pub evals_per_second: f64,
    /// One line per generation.
    pub history: Vec<Progress>,
}

/// A per-generation callback.
pub type GenerationHook<'a> = &'a mut dyn FnMut(&Evolution<'_>) -> Result<()>;

/// What a caller may hook into a long run.
#[derive(Default)]
pub struct EvoHooks<'a> {
    /// Called after every generation (progress display, history file, checkpoints); an error
    /// ends the run with that error.
    pub on_generation: Option<GenerationHook<'a>>,
    /// Continue from this checkpoint instead of starting afresh.
    pub resume: Option<Checkpoint>,
}

/// A whole run: from the start (or `hooks.resume`) until a stop criterion holds.
pub fn evolve(
    problem: &dyn PopulationObjective,
    algorithm: Method,
    options: &EvoOptions,
    hooks: &mut EvoHooks<'_>,
) -> Result<EvoResult> {
    let mut run = match &hooks.resume {
        Some(c) => Evolution::resume(problem, algorithm, options, c)?,
        None => Evolution::new(problem, algorithm, options)?,
    };
    let stop = match hooks.on_generation.as_mut() {
        Some(f) => run.run(|e| f(e))?,
        None => run.run(|_| Ok(()))?,
    };
    run.finish(stop)
}

/// A run that moves generation by generation: [`Evolution`], and the runs built on it, which
/// decide how a generation is taken and leave when to stop to the evolution inside.
pub(crate) trait Generations {
    /// One generation.
    fn next_generation(&mut self) -> Result<()>;
    /// The evolution the run steps.
    fn evolution(&self) -> &Evolution<'_>;
    /// Why the run should stop now, if it should.
    fn stop_reason(&self) -> Option<EvoStop> {
        self.evolution().stop()
    }
    /// Whether it has recorded a generation (a run resumed from a checkpoint has).
    fn has_history(&self) -> bool {
        !self.evolution().history.is_empty()
    }
}

impl Generations for Evolution<'_> {
    fn next_generation(&mut self) -> Result<()> {
        self.step().map(|_| ())
    }

    fn evolution(&self) -> &Evolution<'_> {
        self
    }
}

/// Step `run` until it says why it stops, calling `on_generation` after each step; a run
/// that has already stopped takes no step and, where it has a history (a resumed run), is
/// handed to `on_generation` once, so that its outputs are written.
pub(crate) fn drive<R: Generations>(
    run: &mut R,
    mut on_generation: impl FnMut(&R) -> Result<()>,
) -> Result<EvoStop> {
    if let Some(why) = run.stop_reason() {
        if run.has_history() {
            on_generation(run)?;
        }
        return Ok(why);
    }
    loop {
        run.next_generation()?;
        on_generation(run)?;
        if let Some(why) = run.stop_reason() {
            return Ok(why);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A test objective: `value` of the design in f64, between `bounds`, from `start`; its
    /// scorer records the designs it is centred on.
    struct Quadratic {
        start: Vec<f64>,
        bounds: Vec<[f64; 2]>,
        value: fn(&[f64]) -> f64,
        centres: Arc<Mutex<Vec<Vec<f64>>>>,
    }

    impl Quadratic {
        fn new(value: fn(&[f64]) -> f64, start: Vec<f64>) -> Self {
            let n = start.len();
            Quadratic {
                start,
                bounds: vec![[-1.0, 1.0]; n],
                value,
                centres: Arc::default(),
            }
        }
    }

    struct QuadraticScorer {
        value: fn(&[f64]) -> f64,
        centres: Arc<Mutex<Vec<Vec<f64>>>>,
        info: BackendInfo,
    }

    impl Scorer for QuadraticScorer {
        fn record(&self) -> usize {
            8
        }
        fn measure(&mut self, rows: &[f32], records: &mut [u8]) -> Result<()> {
            let n = rows.len() / (records.len() / 8).max(1);
            for (row, r) in rows.chunks_exact(n).zip(records.chunks_exact_mut(8)) {
                let x: Vec<f64> = row.iter().map(|&v| f64::from(v)).collect();
                r.copy_from_slice(&(self.value)(&x).to_le_bytes());
            }
            Ok(())
        }
        fn absorb(&mut self, _population: &[f32], records: &[u8], scores: &mut [Score]) {
            for (r, s) in records.chunks_exact(8).zip(scores.iter_mut()) {
                let mut b = [0u8; 8];
                b.copy_from_slice(r);
                *s = Score {
                    sum_sq: f64::from_le_bytes(b),
                    max: 0.0,
                };
            }
        }
        fn recentre(&mut self, _generation: u64, centre: &[f64]) -> Result<()> {
            self.centres.lock().unwrap().push(centre.to_vec());
            Ok(())
        }
        fn state(&self) -> Vec<[f64; 2]> {
            Vec::new()
        }
        fn info(&self) -> &BackendInfo {
            &self.info
        }
        fn work(&self) -> usize {
            1
        }
    }

    impl PopulationObjective for Quadratic {
        fn dim(&self) -> usize {
            self.start.len()
        }
        fn start(&self) -> &[f64] {
            &self.start
        }
        fn bounds(&self) -> &[[f64; 2]] {
            &self.bounds
        }
        fn extent(&self) -> f64 {
            1.0
        }
        fn fingerprint(&self) -> u64 {
            0
        }
        fn scorer<'s>(
            &'s self,
            _state: Option<Vec<[f64; 2]>>,
            _options: &EvoOptions,
        ) -> Result<Box<dyn Scorer + 's>> {
            Ok(Box::new(QuadraticScorer {
                value: self.value,
                centres: Arc::clone(&self.centres),
                info: BackendInfo {
                    backend: Backend::Cpu,
                    adapter: "test".into(),
                    fallback: None,
                },
            }))
        }
        fn measure(&self, design: &[f64], _options: &EvoOptions) -> Result<f64> {
            Ok((self.value)(design))
        }
    }

    /// A sum of squares about `(0.3, …)`.
    fn bowl(x: &[f64]) -> f64 {
        x.iter().map(|x| (x - 0.3).powi(2)).sum()
    }

    /// CMA-ES re-anchors its scorer at its mean, around which each generation is
    /// sampled (anchored at a stale best, case 3 stopped at 1.7e-5 instead of 2.3e-8); the GA
    /// at its best design, an elite of the population.
    #[test]
    fn the_scorer_is_centred_where_the_generation_lies() {
        let bowl = Quadratic::new(bowl, vec![0.0; 4]);
        let options = EvoOptions {
            population: Some(16),
            generations: Some(5),
            ..EvoOptions::default()
        };
        let mut run = Evolution::new(&bowl, Method::Cmaes, &options).unwrap();
        for _ in 0..5 {
            let mean = run.strategy().unwrap().mean.clone();
            run.step().unwrap();
            assert_eq!(bowl.centres.lock().unwrap().last(), Some(&mean));
        }
        let mut run = Evolution::new(&bowl, Method::Ga, &options).unwrap();
        for _ in 0..5 {
            let best: Vec<f64> = run.best().0.iter().map(|&x| f64::from(x)).collect();
            run.step().unwrap();
            assert_eq!(bowl.centres.lock().unwrap().last(), Some(&best));
        }
        // The mean has moved off the best sample (the test is not vacuous).
        let mut run = Evolution::new(&bowl, Method::Cmaes, &options).unwrap();
        run.step().unwrap();
        let best: Vec<f64> = run.best().0.iter().map(|&x| f64::from(x)).collect();
        assert_ne!(run.strategy().unwrap().mean, best);
    }

    /// A badly conditioned quadratic in rotated coordinates: `Σ_i 10^(4i/(n-1)) (q_iᵀ x)²`
    /// over the rows `q_i` of a rotation (a Householder reflection), minimum 0 at the origin.
    fn valley(x: &[f64]) -> f64 {
        let n = x.len();
        // Reflection about the unit vector v ∝ (1, 2, …, n): q_i = e_i - 2 v_i v.
        let norm = (1..=n).map(|k| (k * k) as f64).sum::<f64>().sqrt();
        let v: Vec<f64> = (1..=n).map(|k| k as f64 / norm).collect();
        let vx: f64 = v.iter().zip(x).map(|(a, b)| a * b).sum();
        (0..n)
            .map(|i| {
                let qx = x[i] - 2.0 * v[i] * vx;
                10f64.powf(4.0 * i as f64 / (n - 1) as f64) * qx * qx
            })
            .sum()
    }

    /// The GA's covariance mutation follows a rotated valley of condition 1e4 that steps along
    /// the axes crawl in: with it the GA ends far lower than with polynomial mutation alone
    /// (P 256, G 150, seed 1: 6.2e-9 against 0.59, from 4.1e3 at the start), and the same seed
    /// gives the same run.
    #[test]
    fn the_covariance_mutation_follows_a_rotated_valley() {
        let valley = Quadratic::new(valley, vec![0.3; 10]);
        let run = |covariance_rate: f64| {
            let options = EvoOptions {
                population: Some(256),
                generations: Some(150),
                spread: 0.1,
                ga: GaOptions {
                    covariance_rate,
                    ..GaOptions::default()
                },
                ..EvoOptions::default()
            };
            evolve(&valley, Method::Ga, &options, &mut EvoHooks::default())
                .unwrap()
                .sum_sq
        };
        let (with, without) = (run(GaOptions::default().covariance_rate), run(0.0));
        assert!(with < 1e-3 * without, "{with:e} against {without:e}");
        assert_eq!(
            with.to_bits(),
            run(GaOptions::default().covariance_rate).to_bits()
        );
    }
}
