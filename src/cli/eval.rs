//! `bezchain eval`: the fitness of a population of designs against data, the door for
//! optimisers outside bezchain.

use super::output::Outputs;
use super::parse_word;
use anyhow::Result;
use bezchain::bezier::Vector;
use bezchain::eval::Backend;
use bezchain::export::Report;
use bezchain::fit::population::{self, eval_curve_population, eval_grid_population, BatchOptions};
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
    #[arg(long, default_value = "auto", value_parser = parse_word::<Backend>)]
    pub backend: Backend,
    /// Newton steps per point and individual from the first individual's foot points (0:
    /// offsets at those parameters).
    #[arg(long, default_value_t = 8)]
    pub newton: u32,
    /// Candidate starts of every individual's foot-point search per segment (over the whole
    /// chain; default 16) or per patch side (the start patch and its neighbours; default 4):
    /// Newton steps also run from the two deepest local minima among them, so that every
    /// backend finds the global closest point (0: only from the first individual's foot
    /// points).
    #[arg(long)]
    pub seeds: Option<u32>,
    /// Evaluate the population this many more times and print the median seconds of one
    /// evaluation (for timing against other tools on the same population).
    #[arg(long, default_value_t = 0)]
    pub repeat: usize,
    /// Output: one line `sum_sq,max` per individual, in input order (`-` for standard output).
    #[arg(short, long, default_value = "-")]
    pub output: PathBuf,
}

/// Refuse data or individuals whose squared distances overflow the evaluator's f32, naming the
/// file and the point or individual.
fn check_f32<P: Vector>(args: &Args, points: &[P], population: &[f64], n_vars: usize) -> Result<()> {
    population::check_f32(points, population, n_vars)
        .map_err(|o| o.in_files(&args.points, &args.population).into())
}

/// Evaluate and write the fitness file.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let out = outs.add("--output", &args.output)?;
    let opts = BatchOptions {
        backend: args.backend,
        newton: args.newton,
        seeds: args.seeds,
        repeat: args.repeat,
        ..BatchOptions::default()
    };
    let in_report = |e: bezchain::Error| anyhow::Error::from(e).context(args.report.display().to_string());
    let result = match Report::read(&args.report)? {
        Report::Curve(rep) => {
            let layout = rep.layout().map_err(in_report)?;
            let points = read_curve(&args.points)?;
            super::warn_all(&args.points, &points.warnings);
            let n_vars = 2 * layout.design_count();
            let pop = read_population(&args.population, n_vars)?;
            check_f32(&args, &points.points, &pop, n_vars)?;
            eval_curve_population(&layout, &points.points, &pop, &opts)?
        }
        Report::Surface(rep) => {
            let layout = rep.layout().map_err(in_report)?;
            let points = read_cloud(&args.points)?;
            super::warn_all(&args.points, &points.warnings);
            let (nu, nv) = layout.design_shape();
            let n_vars = 3 * nu * nv;
            let pop = read_population(&args.population, n_vars)?;
            check_f32(&args, &points.points, &pop, n_vars)?;
            eval_grid_population(&layout, &points.points, &pop, &opts)?
        }
    };
    // The checks above keep every square inside f32; a non-finite fitness is still never
    // printed as a result.
    if let Some(k) = result
        .fitness
        .iter()
        .position(|f| !(f.sum_sq.is_finite() && f.max.is_finite()))
    {
        anyhow::bail!(
            "{}: individual {}: the evaluator's fitness is not finite (sum_sq {}, max {})",
            args.population.display(),
            k + 1,
            result.fitness[k].sum_sq,
            result.fitness[k].max
        );
    }
    let mut text = String::with_capacity(result.fitness.len() * 32);
    for f in &result.fitness {
        let _ = writeln!(text, "{:e},{:e}", f.sum_sq, f.max);
    }
    outs.put(out, text.as_bytes())?;
    outs.commit()?;
    tell!(
        "{} individuals evaluated on {}",
        result.fitness.len(),
        result.info
    );
    if let Some(t) = result.seconds_median {
        tell!("median of {} evaluations: {t:.6} s", args.repeat);
    }
    Ok(())
}
