//! The panel-method benchmark behind `bezchain bench --kernel aero`: populations of shapes
//! around NACA 4412 (its adapted encoding at 1e-4, offsets of up to ±0.2 % of the chord),
//! solved at 4° with the max-CL objective and a thickness constraint, timed per population.

use crate::adaptive::{adapt_curve, AdaptOptions};
use crate::aero::batch::{build_aero_evaluator, AeroBatch, AeroResult, Constraints, Objective};
use crate::aero::contour::Paneling;
use crate::aero::design::DesignSpace;
use crate::error::Result;
use crate::eval::{Backend, GpuOptions};
use crate::geometry::{Naca, NacaOptions};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::time::Instant;

/// What to benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct AeroBenchOptions {
    /// Shapes per population. Default 1024.
    pub population: usize,
    /// Panel nodes per shape. Default 160 (XFOIL's).
    pub nodes: usize,
    /// Where to run. Default [`Backend::Auto`].
    pub backend: Backend,
    /// Timed runs; the median is reported (at least 3). Default 7.
    pub runs: usize,
    /// Seed of the population. Default 1.
    pub seed: u64,
    /// GPU settings. Default [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for AeroBenchOptions {
    fn default() -> Self {
        AeroBenchOptions {
            population: 1024,
            nodes: crate::aero::DEFAULT_NODES,
            backend: Backend::Auto,
            runs: 7,
            seed: 1,
            gpu: GpuOptions::default(),
        }
    }
}

/// The benchmark's figures, as `bezchain bench --kernel aero` prints them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AeroBenchReport {
    /// Always `aero`.
    pub kernel: String,
    /// `cpu` or `gpu`.
    pub backend: String,
    /// The adapter that ran (and, after an Auto fallback, why the CPU).
    pub adapter: String,
    /// Shapes per population.
    pub population: usize,
    /// Panel nodes per shape.
    pub nodes: usize,
    /// Design variables per shape.
    pub design_variables: usize,
    /// Median seconds per population (upload, kernels and read-back included).
    pub seconds_median: f64,
    /// Every timed run's seconds.
    pub seconds: Vec<f64>,
    /// Seconds to build the problem and the evaluator (adapt, paneling, pipelines, buffers).
    pub setup_seconds: f64,
    /// `population / seconds_median`: shapes solved (assembly, solve, CL, CM, score) per second.
    pub shapes_per_second: f64,
    /// Mean CL of the last run (a check that the runs compute what they should).
    pub mean_cl: f64,
    /// Shapes of the last run flagged as invalid.
    pub invalid: usize,
}

/// Run the benchmark.
pub fn run(options: &AeroBenchOptions) -> Result<AeroBenchReport> {
    super::check_population(options.population, 1 << 22)?;
    let clock = Instant::now();
    let pts = Naca::parse("4412")?.contour(&NacaOptions {
        points: 161,
        ..NacaOptions::default()
    })?;
    let adapted = adapt_curve(
        &pts,
        &AdaptOptions {
            tol: 1e-4,
            ..AdaptOptions::default()
        },
    )?;
    let space = DesignSpace::new(
        &adapted.encoding,
        &Paneling::with_nodes(options.nodes),
        0.1,
        crate::aero::Hold::ChordLine,
    )?;
    let batch = AeroBatch::new(
        space.map().clone(),
        4.0,
        Objective::MaxCl,
        Constraints {
            min_thickness: Some(0.1),
            cm_min: None,
        },
    )?;
    let mut evaluator = build_aero_evaluator(&batch.kernel(), options.backend, &options.gpu)?;
    let n = space.dim();
    let mut rng = ChaCha8Rng::seed_from_u64(options.seed);
    let spread = 0.002 * space.chord();
    let population: Vec<f32> = (0..options.population * n)
        .map(|_| (spread * rng.random_range(-1.0..1.0)) as f32)
        .collect();
    let mut out = vec![AeroResult::default(); options.population];
    // One untimed run: pipelines compiled, buffers sized.
    evaluator.evaluate(&population, &mut out)?;
    let setup_seconds = clock.elapsed().as_secs_f64();
    let mut seconds = Vec::new();
    for _ in 0..options.runs.max(3) {
        let t = Instant::now();
        evaluator.evaluate(&population, &mut out)?;
        seconds.push(t.elapsed().as_secs_f64());
    }
    let mut sorted = seconds.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let info = evaluator.info();
    Ok(AeroBenchReport {
        kernel: "aero".into(),
        backend: info.backend.to_string(),
        adapter: info.to_string(),
        population: options.population,
        nodes: options.nodes,
        design_variables: n,
        seconds_median: median,
        seconds,
        setup_seconds,
        shapes_per_second: options.population as f64 / median,
        mean_cl: out.iter().map(|r| f64::from(r.cl)).sum::<f64>() / out.len() as f64,
        invalid: out
            .iter()
            .filter(|r| r.flags & crate::aero::batch::flags::GEOMETRY != 0)
            .count(),
    })
}
