//! `bezchain eval`: the fitness of a population of designs against data, the door for
//! optimisers outside bezchain.

use super::{parse_backend, Target};
use anyhow::Result;
use bezchain::eval::Backend;
use bezchain::export::Report;
use bezchain::fit::population::{eval_curve_population, eval_grid_population, BatchOptions};
use bezchain::geometry::{read_cloud, read_curve, read_population};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `bezchain eval`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A fit report (JSON) whose layout (degree, segments or patches, breaks, continuity) the
    /// population uses.
    pub report: PathBuf,
    /// The population: one individual per line, its design points flattened `x0,y0,x1,y1,…`
    /// (`x,y,z` per point for surfaces, design net row-major), read in f64; the first
    /// individual is the reference the others are measured against.
    #[arg(long)]
    pub population: PathBuf,
    /// The data points (a curve file for curve reports, a cloud for surface reports).
    #[arg(long)]
    pub points: PathBuf,
    /// Where to evaluate: auto, gpu or cpu.
    #[arg(long, default_value = "auto", value_parser = parse_backend)]
    pub backend: Backend,
    /// Newton steps per point and individual from the first individual's foot points (0:
    /// offsets at those parameters).
    #[arg(long, default_value_t = 8)]
    pub newton: u32,
    /// Evaluate the population this many more times and print the median seconds of one
    /// evaluation (for timing against other tools on the same population).
    #[arg(long, default_value_t = 0)]
    pub repeat: usize,
    /// Output: one line `sum_sq,max` per individual, in input order (`-` for standard output).
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
}

/// Evaluate and write the fitness file.
pub fn run(args: Args) -> Result<()> {
    let opts = BatchOptions {
        backend: args.backend,
        newton: args.newton,
        repeat: args.repeat,
        ..BatchOptions::default()
    };
    let result = match Report::read(&args.report)? {
        Report::Curve(rep) => {
            let layout = rep.layout()?;
            let points = read_curve(&args.points)?;
            super::warn_all(&args.points, &points.warnings);
            let pop = read_population(&args.population, 2 * layout.design_count())?;
            eval_curve_population(&layout, &points.points, &pop, &opts)?
        }
        Report::Surface(rep) => {
            let layout = rep.layout()?;
            let points = read_cloud(&args.points)?;
            super::warn_all(&args.points, &points.warnings);
            let (nu, nv) = layout.design_shape();
            let pop = read_population(&args.population, 3 * nu * nv)?;
            eval_grid_population(&layout, &points.points, &pop, &opts)?
        }
    };
    let mut text = String::with_capacity(result.fitness.len() * 32);
    for f in &result.fitness {
        let _ = writeln!(text, "{:e},{:e}", f.sum_sq, f.max);
    }
    Target::parse(&args.output).write(text.as_bytes())?;
    eprintln!(
        "{} individuals evaluated on {}",
        result.fitness.len(),
        result.info
    );
    if let Some(t) = result.seconds_median {
        eprintln!("median of {} evaluations: {t:.6} s", args.repeat);
    }
    Ok(())
}
