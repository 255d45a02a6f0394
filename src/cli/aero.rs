//! `bezchain aero`: the inviscid panel method on an aerofoil file or a curve report: a table of
//! CL and CM, a JSON report with the pressures, an SVG of Cp above the shape.

use super::output::Outputs;
use super::warn;
use anyhow::Result;
use bezchain::aero::{analyse_input, check_polar, AeroReport, Paneling, DEFAULT_NODES};
use bezchain::export::{CpPlot, Schema};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `bezchain aero`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// An aerofoil file (Selig or Lednicer `.dat`, CSV/XYZ `x y` rows: a spline through its
    /// points) or a curve report (JSON from `fit`, `adapt` or `optimise`: its chain).
    pub input: PathBuf,
    /// Angles of attack, degrees, comma-separated.
    #[arg(
        long,
        default_value = "0,4,8",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    pub alpha: Vec<f64>,
    /// Panel nodes (XFOIL's PANE uses 160).
    #[arg(long, default_value_t = DEFAULT_NODES)]
    pub panels: usize,
    /// Trailing-edge panel density relative to the leading edge's curvature (XFOIL's CTERAT).
    #[arg(long, default_value_t = 0.15, allow_negative_numbers = true)]
    pub te_ratio: f64,
    /// Write the JSON report (polar and pressures) here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an SVG of Cp against x above the shape here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
}

/// Analyse and write the outputs.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let svg_out = outs.add_opt("--svg", args.svg.as_deref())?;
    let paneling = Paneling {
        nodes: args.panels,
        te_ratio: args.te_ratio,
    };
    check_polar(&args.alpha, &paneling)?;
    let path_text = args.input.display().to_string();
    let (analysis, input, what) = analyse_input(&args.input, &paneling, &mut warn)?;
    let report = AeroReport::new(&analysis, &paneling, &args.alpha, input);
    // Everything is made before anything is written.
    let svg = match &args.svg {
        Some(_) => Some(
            CpPlot::of_report(
                &report,
                &format!("{path_text}: inviscid Cp, {} panel nodes", report.nodes),
            )
            .to_svg()?,
        ),
        None => None,
    };
    let mut text = format!(
        "{path_text}: {what}, {} panel nodes, {} trailing edge (gap {:.3e}), chord {:.6}\n",
        report.nodes, report.trailing_edge, report.te_gap, report.chord.length
    );
    let _ = writeln!(text, "   alpha          CL          CM");
    for c in &report.polar {
        let _ = writeln!(text, "{:8.3} {:11.5} {:11.5}", c.alpha, c.cl, c.cm);
    }
    if let Some(o) = json {
        outs.put_json(o, Schema::Aero, &report)?;
    }
    if let (Some(o), Some(svg)) = (svg_out, svg) {
        outs.put(o, svg.as_bytes())?;
    }
    outs.commit()?;
    outs.say(&text);
    Ok(())
}
