//! `bezchain optimise`: compress a start aerofoil to its adapted encoding, then optimise those
//! stored numbers for an aerodynamic objective with the GA or CMA-ES on the panel-method
//! evaluator (viscous objectives: on the viscous analysis); a curve report, a Selig file and a
//! picture of the result.

use super::evo::{Monitor, RunArgs};
use super::output::Outputs;
use super::warn;
use anyhow::Result;
use bezchain::aero::{
    objectives, Constraints, ExtraConstraints, Method, Optimisation, OptimiseOptions, Setup, DEFAULT_NODES,
};
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
    /// `max-ld` (maximise the viscous CL/CD at --alpha, or at the design --cl; needs --re),
    /// `min-cd` (minimise the viscous CD at the design --cl; needs --re), `multipoint:FILE`
    /// (maximise the weighted mean CL/CD over FILE's points, one a line: `WEIGHT, alpha=A` or
    /// `cl=C`, `RE`; `#` comments), `inverse:TARGET` (match TARGET's inviscid Cp at --alpha;
    /// TARGET an aerofoil file or a curve report) or `max-cl` (maximise the inviscid CL at
    /// --alpha; needs a constraint).
    #[arg(long)]
    pub objective: String,
    /// Angle of attack, degrees.
    #[arg(long, default_value_t = 4.0, allow_negative_numbers = true)]
    pub alpha: f64,
    /// Chord Reynolds number: max-ld and min-cd are scored by the viscous analysis at it (on
    /// the CPU, rayon over the population).
    #[arg(long)]
    pub re: Option<f64>,
    /// Critical amplification factor of the e^N transition (viscous objectives).
    #[arg(long, default_value_t = 9.0)]
    pub ncrit: f64,
    /// Design lift coefficient of max-ld and min-cd (the angle of attack solved for it).
    #[arg(long, allow_negative_numbers = true)]
    pub cl: Option<f64>,
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
    /// Constraint: thickness/chord at chord fraction X at least T, as X:T (repeatable).
    #[arg(long, value_name = "X:T", value_parser = parse_station)]
    pub min_thickness_at: Vec<(f64, f64)>,
    /// Constraint: CM about the quarter chord at least this (viscous objectives: the viscous
    /// CM at the first operating point).
    #[arg(long, allow_negative_numbers = true)]
    pub cm_min: Option<f64>,
    /// Constraint: CL at least this (viscous objectives: at the first operating point).
    #[arg(long, allow_negative_numbers = true)]
    pub cl_min: Option<f64>,
    /// Constraint: trailing-edge wedge angle at least this, degrees (between the surfaces'
    /// lines from 95 % of the chord to the trailing edge).
    #[arg(long)]
    pub min_te_angle: Option<f64>,
    /// Constraint: enclosed area over chord² at least this.
    #[arg(long)]
    pub min_area: Option<f64>,
    /// Where populations are evaluated: auto (the CPU: the panel kernel is faster there), gpu or
    /// cpu.
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
        extra: ExtraConstraints {
            thickness_at: args.min_thickness_at.clone(),
            min_te_angle: args.min_te_angle,
            min_area: args.min_area,
            cl_min: args.cl_min,
        },
        re: args.re,
        ncrit: args.ncrit,
        cl: args.cl,
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
    if let Some(w) = study.box_warning(&outcome.result.design, args.margin) {
        warn(&args.start, &w);
    }
    Ok(())
}

/// `X:T` of `--min-thickness-at`: a chord fraction and a thickness/chord.
fn parse_station(s: &str) -> std::result::Result<(f64, f64), String> {
    let bad = || format!("expected X:T (a chord fraction and a thickness/chord, e.g. 0.9:0.02), not '{s}'");
    let (x, t) = s.split_once(':').ok_or_else(bad)?;
    let x: f64 = x.trim().parse().map_err(|_| bad())?;
    let t: f64 = t.trim().parse().map_err(|_| bad())?;
    Ok((x, t))
}
