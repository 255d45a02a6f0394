//! `bezchain aero`: the inviscid panel method on an aerofoil file or a curve report (a table of
//! CL and CM, a JSON report with the pressures, an SVG of Cp above the shape), or with `--re`
//! the viscous polar of one or more files (a table, JSON, CSV, an SVG of the polars).

use super::output::Outputs;
use super::picture::PlotArgs;
use super::{usage, warn};
use anyhow::Result;
use bezchain::aero::viscous::polar::MAX_ALPHA;
use bezchain::aero::{
    analyse_input, check_polar, AeroInput, AeroReport, Paneling, Viscous, ViscousOptions, ViscousPoint,
    DEFAULT_NODES,
};
use bezchain::export::{CpPlot, PolarPlot, Schema};
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

/// One file's viscous polar as the JSON report holds it.
#[derive(serde::Serialize)]
struct FilePolar {
    file: String,
    input: AeroInput,
    nodes: usize,
    polar: Vec<ViscousPoint>,
}

/// The JSON report of a viscous run: the operating point and one polar per file (one file:
/// its fields at the top).
#[derive(serde::Serialize)]
struct ViscousReport {
    re: f64,
    mach: f64,
    ncrit: f64,
    xtr_top: f64,
    xtr_bottom: f64,
    #[serde(flatten)]
    polars: Polars,
}

#[derive(serde::Serialize)]
#[serde(untagged)]
enum Polars {
    One(FilePolar),
    Many { aerofoils: Vec<FilePolar> },
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or(String::new(), |x| format!("{x:.prec$}"))
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
    if alphas.iter().any(|a| a.abs() > MAX_ALPHA) {
        return Err(usage(format!(
            "--alpha: the viscous analysis takes angles between -{MAX_ALPHA} and {MAX_ALPHA} degrees"
        )));
    }
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let csv = outs.add_opt("--csv", args.csv.as_deref())?;
    let plots = args.plot.add(&mut outs)?;
    let mut bodies = Vec::new();
    let mut inputs = Vec::new();
    for path in &args.input {
        let (analysis, input, what) = analyse_input(path, paneling, &mut warn)?;
        let body = Viscous::new(analysis.solution.nodes())
            .map_err(|e| anyhow::Error::new(e).context(path.display().to_string()))?;
        bodies.push(body);
        inputs.push((
            path.display().to_string(),
            input,
            what,
            analysis.solution.nodes().len(),
        ));
    }
    let polars = bezchain::aero::polars(&bodies, alphas, &opts);
    let mut text = String::new();
    let mut table = String::from("file,alpha,cl,cd,cdp,cm,xtr_top,xtr_bottom,converged\n");
    for ((file, _, what, nodes), polar) in inputs.iter().zip(&polars) {
        let _ = writeln!(
            text,
            "{file}: {what}, {nodes} panel nodes, Re {re:.3e}, Ncrit {}, transition forced at {} / {}",
            opts.ncrit, opts.xtr_top, opts.xtr_bottom
        );
        let _ = writeln!(
            text,
            "   alpha        CL         CD        CDp         CM   xtr_top  xtr_bot"
        );
        for p in polar {
            match (p.cl, p.cd, p.cdp, p.cm, p.xtr_top, p.xtr_bottom) {
                (Some(cl), Some(cd), Some(cdp), Some(cm), Some(xt), Some(xb)) => {
                    let _ = writeln!(
                        text,
                        "{:8.3} {cl:9.5} {cd:10.6} {cdp:10.6} {cm:10.5} {xt:9.4} {xb:8.4}",
                        p.alpha
                    );
                }
                _ => {
                    let _ = writeln!(text, "{:8.3}   not converged", p.alpha);
                }
            }
            let _ = writeln!(
                table,
                "{file},{},{},{},{},{},{},{},{}",
                p.alpha,
                opt(p.cl, 6),
                opt(p.cd, 7),
                opt(p.cdp, 7),
                opt(p.cm, 6),
                opt(p.xtr_top, 5),
                opt(p.xtr_bottom, 5),
                p.converged
            );
        }
    }
    if plots.wanted() {
        let plot = PolarPlot {
            title: format!("viscous polar, Re {re:.3e}, Ncrit {}", opts.ncrit),
            polars: inputs
                .iter()
                .zip(&polars)
                .map(|((file, ..), p)| (file.clone(), p.clone()))
                .collect(),
        };
        plots.put(&mut outs, &plot)?;
    }
    let mut files: Vec<FilePolar> = inputs
        .into_iter()
        .zip(polars)
        .map(|((file, input, _, nodes), polar)| FilePolar {
            file,
            input,
            nodes,
            polar,
        })
        .collect();
    let report = ViscousReport {
        re,
        mach: 0.0,
        ncrit: opts.ncrit,
        xtr_top: opts.xtr_top,
        xtr_bottom: opts.xtr_bottom,
        polars: if files.len() == 1 {
            Polars::One(files.remove(0))
        } else {
            Polars::Many { aerofoils: files }
        },
    };
    if let Some(o) = json {
        outs.put_json(o, Schema::Aero, &report)?;
    }
    if let Some(o) = csv {
        outs.put(o, table.as_bytes())?;
    }
    outs.commit()?;
    outs.say(&text);
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
