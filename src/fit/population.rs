//! The fitting problem as a population objective: what the GA and CMA-ES see of a
//! [`FitProblem`], scored a whole population at a time on the population evaluator (GPU or
//! CPU), and `bezchain eval`'s one-shot evaluation of a population file.
//!
//! **Objective.** The evaluator measures each individual's closest-point offsets: every free
//! data point starts at its foot point on the best design so far (projected in f64 by
//! [`crate::closest`] every [`EvoOptions::reproject_every`] generations) and follows
//! [`EvoOptions::newton`] clamped Newton steps of its own, free to cross segment and patch
//! borders. Anchored points (a chain's ends) add their squared distance to the shape point
//! they are tied to, in f64. A run's result is re-measured in f64 with the global search.
//!
//! **Precision.** The evolutionary methods carry their populations in f32, so they see the problem
//! in a [`Frame`](crate::problem::Frame) centred on its search box: their variables are the design
//! coordinates less that centre, and the evaluator's targets are moved with them; a shape is then
//! resolved as finely wherever its data sit. Every generation the evaluator's reference design is
//! re-anchored where the population lies (the GA's best design so far, CMA-ES's mean): the kernels
//! compute in f32 only each individual's small difference from it (see [`crate::eval::kernel`]),
//! and [`Scorer::resolution`] reports the rounding that leaves, which CMA-ES's flatness stop uses.

use crate::bezier::Vector;
use crate::chain::shape::{CurveShape, GridShape, Shape};
use crate::chain::{ChainLayout, GridLayout};
use crate::chain::{CurveChain, PatchGrid};
use crate::closest::{chain_feet, feet, grid_feet, FootOptions};
use crate::error::{Error, Result};
use crate::eval::{
    build_evaluator, Backend, BackendInfo, EvalLayout, EvalOptions, Fitness, Gene, GpuOptions,
    PopulationEvaluator, Targets,
};
use crate::geometry::{check_design_scale, check_scale, Precision};
use crate::optim::evo::{EvoOptions, Fnv, PopulationObjective, Score, Scorer};
use crate::problem::FitProblem;
use glam::{DVec2, DVec3};
use std::path::Path;

/// Shapes the population evaluator can score: plane chains and patch grids in space.
pub trait EvalShape<const K: usize>: Shape<K> {
    /// The evaluator's layout.
    fn eval_layout(&self) -> EvalLayout;

    /// Target points with their start parameters (`(u, v)`, `v` unused for a chain).
    fn targets(points: &[Self::Point], params: &[[f64; 2]]) -> Result<Targets>;
}

impl EvalShape<1> for CurveShape<DVec2> {
    fn eval_layout(&self) -> EvalLayout {
        EvalLayout::Curve(self.layout().clone())
    }

    fn targets(points: &[DVec2], params: &[[f64; 2]]) -> Result<Targets> {
        let t: Vec<f64> = params.iter().map(|t| t[0]).collect();
        Targets::curve(points, &t)
    }
}

impl EvalShape<2> for GridShape<DVec3> {
    fn eval_layout(&self) -> EvalLayout {
        EvalLayout::Grid(self.layout())
    }

    fn targets(points: &[DVec3], params: &[[f64; 2]]) -> Result<Targets> {
        let uv: Vec<DVec2> = params.iter().map(|&t| DVec2::from_array(t)).collect();
        Targets::grid(points, &uv)
    }
}

/// The foot-point search with `samples` per segment or patch side.
fn samples(samples: usize) -> FootOptions {
    FootOptions {
        samples: samples.max(1),
        ..FootOptions::default()
    }
}

/// `(u, v)` of a parameter of dimension `K` (`v = 0` for a chain).
fn uv<const K: usize>(t: [f64; K]) -> [f64; 2] {
    [t[0], if K > 1 { t[K - 1] } else { 0.0 }]
}

impl<S: EvalShape<K>, const K: usize> FitProblem<'_, S, K> {
    /// The data points the evaluator measures: all but the anchored ones.
    fn free_points(&self) -> Vec<usize> {
        (0..self.points().len())
            .filter(|&j| !self.is_anchored(j))
            .collect()
    }

    /// Global closest-point parameters of the free data points on the flat design `design`
    /// (f64, `n` samples per segment or patch side), with their squared distances.
    fn project_free(&self, design: &[f64], n: usize) -> (Vec<[f64; 2]>, Vec<f64>) {
        let free: Vec<S::Point> = self.free_points().iter().map(|&j| self.points()[j]).collect();
        self.project_points(design, &free, n)
    }

    /// Global closest-point parameters of `points` on the flat design `design`, with their
    /// squared distances.
    fn project_points(&self, design: &[f64], points: &[S::Point], n: usize) -> (Vec<[f64; 2]>, Vec<f64>) {
        let design = Self::from_flat(design);
        feet(self.shape(), &design, points, None, &samples(n))
            .iter()
            .map(|f| (uv(f.t), f.dist_sq))
            .unzip()
    }

    /// Sum and largest distance of the anchor terms; `x(i, c)` is coordinate `c` of design
    /// point `i`.
    fn anchor_terms(
        anchors: &[(usize, Vec<(usize, f64)>)],
        points: &[S::Point],
        x: impl Fn(usize, usize) -> f64,
    ) -> (f64, f64) {
        let (mut sum, mut max) = (0.0, 0.0f64);
        for (point, weights) in anchors {
            let q = points[*point];
            let mut d2 = 0.0;
            for c in 0..S::Point::DIM {
                let s: f64 = weights.iter().map(|&(i, w)| w * x(i, c)).sum();
                d2 += (s - q.coord(c)).powi(2);
            }
            sum += d2;
            max = max.max(d2.sqrt());
        }
        (sum, max)
    }

    /// Check that the problem has what the evolutionary methods need.
    fn check_population(&self) -> Result<()> {
        if self.start_flat().is_empty() {
            return Err(Error::invalid(
                "the evolutionary methods need a start design (FitProblem::with_start)",
            ));
        }
        if self.bounds().len() != self.dim() {
            return Err(Error::invalid(
                "the evolutionary methods need box bounds (FitProblem::with_bounds)",
            ));
        }
        if self.free_points().is_empty() {
            return Err(Error::invalid(
                "no data points are left to fit once the ends are anchored",
            ));
        }
        Ok(())
    }
}

/// Hash a chain layout as the fingerprint has always hashed it.
fn hash_chain(h: &mut Fnv, l: &ChainLayout) {
    h.usize(l.degree());
    h.usize(l.continuity().order());
    h.f64s(l.breaks());
}

impl<S: EvalShape<K>, const K: usize> PopulationObjective for FitProblem<'_, S, K> {
    fn dim(&self) -> usize {
        FitProblem::dim(self)
    }

    /// The start in the problem's [`Frame`](crate::problem::Frame).
    fn start(&self) -> &[f64] {
        self.frame().start()
    }

    /// The bounds in the problem's [`Frame`](crate::problem::Frame).
    fn bounds(&self) -> &[[f64; 2]] {
        self.frame().bounds()
    }

    fn absolute(&self, x: &[f64]) -> Vec<f64> {
        self.frame().absolute(x)
    }

    fn extent(&self) -> f64 {
        self.box_extent()
    }

    /// Kind, frame, layout, data, anchors, bounds and start.
    fn fingerprint(&self) -> u64 {
        let mut h = Fnv::new();
        // Checkpoints hold designs in the frame (those of builds before it: absolute ones).
        h.bytes(b"centred");
        h.f64s(self.frame().origin());
        match self.shape().eval_layout() {
            EvalLayout::Curve(l) => {
                h.bytes(b"curve");
                hash_chain(&mut h, &l);
            }
            EvalLayout::Grid(g) => {
                h.bytes(b"grid");
                hash_chain(&mut h, &g.u);
                hash_chain(&mut h, &g.v);
            }
        }
        h.usize(self.points().len());
        for p in self.points() {
            let mut c = [0.0; 3];
            for (k, x) in c.iter_mut().enumerate().take(S::Point::DIM) {
                *x = p.coord(k);
            }
            h.f64s(&c);
        }
        for (point, weights) in self.anchors() {
            h.usize(point);
            for (i, w) in weights {
                h.usize(i);
                h.f64s(&[w]);
            }
        }
        for b in FitProblem::bounds(self) {
            h.f64s(b);
        }
        h.f64s(self.start_flat());
        h.finish()
    }

    fn scorer<'s>(
        &'s self,
        state: Option<Vec<[f64; 2]>>,
        options: &EvoOptions,
    ) -> Result<Box<dyn Scorer + 's>> {
        self.check_population()?;
        let free = self.free_points();
        // The free points in the frame (subtracted in f64, before the evaluator rounds
        // anything): the evaluator's targets, and projected onto designs in the frame, so that
        // the foot parameters' rounding does not depend on where the data sit either.
        let frame = self.frame();
        let origin = S::Point::from_coords(frame.origin());
        let pts: Vec<S::Point> = free.iter().map(|&j| self.points()[j] - origin).collect();
        let params = match state {
            Some(p) => {
                if let Some(i) = p.iter().flatten().position(|t| !(0.0..=1.0).contains(t)) {
                    return Err(Error::invalid(format!(
                        "the checkpoint's params[{}][{}] is {} (a parameter lies in [0, 1])",
                        i / 2,
                        i % 2,
                        p[i / 2][i % 2]
                    )));
                }
                p
            }
            None => self.project_points(frame.start(), &pts, options.samples).0,
        };
        if params.len() != free.len() {
            return Err(Error::invalid(format!(
                "{} parameters for {} free data points",
                params.len(),
                free.len()
            )));
        }
        let mut evaluator = build_evaluator(
            &self.shape().eval_layout(),
            &S::targets(&pts, &params)?,
            &EvalOptions::crossing(options.backend, options.newton, &options.gpu),
        )?;
        evaluator.set_reference(frame.start())?;
        // The anchored points in the frame too, indexed 0.. in `anchors`.
        let anchors = self.anchors();
        Ok(Box::new(FitScorer {
            problem: self,
            anchor_points: anchors.iter().map(|(j, _)| self.points()[*j] - origin).collect(),
            anchors: anchors
                .into_iter()
                .enumerate()
                .map(|(k, (_, w))| (k, w))
                .collect(),
            free: free.len(),
            points: pts,
            evaluator,
            params,
            fitness: Vec::new(),
            reproject_every: options.reproject_every.max(1) as u64,
            samples: options.samples,
        }))
    }

    /// Closest-point squared distances of the free points (global search, at least 48
    /// samples per segment or patch side) plus the anchors' terms.
    fn measure(&self, design: &[f64], options: &EvoOptions) -> Result<f64> {
        let (_, d2) = self.project_free(design, options.samples.max(48));
        let dim = S::Point::DIM;
        let anchors = self.anchors();
        let (a_sum, _) = Self::anchor_terms(&anchors, self.points(), |i, c| design[i * dim + c]);
        Ok(d2.iter().sum::<f64>() + a_sum)
    }
}

/// The population evaluator of a fitting problem, with the per-point start parameters it
/// holds.
struct FitScorer<'s, 'a, S: Shape<K>, const K: usize> {
    problem: &'s FitProblem<'a, S, K>,
    /// The anchors' weights, each on its point in `anchor_points`.
    anchors: Vec<(usize, Vec<(usize, f64)>)>,
    /// The anchored data points in the frame.
    anchor_points: Vec<S::Point>,
    /// The free data points in the frame, in the evaluator's order.
    points: Vec<S::Point>,
    free: usize,
    evaluator: Box<dyn PopulationEvaluator>,
    params: Vec<[f64; 2]>,
    fitness: Vec<Fitness>,
    reproject_every: u64,
    samples: usize,
}

impl<S: EvalShape<K>, const K: usize> Scorer for FitScorer<'_, '_, S, K> {
    /// The evaluator's [`Fitness`].
    fn record(&self) -> usize {
        std::mem::size_of::<Fitness>()
    }

    fn measure(&mut self, rows: &[f32], records: &mut [u8]) -> Result<()> {
        debug_assert_eq!(
            rows.len() * self.record(),
            records.len() * self.problem.dim(),
            "one record per row"
        );
        self.fitness
            .resize(records.len() / self.record(), Fitness::default());
        self.evaluator.evaluate(rows, &mut self.fitness)?;
        records.copy_from_slice(bytemuck::cast_slice(&self.fitness));
        Ok(())
    }

    fn absorb(&mut self, population: &[f32], records: &[u8], scores: &mut [Score]) {
        let n = self.problem.dim();
        debug_assert_eq!(population.len(), scores.len() * n, "one score per individual");
        self.fitness.clear();
        self.fitness.extend(
            records
                .chunks_exact(self.record())
                .map(bytemuck::pod_read_unaligned::<Fitness>),
        );
        let dim = S::Point::DIM;
        for (k, (s, f)) in scores.iter_mut().zip(&self.fitness).enumerate() {
            let row = &population[k * n..(k + 1) * n];
            let (a_sum, a_max) =
                FitProblem::<S, K>::anchor_terms(&self.anchors, &self.anchor_points, |i, c| {
                    f64::from(row[i * dim + c])
                });
            let sum_sq = f64::from(f.sum_sq) + a_sum;
            *s = if sum_sq.is_finite() && f.max.is_finite() {
                Score {
                    sum_sq,
                    max: f64::from(f.max).max(a_max),
                }
            } else {
                Score::WORST
            };
        }
    }

    /// Project the data onto `centre` (the GA's best design, CMA-ES's mean) in f64 (every
    /// `reproject_every` generations) and start every later evaluation there; re-anchor the
    /// evaluator's reference design at it every generation (so that a resumed run re-anchors
    /// exactly as an uninterrupted one).
    fn recentre(&mut self, generation: u64, centre: &[f64]) -> Result<()> {
        if generation.is_multiple_of(self.reproject_every) {
            let (params, _) = self.problem.project_points(centre, &self.points, self.samples);
            self.evaluator.set_params(&params)?;
            self.params = params;
        }
        self.evaluator.set_reference(centre)
    }

    /// The evaluator's f32 rounding of a sum of squares near `level` (see
    /// [`PopulationEvaluator::resolution`]); the anchors' f64 terms add nothing to it.
    fn resolution(&self, level: f64) -> f64 {
        self.evaluator.resolution(level)
    }

    fn state(&self) -> Vec<[f64; 2]> {
        self.params.clone()
    }

    fn info(&self) -> &BackendInfo {
        self.evaluator.info()
    }

    fn work(&self) -> usize {
        self.free
    }
}

/// Candidate starts per segment of a curve population's foot-point search by default: with
/// 8, two of 2,000 NACA 4413 contours perturbed by 0.05 chord (degree 3 × 5) still end in a
/// wrong basin (2.8e-3 over the f64 sum); with 16 none does.
pub const CURVE_SEEDS: u32 = 16;

/// Candidate starts per patch side of a grid population's foot-point search by default (over
/// the start patch and its eight neighbours: 9 × 25 a point).
pub const GRID_SEEDS: u32 = 4;

/// Options of a one-shot population evaluation (`bezchain eval`).
#[derive(Clone, Debug, PartialEq)]
pub struct BatchOptions {
    /// Where to run. Default: [`Backend::Auto`].
    pub backend: Backend,
    /// Newton steps per point and individual from the first individual's foot points.
    /// Default: 8.
    pub newton: u32,
    /// Samples per segment (curves) or per patch direction (grids) of the f64 projection onto
    /// the first individual. Default: 16.
    pub samples: usize,
    /// Candidate starts per segment (curves: over the whole chain) or per patch side (grids:
    /// the start patch and its neighbours) of every individual's foot-point search (see
    /// [`PopulationEvaluator::set_seeds`]); 0 starts at the first individual's foot points
    /// only. Default (`None`): [`CURVE_SEEDS`] for curves, [`GRID_SEEDS`] for grids.
    pub seeds: Option<u32>,
    /// Evaluate the population this many more times after the first, timing each (for
    /// comparisons with other tools on the same population). Default: 0.
    pub repeat: usize,
    /// GPU settings. Default: [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for BatchOptions {
    fn default() -> Self {
        BatchOptions {
            backend: Backend::Auto,
            newton: 8,
            samples: 16,
            seeds: None,
            repeat: 0,
            gpu: GpuOptions::default(),
        }
    }
}

/// The fitness of every individual, in input order, and where it was computed.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchResult {
    /// One `(sum_sq, max)` per individual.
    pub fitness: Vec<Fitness>,
    /// The backend and adapter that ran.
    pub info: BackendInfo,
    /// The median seconds of one evaluation of the whole population over the
    /// [`BatchOptions::repeat`] timed ones (`None` without).
    pub seconds_median: Option<f64>,
}

/// Where data or a population would overflow the evaluator's f32 squares.
#[derive(Clone, Debug, PartialEq)]
pub enum F32Overflow {
    /// The data: at a point (0-based) where one is to blame, and why.
    Data(Option<usize>, String),
    /// An individual (0-based), its variable (0-based) and why.
    Individual(usize, usize, String),
}

impl F32Overflow {
    /// The input error, naming the data file `points` (and the point to blame) or the
    /// population file `population` (the individual, its row and the variable).
    #[must_use]
    pub fn in_files(&self, points: &Path, population: &Path) -> Error {
        Error::invalid(match self {
            F32Overflow::Data(at, message) => {
                let at = at.map_or(String::new(), |k| format!(" (point {})", k + 1));
                format!("{}{at}: {message}", points.display())
            }
            F32Overflow::Individual(k, i, message) => format!(
                "{}: individual {} (its row {} of values), variable {}: {message}",
                population.display(),
                k + 1,
                k + 1,
                i + 1
            ),
        })
    }
}

/// Check that `points` and every individual of `population` (rows of `n_vars`) keep their
/// squared distances inside the evaluator's f32 ([`check_scale`], [`check_design_scale`]).
pub fn check_f32<P: Vector>(points: &[P], population: &[f64], n_vars: usize) -> Result<(), F32Overflow> {
    check_scale(points, Precision::F32).map_err(|(at, m)| F32Overflow::Data(at, m))?;
    for (k, individual) in population.chunks_exact(n_vars.max(1)).enumerate() {
        check_design_scale(individual, points).map_err(|(i, m)| F32Overflow::Individual(k, i, m))?;
    }
    Ok(())
}

/// The first row of `population`, checked to be a whole number of rows of `n_vars` finite
/// leading values, in f64.
fn first_row<T: Gene>(population: &[T], n_vars: usize) -> Result<Vec<f64>> {
    if population.is_empty() {
        return Err(Error::invalid("the population has no individuals"));
    }
    if !population.len().is_multiple_of(n_vars) {
        return Err(Error::invalid(format!(
            "population of {} values is not a whole number of rows of {n_vars} design variables",
            population.len()
        )));
    }
    let row: Vec<f64> = population[..n_vars].iter().map(|&x| x.to_f64()).collect();
    if row.iter().any(|x| !x.is_finite()) {
        return Err(Error::invalid(
            "the first individual has non-finite design variables",
        ));
    }
    Ok(row)
}

/// Evaluate a population of chains of `layout` against `points` (rows of `x0,y0,x1,y1,…`
/// over the design points): every point starts at its closest point on the first individual
/// (f64) and follows [`BatchOptions::newton`] Newton steps of its own on every individual
/// (f32), free to cross segment borders, and as many from the deepest of
/// [`BatchOptions::seeds`] candidate starts a segment over the whole chain: the closest-point
/// distance to f32 accuracy wherever the samples resolve the basins, for individuals far from
/// the first one too (folds, the ends parted at a trailing edge). With `seeds` 0, the start's
/// descent only: exact for individuals in the first one's basin, an upper bound beyond it.
///
/// The rows may be f32 or f64 (designs far from the origin). The evaluator keeps its default
/// reference, the centre of the data (see [`crate::eval::kernel`]): exact for any
/// population, with offsets accurate to about `2⁻²⁴ ×` the data's extent wherever the data
/// sit. (Anchoring at the first individual would sharpen individuals close to it, but its
/// Taylor polynomial grows inexact for individuals whose foot points move far from the
/// first's, across patch borders in particular, which an outside optimiser's population may
/// well do.)
pub fn eval_curve_population<T: Gene>(
    layout: &ChainLayout,
    points: &[DVec2],
    population: &[T],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let row = first_row(population, layout.design_count() * 2)?;
    let chain = CurveChain::new(layout.clone(), CurveProblem2::from_flat(&row))?;
    let t: Vec<[f64; 2]> = chain_feet(&chain, points, &samples(options.samples))
        .iter()
        .map(|f| uv(f.t))
        .collect();
    let targets = CurveShape::<DVec2>::targets(points, &t)?;
    run(EvalLayout::Curve(layout.clone()), &targets, population, options)
}

/// [`eval_curve_population`] for patch grids of `layout` (rows of `x,y,z` per design point of
/// the row-major design net).
pub fn eval_grid_population<T: Gene>(
    layout: &GridLayout,
    points: &[DVec3],
    population: &[T],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let (nu, nv) = layout.design_shape();
    let row = first_row(population, nu * nv * 3)?;
    let grid = PatchGrid::new(layout.clone(), GridProblem3::from_flat(&row))?;
    let uv: Vec<[f64; 2]> = grid_feet(&grid, points, &samples(options.samples))
        .iter()
        .map(|f| f.t)
        .collect();
    let targets = GridShape::<DVec3>::targets(points, &uv)?;
    run(EvalLayout::Grid(layout.clone()), &targets, population, options)
}

type CurveProblem2<'a> = FitProblem<'a, CurveShape<DVec2>, 1>;
type GridProblem3<'a> = FitProblem<'a, GridShape<DVec3>, 2>;

fn run<T: Gene>(
    layout: EvalLayout,
    targets: &Targets,
    population: &[T],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let curve = matches!(layout, EvalLayout::Curve(_));
    let eval_options = EvalOptions {
        seeds: options
            .seeds
            .unwrap_or(if curve { CURVE_SEEDS } else { GRID_SEEDS }),
        ..EvalOptions::crossing(options.backend, options.newton, &options.gpu)
    };
    let mut evaluator = build_evaluator(&layout, targets, &eval_options)?;
    let n = evaluator.design_variables();
    let rows = population.len() / n;
    // Under MPI each rank evaluates its share of the rows (a row's fitness does not depend on
    // the others, `tests/eval_parity.rs`), and every rank gets them all (§4.3).
    let mut shared = population.to_vec();
    let mut evaluate = || -> Result<Vec<Fitness>> {
        let size = std::mem::size_of::<Fitness>();
        let bytes = crate::team::share_rows(rows, size, &mut shared, |range, pop, out| {
            let mut part = vec![Fitness::default(); range.len()];
            T::evaluate_on(
                evaluator.as_mut(),
                &pop[range.start * n..range.end * n],
                &mut part,
            )?;
            out.copy_from_slice(bytemuck::cast_slice(&part));
            Ok(())
        })?;
        Ok(bytes
            .chunks_exact(size)
            .map(bytemuck::pod_read_unaligned)
            .collect())
    };
    let fitness = evaluate()?;
    let mut times: Vec<f64> = (0..options.repeat)
        .map(|_| {
            let clock = std::time::Instant::now();
            evaluate().map(|_| clock.elapsed().as_secs_f64())
        })
        .collect::<Result<_>>()?;
    times.sort_by(f64::total_cmp);
    Ok(BatchResult {
        fitness,
        info: evaluator.info().clone(),
        seconds_median: times.get(times.len() / 2).copied(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Continuity;
    use crate::optim::evo::PopulationObjective;
    use crate::problem::{CurveProblem, Metric};

    /// An overflow names the data file and its point, or the population file, the
    /// individual's row and its variable, all counted from 1.
    #[test]
    fn an_f32_overflow_names_the_file_and_where() {
        let (pts, pop) = (Path::new("a.dat"), Path::new("p.csv"));
        let data = F32Overflow::Data(Some(4), "too far".into()).in_files(pts, pop);
        assert_eq!(data.to_string(), "a.dat (point 5): too far");
        assert!(data.is_user_error());
        let whole = F32Overflow::Data(None, "too wide".into()).in_files(pts, pop);
        assert_eq!(whole.to_string(), "a.dat: too wide");
        let row = F32Overflow::Individual(2, 0, "too large".into()).in_files(pts, pop);
        assert_eq!(
            row.to_string(),
            "p.csv: individual 3 (its row 3 of values), variable 1: too large"
        );
        // A population with a design far beyond the data's scale is refused there.
        let points = vec![DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0)];
        let far = [0.0, 0.0, 1.0, 0.0, 1e30, 0.0, 1.0, 0.0];
        assert!(matches!(
            check_f32(&points, &far, 4),
            Err(F32Overflow::Individual(1, 0, _))
        ));
    }

    /// The frame centres start and bounds on the bounds' box, `absolute` moves designs back,
    /// and the objective measured in model coordinates is the same wherever the data sit.
    #[test]
    fn the_frame_centres_the_problem_on_its_box() {
        let near: Vec<DVec2> = (0..41)
            .map(|i| {
                let a = std::f64::consts::PI * f64::from(i) / 40.0;
                DVec2::new(1.0 - a.cos(), 0.5 * a.sin())
            })
            .collect();
        let shift = DVec2::new(1000.0, -250.0);
        let far: Vec<DVec2> = near.iter().map(|&p| p + shift).collect();
        let layout = ChainLayout::uniform(3, 4, Continuity::C1).unwrap();
        let problem = |pts| {
            CurveProblem::curve(layout.clone(), pts, Metric::Closest)
                .and_then(|p| p.with_bounds(0.1))
                .unwrap()
        };
        let (a, b) = (problem(&near), problem(&far));
        let frame = a.frame();
        // x spans [0, 2] and y [0, 0.5], grown by 0.2: the box centre is (1, 0.25).
        assert!((frame.origin()[0] - 1.0).abs() < 1e-12);
        assert!((frame.origin()[1] - 0.25).abs() < 1e-12);
        let [lo, hi] = PopulationObjective::bounds(&a)[1];
        assert!(
            (lo + 0.45).abs() < 1e-12 && (hi - 0.45).abs() < 1e-12,
            "{lo} {hi}"
        );
        let back = PopulationObjective::absolute(&a, PopulationObjective::start(&a));
        for (x, y) in back.iter().zip(a.start_flat()) {
            assert!((x - y).abs() < 1e-15);
        }
        // The far problem has the same variables (to the rounding of the move).
        for (x, y) in PopulationObjective::start(&a)
            .iter()
            .zip(PopulationObjective::start(&b))
        {
            assert!((x - y).abs() < 1e-12, "{x} {y}");
        }
        let options = EvoOptions::default();
        let m_near = a.measure(a.start_flat(), &options).unwrap();
        let m_far = b.measure(b.start_flat(), &options).unwrap();
        assert!(
            m_near > 0.0 && (m_near - m_far).abs() < 1e-9 * m_near,
            "{m_near} {m_far}"
        );
        assert_ne!(a.fingerprint(), b.fingerprint());
    }
}
