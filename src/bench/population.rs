//! The population benchmark behind `bezchain bench`: times the GA fitness kernel on a random
//! bicubic patch grid and reports its throughput against the machine's FP32 FMA peak.
//!
//! **FLOPs counted.** Additions, subtractions, multiplications and divisions as the kernels
//! execute them, a fused multiply-add as 2; comparisons, `min`/`max`, clamps and selects are
//! not counted. Per (individual, point) for degrees `du × dv`, `n = (du + 1)(dv + 1)` control
//! points a patch and `D` coordinates ([`kernel_flops`]):
//!
//! - `--newton 0` (`eval_patch` with fixed parameters; the weights `B_a(u) B_b(v)` come from
//!   f64 once per projection, not per evaluation): the offset `r0 + Σ w_k Δ_k` is `D n` FMAs,
//!   its square `1 + 2 (D - 1)` (a multiply, then FMAs), the sum 1: `2 D n + 2 D`. Bicubic in
//!   space: **102**.
//! - each Newton step: both bases with derivatives, `2 (3 + 3 d (d + 1) / 2 + 6 (d + 1))` for
//!   `d = du` and `dv` (the recurrence, the derivative combinations); the jet contraction,
//!   `D (2 · 3 n + 2 · 6 (du + 1))`; the reference's Taylor polynomial and its two partials
//!   (four FMAs, two products, two sums), `16 D`; combining them with the jet, `14 D`; nine
//!   dot products, `18 D`; the 2 × 2 solve and the update, 27. Bicubic in space:
//!   90 + 432 + 48 + 42 + 54 + 27 = **693**;
//! - after the steps, the offset there: both plain bases, `2 (1 + 3 d (d + 1) / 2)`; the
//!   weights, `n`; the contraction, `2 D n`; the square, `2 D`; the Taylor polynomial, `16 D`;
//!   the sum, 1. Bicubic in space: 38 + 16 + 96 + 6 + 48 + 1 = **205**; so `--newton K ≥ 1`
//!   counts `205 + 693 K` (K = 2: 1591).
//!
//! Expanding each individual's design differences through the extraction map adds
//! `2 D × (map entries)` once per individual (384 for the default 2 × 2 grid, 0.09 a point at
//! 4096 points); [`BenchReport::flops_per_eval`] includes it, spread over the points. The
//! previous count (147 and 601 a step) charged the basis to every individual; this kernel
//! computes it once per point for all individuals (fixed parameters) or per lane only where
//! it runs. The count is for steps clamped to their patch (`cross_patches` off), as the bench
//! runs them.

use super::peak::{measure_fma, process_cpu_seconds, CpuPeak, FmaRate, FmaSet};
use crate::chain::{Continuity, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use crate::eval::{build_evaluator, BackendInfo, EvalLayout, EvalOptions, Fitness, GpuOptions, Targets};
use crate::eval::{Backend, CpuEvaluator, PopulationEvaluator, Simd};
use glam::{DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;
use std::time::Instant;

/// FLOP per (individual, point) of the kernels for degrees `du × dv` in `dim` coordinates
/// with `newton` clamped steps (see the module notes for the derivation).
#[must_use]
pub fn kernel_flops(du: usize, dv: usize, dim: usize, newton: u32) -> f64 {
    let n = ((du + 1) * (dv + 1)) as f64;
    let d = dim as f64;
    if newton == 0 {
        return 2.0 * d * n + 2.0 * d;
    }
    let basis = |k: usize| 3.0 + 1.5 * (k * (k + 1)) as f64 + 6.0 * (k + 1) as f64;
    let plain = |k: usize| 1.0 + 1.5 * (k * (k + 1)) as f64;
    let step = basis(du)
        + basis(dv)
        + d * (6.0 * n + 12.0 * (du + 1) as f64)
        + 16.0 * d
        + 14.0 * d
        + 18.0 * d
        + 27.0;
    let last = plain(du) + plain(dv) + n + 2.0 * d * n + 2.0 * d + 16.0 * d + 1.0;
    last + f64::from(newton) * step
}

/// FLOP per individual of expanding its design differences: `2 dim × entries`.
#[must_use]
pub fn expand_flops(layout: &GridLayout) -> f64 {
    (2 * 3 * layout.u.map().nnz() * layout.v.map().nnz()) as f64
}

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
    /// The CPU kernels (`None`: the best this CPU runs). Default: `None`.
    pub simd: Option<Simd>,
    /// Bicubic patches along u and v. Default: 2 × 2.
    pub patches: [usize; 2],
    /// Timed runs; the median is reported (at least 5 are made). Default: 7.
    pub runs: usize,
    /// Untimed runs first. Default: 1.
    pub warmup: usize,
    /// Seed of the random problem. Default: 1.
    pub seed: u64,
    /// The FP32 peak to compare with, GFLOP/s (`None`: [`CpuPeak::detect`]'s). Default: `None`.
    pub peak: Option<f64>,
    /// Also measure the FMA peak with [`measure_fma`] (about a second). Default: true.
    pub measure_peak: bool,
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
            simd: None,
            patches: [2, 2],
            runs: 7,
            warmup: 1,
            seed: 1,
            peak: None,
            measure_peak: true,
            gpu: GpuOptions::default(),
        }
    }
}

/// The machine's FP32 peak as the bench states it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PeakReport {
    /// The processor and its peak on paper.
    pub cpu: CpuPeak,
    /// The peak compared with: `--peak`, or the paper peak.
    pub gflops: f64,
    /// Where `gflops` came from: `"--peak"` or `"detected"`.
    pub source: String,
    /// Independent AVX-512 FMAs on every thread, measured in this run.
    pub measured_avx512: Option<FmaRate>,
    /// Independent AVX2 FMAs on every thread, measured in this run.
    pub measured_avx2: Option<FmaRate>,
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
    /// FLOP per evaluation as the kernels execute them: [`kernel_flops`] plus the expansion
    /// spread over the points.
    pub flops_per_eval: f64,
    /// `evals_per_second × flops_per_eval / 1e9`.
    pub gflops: f64,
    /// The same FLOPs over the process's CPU time spread over the cores (all timed runs): the
    /// rate of busy cores, which other jobs sharing the machine do not lower (rayon's and the
    /// driver's idle spinning counts as busy). `None` where CPU time is not available.
    pub gflops_busy: Option<f64>,
    /// The peak compared with.
    pub peak: PeakReport,
    /// `gflops` as a percentage of `peak.gflops`.
    pub percent_of_peak: f64,
    /// `gflops_busy` as a percentage of the best FMA rate of busy cores measured in this run
    /// (absent when not measured).
    pub percent_of_measured: Option<f64>,
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
    /// The design the population was drawn around (the evaluator's reference, as a population
    /// method re-anchors it at its best design).
    pub reference: Vec<f64>,
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
    let layout = GridLayout::uniform((3, 3), (pu, pv), Continuity::C1)?;
    let design: Vec<DVec3> =
        layout.design_from(|x, y| DVec3::new(x, y, 0.2 * (std::f64::consts::PI * x).sin() * (2.0 * y).cos()));
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
        reference: flat,
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

/// The peak of `options`: `--peak` or detected, with the FMA rates measured now when asked.
#[must_use]
pub fn peak(options: &BenchOptions) -> PeakReport {
    let cpu = CpuPeak::detect();
    let (gflops, source) = match options.peak {
        Some(p) => (p, "--peak".to_owned()),
        None => (cpu.gflops, "detected".to_owned()),
    };
    let (measured_avx512, measured_avx2) = if options.measure_peak {
        (measure_fma(FmaSet::Avx512, 0.5), measure_fma(FmaSet::Avx2, 0.5))
    } else {
        (None, None)
    };
    PeakReport {
        cpu,
        gflops,
        source,
        measured_avx512,
        measured_avx2,
    }
}

/// Run the benchmark: build the evaluator once (timed apart) with the population's base
/// design as its reference, evaluate `warmup` populations, then time `runs` (at least 5) and
/// report the median; the FMA peak is measured right after.
pub fn run(options: &BenchOptions) -> Result<BenchReport> {
    let bench = problem(options)?;
    let setup = Instant::now();
    let eval_options = EvalOptions {
        backend: options.backend,
        newton: options.newton,
        cross_patches: false,
        seeds: 0,
        gpu: options.gpu.clone(),
    };
    let mut evaluator: Box<dyn PopulationEvaluator> = match (options.simd, options.backend) {
        (Some(simd), Backend::Cpu) => Box::new(CpuEvaluator::with_simd(
            &bench.layout,
            &bench.targets,
            options.newton,
            simd,
        )?),
        (Some(_), _) => return Err(Error::invalid("choosing the CPU kernels needs the cpu backend")),
        (None, _) => build_evaluator(&bench.layout, &bench.targets, &eval_options)?,
    };
    evaluator.set_reference(&bench.reference)?;
    let setup_seconds = setup.elapsed().as_secs_f64();
    let EvalLayout::Grid(layout) = &bench.layout else {
        return Err(Error::invalid("the benchmark problem is a grid"));
    };
    let flops = kernel_flops(3, 3, 3, options.newton) + expand_flops(layout) / options.points as f64;
    let mut report = time(
        evaluator.as_mut(),
        &bench.population,
        options,
        setup_seconds,
        flops,
    )?;
    report.set_peak(peak(options));
    Ok(report)
}

/// Time `evaluator` on `population` as [`run`] does, counting `flops_per_eval`; the peak is
/// left unset (zero) for [`BenchReport::set_peak`].
pub fn time(
    evaluator: &mut dyn PopulationEvaluator,
    population: &[f32],
    options: &BenchOptions,
    setup_seconds: f64,
    flops_per_eval: f64,
) -> Result<BenchReport> {
    let rows = population.len() / evaluator.design_variables().max(1);
    let mut fitness = vec![Fitness::default(); rows];
    for _ in 0..options.warmup {
        evaluator.evaluate(population, &mut fitness)?;
    }
    let mut times = Vec::new();
    let cpu_start = process_cpu_seconds();
    for _ in 0..options.runs.max(5) {
        let start = Instant::now();
        evaluator.evaluate(population, &mut fitness)?;
        times.push(start.elapsed().as_secs_f64());
    }
    let cpu_seconds = process_cpu_seconds().zip(cpu_start).map(|(b, a)| b - a);
    let runs = times.len() as f64;
    let seconds_median = median(times);
    let evals = (rows * evaluator.points()) as f64;
    let evals_per_second = evals / seconds_median;
    let info = evaluator.info().clone();
    let adapter = match &info.fallback {
        Some(why) => format!("{} (auto took the CPU: {why})", info.adapter),
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
        gflops_busy: cpu_seconds.filter(|&c| c > 0.0).map(|c| {
            let cores = rayon::current_num_threads() as f64;
            runs * evals * flops_per_eval / (c / cores) / 1e9
        }),
        peak: PeakReport {
            cpu: CpuPeak::detect(),
            gflops: 0.0,
            source: String::new(),
            measured_avx512: None,
            measured_avx2: None,
        },
        percent_of_peak: 0.0,
        percent_of_measured: None,
        fitness,
        info: Some(info),
    })
}

impl BenchReport {
    /// Compare with `peak`.
    pub fn set_peak(&mut self, peak: PeakReport) {
        self.percent_of_peak = 100.0 * self.gflops / peak.gflops;
        let measured = peak
            .measured_avx512
            .into_iter()
            .chain(peak.measured_avx2)
            .map(|r| r.gflops)
            .fold(0.0, f64::max);
        self.percent_of_measured = self
            .gflops_busy
            .filter(|_| measured > 0.0)
            .map(|g| 100.0 * g / measured);
        self.peak = peak;
    }
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
        let mut report = BenchReport {
            backend: "cpu".into(),
            adapter: "x".into(),
            population: 1,
            points: 2,
            design_variables: 3,
            newton: 0,
            seconds_median: 1.0,
            setup_seconds: 0.5,
            evals_per_second: 2.0,
            flops_per_eval: 102.0,
            gflops: 10.0,
            gflops_busy: Some(10.0),
            peak: peak(&BenchOptions {
                measure_peak: false,
                ..BenchOptions::default()
            }),
            percent_of_peak: 0.0,
            percent_of_measured: None,
            fitness: vec![Fitness::default()],
            info: None,
        };
        report.set_peak(peak(&BenchOptions {
            measure_peak: false,
            peak: Some(40.0),
            ..BenchOptions::default()
        }));
        assert_eq!(report.percent_of_peak, 25.0);
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
                "gflops_busy",
                "newton",
                "peak",
                "percent_of_measured",
                "percent_of_peak",
                "points",
                "population",
                "seconds_median",
                "setup_seconds"
            ]
        );
    }

    #[test]
    fn flop_counts_follow_the_derivation() {
        assert_eq!(kernel_flops(3, 3, 3, 0), 102.0);
        assert_eq!(kernel_flops(3, 3, 3, 1), 205.0 + 693.0);
        assert_eq!(kernel_flops(3, 3, 3, 2), 1591.0);
        // A cubic curve: 4 control points in the plane.
        assert_eq!(kernel_flops(3, 0, 2, 0), 2.0 * 2.0 * 4.0 + 4.0);
        let g = GridLayout::uniform((3, 3), (2, 2), Continuity::C1).unwrap();
        assert_eq!(expand_flops(&g), 384.0);
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
        assert_eq!(a.reference.len(), 6 * 6 * 3);
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
    }
}
