//! `bezchain optimise`: compress a start aerofoil to its adapted encoding, then optimise those
//! stored numbers for an aerodynamic objective with the GA or CMA-ES on the panel-method
//! evaluator; a curve report, a Selig file and a picture of the result.

use super::evo::{Monitor, RunArgs};
use super::output::Outputs;
use super::warn;
use anyhow::Result;
use bezchain::aero::{objectives, Constraints, Method, Optimisation, OptimiseOptions, Setup, DEFAULT_NODES};
use bezchain::eval::Backend;
use bezchain::export::{CpPlot, Schema};
use bezchain::geometry::write_selig_to;
use bezchain::optim::evo::Checkpoint;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `bezchain optimise`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The start: an aerofoil file (adapted to `--tol` first) or an `adapt` report (its
    /// encoding is used as it stands).
    pub start: PathBuf,
    /// `max-cl` (maximise CL at --alpha) or `inverse:TARGET` (match TARGET's Cp at --alpha;
    /// TARGET an aerofoil file or a curve report).
    #[arg(long)]
    pub objective: String,
    /// Angle of attack, degrees.
    #[arg(long, default_value_t = 4.0, allow_negative_numbers = true)]
    pub alpha: f64,
    /// Method: ga, cmaes or ga+cmaes (the GA for half the generations, then CMA-ES from its
    /// best).
    #[arg(long, default_value = "cmaes", value_parser = |s: &str| Method::parse_among(s, Method::AERO).map_err(|e| e.to_string()))]
    pub method: Method,
    /// Individuals per generation [default: 256 for ga, 4 + 3 ln n for cmaes].
    #[arg(long)]
    pub population: Option<usize>,
    /// Generation limit [default: 200 for ga, 1000 for cmaes and ga+cmaes].
    #[arg(long)]
    pub generations: Option<usize>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Tolerance (max closest-point offset, model units) of the adapted encoding whose stored
    /// numbers are the design variables.
    #[arg(long, default_value_t = 1e-4)]
    pub tol: f64,
    /// Box: every design variable within ± this fraction of the chord of its start value.
    #[arg(long, default_value_t = 0.1)]
    pub margin: f64,
    /// Initial spread (ga) or step (cmaes), a fraction of the chord.
    #[arg(long, default_value_t = 0.01)]
    pub spread: f64,
    /// Stop after this many generations without a relative improvement of 1e-6 (0: never).
    #[arg(long, default_value_t = 0)]
    pub stall: usize,
    /// Panel nodes per shape.
    #[arg(long, default_value_t = DEFAULT_NODES)]
    pub panels: usize,
    /// Constraint: thickness/chord at least this.
    #[arg(long)]
    pub min_thickness: Option<f64>,
    /// Constraint: CM about the quarter chord at least this.
    #[arg(long, allow_negative_numbers = true)]
    pub cm_min: Option<f64>,
    /// Where populations are evaluated: auto, gpu or cpu.
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<Backend>)]
    pub backend: Backend,
    /// Write the curve report (with an `optimise` block) here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    // The shapes and pressures before and after.
    #[command(flatten)]
    pub plot: super::picture::PlotArgs,
    /// Write the result as a Selig `.dat` file here.
    #[arg(long)]
    pub dat: Option<PathBuf>,
    #[command(flatten)]
    pub run: RunArgs,
}

/// Optimise, report and write the outputs.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let plots = args.plot.add(&mut outs)?;
    let dat = outs.add_opt("--dat", args.dat.as_deref())?;
    let (checkpoint, every) = args.run.add(&mut outs)?;
    let setup = Setup {
        start: args.start.clone(),
        spec: args.objective.clone(),
        alpha: args.alpha,
        tol: args.tol,
        margin: args.margin,
        panels: args.panels,
        constraints: Constraints {
            min_thickness: args.min_thickness,
            cm_min: args.cm_min,
        },
    };
    setup.check()?;
    let resume = args.run.resume.as_deref().map(Checkpoint::read).transpose()?;
    let clock = Instant::now();
    let objective = objectives::parse(&args.objective)?;
    let study = setup.prepare(objective, &mut warn)?;
    let options = OptimiseOptions {
        population: args.population,
        generations: args.generations,
        seed: args.seed,
        backend: args.backend,
        spread: args.spread,
        stall_generations: args.stall,
        ..OptimiseOptions::default()
    };
    outs.say(&study.describe());
    let mut run = match &resume {
        Some(c) => Optimisation::resume(&study.problem, args.method, &options, c)?,
        None => Optimisation::new(&study.problem, args.method, &options)?,
    };
    outs.say(&format!("{} on {}\n", args.method, run.info()));
    let mut monitor = Monitor::with(None, checkpoint, every);
    let stop = run.run(|r| monitor.generation(r, &mut outs));
    monitor.finish();
    let stop = stop?;
    if let Some(o) = checkpoint {
        outs.interim(o, &run.checkpoint().to_bytes())?;
    }
    let outcome = study.outcome(run.finish(stop)?, &options)?;
    if plots.wanted() {
        plots.put(&mut outs, &CpPlot::of_optimisation(&study, &outcome.result)?)?;
    }
    let elapsed = clock.elapsed().as_secs_f64();
    if let Some(o) = json {
        outs.put_json(o, Schema::Optimise, &outcome.report)?;
    }
    if let Some(o) = dat {
        let mut text = Vec::new();
        write_selig_to(&mut text, &study.selig_name(), &outcome.selig)?;
        outs.put(o, &text)?;
    }
    outs.commit()?;
    outs.say(&outcome.summary(args.alpha, elapsed));
    Ok(())
}
