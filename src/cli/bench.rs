//! `bezchain bench`: time the GA fitness kernel on a random bicubic patch grid, with its real
//! FLOPs against the machine's FP32 FMA peak, or (`--kernel aero`) the panel method on
//! populations of aerofoils, or (`--kernel viscous`) the viscous analysis over a population
//! and 11 angles.

use super::output::Outputs;
use super::{bounded, parse_word};
use anyhow::Result;
use bezchain::bench::population::{run as run_bench, BenchOptions};
use bezchain::eval::{Backend, Simd};
use bezchain::export::Schema;
use bezchain::optim::evo::{MAX_POPULATION, MAX_POPULATION_VALUES};
use std::path::{Path, PathBuf};

/// Which kernel `bench` times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Kernel {
    /// The GA fitness kernel (closest-point offsets of a patch grid).
    Fitness,
    /// The panel method (shapes per second; --population and --panels apply).
    Aero,
    /// The viscous analysis (converged points per second over 11 angles; --population
    /// [default here 256] and --panels apply).
    Viscous,
}

/// Arguments of `bezchain bench`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The kernel to time.
    #[arg(long, value_enum, default_value = "fitness")]
    pub kernel: Kernel,
    /// Panel nodes per shape (`--kernel aero`).
    #[arg(long, default_value_t = bezchain::aero::DEFAULT_NODES)]
    pub panels: usize,
    /// Individuals per population.
    #[arg(long, default_value_t = 1024)]
    pub population: usize,
    /// Target points.
    #[arg(long, default_value_t = 4096)]
    pub points: usize,
    /// Foot-point Newton steps per point (0: parameters held fixed, as between generations).
    #[arg(long, default_value_t = 0)]
    pub newton: u32,
    /// Where to run: auto, gpu or cpu.
    #[arg(long, default_value = "auto", value_parser = parse_word::<Backend>)]
    pub backend: Backend,
    /// The CPU path's vector instructions: avx512, avx2 or portable [default: the best this
    /// CPU runs].
    #[arg(long, value_parser = parse_simd)]
    pub simd: Option<Simd>,
    /// Bicubic patches along u and v, `PUxPV`.
    #[arg(long, default_value = "2x2", value_parser = super::parse_pair)]
    pub patches: [usize; 2],
    /// Timed runs (the median is reported; at least 5).
    #[arg(long, default_value_t = 7)]
    pub runs: usize,
    /// The FP32 peak to compare with, GFLOP/s [default: detected from the CPU].
    #[arg(long)]
    pub peak: Option<f64>,
    /// Skip the FMA microbenchmark (about a second) that measures the peak in the same run.
    #[arg(long)]
    pub no_peak_measure: bool,
    /// Write the JSON here instead of standard output.
    #[arg(long, default_value = "-")]
    pub json: PathBuf,
}

/// clap parser for `avx512|avx2|portable`.
fn parse_simd(s: &str) -> std::result::Result<Simd, String> {
    match s.to_ascii_lowercase().as_str() {
        "avx512" | "avx-512" => Ok(Simd::Avx512),
        "avx2" => Ok(Simd::Avx2),
        "portable" => Ok(Simd::Portable),
        _ => Err(format!(
            "unknown --simd '{s}' (expected avx512, avx2 or portable)"
        )),
    }
}

/// Run the benchmark and print its JSON.
pub fn run(args: Args) -> Result<()> {
    if args.kernel == Kernel::Aero {
        bounded(
            "--population",
            args.population as u64,
            bezchain::aero::optimise::MAX_POPULATION as u64,
            "the default is 1024",
        )?;
        bounded("--runs", args.runs as u64, 1000, "the default is 7")?;
        return put_report(&args.json, || {
            if !(8..=bezchain::aero::batch::MAX_GPU_NODES).contains(&args.panels) {
                return Err(super::usage(format!(
                    "--panels must be between 8 and {}",
                    bezchain::aero::batch::MAX_GPU_NODES
                )));
            }
            Ok(bezchain::bench::aero::run(
                &bezchain::bench::aero::AeroBenchOptions {
                    population: args.population,
                    nodes: args.panels,
                    backend: args.backend,
                    runs: args.runs,
                    ..Default::default()
                },
            )?)
        });
    }
    if args.kernel == Kernel::Viscous {
        // 1024 is the other kernels' default; this one's is 256 shapes.
        let population = if args.population == 1024 {
            256
        } else {
            args.population
        };
        bounded("--population", population as u64, 1 << 16, "the default is 256")?;
        if !(bezchain::aero::panel::MIN_NODES..=1000).contains(&args.panels) {
            return Err(super::usage("--panels must be between 8 and 1000"));
        }
        return put_report(&args.json, || {
            Ok(bezchain::bench::viscous::run(
                &bezchain::bench::viscous::ViscousBenchOptions {
                    population,
                    nodes: args.panels,
                    ..Default::default()
                },
            )?)
        });
    }
    if let Some(p) = args.peak {
        if !(p > 0.0 && p.is_finite()) {
            return Err(super::usage(format!(
                "--peak must be a positive GFLOP/s figure, not {p}"
            )));
        }
    }
    bounded(
        "--population",
        args.population as u64,
        MAX_POPULATION as u64,
        "the default is 1024",
    )?;
    bounded(
        "--points",
        args.points as u64,
        MAX_BENCH_POINTS as u64,
        "the default is 4096",
    )?;
    for (flag, p) in [
        ("--patches (u)", args.patches[0]),
        ("--patches (v)", args.patches[1]),
    ] {
        bounded(flag, p as u64, MAX_BENCH_PATCHES as u64, "the default is 2x2")?;
    }
    bounded("--runs", args.runs as u64, 1000, "the default is 7")?;
    // At most 3 (3 PU + 1)(3 PV + 1) design variables an individual (the expanded net).
    let vars = 3 * (3 * args.patches[0] + 1) * (3 * args.patches[1] + 1);
    bounded(
        "--population",
        args.population as u64,
        (MAX_POPULATION_VALUES / vars) as u64,
        &format!(
            "a generation holds at most {MAX_POPULATION_VALUES} design variables ({vars} an individual \
             here); ask for fewer individuals or patches"
        ),
    )?;
    let opts = BenchOptions {
        population: args.population,
        points: args.points,
        newton: args.newton,
        backend: args.backend,
        simd: args.simd,
        patches: args.patches,
        runs: args.runs,
        peak: args.peak,
        measure_peak: !args.no_peak_measure,
        ..BenchOptions::default()
    };
    put_report(&args.json, || Ok(run_bench(&opts)?))
}

/// Check the `--json` output, run `bench` and write its report there.
fn put_report<R: serde::Serialize>(json: &Path, bench: impl FnOnce() -> Result<R>) -> Result<()> {
    let mut outs = Outputs::new();
    let out = outs.add("--json", json)?;
    let report = bench()?;
    outs.put_json(out, Schema::Bench, &report)?;
    outs.commit()
}

/// The most target points a benchmark may ask for (96 MB of f32 points and parameters).
const MAX_BENCH_POINTS: usize = 1 << 22;

/// The most bicubic patches a benchmark grid may have along each direction.
const MAX_BENCH_PATCHES: usize = 256;
