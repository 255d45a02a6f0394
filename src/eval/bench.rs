//! The population benchmark behind `bezchain bench`: times the GA fitness kernel on a random
//! bicubic patch grid and reports throughput.
//!
//! FLOP counts are the naive ones, per (individual, point), on bicubic patches in space:
//! - the fixed-parameter offset (`--newton 0`): 147 = Bernstein weights 18 + the 16-point
//!   weighted sum 120 + squared distance and accumulation 9;
//! - each Newton step adds [`NEWTON_STEP_FLOPS`] = 601: value, first and second derivative
//!   weights in both directions (2 × 45), the contraction of the 4 × 4 net to the point and
//!   its five partials (144 + 72 multiply-adds, 432), and the 2 × 2 Newton solve with its
//!   residual and dot products (79), counting a multiply-add as 2.

use super::{build_evaluator, BackendInfo, EvalLayout, EvalOptions, Fitness, GpuOptions, Targets};
use super::{Backend, PopulationEvaluator};
use crate::chain::{ChainLayout, Continuity, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::time::Instant;

/// FLOP per (individual, point) of the fixed-parameter bicubic offset.
pub const FIXED_FLOPS: f64 = 147.0;
/// FLOP per (individual, point) of one bicubic foot-point Newton step.
pub const NEWTON_STEP_FLOPS: f64 = 601.0;

/// What to benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Individuals per population. Default: 1024.
    pub population: usize,
    /// Target points. Default: 4096.
    pub points: usize,
    /// Foot-point Newton steps (0: parameters held fixed, as between generations). Default: 0.
    pub newton: u32,
    /// Where to run. Default: [`Backend::Auto`].
    pub backend: Backend,
    /// Bicubic patches along u and v. Default: 2 × 2.
    pub patches: [usize; 2],
    /// Timed runs; the median is reported (at least 5 are made). Default: 7.
    pub runs: usize,
    /// Untimed runs first. Default: 1.
    pub warmup: usize,
    /// Seed of the random problem. Default: 1.
    pub seed: u64,
    /// GPU settings. Default: [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            population: 1024,
            points: 4096,
            newton: 0,
            backend: Backend::Auto,
            patches: [2, 2],
            runs: 7,
            warmup: 1,
            seed: 1,
            gpu: GpuOptions::default(),
        }
    }
}

/// The benchmark's figures; serialises to exactly the keys `bezchain bench` prints.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BenchReport {
    /// `"cpu"` or `"gpu"`.
    pub backend: String,
    /// The adapter that ran (and, after an Auto fallback, why the CPU).
    pub adapter: String,
    /// Individuals per population.
    pub population: usize,
    /// Target points.
    pub points: usize,
    /// Design variables per individual.
    pub design_variables: usize,
    /// Newton steps per point.
    pub newton: u32,
    /// Median seconds per population (upload, kernels and read-back included).
    pub seconds_median: f64,
    /// Seconds to build the evaluator: context, pipelines, buffers.
    pub setup_seconds: f64,
    /// (individual × point) evaluations per second.
    pub evals_per_second: f64,
    /// FLOP per evaluation: [`FIXED_FLOPS`] + newton × [`NEWTON_STEP_FLOPS`].
    pub flops_per_eval: f64,
    /// `evals_per_second × flops_per_eval / 1e9`.
    pub gflops: f64,
    /// The fitness of the last timed run, for comparing backends (not serialised).
    #[serde(skip)]
    pub fitness: Vec<Fitness>,
    /// Backend details (not serialised).
    #[serde(skip)]
    pub info: Option<BackendInfo>,
}

/// A random benchmark problem: a smooth bicubic grid, points scattered about it with their
/// true parameters, and a population of perturbed designs.
#[derive(Clone, Debug)]
pub struct BenchProblem {
    /// The grid layout.
    pub layout: EvalLayout,
    /// Target points with the parameters they were sampled at.
    pub targets: Targets,
    /// Rows of design variables.
    pub population: Vec<f32>,
}

/// Build the benchmark problem of `options` (deterministic in the seed).
pub fn problem(options: &BenchOptions) -> Result<BenchProblem> {
    if options.points == 0 || options.population == 0 {
        return Err(Error::invalid(
            "the benchmark needs at least one point and one individual",
        ));
    }
    let [pu, pv] = options.patches;
    let layout = GridLayout::new(
        ChainLayout::uniform(3, pu, Continuity::C1)?,
        ChainLayout::uniform(3, pv, Continuity::C1)?,
    );
    let (nu, nv) = layout.design_shape();
    let design: Vec<DVec3> = (0..nu * nv)
        .map(|k| {
            let (x, y) = (
                (k / nv) as f64 / (nu - 1) as f64,
                (k % nv) as f64 / (nv - 1) as f64,
            );
            DVec3::new(x, y, 0.2 * (std::f64::consts::PI * x).sin() * (2.0 * y).cos())
        })
        .collect();
    let grid = PatchGrid::new(layout.clone(), design.clone())?;
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let noise = Normal::new(0.0, 1e-3).map_err(|e| Error::invalid(e.to_string()))?;
    let perturb = Normal::new(0.0, 1e-2).map_err(|e| Error::invalid(e.to_string()))?;
    let mut points = Vec::with_capacity(options.points);
    let mut uv = Vec::with_capacity(options.points);
    for _ in 0..options.points {
        let p = DVec2::new(rng.random::<f64>(), rng.random::<f64>());
        let q = grid.eval(p.x, p.y)
            + DVec3::new(
                noise.sample(&mut rng),
                noise.sample(&mut rng),
                noise.sample(&mut rng),
            );
        points.push(q);
        uv.push(p);
    }
    let targets = Targets::grid(&points, &uv)?;
    let flat: Vec<f64> = design.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let population = (0..options.population)
        .flat_map(|_| {
            flat.iter()
                .map(|&x| (x + perturb.sample(&mut rng)) as f32)
                .collect::<Vec<_>>()
        })
        .collect();
    Ok(BenchProblem {
        layout: EvalLayout::Grid(layout),
        targets,
        population,
    })
}

/// Median of a non-empty list.
fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    if n % 2 == 1 {
        xs[n / 2]
    } else {
        0.5 * (xs[n / 2 - 1] + xs[n / 2])
    }
}

/// Run the benchmark: build the evaluator once (timed apart), evaluate `warmup` populations,
/// then time `runs` (at least 5) and report the median.
pub fn run(options: &BenchOptions) -> Result<BenchReport> {
    let bench = problem(options)?;
    let setup = Instant::now();
    let mut evaluator = build_evaluator(
        &bench.layout,
        &bench.targets,
        &EvalOptions {
            backend: options.backend,
            newton: options.newton,
            cross_patches: false,
            gpu: options.gpu.clone(),
        },
    )?;
    let setup_seconds = setup.elapsed().as_secs_f64();
    time(evaluator.as_mut(), &bench.population, options, setup_seconds)
}

/// Time `evaluator` on `population` as [`run`] does.
pub fn time(
    evaluator: &mut dyn PopulationEvaluator,
    population: &[f32],
    options: &BenchOptions,
    setup_seconds: f64,
) -> Result<BenchReport> {
    let rows = population.len() / evaluator.design_variables().max(1);
    let mut fitness = vec![Fitness::default(); rows];
    for _ in 0..options.warmup {
        evaluator.evaluate(population, &mut fitness)?;
    }
    let mut times = Vec::new();
    for _ in 0..options.runs.max(5) {
        let start = Instant::now();
        evaluator.evaluate(population, &mut fitness)?;
        times.push(start.elapsed().as_secs_f64());
    }
    let seconds_median = median(times);
    let evals = (rows * evaluator.points()) as f64;
    let evals_per_second = evals / seconds_median;
    let flops_per_eval = FIXED_FLOPS + f64::from(options.newton) * NEWTON_STEP_FLOPS;
    let info = evaluator.info().clone();
    let adapter = match &info.fallback {
        Some(why) => format!("{} (Auto fell back to the CPU: {why})", info.adapter),
        None => info.adapter.clone(),
    };
    Ok(BenchReport {
        backend: info.backend.to_string(),
        adapter,
        population: rows,
        points: evaluator.points(),
        design_variables: evaluator.design_variables(),
        newton: options.newton,
        seconds_median,
        setup_seconds,
        evals_per_second,
        flops_per_eval,
        gflops: evals_per_second * flops_per_eval / 1e9,
        fitness,
        info: Some(info),
    })
}

/// The largest relative difference of `sum_sq` (and of `max`) between two fitness lists,
/// relative to the larger magnitude of each pair.
#[must_use]
pub fn max_relative_difference(a: &[Fitness], b: &[Fitness]) -> f64 {
    let rel = |x: f32, y: f32| {
        let (x, y) = (f64::from(x), f64::from(y));
        let scale = x.abs().max(y.abs());
        if scale == 0.0 {
            0.0
        } else {
            (x - y).abs() / scale
        }
    };
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    a.iter()
        .zip(b)
        .map(|(x, y)| rel(x.sum_sq, y.sum_sq).max(rel(x.max, y.max)))
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_has_exactly_the_documented_keys() {
        let report = BenchReport {
            backend: "cpu".into(),
            adapter: "x".into(),
            population: 1,
            points: 2,
            design_variables: 3,
            newton: 0,
            seconds_median: 1.0,
            setup_seconds: 0.5,
            evals_per_second: 2.0,
            flops_per_eval: 147.0,
            gflops: 0.0,
            fitness: vec![Fitness::default()],
            info: None,
        };
        let json = serde_json::to_value(&report).unwrap();
        let mut keys: Vec<&str> = json.as_object().unwrap().keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(
            keys,
            [
                "adapter",
                "backend",
                "design_variables",
                "evals_per_second",
                "flops_per_eval",
                "gflops",
                "newton",
                "points",
                "population",
                "seconds_median",
                "setup_seconds"
            ]
        );
    }

    #[test]
    fn the_problem_is_deterministic_and_sized() {
        let o = BenchOptions {
            population: 3,
            points: 10,
            ..BenchOptions::default()
        };
        let (a, b) = (problem(&o).unwrap(), problem(&o).unwrap());
        assert_eq!(a.population, b.population);
        assert_eq!(a.targets, b.targets);
        assert_eq!(a.population.len(), 3 * 6 * 6 * 3);
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
