//! `bezchain fit`: fit a chain of Bezier curves to a 2D contour and report it; the evolutionary
//! methods with a progress bar, a history file and checkpoints.

use super::evo::{EvoArgs, Monitor};
use super::{say, warn_all, write_json, Target};
use anyhow::{Context, Result};
use bezchain::chain::{ChainLayout, Continuity};
use bezchain::export::{CurvePlot, CurveReport, InputInfo};
use bezchain::fit::evo::{EvoHooks, Evolution};
use bezchain::fit::{fit_curve_with, point_offsets, CurveFit, FitOptions, Method, Metric};
use bezchain::geometry::{read_curve, Loaded2};
use glam::DVec2;
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
    #[arg(long, default_value = "c1", value_parser = parse_continuity)]
    pub continuity: Continuity,
    /// Method: lsq, nelder-mead, bfgs, ga, cmaes, ga+lsq or cmaes+lsq.
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
    #[command(flatten)]
    pub cad: super::export::CadArgs,
    #[command(flatten)]
    pub evo: EvoArgs,
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

/// Fit, report and plot.
pub fn run(args: Args) -> Result<()> {
    args.cad.check()?;
    let loaded = load(&args.input)?;
    let layout = ChainLayout::uniform(args.degree, args.segments, args.continuity)?;
    let evolutionary = args.method.evolutionary().is_some();
    let (evo, resume) = args.evo.settings(evolutionary, &args.method)?;
    let opts = FitOptions {
        method: args.method,
        metric: args.metric,
        evo,
        ..FitOptions::default()
    };
    let mut monitor = Monitor::new(&args.evo);
    let quiet = args.evo.quiet;
    let mut started = false;
    let mut on_generation = |run: &Evolution<'_>| {
        if !started {
            monitor.start_bar(run, quiet);
            started = true;
        }
        monitor.generation(run)
    };
    let resume_path = args.evo.resume.clone();
    let mut hooks = EvoHooks {
        on_generation: if evolutionary {
            Some(&mut on_generation)
        } else {
            None
        },
        resume,
    };
    let fit = fit_curve_with(&loaded.points, layout, &opts, &mut hooks);
    drop(hooks);
    monitor.finish();
    let fit = fit.with_context(|| match &resume_path {
        Some(p) => format!("{}: resuming from {}", args.input.display(), p.display()),
        None => format!("{}: fitting {} points", args.input.display(), loaded.points.len()),
    })?;
    if fit.span_ratio > FitOptions::default().max_span_ratio {
        eprintln!(
            "warning: {}: the fitted chain doubles back on itself (span ratio {:.1}): its closest-point \
             offsets are small but neighbouring data points are far apart along the chain; try \
             another degree or number of segments",
            args.input.display(),
            fit.span_ratio
        );
    }
    let rep = CurveReport::from_fit(
        &fit,
        InputInfo {
            path: args.input.display().to_string(),
            points: loaded.points.len(),
        },
    );
    let json_target = args.json.as_deref().map(Target::parse);
    if let Some(target) = &json_target {
        write_json(target, &rep)?;
    }
    if args.cad.wanted() {
        let shape = bezchain::export::CadShape::from_curve_report(&rep)?;
        args.cad.write(&[shape], &super::export::stem(&args.input))?;
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
    say(json_target.as_ref(), &summary(&args.input, &loaded, &fit));
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
    if let Some(evo) = &fit.evolution {
        let r = &evo.run;
        s += &format!(
            "{}: population {}, {} generations ({}), {} individuals, {:.1} s; objective {:.4e} (f64, ends tied)\n",
            evo.stages[0].method,
            r.size,
            r.report.iterations,
            r.stop,
            r.report.evaluations,
            r.report.seconds,
            r.sum_sq
        );
        s += &format!(
            "backend {}: {:.3e} point evaluations/s ({:.3e} individuals/s) in the evaluator ({:.2} s of {:.2} s)\n",
            r.backend,
            r.evals_per_second,
            r.report.evaluations as f64 / r.eval_seconds.max(1e-12),
            r.eval_seconds,
            r.report.seconds
        );
        for st in &evo.stages[1..] {
            let from = match evo.polish_from_evolved {
                Some(true) => " (the polish of the evolved design won)",
                Some(false) => " (one of lsq's own starts beat the polish of the evolved design)",
                None => "",
            };
            s += &format!(
                "{}: {} iterations, {} evaluations, {:.1} ms{from}\n",
                st.method,
                st.report.iterations,
                st.report.evaluations,
                st.report.seconds * 1e3
            );
        }
        s += &format!("total {:.2} s\n", fit.report.seconds);
    } else {
        s += &format!(
            "{} iterations, {} evaluations, {:.1} ms\n",
            fit.report.iterations,
            fit.report.evaluations,
            fit.report.seconds * 1e3
        );
    }
    s
}
