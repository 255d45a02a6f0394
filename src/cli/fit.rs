//! `bezchain fit`: fit a chain of Bezier curves to a 2D contour and report it.

use super::{warn_all, write_json, Target};
use anyhow::{Context, Result};
use bezchain::chain::{ChainLayout, Continuity};
use bezchain::export::{CurvePlot, CurveReport, FitInfo, InputInfo, OffsetReport};
use bezchain::fit::{fit_curve, point_offsets, CurveFit, FitOptions, Method, Metric, OffsetStats};
use bezchain::geometry::{read_curve, Loaded2};
use glam::DVec2;
use std::path::{Path, PathBuf};

/// Arguments of `bezchain fit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Contour: Selig or Lednicer `.dat`, or CSV/XYZ rows of `x y` (detected).
    pub input: PathBuf,
    /// Degree of every segment (1 to 16).
    #[arg(long)]
    pub degree: usize,
    /// Number of chained segments.
    #[arg(long)]
    pub segments: usize,
    /// Continuity at the joins: c0, c1 or c2.
    #[arg(long, default_value = "c1", value_parser = parse_continuity)]
    pub continuity: Continuity,
    /// Method: lsq, nelder-mead or bfgs.
    #[arg(long, default_value = "lsq", value_parser = parse_method)]
    pub method: Method,
    /// Offset metric minimised and reported: closest or corresponding.
    #[arg(long, default_value = "closest", value_parser = parse_metric)]
    pub metric: Metric,
    /// Write the JSON report here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an SVG plot (data, chain, design and generated points, offsets) here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
}

fn parse_continuity(s: &str) -> Result<Continuity, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

fn parse_method(s: &str) -> Result<Method, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

fn parse_metric(s: &str) -> Result<Metric, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

/// Read a contour, printing the reader's warnings.
pub fn load(path: &Path) -> Result<Loaded2> {
    let loaded = read_curve(path)?;
    warn_all(path, &loaded.warnings);
    Ok(loaded)
}

/// The report's `offset` block from the library's statistics.
pub fn offset_report(stats: &OffsetStats<DVec2>) -> OffsetReport {
    OffsetReport {
        metric: stats.metric.to_string(),
        sum_sq: stats.sum_sq,
        sum: stats.sum,
        rms: stats.rms,
        max: stats.max,
        max_at: stats.max_at.to_array().to_vec(),
    }
}

/// The report of a finished curve fit.
pub fn report(fit: &CurveFit<DVec2>, input: &Path, points: usize) -> CurveReport {
    let info = FitInfo {
        method: fit.method.name().to_string(),
        iterations: fit.report.iterations as u64,
        evaluations: fit.report.evaluations as u64,
        seconds: fit.report.seconds,
        backend: "cpu".to_string(),
        stages: Vec::new(),
        evals_per_second: None,
    };
    let input = InputInfo {
        path: input.display().to_string(),
        points,
    };
    CurveReport::new(&fit.chain, offset_report(&fit.offset), info, input)
}

/// Fit, report and plot.
pub fn run(args: Args) -> Result<()> {
    let loaded = load(&args.input)?;
    let layout = ChainLayout::uniform(args.degree, args.segments, args.continuity)?;
    let opts = FitOptions {
        method: args.method,
        metric: args.metric,
        ..FitOptions::default()
    };
    let fit = fit_curve(&loaded.points, layout, &opts)
        .with_context(|| format!("{}: fitting {} points", args.input.display(), loaded.points.len()))?;
    if fit.span_ratio > FitOptions::default().max_span_ratio {
        eprintln!(
            "warning: {}: the fitted chain doubles back on itself (span ratio {:.1}): its closest-point \
             offsets are small but neighbouring data points are far apart along the chain; try \
             another degree or number of segments",
            args.input.display(),
            fit.span_ratio
        );
    }
    let rep = report(&fit, &args.input, loaded.points.len());
    let json_target = args.json.as_deref().map(Target::parse);
    if let Some(target) = &json_target {
        write_json(target, &rep)?;
    }
    if let Some(path) = &args.svg {
        let offsets = point_offsets(&fit.chain, &loaded.points)?;
        let l = fit.chain.layout();
        let title = format!(
            "{} — degree {}, {} segments, {}, {}: {} design points, sum_sq {:.3e}, max {:.3e}",
            loaded.name,
            l.degree(),
            l.segments(),
            l.continuity(),
            fit.method,
            l.design_count(),
            fit.closest.sum_sq,
            fit.closest.max
        );
        let svg = CurvePlot {
            title,
            data: &loaded.points,
            chain: &fit.chain,
            offsets: &offsets,
        }
        .to_svg()?;
        Target::parse(path).write(svg.as_bytes())?;
    }
    let summary = summary(&args.input, &loaded, &fit);
    if matches!(json_target, Some(Target::Stdout)) {
        eprint!("{summary}");
    } else {
        print!("{summary}");
    }
    Ok(())
}

/// A few readable lines about the fit.
fn summary(input: &Path, loaded: &Loaded2, fit: &CurveFit<DVec2>) -> String {
    let l = fit.chain.layout();
    let c = &fit.closest;
    let mut s = format!(
        "{}: {} points ({:?}, {})\n",
        input.display(),
        loaded.points.len(),
        loaded.format,
        loaded.name
    );
    s += &format!(
        "chain: degree {}, {} segments, {}: {} design points ({} variables), {} control points\n",
        l.degree(),
        l.segments(),
        l.continuity(),
        l.design_count(),
        2 * l.design_count(),
        l.expanded_count()
    );
    s += &format!(
        "{}: sum_sq {:.4e}  rms {:.3e}  max {:.3e} at ({:.4}, {:.4})  [closest point]\n",
        fit.method, c.sum_sq, c.rms, c.max, c.max_at.x, c.max_at.y
    );
    if fit.metric == Metric::Corresponding {
        s += &format!(
            "corresponding-point sum_sq {:.4e}, max {:.3e}\n",
            fit.offset.sum_sq, fit.offset.max
        );
    }
    s += &format!(
        "{} iterations, {} evaluations, {:.1} ms\n",
        fit.report.iterations,
        fit.report.evaluations,
        fit.report.seconds * 1e3
    );
    s
}
