//! Aerodynamic shape optimisation: the GA and CMA-ES of [`crate::fit::evo`] over a
//! [`DesignSpace`] (an adapted encoding's stored numbers as bounded offsets), every generation
//! scored in one call of the panel-method evaluator ([`AeroBatch`] on the GPU or the CPU).
//!
//! This is a driver of its own beside [`crate::fit::evo::Evolution`], which is built around a
//! distance-to-data problem: it reuses the operators (`Ga`, `Cmaes` through
//! [`SearchSpace`]), the random streams, the scores, the progress lines and the checkpoint
//! format, and replaces only the objective. It is meant to move onto the project's general
//! problem type once there is one.
//!
//! **Constraints and bad shapes** (see [`super::batch`]): the optimisers rank the kernel's
//! score, which is the objective for a valid shape meeting the constraints, `1e3 + shortfall`
//! for a valid shape breaking them, and `1e6 + violation` for an unusable one; so every
//! feasible shape ranks before every infeasible one, and infeasible ones by how far they are
//! from feasible (Deb's rules, as a penalty). Every individual flagged is counted per reason.
//!
//! **Checkpoints** are [`Checkpoint`]s: the population (GA) or the strategy (CMA-ES), the best,
//! the counters and the history; the per-reason counts travel in its `params` field, one
//! `(count, 0)` pair per reason of [`flags::NAMES`] then the individuals evaluated. A run
//! resumed from one continues bit-identically on the same backend.

use super::batch::{build_aero_evaluator, flags, AeroBatch, AeroEval, AeroEvaluator, AeroResult, Objective};
use super::design::DesignSpace;
use crate::error::{Error, Result};
use crate::eval::{Backend, BackendInfo, GpuOptions};
use crate::fit::evo::cmaes::{default_lambda, flat_window, Cmaes};
use crate::fit::evo::ga::{initial_population, Ga};
use crate::fit::evo::problem::Fnv;
use crate::fit::evo::rng::Streams;
use crate::fit::evo::{
    Algorithm, Checkpoint, CmaesOptions, CmaesState, GaOptions, Progress, Score, SearchSpace,
};
use serde::Serialize;
use std::fmt;
use std::str::FromStr;
use std::time::Instant;

/// An optimisation method.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The genetic algorithm.
    Ga,
    /// CMA-ES.
    Cmaes,
    /// The GA for the first half of the generations, then CMA-ES from its best.
    GaCmaes,
}

impl Method {
    /// The name on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Method::Ga => "ga",
            Method::Cmaes => "cmaes",
            Method::GaCmaes => "ga+cmaes",
        }
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "ga" => Ok(Method::Ga),
            "cmaes" | "cma-es" => Ok(Method::Cmaes),
            "ga+cmaes" => Ok(Method::GaCmaes),
            _ => Err(Error::invalid(format!(
                "unknown method '{s}' (expected ga, cmaes or ga+cmaes)"
            ))),
        }
    }
}

/// Options of an optimisation.
#[derive(Clone, Debug, PartialEq)]
pub struct OptimiseOptions {
    /// Individuals per generation. `None`: 256 for the GA, `4 + ⌊3 ln n⌋` for CMA-ES (the
    /// CMA-ES stage of `ga+cmaes` too). Default `None`.
    pub population: Option<usize>,
    /// Generations in all, at least 1. `None`: 200 for the GA, 1000 for CMA-ES and
    /// `ga+cmaes` (CMA-ES usually stops earlier, flat). Default `None`.
    pub generations: Option<usize>,
    /// Seed of every random stream. Default 1.
    pub seed: u64,
    /// Where populations are evaluated. Default [`Backend::Auto`].
    pub backend: Backend,
    /// Spread of the GA's initial population around the start, and CMA-ES's initial step,
    /// as a fraction of the chord. Default 0.01.
    pub spread: f64,
    /// Stop when the best score has not improved by the fraction `stall_tolerance` of its
    /// size for this many generations; 0: never. Default 0.
    pub stall: usize,
    /// Relative improvement that resets the stall count. Default 1e-6.
    pub stall_tolerance: f64,
    /// Options of the GA.
    pub ga: GaOptions,
    /// Options of CMA-ES.
    pub cmaes: CmaesOptions,
    /// GPU settings. Default [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for OptimiseOptions {
    fn default() -> Self {
        OptimiseOptions {
            population: None,
            generations: None,
            seed: 1,
            backend: Backend::Auto,
            spread: 0.01,
            stall: 0,
            stall_tolerance: 1e-6,
            ga: GaOptions::default(),
            cmaes: CmaesOptions::default(),
            gpu: GpuOptions::default(),
        }
    }
}

/// The most individuals per generation accepted.
pub const MAX_POPULATION: usize = 1 << 20;
/// The most generations accepted.
pub const MAX_GENERATIONS: usize = 10_000_000;

impl OptimiseOptions {
    /// Check every field; the message names the option and its range.
    pub fn check(&self) -> Result<()> {
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
        if !(self.spread > 0.0) || !self.spread.is_finite() {
            return Err(Error::invalid(format!(
                "the spread must be a finite fraction > 0 of the chord, not {}",
                self.spread
            )));
        }
        if !(self.stall_tolerance >= 0.0) || !self.stall_tolerance.is_finite() {
            return Err(Error::invalid("the stall tolerance must be finite and ≥ 0"));
        }
        self.ga.check()?;
        self.cmaes.check()
    }

    /// Individuals per generation of `stage` on `n` variables.
    #[must_use]
    pub fn size(&self, stage: Algorithm, n: usize) -> usize {
        self.population.unwrap_or(match stage {
            Algorithm::Ga => 256,
            Algorithm::Cmaes => default_lambda(n),
        })
    }

    /// The generation limit of `method`.
    #[must_use]
    pub fn generation_limit(&self, method: Method) -> usize {
        self.generations.unwrap_or(match method {
            Method::Ga => 200,
            Method::Cmaes | Method::GaCmaes => 1000,
        })
    }
}

/// An optimisation problem: the design space, and the population problem on its node map.
#[derive(Clone, Debug, PartialEq)]
pub struct AeroProblem {
    /// The design variables and their node map.
    pub space: DesignSpace,
    /// The angle, objective and constraints on that map.
    pub batch: AeroBatch,
}

impl AeroProblem {
    /// A 64-bit fingerprint: the node map, the box, the angle, the objective and constraints.
    #[must_use]
    pub fn fingerprint(&self) -> u64 {
        let mut h = Fnv::new();
        let map = self.space.map();
        h.usize(map.base.len());
        for p in &map.base {
            h.f64s(&[p.x, p.y]);
        }
        for col in &map.columns {
            for p in col {
                h.f64s(&[p.x, p.y]);
            }
        }
        for b in self.space.bounds() {
            h.f64s(b);
        }
        h.f64s(&[self.batch.alpha()]);
        match self.batch.objective() {
            Objective::None => h.bytes(b"none"),
            Objective::MaxCl => h.bytes(b"max-cl"),
            Objective::Inverse(t) => {
                h.bytes(b"inverse");
                h.f64s(&t.table);
            }
        }
        let c = self.batch.constraints();
        h.f64s(&[c.min_thickness.unwrap_or(f64::NAN), c.cm_min.unwrap_or(f64::NAN)]);
        h.finish()
    }
}

impl SearchSpace for AeroProblem {
    fn dim(&self) -> usize {
        self.space.dim()
    }
    fn bounds(&self) -> &[[f64; 2]] {
        self.space.bounds()
    }
    fn start(&self) -> &[f64] {
        self.space.start()
    }
}

/// Individuals flagged, per reason, over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Reasons {
    /// Individuals evaluated.
    pub evaluated: u64,
    /// Non-finite nodes or coefficients.
    pub non_finite: u64,
    /// A surface folding back in x.
    pub fold: u64,
    /// Upper below lower (negative thickness).
    pub crossing: u64,
    /// Coincident nodes, no chord or a singular system.
    pub singular: u64,
    /// Thinner than the minimum thickness.
    pub thin: u64,
    /// CM below its minimum.
    pub cm: u64,
}

impl Reasons {
    fn count(&mut self, results: &[AeroResult]) {
        self.evaluated += results.len() as u64;
        for r in results {
            let f = r.flags;
            self.non_finite += u64::from(f & flags::NON_FINITE != 0);
            self.fold += u64::from(f & flags::FOLD != 0);
            self.crossing += u64::from(f & flags::CROSSING != 0);
            self.singular += u64::from(f & flags::SINGULAR != 0);
            self.thin += u64::from(f & flags::THIN != 0);
            self.cm += u64::from(f & flags::CM != 0);
        }
    }

    fn to_params(self) -> Vec<[f64; 2]> {
        [
            self.non_finite,
            self.fold,
            self.crossing,
            self.singular,
            self.thin,
            self.cm,
            self.evaluated,
        ]
        .iter()
        .map(|&c| [c as f64, 0.0])
        .collect()
    }

    fn from_params(p: &[[f64; 2]]) -> Result<Reasons> {
        let ok = p.len() == 7
            && p.iter()
                .all(|c| c[0] >= 0.0 && c[0].fract() == 0.0 && c[1] == 0.0);
        if !ok {
            return Err(Error::invalid(
                "the checkpoint's reason counts are not those of an aerodynamic run",
            ));
        }
        let c = |k: usize| p[k][0] as u64;
        Ok(Reasons {
            non_finite: c(0),
            fold: c(1),
            crossing: c(2),
            singular: c(3),
            thin: c(4),
            cm: c(5),
            evaluated: c(6),
        })
    }
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Stop {
    /// The generation limit.
    Generations,
    /// No improvement for the stall limit.
    Stall,
    /// CMA-ES: the sampling spread fell below the tolerance.
    StepSize,
    /// CMA-ES: the covariance became too ill-conditioned.
    Condition,
    /// CMA-ES: the generation bests have been flat for the flatness window.
    Flat,
}

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Stop::Generations => "generation limit",
            Stop::Stall => "stalled",
            Stop::StepSize => "step size below tolerance",
            Stop::Condition => "covariance ill-conditioned",
            Stop::Flat => "objective flat",
        })
    }
}

// One per run: the size difference does not matter.
#[allow(clippy::large_enum_variant)]
enum Engine {
    Ga(Ga),
    Cmaes(Cmaes),
}

/// One optimisation run, a generation at a time.
pub struct Optimisation<'p> {
    problem: &'p AeroProblem,
    method: Method,
    options: OptimiseOptions,
    fingerprint: u64,
    streams: Streams,
    evaluator: Box<dyn AeroEvaluator>,
    results: Vec<AeroResult>,
    engine: Engine,
    generation: u64,
    evaluations: u64,
    eval_seconds: f64,
    seconds_before: f64,
    clock: Instant,
    best: Vec<f32>,
    best_score: Score,
    best_result: AeroResult,
    stall_reference: f64,
    stall_since: u64,
    history: Vec<Progress>,
    reasons: Reasons,
}

/// The fingerprint of a run: the problem's, the method, the seed and the options that shape
/// it (not the generation limit or the stall options).
fn run_fingerprint(problem: &AeroProblem, method: Method, options: &OptimiseOptions) -> u64 {
    let n = problem.dim();
    let mut h = Fnv::new();
    h.bytes(&problem.fingerprint().to_le_bytes());
    h.bytes(method.name().as_bytes());
    h.usize(options.size(Algorithm::Ga, n));
    h.usize(options.size(Algorithm::Cmaes, n));
    h.bytes(&options.seed.to_le_bytes());
    h.f64s(&[options.spread]);
    let g = &options.ga;
    h.usize(g.tournament);
    h.f64s(&[
        g.crossover_rate,
        g.crossover_eta,
        g.mutation_rate.unwrap_or(-1.0),
        g.mutation_eta,
        g.elite_fraction,
    ]);
    h.usize(options.cmaes.resample);
    if method == Method::GaCmaes {
        h.usize(options.generation_limit(method));
    }
    h.finish()
}

/// The mean of the finite scores of valid individuals (`+∞` when there are none).
fn mean_valid(scores: &[Score]) -> f64 {
    let (sum, count) = scores
        .iter()
        .filter(|s| s.sum_sq.is_finite() && s.sum_sq < super::batch::PENALTY_CONSTRAINT)
        .fold((0.0, 0usize), |(s, c), x| (s + x.sum_sq, c + 1));
    if count == 0 {
        f64::INFINITY
    } else {
        sum / count as f64
    }
}

fn best_index(scores: &[Score]) -> usize {
    (0..scores.len())
        .min_by(|&a, &b| scores[a].before(a, &scores[b], b))
        .unwrap_or(0)
}

impl<'p> Optimisation<'p> {
    /// Start a run: check the options, build the evaluator, evaluate generation 0 (the GA's
    /// initial population; CMA-ES's start).
    pub fn new(problem: &'p AeroProblem, method: Method, options: &OptimiseOptions) -> Result<Self> {
        options.check()?;
        let evaluator = build_aero_evaluator(&problem.batch.kernel(), options.backend, &options.gpu)?;
        let mut run = Optimisation {
            problem,
            method,
            fingerprint: run_fingerprint(problem, method, options),
            options: options.clone(),
            streams: Streams::new(options.seed),
            evaluator,
            results: Vec::new(),
            engine: Engine::Ga(Ga::new(Vec::new(), Vec::new())),
            generation: 0,
            evaluations: 0,
            eval_seconds: 0.0,
            seconds_before: 0.0,
            clock: Instant::now(),
            best: vec![0.0; problem.dim()],
            best_score: Score::WORST,
            best_result: AeroResult::default(),
            stall_reference: f64::INFINITY,
            stall_since: 0,
            history: Vec::new(),
            reasons: Reasons::default(),
        };
        let n = problem.dim();
        let spread = options.spread * problem.space.chord();
        let mean = match method {
            Method::Ga | Method::GaCmaes => {
                let size = options.size(Algorithm::Ga, n);
                let pop = initial_population(problem, size, spread, &run.streams);
                let mut scores = vec![Score::WORST; size];
                run.evaluate(&pop, &mut scores)?;
                run.note_best(&pop, &scores);
                let mean = mean_valid(&scores);
                run.engine = Engine::Ga(Ga::new(pop, scores));
                mean
            }
            Method::Cmaes => {
                let start: Vec<f32> = vec![0.0; n];
                let mut s = [Score::WORST];
                run.evaluate(&start, &mut s)?;
                run.note_best(&start, &s);
                let size = options.size(Algorithm::Cmaes, n);
                run.engine = Engine::Cmaes(Cmaes::new(CmaesState::new(problem.start(), spread), size));
                s[0].sum_sq
            }
        };
        run.stall_reference = run.best_score.sum_sq;
        run.history.push(Progress {
            generation: 0,
            best: run.best_score.sum_sq,
            mean,
            evaluations: run.evaluations,
            seconds: run.seconds(),
        });
        Ok(run)
    }

    /// Continue a run from a checkpoint written by the same problem, method and options (the
    /// generation limit and stall options may differ).
    pub fn resume(
        problem: &'p AeroProblem,
        method: Method,
        options: &OptimiseOptions,
        checkpoint: &Checkpoint,
    ) -> Result<Self> {
        options.check()?;
        let n = problem.dim();
        let fingerprint = run_fingerprint(problem, method, options);
        if checkpoint.fingerprint != fingerprint || checkpoint.dim != n {
            return Err(Error::invalid(format!(
                "the checkpoint was written for another problem or other settings (fingerprint {:016x}, \
                 this run {fingerprint:016x}): the start, tolerance, target, angle, constraints, method, \
                 population, seed and optimiser options must be those of the interrupted run",
                checkpoint.fingerprint
            )));
        }
        let stage = checkpoint.algorithm;
        let allowed = match method {
            Method::Ga => stage == Algorithm::Ga,
            Method::Cmaes => stage == Algorithm::Cmaes,
            Method::GaCmaes => true,
        };
        if !allowed || checkpoint.size != options.size(stage, n) {
            return Err(Error::invalid(format!(
                "the checkpoint holds a {stage} stage of {} individuals, which a {method} run of this \
                 population does not have",
                checkpoint.size
            )));
        }
        let engine = match (&checkpoint.cmaes, stage) {
            (None, Algorithm::Ga) if checkpoint.population.len() == checkpoint.size * n => {
                Engine::Ga(Ga::new(checkpoint.population.clone(), checkpoint.scores.clone()))
            }
            (Some(state), Algorithm::Cmaes) => {
                state.check(n)?;
                Engine::Cmaes(Cmaes::new(state.clone(), checkpoint.size))
            }
            _ => {
                return Err(Error::invalid(
                    "the checkpoint's strategy does not match its method",
                ))
            }
        };
        if checkpoint.best.len() != n || checkpoint.best.iter().any(|x| !x.is_finite()) {
            return Err(Error::invalid(
                "the checkpoint's best individual is not a finite design",
            ));
        }
        let evaluator = build_aero_evaluator(&problem.batch.kernel(), options.backend, &options.gpu)?;
        let mut run = Optimisation {
            problem,
            method,
            options: options.clone(),
            fingerprint,
            streams: Streams::new(options.seed),
            evaluator,
            results: Vec::new(),
            engine,
            generation: checkpoint.generation,
            evaluations: checkpoint.evaluations,
            eval_seconds: checkpoint.eval_seconds,
            seconds_before: checkpoint.seconds,
            clock: Instant::now(),
            best: checkpoint.best.clone(),
            best_score: checkpoint.best_score,
            best_result: AeroResult::default(),
            stall_reference: checkpoint.stall_reference,
            stall_since: checkpoint.stall_since,
            history: checkpoint.history.clone(),
            reasons: Reasons::from_params(&checkpoint.params)?,
        };
        // The best individual's kernel result again (a checkpoint keeps only its score).
        let best = run.best.clone();
        let mut s = [Score::WORST];
        run.results.resize(1, AeroResult::default());
        run.evaluator.evaluate(&best, &mut run.results)?;
        run.best_result = run.results[0];
        s[0] = Score {
            sum_sq: f64::from(run.results[0].score),
            max: 0.0,
        };
        if s[0].sum_sq.to_bits() != run.best_score.sum_sq.to_bits() {
            return Err(Error::invalid(format!(
                "the checkpoint's best individual scores {} here, {} when it was written: another \
                 backend or build",
                s[0].sum_sq, run.best_score.sum_sq
            )));
        }
        Ok(run)
    }

    /// Score every row of `population` into `scores` (one evaluator call), counting reasons.
    fn evaluate(&mut self, population: &[f32], scores: &mut [Score]) -> Result<()> {
        self.results.resize(scores.len(), AeroResult::default());
        let clock = Instant::now();
        self.evaluator.evaluate(population, &mut self.results)?;
        self.eval_seconds += clock.elapsed().as_secs_f64();
        self.evaluations += scores.len() as u64;
        self.reasons.count(&self.results);
        for (s, r) in scores.iter_mut().zip(&self.results) {
            *s = if r.score.is_finite() {
                Score {
                    sum_sq: f64::from(r.score),
                    max: 0.0,
                }
            } else {
                Score::WORST
            };
        }
        Ok(())
    }

    /// Keep the best of `scores` if it beats the best so far.
    fn note_best(&mut self, population: &[f32], scores: &[Score]) {
        let n = self.problem.dim();
        let k = best_index(scores);
        if scores[k].sum_sq < self.best_score.sum_sq {
            self.best_score = scores[k];
            self.best.copy_from_slice(&population[k * n..(k + 1) * n]);
            self.best_result = self.results[k];
        }
    }

    /// The generation at which `ga+cmaes` hands over from the GA to CMA-ES.
    fn handover(&self) -> u64 {
        (self.options.generation_limit(self.method) / 2).max(1) as u64
    }

    /// Run one generation.
    pub fn step(&mut self) -> Result<&Progress> {
        let g = self.generation + 1;
        let problem = self.problem;
        let n = problem.dim();
        if self.method == Method::GaCmaes
            && matches!(self.engine, Engine::Ga(_))
            && self.generation >= self.handover()
        {
            // CMA-ES from the GA's best, its step the initial spread.
            let start: Vec<f64> = self.best.iter().map(|&x| f64::from(x)).collect();
            let sigma = self.options.spread * problem.space.chord();
            let size = self.options.size(Algorithm::Cmaes, n);
            self.engine = Engine::Cmaes(Cmaes::new(CmaesState::new(&start, sigma), size));
        }
        let mut engine = std::mem::replace(&mut self.engine, Engine::Ga(Ga::new(Vec::new(), Vec::new())));
        let mean = match &mut engine {
            Engine::Ga(ga) => {
                ga.breed(problem, &self.options.ga, &self.streams, g);
                let mut scores = std::mem::take(&mut ga.next_scores);
                self.evaluate(&ga.next, &mut scores)?;
                ga.next_scores = scores;
                ga.advance();
                self.note_best(&ga.population, &ga.scores);
                mean_valid(&ga.scores)
            }
            Engine::Cmaes(es) => {
                es.sample(problem, &self.options.cmaes, &self.streams, g);
                let mut scores = std::mem::take(&mut es.scores);
                self.evaluate(&es.samples, &mut scores)?;
                es.scores = scores;
                es.update();
                self.note_best(&es.samples, &es.scores);
                mean_valid(&es.scores)
            }
        };
        self.engine = engine;
        let reference = self.stall_reference;
        if self.best_score.sum_sq < reference - self.options.stall_tolerance * reference.abs() {
            self.stall_reference = self.best_score.sum_sq;
            self.stall_since = g;
        }
        self.generation = g;
        self.history.push(Progress {
            generation: g,
            best: self.best_score.sum_sq,
            mean,
            evaluations: self.evaluations,
            seconds: self.seconds(),
        });
        Ok(&self.history[self.history.len() - 1])
    }

    /// Why the run should stop now, if it should.
    #[must_use]
    pub fn stop(&self) -> Option<Stop> {
        let o = &self.options;
        if self.generation >= o.generation_limit(self.method) as u64 {
            return Some(Stop::Generations);
        }
        if o.stall > 0 && self.generation - self.stall_since >= o.stall as u64 {
            return Some(Stop::Stall);
        }
        if let Engine::Cmaes(es) = &self.engine {
            let st = &es.state;
            if st.spread() < o.cmaes.tol_x * self.problem.space.chord() {
                return Some(Stop::StepSize);
            }
            if st.condition() > o.cmaes.max_condition {
                return Some(Stop::Condition);
            }
            let window = flat_window(self.problem.dim(), es.scores.len());
            if st.recent.len() >= window {
                let lo = st.recent.iter().fold(f64::INFINITY, |a, &b| a.min(b));
                let hi = st.recent.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
                if lo.is_finite() && hi - lo <= o.cmaes.tol_fun * lo.abs().max(1e-12) {
                    return Some(Stop::Flat);
                }
            }
        }
        None
    }

    /// Everything needed to continue bit-identically.
    #[must_use]
    pub fn checkpoint(&self) -> Checkpoint {
        let (algorithm, size, population, scores, cmaes) = match &self.engine {
            Engine::Ga(ga) => (
                Algorithm::Ga,
                ga.scores.len(),
                ga.population.clone(),
                ga.scores.clone(),
                None,
            ),
            Engine::Cmaes(es) => (
                Algorithm::Cmaes,
                es.scores.len(),
                Vec::new(),
                Vec::new(),
                Some(es.state.clone()),
            ),
        };
        Checkpoint {
            fingerprint: self.fingerprint,
            algorithm,
            backend: self.evaluator.info().to_string(),
            dim: self.problem.dim(),
            size,
            generation: self.generation,
            evaluations: self.evaluations,
            seconds: self.seconds(),
            eval_seconds: self.eval_seconds,
            point_evals: self.evaluations,
            params: self.reasons.to_params(),
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
    pub fn method(&self) -> Method {
        self.method
    }

    /// The running stage: the GA or CMA-ES.
    #[must_use]
    pub fn stage(&self) -> Algorithm {
        match self.engine {
            Engine::Ga(_) => Algorithm::Ga,
            Engine::Cmaes(_) => Algorithm::Cmaes,
        }
    }

    /// Generations completed.
    #[must_use]
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The generation limit.
    #[must_use]
    pub fn generations(&self) -> usize {
        self.options.generation_limit(self.method)
    }

    /// The best individual so far (f32 offsets) and its kernel result.
    #[must_use]
    pub fn best(&self) -> (&[f32], AeroResult) {
        (&self.best, self.best_result)
    }

    /// One line per generation.
    #[must_use]
    pub fn history(&self) -> &[Progress] {
        &self.history
    }

    /// The individuals flagged so far, per reason.
    #[must_use]
    pub fn reasons(&self) -> Reasons {
        self.reasons
    }

    /// The backend that runs the evaluations.
    #[must_use]
    pub fn info(&self) -> &BackendInfo {
        self.evaluator.info()
    }

    /// Wall-clock seconds so far, including those before a checkpoint.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        self.seconds_before + self.clock.elapsed().as_secs_f64()
    }

    /// Step until [`stop`](Self::stop) says why, calling `on_generation` after each step.
    pub fn run(&mut self, mut on_generation: impl FnMut(&Optimisation<'_>) -> Result<()>) -> Result<Stop> {
        loop {
            if let Some(why) = self.stop() {
                return Ok(why);
            }
            self.step()?;
            on_generation(self)?;
        }
    }

    /// End the run: re-measure the candidates in f64 (the best individual; for CMA-ES also
    /// its mean) and return the better.
    pub fn finish(self, stop: Stop) -> Result<OptimiseResult> {
        let mut candidates = vec![self.best.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>()];
        if let Engine::Cmaes(es) = &self.engine {
            candidates.push(es.state.mean.clone());
        }
        let mut chosen: Option<(Vec<f64>, AeroEval)> = None;
        for c in candidates {
            if c.iter().any(|x| !x.is_finite()) {
                continue;
            }
            let e = self.problem.batch.reference(&c);
            if chosen.as_ref().is_none_or(|(_, b)| e.score < b.score) {
                chosen = Some((c, e));
            }
        }
        let (design, eval) = chosen.ok_or_else(|| Error::Numerical("no finite design to report".into()))?;
        Ok(OptimiseResult {
            seconds: self.seconds(),
            design,
            eval,
            kernel: self.best_result,
            stop,
            method: self.method,
            generations: self.generation,
            evaluations: self.evaluations,
            eval_seconds: self.eval_seconds,
            backend: self.evaluator.info().clone(),
            reasons: self.reasons,
            history: self.history,
        })
    }
}

/// The outcome of an optimisation.
#[derive(Clone, Debug, PartialEq)]
pub struct OptimiseResult {
    /// The chosen offsets (f64).
    pub design: Vec<f64>,
    /// Its objective, coefficients and flags re-measured in f64.
    pub eval: AeroEval,
    /// The best individual's kernel result (f32).
    pub kernel: AeroResult,
    /// Why the run stopped.
    pub stop: Stop,
    /// The method.
    pub method: Method,
    /// Generations run.
    pub generations: u64,
    /// Individuals evaluated.
    pub evaluations: u64,
    /// Seconds in the evaluator.
    pub eval_seconds: f64,
    /// Wall-clock seconds, those before a checkpoint included.
    pub seconds: f64,
    /// The backend and adapter.
    pub backend: BackendInfo,
    /// Individuals flagged, per reason.
    pub reasons: Reasons,
    /// One line per generation.
    pub history: Vec<Progress>,
}
