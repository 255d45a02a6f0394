//! `bezchain bench`: time the GA fitness kernel on a random bicubic patch grid, or (`--kernel
//! aero`) the panel method on populations of aerofoils.

use super::{parse_backend, write_json, Target};
use anyhow::Result;
use bezchain::eval::bench::{run as run_bench, BenchOptions};
use bezchain::eval::Backend;
use std::path::PathBuf;

/// Which kernel `bench` times.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Kernel {
    /// The GA fitness kernel (closest-point offsets of a patch grid).
    Fitness,
    /// The panel method (shapes per second; --population and --panels apply).
    Aero,
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
    #[arg(long, default_value = "auto", value_parser = parse_backend)]
    pub backend: Backend,
    /// Bicubic patches along u and v, `PUxPV`.
    #[arg(long, default_value = "2x2", value_parser = super::parse_pair)]
    pub patches: [usize; 2],
    /// Timed runs (the median is reported; at least 5).
    #[arg(long, default_value_t = 7)]
    pub runs: usize,
    /// Write the JSON here instead of standard output.
    #[arg(long, default_value = "-")]
    pub json: PathBuf,
}

/// Run the benchmark and print its JSON.
pub fn run(args: Args) -> Result<()> {
    if args.kernel == Kernel::Aero {
        if !(8..=bezchain::aero::batch::MAX_GPU_NODES).contains(&args.panels) {
            return Err(super::usage(format!(
                "--panels must be between 8 and {}",
                bezchain::aero::batch::MAX_GPU_NODES
            )));
        }
        let report = bezchain::aero::bench::run(&bezchain::aero::bench::AeroBenchOptions {
            population: args.population,
            nodes: args.panels,
            backend: args.backend,
            runs: args.runs,
            ..Default::default()
        })?;
        return write_json(&Target::parse(&args.json), &report);
    }
    let opts = BenchOptions {
        population: args.population,
        points: args.points,
        newton: args.newton,
        backend: args.backend,
        patches: args.patches,
        runs: args.runs,
        ..BenchOptions::default()
    };
    let report = run_bench(&opts)?;
    write_json(&Target::parse(&args.json), &report)
}
