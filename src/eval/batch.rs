//! One-shot evaluation of a population file: the library side of `bezchain eval`, the door for
//! optimisers outside bezchain.
//!
//! Offsets are closest-point distances. Each data point's start parameters come from the
//! first individual: the point is projected onto that shape in f64 (sampling every segment or
//! patch, then Newton, see [`nearest`](super::nearest)). Every individual then refines those
//! parameters with [`BatchOptions::newton`] clamped Newton steps of its own in f32, free to
//! cross segment and patch borders, and keeps the least distance met. For individuals in the
//! basin of the first one (a GA or CMA-ES population around a current design) this is the
//! true closest-point distance to f32 accuracy; for an unrelated shape it is an upper bound
//! (a local, not global, foot point).

use super::nearest::{curve_nearest, grid_nearest};
use super::{build_evaluator, Backend, BackendInfo, EvalLayout, EvalOptions, Fitness, GpuOptions, Targets};
use crate::chain::{ChainLayout, CurveChain, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};

/// Options of a one-shot population evaluation.
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

/// Evaluate a population of curve chains of `layout` against `points`: rows of
/// `x0,y0,x1,y1,…` over the layout's design points.
pub fn eval_curve_population(
    layout: &ChainLayout,
    points: &[DVec2],
    population: &[f32],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let row = first_row(population, layout.design_count() * 2)?;
    let design: Vec<DVec2> = row.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect();
    let chain = CurveChain::new(layout.clone(), design)?;
    let t: Vec<f64> = curve_nearest(&chain, points, options.samples)
        .into_iter()
        .map(|(t, _)| t)
        .collect();
    let targets = Targets::curve(points, &t)?;
    run(EvalLayout::Curve(layout.clone()), &targets, population, options)
}

/// Evaluate a population of patch grids of `layout` against `points`: rows of `x,y,z` per
/// design point of the row-major design net.
pub fn eval_grid_population(
    layout: &GridLayout,
    points: &[DVec3],
    population: &[f32],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let (nu, nv) = layout.design_shape();
    let row = first_row(population, nu * nv * 3)?;
    let design: Vec<DVec3> = row
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect();
    let grid = PatchGrid::new(layout.clone(), design)?;
    let uv: Vec<DVec2> = grid_nearest(&grid, points, options.samples)
        .into_iter()
        .map(|(uv, _)| uv)
        .collect();
    let targets = Targets::grid(points, &uv)?;
    run(EvalLayout::Grid(layout.clone()), &targets, population, options)
}

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
