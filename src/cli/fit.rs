//! `bezchain fit`: fit a chain of Bezier curves to a 2D contour and report it; the evolutionary
//! methods with a progress bar, a history file and checkpoints.

use super::evo::{EvoArgs, Monitor};
use super::export::{CadArgs, CadOutputs};
use super::output::Outputs;
use super::picture::{PlotArgs, Plots};
use super::{usage, warn, warn_all};
use anyhow::Result;
use bezchain::chain::{ChainLayout, Continuity};
use bezchain::export::{summary, CurveReport, InputInfo, Schema};
use bezchain::fit::segments::{check_segments, SegmentsRefused};
use bezchain::fit::{fit_curve_with, FitOptions, Method};
use bezchain::geometry::{read_curve, Loaded2};
use bezchain::problem::Metric;
use std::path::{Path, PathBuf};

/// Arguments of `bezchain fit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Contour: Selig or Lednicer `.dat`, CSV/XYZ rows of `x y`, or CSV whose header names `x`
    /// and `y` columns (any order, other columns ignored) (detected).
    pub input: PathBuf,
    /// Degree of every segment (1 to 7).
    #[arg(long)]
    pub degree: usize,
    /// Number of chained segments.
    #[arg(long)]
    pub segments: usize,
    /// Continuity at the joins: c0, c1 or c2.
    #[arg(long, default_value = "c1", value_parser = super::parse_word::<Continuity>)]
    pub continuity: Continuity,
    /// Method: lsq, nelder-mead, bfgs, ga, cmaes, ga+lsq or cmaes+lsq.
    #[arg(long, default_value = "lsq", value_parser = super::curve_method)]
    pub method: Method,
    /// Offset metric minimised and reported: closest or corresponding.
    #[arg(long, default_value = "closest", value_parser = super::parse_word::<Metric>)]
    pub metric: Metric,
    /// Write the JSON report here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    #[command(flatten)]
    pub outputs: ChainOutputArgs,
    #[command(flatten)]
    pub evo: EvoArgs,
}

/// The outputs of a fitted chain besides its report, shared by `fit` and `adapt`: the plot of
/// the chain over its data points and their offsets, and the STEP and IGES files.
#[derive(clap::Args, Debug)]
pub struct ChainOutputArgs {
    #[command(flatten)]
    pub plot: PlotArgs,
    #[command(flatten)]
    pub cad: CadArgs,
}

impl ChainOutputArgs {
    /// Check the plot and CAD outputs asked for before any work, and add them to the run's
    /// outputs.
    pub fn add(&self, outs: &mut Outputs) -> Result<(Plots, CadOutputs)> {
        Ok((self.plot.add(outs)?, self.cad.add(outs)?))
    }
}

/// Read a contour, printing the reader's warnings.
pub fn load(path: &Path) -> Result<Loaded2> {
    let loaded = read_curve(path)?;
    warn_all(path, &loaded.warnings);
    Ok(loaded)
}

/// The layout asked for, refused before the fit when the data cannot determine its design
/// points (the message gives the most segments that fit).
fn layout(args: &Args, points: usize) -> Result<ChainLayout> {
    check_segments(args.degree, args.segments, args.continuity, points).map_err(|r| match r {
        SegmentsRefused::Layout(e) => usage(format!(
            "--degree {} --segments {}: {e}",
            args.degree, args.segments
        )),
        SegmentsRefused::TooMany { design, most } => {
            let hint = match most {
                0 => "use a lower --degree or more data points".to_string(),
                s => format!("use at most --segments {s} at degree {}", args.degree),
            };
            usage(format!(
                "--segments {}: {design}, more than the {points} data points of {} can determine; {hint}",
                args.segments,
                args.input.display()
            ))
        }
    })
}

/// Fit, report and plot.
pub fn run(args: Args) -> Result<()> {
    // Every output is checked (and its temporary file made) before the work.
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let (plots, cad) = args.outputs.add(&mut outs)?;
    let mut monitor = Monitor::new(&args.evo, &mut outs)?;
    let evolutionary = args.method.evolutionary();
    let (evo, resume) = args.evo.settings(evolutionary.is_some(), &args.method)?;
    let loaded = load(&args.input)?;
    let layout = layout(&args, loaded.points.len())?;
    args.evo
        .check_size(&evo, evolutionary.map(|e| e.0), 2 * layout.design_count())?;
    let opts = FitOptions {
        method: args.method,
        metric: args.metric,
        evo,
        ..FitOptions::default()
    };
    let fit = monitor.run(
        &mut outs,
        (&args.evo, evolutionary.is_some(), resume),
        (&args.input, loaded.points.len()),
        |hooks| fit_curve_with(&loaded.points, layout, &opts, hooks),
    )?;
    if let Some(cap) = fit.stopped() {
        warn(
            &args.input,
            &summary::cap_warning(&fit.method.to_string(), cap, &fit.report),
        );
    }
    if let Some(w) = summary::fold_warning(&fit) {
        warn(&args.input, &w);
    }
    let rep = CurveReport::from_fit(
        &fit,
        InputInfo {
            path: args.input.display().to_string(),
            points: loaded.points.len(),
        },
    );
    if let Some(o) = json {
        outs.put_json(o, Schema::Curve, &rep)?;
    }
    let cad_args = &args.outputs.cad;
    if cad_args.wanted() {
        let shape = bezchain::export::CadShape::from_curve_report(&rep)?;
        cad_args.put(&mut outs, &cad, &[shape], &super::export::stem(&args.input))?;
    }
    if plots.wanted() {
        let title = summary::curve_title(&loaded.name, &fit);
        plots.put_chain(&mut outs, title, &loaded.points, &fit.chain)?;
    }
    outs.commit()?;
    outs.say(&summary::curve_fit(&args.input, &loaded, &fit));
    Ok(())
}
