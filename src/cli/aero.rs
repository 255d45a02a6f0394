//! `bezchain aero`: the inviscid panel method on an aerofoil file or a curve report (a table of
//! CL and CM, a JSON report with the pressures, an SVG of Cp above the shape), or with `--re`
//! the viscous polar of one or more files (a table, JSON, CSV, an SVG of the polars).

use super::output::Outputs;
use super::picture::PlotArgs;
use super::{usage, warn};
use anyhow::Result;
use bezchain::aero::viscous::polar::check_alphas;
use bezchain::aero::{analyse_input, check_polar, AeroReport, Paneling, ViscousOptions, DEFAULT_NODES};
use bezchain::export::{CpPlot, Schema, ViscousReport};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `bezchain aero`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Aerofoil files (Selig or Lednicer `.dat`, CSV/XYZ `x y` rows: a spline through its
    /// points) or curve reports (JSON from `fit`, `adapt` or `optimise`: its chain). More than
    /// one only with `--re`.
    #[arg(required = true)]
    pub input: Vec<PathBuf>,
    /// Angles of attack, degrees: a list `0,4,8` or a range `start:stop:step` (stop included).
    #[arg(long, default_value = "0,4,8", allow_hyphen_values = true)]
    pub alpha: String,
    /// Chord Reynolds number: the viscous analysis (boundary layer and wake coupled to the
    /// panel method). Without it, inviscid.
    #[arg(long)]
    pub re: Option<f64>,
    /// Critical amplification factor of the e^N transition model (with `--re`).
    #[arg(long, default_value_t = 9.0)]
    pub ncrit: f64,
    /// Forced transition on the upper surface, chord fraction (1: free; with `--re`).
    #[arg(long, default_value_t = 1.0)]
    pub xtr_top: f64,
    /// Forced transition on the lower surface, chord fraction (1: free; with `--re`).
    #[arg(long, default_value_t = 1.0)]
    pub xtr_bottom: f64,
    /// Panel nodes (XFOIL's PANE uses 160).
    #[arg(long, default_value_t = DEFAULT_NODES)]
    pub panels: usize,
    /// Trailing-edge panel density relative to the leading edge's curvature (XFOIL's CTERAT).
    #[arg(long, default_value_t = 0.15, allow_negative_numbers = true)]
    pub te_ratio: f64,
    /// Write the JSON report here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the viscous polar as one CSV table here (`-` for standard output; with `--re`).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    // `--svg`, `--png`: Cp against x above the shape, or with `--re` the polars.
    #[command(flatten)]
    pub plot: PlotArgs,
}

/// The angles of `--alpha`: a comma-separated list or `start:stop:step` (stop included when
/// the steps reach it).
pub fn parse_alphas(s: &str) -> std::result::Result<Vec<f64>, String> {
    let bad = || format!("--alpha takes a list `0,4,8` or a range `start:stop:step`, not `{s}`");
    let num = |w: &str| w.trim().parse::<f64>().ok().filter(|v| v.is_finite());
    if s.contains(':') {
        let f: Vec<f64> = s.split(':').map(num).collect::<Option<_>>().ok_or_else(bad)?;
        let [a, b, step] = f[..] else { return Err(bad()) };
        if step == 0.0 || (b - a) * step < 0.0 {
            return Err(format!("--alpha {s}: the step must lead from start to stop"));
        }
        let n = ((b - a) / step + 1e-9).floor() as usize + 1;
        if n > 1000 {
            return Err(format!("--alpha {s}: at most 1000 angles"));
        }
        return Ok((0..n).map(|k| a + k as f64 * step).collect());
    }
    s.split(',')
        .map(num)
        .collect::<Option<Vec<f64>>>()
        .ok_or_else(bad)
}

/// Analyse and write the outputs.
pub fn run(args: Args) -> Result<()> {
    let alphas = parse_alphas(&args.alpha).map_err(usage)?;
    let paneling = Paneling {
        nodes: args.panels,
        te_ratio: args.te_ratio,
    };
    check_polar(&alphas, &paneling)?;
    match args.re {
        Some(re) => viscous(&args, re, &alphas, &paneling),
        None => inviscid(&args, &alphas, &paneling),
    }
}

fn inviscid(args: &Args, alphas: &[f64], paneling: &Paneling) -> Result<()> {
    if args.input.len() > 1 {
        return Err(usage(
            "several files need --re (the viscous polar); the inviscid report takes one",
        ));
    }
    if args.csv.is_some() {
        return Err(usage("--csv writes the viscous polar: give --re"));
    }
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let plots = args.plot.add(&mut outs)?;
    let path_text = args.input[0].display().to_string();
    let (analysis, input, what) = analyse_input(&args.input[0], paneling, &mut warn)?;
    let report = AeroReport::new(&analysis, paneling, alphas, input);
    if plots.wanted() {
        let plot = CpPlot::of_report(
            &report,
            &format!("{path_text}: inviscid Cp, {} panel nodes", report.nodes),
        );
        plots.put(&mut outs, &plot)?;
    }
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
    outs.commit()?;
    outs.say(&text);
    Ok(())
}

fn viscous(args: &Args, re: f64, alphas: &[f64], paneling: &Paneling) -> Result<()> {
    let opts = ViscousOptions {
        re,
        ncrit: args.ncrit,
        xtr_top: args.xtr_top,
        xtr_bottom: args.xtr_bottom,
        ..ViscousOptions::default()
    };
    opts.check()
        .map_err(|e| usage(format!("--re/--ncrit/--xtr-*: {e}")))?;
    check_alphas(alphas).map_err(|e| usage(format!("--alpha: {e}")))?;
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let csv = outs.add_opt("--csv", args.csv.as_deref())?;
    let plots = args.plot.add(&mut outs)?;
    let report = ViscousReport::analyse(&args.input, alphas, paneling, &opts, &mut warn)?;
    if plots.wanted() {
        plots.put(&mut outs, &report.plot())?;
    }
    if let Some(o) = json {
        outs.put_json(o, Schema::Aero, &report)?;
    }
    if let Some(o) = csv {
        outs.put(o, report.table().as_bytes())?;
    }
    outs.commit()?;
    outs.say(&report.summary());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_alphas;

    #[test]
    fn alphas_parse_as_lists_and_ranges() {
        assert_eq!(parse_alphas("0,4,8").unwrap(), vec![0.0, 4.0, 8.0]);
        assert_eq!(parse_alphas("-2:2:1").unwrap(), vec![-2.0, -1.0, 0.0, 1.0, 2.0]);
        assert_eq!(parse_alphas("4:0:-2").unwrap(), vec![4.0, 2.0, 0.0]);
        assert_eq!(parse_alphas("0:1:0.25").unwrap().len(), 5);
        for bad in ["", "a", "0:1", "0:1:0", "0:4:-1", "1,,2", "0:1e9:1e-6"] {
            assert!(parse_alphas(bad).is_err(), "{bad}");
        }
    }
}
