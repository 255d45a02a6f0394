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

use super::evo::{EvoOptions, Fnv, PopulationObjective, Score, Scorer};
use super::problem::FitProblem;
use crate::bezier::Vector;
use crate::chain::shape::{CurveShape, GridShape, Shape};
use crate::chain::{ChainLayout, GridLayout};
use crate::chain::{CurveChain, PatchGrid};
use crate::closest::{chain_feet, feet, grid_feet, FootOptions};
use crate::error::{Error, Result};
use crate::eval::{
    build_evaluator, Backend, BackendInfo, EvalLayout, EvalOptions, Fitness, GpuOptions, PopulationEvaluator,
    Targets,
};
use glam::{DVec2, DVec3};

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
        let design = Self::from_flat(design);
        let free: Vec<S::Point> = self.free_points().iter().map(|&j| self.points()[j]).collect();
        feet(self.shape(), &design, &free, None, &samples(n))
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

    fn start(&self) -> &[f64] {
        self.start_flat()
    }

    fn bounds(&self) -> &[[f64; 2]] {
        FitProblem::bounds(self)
    }

    fn extent(&self) -> f64 {
        self.box_extent()
    }

    /// Kind, layout, data, anchors, bounds and start.
    fn fingerprint(&self) -> u64 {
        let mut h = Fnv::new();
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
            None => self.project_free(self.start_flat(), options.samples).0,
        };
        if params.len() != free.len() {
            return Err(Error::invalid(format!(
                "{} parameters for {} free data points",
                params.len(),
                free.len()
            )));
        }
        let pts: Vec<S::Point> = free.iter().map(|&j| self.points()[j]).collect();
        let evaluator = build_evaluator(
            &self.shape().eval_layout(),
            &S::targets(&pts, &params)?,
            &EvalOptions {
                backend: options.backend,
                newton: options.newton,
                cross_patches: true,
                gpu: options.gpu.clone(),
            },
        )?;
        Ok(Box::new(FitScorer {
            problem: self,
            anchors: self.anchors(),
            free: free.len(),
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
    anchors: Vec<(usize, Vec<(usize, f64)>)>,
    free: usize,
    evaluator: Box<dyn PopulationEvaluator>,
    params: Vec<[f64; 2]>,
    fitness: Vec<Fitness>,
    reproject_every: u64,
    samples: usize,
}

impl<S: EvalShape<K>, const K: usize> Scorer for FitScorer<'_, '_, S, K> {
    fn evaluate(&mut self, population: &[f32], scores: &mut [Score]) -> Result<()> {
        let n = self.problem.dim();
        debug_assert_eq!(population.len(), scores.len() * n, "one score per individual");
        self.fitness.resize(scores.len(), Fitness::default());
        self.evaluator.evaluate(population, &mut self.fitness)?;
        let dim = S::Point::DIM;
        for (k, (s, f)) in scores.iter_mut().zip(&self.fitness).enumerate() {
            let row = &population[k * n..(k + 1) * n];
            let (a_sum, a_max) =
                FitProblem::<S, K>::anchor_terms(&self.anchors, self.problem.points(), |i, c| {
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
        Ok(())
    }

    /// Project the data onto the best design in f64 (every `reproject_every` generations)
    /// and start every later evaluation there.
    fn recentre(&mut self, generation: u64, best: &[f64]) -> Result<()> {
        if !generation.is_multiple_of(self.reproject_every) {
            return Ok(());
        }
        let (params, _) = self.problem.project_free(best, self.samples);
        self.evaluator.set_params(&params)?;
        self.params = params;
        Ok(())
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
    /// GPU settings. Default: [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for BatchOptions {
    fn default() -> Self {
        BatchOptions {
            backend: Backend::Auto,
            newton: 8,
            samples: 16,
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
}

/// The first row of `population`, checked to be a whole number of rows of `n_vars` finite
/// leading values, in f64.
fn first_row(population: &[f32], n_vars: usize) -> Result<Vec<f64>> {
    if population.is_empty() {
        return Err(Error::invalid("the population has no individuals"));
    }
    if !population.len().is_multiple_of(n_vars) {
        return Err(Error::invalid(format!(
            "population of {} values is not a whole number of rows of {n_vars} design variables",
            population.len()
        )));
    }
    let row: Vec<f64> = population[..n_vars].iter().map(|&x| f64::from(x)).collect();
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
/// (f32), free to cross segment borders. For individuals in the first one's basin (a GA or
/// CMA-ES population around a design) that is the closest-point distance to f32 accuracy;
/// for an unrelated shape an upper bound.
pub fn eval_curve_population(
    layout: &ChainLayout,
    points: &[DVec2],
    population: &[f32],
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
pub fn eval_grid_population(
    layout: &GridLayout,
    points: &[DVec3],
    population: &[f32],
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

fn run(
    layout: EvalLayout,
    targets: &Targets,
    population: &[f32],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let mut evaluator = build_evaluator(
        &layout,
        targets,
        &EvalOptions {
            backend: options.backend,
            newton: options.newton,
            cross_patches: true,
            gpu: options.gpu.clone(),
        },
    )?;
    let mut fitness = vec![Fitness::default(); population.len() / evaluator.design_variables()];
    evaluator.evaluate(population, &mut fitness)?;
    Ok(BatchResult {
        fitness,
        info: evaluator.info().clone(),
    })
}
