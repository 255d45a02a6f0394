//! What the GA and CMA-ES optimise: a [`PopulationObjective`] (a box-bounded vector of
//! variables with a start, scored a whole population at a time through a [`Scorer`]), and
//! the [`Score`] they rank individuals by.
//!
//! The fitting problem is one such objective ([`crate::problem::FitProblem`], scored on the
//! population evaluator, see [`crate::fit::population`]); any other (an aerodynamic
//! coefficient of the shape the variables encode, say) implements the same two traits.

use crate::error::Result;
use crate::eval::BackendInfo;
use serde::{Deserialize, Serialize};

use super::{default_generations, default_population, EvoOptions};
use crate::optim::method::Method;

/// The objective of one individual as the evolutionary methods rank it (lower is better).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// The objective: for fitting problems the sum of squared offsets (free points from the
    /// evaluator, in f32, plus anchors in f64); `+∞` when it is not finite.
    pub sum_sq: f64,
    /// A secondary figure reported beside it: for fitting problems the largest offset.
    pub max: f64,
}

impl Score {
    /// The worst score, for individuals not yet evaluated.
    pub const WORST: Score = Score {
        sum_sq: f64::INFINITY,
        max: f64::INFINITY,
    };

    /// Total order for ranking: lower objectives first, ties by index (so sorting is
    /// deterministic).
    #[must_use]
    pub fn before(&self, i: usize, other: &Score, j: usize) -> std::cmp::Ordering {
        self.sum_sq.total_cmp(&other.sum_sq).then(i.cmp(&j))
    }
}

/// A vector of `dim()` variables inside box bounds, with a start, that the GA and CMA-ES
/// minimise.
pub trait PopulationObjective: Sync {
    /// Variables per individual.
    fn dim(&self) -> usize;

    /// The start (the GA spreads its first population around it; CMA-ES's first mean).
    fn start(&self) -> &[f64];

    /// `[lower, upper]` of every variable.
    fn bounds(&self) -> &[[f64; 2]];

    /// The variables `x` as the design a run hands back and [`measure`](Self::measure)
    /// takes. Populations are carried in f32, so an objective may define its variables in a
    /// frame of its own (the fitting problem: the design less the centre of its box, see
    /// [`crate::problem::Frame`]); start, bounds and the rows scored are in that
    /// frame. Default: the variables themselves.
    fn absolute(&self, x: &[f64]) -> Vec<f64> {
        x.to_vec()
    }

    /// The variables' scale, in their units: the initial spread and the step-size tolerance
    /// are fractions of it.
    fn extent(&self) -> f64;

    /// What [`extent`](Self::extent) measures, for messages. Default `the data extent`.
    fn extent_name(&self) -> &'static str {
        "the data extent"
    }

    /// Individuals per generation of `method` where the options leave it open. Default: the
    /// fitting problems' ([`default_population`]).
    fn default_population(&self, method: Method) -> usize {
        default_population(method, self.dim())
    }

    /// The generation limit of `method` with `size` individuals a generation where the
    /// options leave it open. Default: the fitting problems' ([`default_generations`]).
    fn default_generations(&self, method: Method, size: usize) -> usize {
        default_generations(method, self.dim(), size)
    }

    /// A 64-bit fingerprint of everything that decides a run's results (data, layout,
    /// bounds, start): a checkpoint is resumed only by a problem with the same one.
    fn fingerprint(&self) -> u64;

    /// A scorer for one run: fresh (state `None`) or continuing a checkpoint's state.
    fn scorer<'s>(
        &'s self,
        state: Option<Vec<[f64; 2]>>,
        options: &EvoOptions,
    ) -> Result<Box<dyn Scorer + 's>>;

    /// Whether a score is that of an admissible design, for the generation's mean in the
    /// progress lines (an objective that ranks inadmissible designs by a penalty keeps those
    /// out of it). Default: a finite score.
    fn feasible(&self, score: &Score) -> bool {
        score.sum_sq.is_finite()
    }

    /// The objective of one design (as [`absolute`](Self::absolute) gives it) measured as
    /// exactly as the objective can (the fitting problem: closest points by the global f64
    /// search); the run's result is re-measured so.
    fn measure(&self, design: &[f64], options: &EvoOptions) -> Result<f64>;
}

/// Scores populations for one run of a [`PopulationObjective`], in two halves so that a
/// generation can be spread over processes ([`crate::team::share_rows`]): each process
/// [`measure`](Self::measure)s a range of rows into per-row records, and every process
/// [`absorb`](Self::absorb)s the records of the whole generation, in order.
pub trait Scorer {
    /// Bytes of one individual's record.
    fn record(&self) -> usize;

    /// Evaluate every row of `rows` (f32, `dim()` values each) into `records`
    /// ([`record`](Self::record) bytes a row), changing nothing else. A row's record depends
    /// only on the row and on what [`recentre`](Self::recentre) set, never on the other rows
    /// of the batch: the results are the same however a generation is split.
    fn measure(&mut self, rows: &[f32], records: &mut [u8]) -> Result<()>;

    /// Turn a whole generation's `records`, in order, into `scores`, and take them into the
    /// scorer's state (counts, the best so far).
    fn absorb(&mut self, population: &[f32], records: &[u8], scores: &mut [Score]);

    /// Score every row of `population` (f32, `dim()` values each) into `scores`, in this
    /// process: [`measure`](Self::measure) then [`absorb`](Self::absorb).
    fn evaluate(&mut self, population: &[f32], scores: &mut [Score]) -> Result<()> {
        let mut records = vec![0u8; scores.len() * self.record()];
        self.measure(population, &mut records)?;
        self.absorb(population, &records, scores);
        Ok(())
    }

    /// Called before generation `generation` with the design it centres on (the GA: the best
    /// so far; CMA-ES: its mean): the fitting problem re-projects its data there when due and
    /// re-anchors its evaluator there.
    fn recentre(&mut self, generation: u64, centre: &[f64]) -> Result<()>;

    /// The rounding a score near `level` may carry: differences below it are not resolved
    /// (CMA-ES stops when its objective is flat to it). The fitting problem: the population
    /// evaluator's f32 rounding of a sum of offsets. Default: one f32 unit in the last place,
    /// `2⁻²³ |level|` (objectives may be negative, as `−CL`).
    fn resolution(&self, level: f64) -> f64 {
        level.abs() * f64::from(f32::EPSILON)
    }

    /// What a checkpoint must hold to continue bit-identically (the fitting problem: the
    /// evaluator's start parameters).
    fn state(&self) -> Vec<[f64; 2]>;

    /// The backend that scores (for reports; a CPU description for objectives without one).
    fn info(&self) -> &BackendInfo;

    /// Work units per individual, for the throughput figure (the fitting problem: the data
    /// points the evaluator measures).
    fn work(&self) -> usize;
}

/// 64-bit FNV-1a, stable across platforms and compiler versions (unlike `DefaultHasher`).
#[derive(Clone, Copy, Debug)]
pub struct Fnv(u64);

impl Fnv {
    /// The empty hash.
    #[must_use]
    pub fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    /// Hash bytes.
    pub fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
    /// Hash an integer.
    pub fn usize(&mut self, x: usize) {
        self.bytes(&(x as u64).to_le_bytes());
    }
    /// Hash numbers by their bits.
    pub fn f64s(&mut self, xs: &[f64]) {
        for x in xs {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
    /// The hash.
    #[must_use]
    pub fn finish(self) -> u64 {
        self.0
    }
}

impl Default for Fnv {
    fn default() -> Self {
        Fnv::new()
    }
}
