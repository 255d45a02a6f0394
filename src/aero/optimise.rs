//! Aerodynamic shape optimisation: the GA and CMA-ES of [`crate::optim::evo`] on an
//! [`AeroProblem`] (an adapted encoding's stored numbers as bounded offsets, [`DesignSpace`]),
//! a [`PopulationObjective`] whose every generation is one call of the panel-method evaluator
//! ([`AeroBatch`] on the GPU or the CPU), or for a viscous objective ([`ViscousScoring`]) the
//! viscous analysis of every individual in f64, rayon over the population, each point begun
//! from the population centre's solution. The run is the project's one evolutionary driver,
//! [`Evolution`]; [`Optimisation`] adds the `ga+cmaes` handover and the per-reason counts.
//!
//! **Constraints and bad shapes** (see [`super::batch`]): the optimisers rank the score, which
//! is the objective for a valid shape meeting the constraints, `1e3 + shortfall` for a valid
//! shape breaking them (the kernel's, plus those of [`ExtraConstraints`] checked after it),
//! `1e4 + shortfall` for a valid shape whose viscous analysis does not converge, and
//! `1e6 + violation` for an unusable one; so every feasible shape ranks before every
//! infeasible one, and infeasible ones by how far they are from feasible (Deb's rules, as a
//! penalty), and no shape gains by not converging. Every individual flagged is counted per
//! reason; the generation means of the progress lines are over the feasible ones. A first
//! generation without a single shape that can be scored stops the run with the counts.
//!
//! **Checkpoints** are the evolutionary [`Checkpoint`]s; the scorer's state (its `params`
//! field) holds the counts, one `(count, 0)` pair each: the individuals evaluated, those that
//! could not be scored, then one per reason of [`flags::NAMES`]; and then the best
//! individual's result, one pair per field. A run resumed from one continues bit-identically
//! on the same backend (a viscous run's warm starts follow from the centre alone).

use super::batch::{
    build_aero_evaluator, flags, AeroBatch, AeroEval, AeroEvaluator, AeroResult, Objective, MAX_VIOLATION,
    PENALTY_UNCONVERGED,
};
use super::constraints::{penalised, ExtraConstraints};
use super::design::DesignSpace;
use super::operating::{Condition, Solved, ViscousGoal};
use crate::error::{Error, Result};
use crate::eval::BackendInfo;
use crate::optim::evo::{
    default_lambda, drive, Checkpoint, EvoOptions, EvoStop, Evolution, Fnv, Generations, PopulationObjective,
    Progress, Score, Scorer, Watched,
};
use crate::optim::method::Method;
use rayon::prelude::*;
use serde::Serialize;

/// Options of an optimisation: the evolutionary options every objective takes. Their
/// defaults where left open are the aerodynamic problem's ([`AeroProblem`]'s
/// [`PopulationObjective::default_population`] and
/// [`PopulationObjective::default_generations`]): 256 individuals for the GA, `4 + ⌊3 ln n⌋`
/// for CMA-ES (the CMA-ES stage of `ga+cmaes` takes the GA's); 200 generations for the GA,
/// 1000 for CMA-ES and `ga+cmaes`.
pub use crate::optim::evo::EvoOptions as OptimiseOptions;
pub use crate::optim::evo::{MAX_GENERATIONS, MAX_POPULATION};

/// The aerodynamic problem's GA population where the options leave it open.
pub const GA_POPULATION: usize = 256;
/// The aerodynamic problem's GA generation limit where the options leave it open.
pub const GA_GENERATIONS: usize = 200;
/// The aerodynamic problem's CMA-ES (and `ga+cmaes`) generation limit where the options leave
/// it open (CMA-ES usually stops earlier, flat).
pub const CMAES_GENERATIONS: usize = 1000;

/// An optimisation problem: the design space, and the population problem on its node map.
#[derive(Clone, Debug, PartialEq)]
pub struct AeroProblem {
    /// The design variables and their node map.
    pub space: DesignSpace,
    /// The angle, objective and constraints on that map (for a viscous objective: the
    /// geometry and the thickness bound only).
    pub batch: AeroBatch,
    /// The constraints checked on the CPU after the kernel.
    pub extra: ExtraConstraints,
    /// The viscous objective's scoring, for viscous objectives.
    pub viscous: Option<ViscousScoring>,
}

/// How a viscous objective scores a shape: its operating points, the CM bound (on the viscous
/// CM of the first point), and the start's solution that every shape's points begin from.
#[derive(Clone, Debug)]
pub struct ViscousScoring {
    /// The operating points.
    pub goal: ViscousGoal,
    /// Smallest CM allowed.
    pub cm_min: Option<f64>,
    start: Vec<Option<Solved>>,
}

impl PartialEq for ViscousScoring {
    /// The same points and bound (the start's solution follows from the problem).
    fn eq(&self, other: &Self) -> bool {
        self.goal == other.goal && self.cm_min == other.cm_min
    }
}

impl ViscousScoring {
    /// The scoring of `goal` with the CM bound `cm_min`, its points begun from `start` (the
    /// start shape's solution, one entry a point).
    #[must_use]
    pub fn new(goal: ViscousGoal, cm_min: Option<f64>, start: Vec<Option<Solved>>) -> Self {
        ViscousScoring { goal, cm_min, start }
    }
}

impl AeroProblem {
    /// One design measured in f64: the panel kernel's reference, the constraints checked after
    /// it and, for a viscous objective, its points solved from the start's solution.
    #[must_use]
    pub fn reference(&self, delta: &[f64]) -> AeroEval {
        let anchors = self.viscous.as_ref().map_or(&[][..], |v| v.start.as_slice());
        self.evaluate(delta, anchors).0
    }

    /// A viscous objective's first operating point solved on a design, begun from the start's
    /// solution; `None` for an inviscid objective, an unusable shape or a point that does not
    /// converge.
    #[must_use]
    pub fn first_viscous_point(&self, delta: &[f64]) -> Option<Solved> {
        let anchors = self.viscous.as_ref()?.start.as_slice();
        let (_, solved) = self.evaluate(delta, anchors);
        solved.into_iter().next().flatten()
    }

    /// [`reference`](Self::reference) with the viscous points begun from `anchors`, and the
    /// points solved (empty for an inviscid objective or an unusable shape).
    pub fn evaluate(&self, delta: &[f64], anchors: &[Option<Solved>]) -> (AeroEval, Vec<Option<Solved>>) {
        let mut e = self.batch.reference(delta);
        if e.flags & flags::GEOMETRY != 0 {
            return (e, Vec::new());
        }
        let nodes = self.space.map().nodes(delta);
        let (geometric, short) = self.extra.geometry(&nodes);
        e.flags |= geometric;
        let mut short = e.violation + short;
        let Some(v) = &self.viscous else {
            let (fl, s) = self.extra.lift(e.cl);
            e.flags |= fl;
            e.violation = short + s;
            e.score = penalised(e.objective, e.violation);
            return (e, Vec::new());
        };
        let solved = v
            .goal
            .solve(&nodes, anchors)
            .unwrap_or_else(|_| vec![None; v.goal.points.len()]);
        let Some(objective) = v.goal.objective(&solved) else {
            // CL and CM stay the inviscid ones; the score ranks it after every converged shape.
            e.flags |= flags::UNCONVERGED;
            e.objective = 0.0;
            e.violation = short;
            e.score = PENALTY_UNCONVERGED + short.min(MAX_VIOLATION);
            return (e, solved);
        };
        if let Some(first) = solved.first().and_then(Option::as_ref) {
            (e.cl, e.cm, e.cd, e.alpha) = (first.cl, first.cm, Some(first.cd), Some(first.alpha));
        }
        let (fl, s) = self.extra.lift(e.cl);
        e.flags |= fl;
        short += s;
        if let Some(m) = v.cm_min {
            if e.cm < m {
                e.flags |= flags::CM;
                short += m - e.cm;
            }
        }
        e.objective = objective;
        e.violation = short;
        e.score = penalised(objective, short);
        (e, solved)
    }

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
        let x = &self.extra;
        for &(at, t) in &x.thickness_at {
            h.f64s(&[at, t]);
        }
        let or_nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
        h.f64s(&[or_nan(x.min_te_angle), or_nan(x.min_area), or_nan(x.cl_min)]);
        if let Some(v) = &self.viscous {
            h.bytes(format!("{:?}", v.goal.goal).as_bytes());
            h.f64s(&[v.goal.ncrit, or_nan(v.cm_min)]);
            for p in &v.goal.points {
                let (kind, at) = match p.at {
                    Condition::Alpha(a) => (0.0, a),
                    Condition::Cl(c) => (1.0, c),
                };
                h.f64s(&[p.weight, kind, at, p.re]);
            }
        }
        h.finish()
    }
}

impl PopulationObjective for AeroProblem {
    fn dim(&self) -> usize {
        self.space.dim()
    }
    fn start(&self) -> &[f64] {
        self.space.start()
    }
    fn bounds(&self) -> &[[f64; 2]] {
        self.space.bounds()
    }
    /// The chord: the spread and CMA-ES's step tolerance are fractions of it.
    fn extent(&self) -> f64 {
        self.space.chord()
    }
    fn extent_name(&self) -> &'static str {
        "the chord"
    }
    /// [`GA_POPULATION`] for the GA, `4 + ⌊3 ln n⌋` for CMA-ES.
    fn default_population(&self, method: Method) -> usize {
        match method {
            Method::Ga => GA_POPULATION,
            _ => default_lambda(self.dim()),
        }
    }
    /// [`GA_GENERATIONS`] for the GA, [`CMAES_GENERATIONS`] for CMA-ES and `ga+cmaes`.
    fn default_generations(&self, method: Method, _size: usize) -> usize {
        match method {
            Method::Ga => GA_GENERATIONS,
            _ => CMAES_GENERATIONS,
        }
    }
    fn fingerprint(&self) -> u64 {
        AeroProblem::fingerprint(self)
    }
    fn scorer<'s>(
        &'s self,
        state: Option<Vec<[f64; 2]>>,
        options: &EvoOptions,
    ) -> Result<Box<dyn Scorer + 's>> {
        let (reasons, best) = match state {
            Some(p) => decode_state(&p)?,
            None => (Reasons::default(), None),
        };
        // A viscous objective is scored on the CPU; the panel kernel's backend is not used.
        let backend = if self.viscous.is_some() {
            crate::eval::Backend::Cpu
        } else {
            options.backend
        };
        let evaluator = build_aero_evaluator(&self.batch.kernel(), backend, &options.gpu)?;
        let info = if self.viscous.is_some() {
            BackendInfo {
                adapter: format!(
                    "CPU: viscous-inviscid Newton in f64, {} rayon threads over the population",
                    rayon::current_num_threads()
                ),
                ..evaluator.info().clone()
            }
        } else {
            evaluator.info().clone()
        };
        Ok(Box::new(AeroScorer {
            problem: self,
            evaluator,
            info,
            anchors: self.viscous.as_ref().map_or_else(Vec::new, |v| v.start.clone()),
            results: Vec::new(),
            reasons,
            best,
        }))
    }
    /// The f64 reference's score.
    fn measure(&self, design: &[f64], _options: &EvoOptions) -> Result<f64> {
        Ok(self.reference(design).score)
    }
    /// A shape without a penalty: valid and within the constraints.
    fn feasible(&self, score: &Score) -> bool {
        score.sum_sq.is_finite() && score.sum_sq < super::batch::PENALTY_CONSTRAINT
    }
}

/// Scores populations on the panel-method evaluator (then the constraints it does not check,
/// in f64) or, for a viscous objective, on the viscous analysis in f64 with rayon; counts the
/// flagged shapes and keeps the best individual's result.
struct AeroScorer<'s> {
    problem: &'s AeroProblem,
    evaluator: Box<dyn AeroEvaluator>,
    /// What scores: the evaluator's backend, or the viscous analysis on the CPU.
    info: BackendInfo,
    /// Where each viscous point of a shape begins: the solution of the population's centre
    /// where it converged, else the start's.
    anchors: Vec<Option<Solved>>,
    results: Vec<AeroResult>,
    reasons: Reasons,
    best: Option<AeroResult>,
}

/// The f32 record of an f64 measurement.
fn record_of(e: &AeroEval) -> AeroResult {
    AeroResult {
        cl: e.cl as f32,
        cm: e.cm as f32,
        thickness: e.thickness as f32,
        objective: e.objective as f32,
        score: e.score as f32,
        flags: e.flags,
        violation: e.violation as f32,
        _pad0: 0,
    }
}

impl AeroScorer<'_> {
    /// The panel kernel's results of `rows`, then the constraints it does not check.
    fn inviscid(&mut self, rows: &[f32]) -> Result<()> {
        self.evaluator.evaluate(rows, &mut self.results)?;
        let problem = self.problem;
        let extra = &problem.extra;
        if extra.is_empty() {
            return Ok(());
        }
        let nv = problem.dim().max(1);
        self.results
            .par_iter_mut()
            .zip(rows.par_chunks(nv))
            .for_each(|(r, row)| {
                if r.flags & flags::GEOMETRY != 0 {
                    return;
                }
                let delta: Vec<f64> = row.iter().map(|&x| f64::from(x)).collect();
                let (gf, gs) = extra.geometry(&problem.space.map().nodes(&delta));
                let (lf, ls) = extra.lift(f64::from(r.cl));
                r.flags |= gf | lf;
                let violation = f64::from(r.violation) + gs + ls;
                r.violation = violation as f32;
                r.score = penalised(f64::from(r.objective), violation) as f32;
            });
        Ok(())
    }

    /// The viscous measurement of every row, in f64, from the anchors.
    fn viscous(&mut self, rows: &[f32]) {
        let (problem, anchors) = (self.problem, &self.anchors);
        let nv = problem.dim().max(1);
        self.results
            .par_iter_mut()
            .zip(rows.par_chunks(nv))
            .for_each(|(r, row)| {
                let delta: Vec<f64> = row.iter().map(|&x| f64::from(x)).collect();
                *r = record_of(&problem.evaluate(&delta, anchors).0);
            });
    }
}

/// The score the optimisers rank by: the kernel's, `+∞` when it is not finite.
fn score_of(r: &AeroResult) -> f64 {
    if r.score.is_finite() {
        f64::from(r.score)
    } else {
        f64::INFINITY
    }
}

impl Scorer for AeroScorer<'_> {
    /// The kernel's [`AeroResult`].
    fn record(&self) -> usize {
        std::mem::size_of::<AeroResult>()
    }
    fn measure(&mut self, rows: &[f32], records: &mut [u8]) -> Result<()> {
        self.results
            .resize(records.len() / self.record(), AeroResult::default());
        if self.problem.viscous.is_some() {
            self.problem.batch.kernel().rows(rows, self.results.len())?;
            self.viscous(rows);
        } else {
            self.inviscid(rows)?;
        }
        records.copy_from_slice(bytemuck::cast_slice(&self.results));
        Ok(())
    }
    fn absorb(&mut self, _population: &[f32], records: &[u8], scores: &mut [Score]) {
        self.results.clear();
        self.results.extend(
            records
                .chunks_exact(self.record())
                .map(bytemuck::pod_read_unaligned::<AeroResult>),
        );
        self.reasons.count(&self.results);
        for (s, r) in scores.iter_mut().zip(&self.results) {
            *s = Score {
                sum_sq: score_of(r),
                max: 0.0,
            };
            // The driver keeps the first strictly better individual, in the same order.
            if self.best.is_none_or(|b| s.sum_sq < score_of(&b)) {
                self.best = Some(*r);
            }
        }
    }
    /// A viscous objective's points begin at the centre's solution where it converges, else
    /// at the start's (so the anchors depend on the centre alone, and a resumed run has the
    /// same).
    fn recentre(&mut self, _generation: u64, centre: &[f64]) -> Result<()> {
        if let Some(v) = &self.problem.viscous {
            let (_, solved) = self.problem.evaluate(centre, &v.start);
            self.anchors = v
                .start
                .iter()
                .enumerate()
                .map(|(i, s)| solved.get(i).cloned().flatten().or_else(|| s.clone()))
                .collect();
        }
        Ok(())
    }
    fn state(&self) -> Vec<[f64; 2]> {
        encode_state(self.reasons, self.best)
    }
    fn info(&self) -> &BackendInfo {
        &self.info
    }
    /// One shape per individual: the throughput figure is in shapes.
    fn work(&self) -> usize {
        1
    }
}

/// Individuals flagged, per reason, over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Reasons {
    /// Individuals evaluated.
    pub evaluated: u64,
    /// Individuals that could not be scored at all: unusable geometry, or a viscous analysis
    /// that did not converge.
    pub failed: u64,
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
    /// The viscous analysis did not converge.
    pub unconverged: u64,
    /// Thinner than a minimum at a station.
    pub thin_at: u64,
    /// A trailing-edge angle below its minimum.
    pub te_angle: u64,
    /// An area below its minimum.
    pub area: u64,
    /// CL below its minimum.
    pub cl: u64,
}

/// Counts in a checkpoint's scorer state: `evaluated`, `failed`, then one per reason of
/// [`flags::NAMES`].
const COUNTS: usize = 2 + flags::NAMES.len();

impl Reasons {
    /// The per-reason counts in [`flags::NAMES`]' order.
    fn per_reason(&mut self) -> [&mut u64; flags::NAMES.len()] {
        [
            &mut self.non_finite,
            &mut self.fold,
            &mut self.crossing,
            &mut self.singular,
            &mut self.thin,
            &mut self.cm,
            &mut self.unconverged,
            &mut self.thin_at,
            &mut self.te_angle,
            &mut self.area,
            &mut self.cl,
        ]
    }

    fn count(&mut self, results: &[AeroResult]) {
        self.evaluated += results.len() as u64;
        for r in results {
            self.failed += u64::from(r.flags & (flags::GEOMETRY | flags::UNCONVERGED) != 0);
            for (c, (bit, _)) in self.per_reason().into_iter().zip(flags::NAMES) {
                *c += u64::from(r.flags & bit != 0);
            }
        }
    }

    /// Individuals flagged for any reason, counted once per reason.
    #[must_use]
    pub fn flagged(&self) -> u64 {
        let mut r = *self;
        r.per_reason().into_iter().map(|c| *c).sum()
    }

    /// `3 fold, 2 unconverged`: the reasons that occurred.
    #[must_use]
    pub fn describe(&self) -> String {
        let mut r = *self;
        let parts: Vec<String> = r
            .per_reason()
            .into_iter()
            .zip(flags::NAMES)
            .filter(|(c, _)| **c > 0)
            .map(|(c, (_, name))| format!("{c} {name}"))
            .collect();
        parts.join(", ")
    }
}

/// The scorer's checkpoint state: the counts, then the best kernel result's fields.
fn encode_state(mut r: Reasons, best: Option<AeroResult>) -> Vec<[f64; 2]> {
    let mut p: Vec<[f64; 2]> = vec![[r.evaluated as f64, 0.0], [r.failed as f64, 0.0]];
    p.extend(r.per_reason().into_iter().map(|c| [*c as f64, 0.0]));
    if let Some(b) = best {
        let fields = [b.cl, b.cm, b.thickness, b.objective, b.score];
        p.extend(fields.iter().map(|&x| [f64::from(x), 0.0]));
        p.push([f64::from(b.flags), 0.0]);
        p.push([f64::from(b.violation), 0.0]);
    }
    p
}

/// The inverse of [`encode_state`].
fn decode_state(p: &[[f64; 2]]) -> Result<(Reasons, Option<AeroResult>)> {
    let counts_ok = p.len() >= COUNTS
        && p[..COUNTS]
            .iter()
            .all(|c| c[0] >= 0.0 && c[0].fract() == 0.0 && c[1] == 0.0);
    if !counts_ok || !(p.len() == COUNTS || p.len() == COUNTS + 7) {
        return Err(Error::invalid(
            "the checkpoint's scorer state is not that of an aerodynamic run",
        ));
    }
    let c = |k: usize| p[k][0] as u64;
    let mut reasons = Reasons {
        evaluated: c(0),
        failed: c(1),
        ..Reasons::default()
    };
    for (k, r) in reasons.per_reason().into_iter().enumerate() {
        *r = c(2 + k);
    }
    let best = (p.len() == COUNTS + 7).then(|| {
        let f = |k: usize| p[COUNTS + k][0] as f32;
        AeroResult {
            cl: f(0),
            cm: f(1),
            thickness: f(2),
            objective: f(3),
            score: f(4),
            flags: p[COUNTS + 5][0] as u32,
            violation: f(6),
            ..AeroResult::default()
        }
    });
    Ok((reasons, best))
}

/// The stage `method` starts with: the GA, or CMA-ES; an error for a method that is not one
/// of [`Method::AERO`].
fn first_stage(method: Method) -> Result<Method> {
    match method {
        Method::Ga | Method::GaCmaes => Ok(Method::Ga),
        Method::Cmaes => Ok(Method::Cmaes),
        _ => Err(Error::invalid(format!(
            "{method} is not a method of aerodynamic optimisation (ga, cmaes or ga+cmaes)"
        ))),
    }
}

/// The generation limit of a `method` run: the options', or the problem's default for the
/// GA, or for CMA-ES (`ga+cmaes` too).
fn generation_limit(problem: &AeroProblem, method: Method, options: &OptimiseOptions) -> usize {
    let last = if method == Method::Ga {
        Method::Ga
    } else {
        Method::Cmaes
    };
    options.generation_limit(problem, last)
}

/// The evolutionary driver's options for the `stage` of a `method` run: the population and the
/// generation limit settled (the `ga+cmaes` run keeps its first stage's population and its
/// whole limit across the handover).
fn stage_options(
    problem: &AeroProblem,
    method: Method,
    stage: Method,
    options: &OptimiseOptions,
) -> EvoOptions {
    EvoOptions {
        population: Some(options.size(problem, stage)),
        generations: Some(generation_limit(problem, method, options)),
        ..options.clone()
    }
}

/// One optimisation run, a generation at a time: the evolutionary driver on the problem, and
/// for `ga+cmaes` the handover to CMA-ES halfway.
pub struct Optimisation<'p> {
    problem: &'p AeroProblem,
    method: Method,
    options: OptimiseOptions,
    run: Evolution<'p>,
}

impl<'p> Optimisation<'p> {
    /// Start a run: check the options, build the evaluator, evaluate generation 0 (the GA's
    /// initial population; CMA-ES's start).
    pub fn new(problem: &'p AeroProblem, method: Method, options: &OptimiseOptions) -> Result<Self> {
        let stage = first_stage(method)?;
        options.check_for(problem)?;
        let run = Evolution::new(problem, stage, &stage_options(problem, method, stage, options))?;
        let run = Optimisation {
            problem,
            method,
            options: options.clone(),
            run,
        };
        let r = run.reasons();
        if r.evaluated > 0 && r.failed == r.evaluated {
            return Err(Error::invalid(format!(
                "no shape of the first generation can be scored ({} of {}: {}): nothing to optimise from \
(a smaller --spread keeps the first shapes nearer the start)",
                r.failed,
                r.evaluated,
                r.describe()
            )));
        }
        Ok(run)
    }

    /// Continue a run from a checkpoint written by the same problem, method and options (the
    /// generation limit and stall options may differ). A `ga+cmaes` run resumes in either
    /// stage; its GA stage is a GA run's, its CMA-ES stage continues as a CMA-ES run's.
    pub fn resume(
        problem: &'p AeroProblem,
        method: Method,
        options: &OptimiseOptions,
        checkpoint: &Checkpoint,
    ) -> Result<Self> {
        first_stage(method)?;
        options.check_for(problem)?;
        let stage = checkpoint.algorithm;
        let allowed = method == Method::GaCmaes || stage == method;
        if !allowed {
            return Err(Error::invalid(format!(
                "the checkpoint holds a {stage} run, which a {method} run does not have"
            )));
        }
        let run = Evolution::resume(
            problem,
            stage,
            &stage_options(problem, method, stage, options),
            checkpoint,
        )?;
        Ok(Optimisation {
            problem,
            method,
            options: options.clone(),
            run,
        })
    }

    /// The generation at which `ga+cmaes` hands over from the GA to CMA-ES.
    fn handover(&self) -> u64 {
        (self.generations() / 2).max(1) as u64
    }

    /// Run one generation (for `ga+cmaes`, CMA-ES from the GA's best once half the
    /// generations are done).
    pub fn step(&mut self) -> Result<&Progress> {
        if self.method == Method::GaCmaes
            && self.run.algorithm() == Method::Ga
            && self.run.generation() >= self.handover()
        {
            self.run.switch_to_cmaes();
        }
        self.run.step()
    }

    /// Why the run should stop now, if it should.
    #[must_use]
    pub fn stop(&self) -> Option<EvoStop> {
        self.run.stop()
    }

    /// Step until [`stop`](Self::stop) says why, calling `on_generation` after each step.
    ///
    /// A run resumed from a checkpoint that had already stopped takes no step:
    /// `on_generation` is called once on the resumed state, so that its outputs are written.
    pub fn run(&mut self, on_generation: impl FnMut(&Optimisation<'_>) -> Result<()>) -> Result<EvoStop> {
        drive(self, on_generation)
    }

    /// Everything needed to continue bit-identically.
    #[must_use]
    pub fn checkpoint(&self) -> Checkpoint {
        self.run.checkpoint()
    }

    /// The method.
    #[must_use]
    pub fn method(&self) -> Method {
        self.method
    }

    /// The running stage: the GA or CMA-ES.
    #[must_use]
    pub fn stage(&self) -> Method {
        self.run.algorithm()
    }

    /// Generations completed.
    #[must_use]
    pub fn generation(&self) -> u64 {
        self.run.generation()
    }

    /// The generation limit.
    #[must_use]
    pub fn generations(&self) -> usize {
        generation_limit(self.problem, self.method, &self.options)
    }

    /// The best individual so far (f32 offsets) and its kernel result.
    #[must_use]
    pub fn best(&self) -> (&[f32], AeroResult) {
        let (_, best) = self.scorer_state();
        (self.run.best().0, best.unwrap_or_default())
    }

    /// One line per generation.
    #[must_use]
    pub fn history(&self) -> &[Progress] {
        self.run.history()
    }

    /// The individuals flagged so far, per reason.
    #[must_use]
    pub fn reasons(&self) -> Reasons {
        self.scorer_state().0
    }

    fn scorer_state(&self) -> (Reasons, Option<AeroResult>) {
        // The state is this module's own encoding: it always decodes.
        decode_state(&self.run.scorer_state()).unwrap_or_default()
    }

    /// The backend that runs the evaluations.
    #[must_use]
    pub fn info(&self) -> &BackendInfo {
        self.run.info()
    }

    /// Wall-clock seconds so far, including those before a checkpoint.
    #[must_use]
    pub fn seconds(&self) -> f64 {
        self.run.seconds()
    }

    /// End the run: the driver re-measures its candidates in f64 (the best individual; for
    /// CMA-ES also its mean) and keeps the better; its coefficients and flags in f64.
    pub fn finish(self, stop: EvoStop) -> Result<OptimiseResult> {
        let (reasons, kernel) = self.scorer_state();
        let r = self.run.finish(stop)?;
        let eval = self.problem.reference(&r.design);
        Ok(OptimiseResult {
            seconds: r.report.seconds,
            eval,
            kernel: kernel.unwrap_or_default(),
            stop,
            method: self.method,
            generations: r.report.iterations as u64,
            evaluations: r.report.evaluations as u64,
            eval_seconds: r.eval_seconds,
            backend: r.backend,
            reasons,
            history: r.history,
            design: r.design,
        })
    }
}

impl Watched for Optimisation<'_> {
    fn label(&self) -> String {
        self.method.to_string()
    }
    fn generation(&self) -> u64 {
        Optimisation::generation(self)
    }
    fn limit(&self) -> u64 {
        self.generations() as u64
    }
    fn history(&self) -> &[Progress] {
        Optimisation::history(self)
    }
    fn stopping(&self) -> bool {
        self.stop().is_some()
    }
    /// The best score and its coefficients, the stage, shapes a second and shapes flagged.
    fn status(&self) -> String {
        let Some(last) = self.history().last() else {
            return String::new();
        };
        let (_, best) = self.best();
        let r = self.reasons();
        format!(
            "best {:.5e} (CL {:.4}, CM {:.4}, t/c {:.4}) | {} stage | {} shapes/s | {} flagged",
            last.best,
            best.cl,
            best.cm,
            best.thickness,
            self.stage(),
            per_second(last.evaluations as f64 / last.seconds.max(1e-9)),
            r.flagged()
        )
    }
    fn checkpoint(&self) -> Checkpoint {
        Optimisation::checkpoint(self)
    }
}

/// A rate as printed: whole numbers from 10 up, two decimals below (a viscous run scores a few
/// shapes a second).
#[must_use]
pub fn per_second(rate: f64) -> String {
    if rate >= 10.0 {
        format!("{rate:.0}")
    } else {
        format!("{rate:.2}")
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
    pub stop: EvoStop,
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

impl Generations for Optimisation<'_> {
    fn next_generation(&mut self) -> Result<()> {
        self.step().map(|_| ())
    }

    fn evolution(&self) -> &Evolution<'_> {
        &self.run
    }
}
