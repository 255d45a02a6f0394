//! `bezchain fit`: fit a chain of Bezier curves to a 2D contour and report it; the evolutionary
//! methods with a progress bar, a history file and checkpoints.

use super::evo::{warn_cap, EvoArgs, Monitor};
use super::output::Outputs;
use super::{usage, warn_all};
use anyhow::{Context, Result};
use bezchain::chain::{ChainLayout, Continuity};
use bezchain::export::{CurvePlot, CurveReport, InputInfo};
use bezchain::fit::{fit_curve_with, CurveFit, FitOptions, Method};
use bezchain::geometry::{read_curve, Loaded2};
use bezchain::optim::evo::{EvoHooks, Evolution};
use bezchain::problem::{point_offsets, Metric};
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
    /// Write an SVG plot (data, chain, design and generated points, offsets) here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    #[command(flatten)]
    pub cad: super::export::CadArgs,
    #[command(flatten)]
    pub evo: EvoArgs,
}

/// Read a contour, printing the reader's warnings.
pub fn load(path: &Path) -> Result<Loaded2> {
    let loaded = read_curve(path)?;
    warn_all(path, &loaded.warnings);
    Ok(loaded)
}

/// Refuse, before the fit, a layout with more design points than the data can determine; the
/// message gives the most segments that fit.
fn check_segments(args: &Args, points: usize) -> Result<ChainLayout> {
    let fits = |s: usize| {
        ChainLayout::uniform(args.degree, s, args.continuity).is_ok_and(|l| l.design_count() <= points)
    };
    let too_many = |design: String| {
        // Design points grow with the segments: the most that fit, by bisection.
        let (mut lo, mut hi) = (0, points.min(args.segments));
        while lo < hi {
            let mid = (lo + hi).div_ceil(2);
            if fits(mid) {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        let hint = match lo {
            0 => "use a lower --degree or more data points".to_string(),
            s => format!("use at most --segments {s} at degree {}", args.degree),
        };
        usage(format!(
            "--segments {}: {design}, more than the {points} data points of {} can determine; {hint}",
            args.segments,
            args.input.display()
        ))
    };
    // Each segment adds at least one design point: far too many are refused before the layout
    // is built.
    if args.segments > 4 * points.max(64) {
        return Err(too_many(format!(
            "{} segments need more than {} design points",
            args.segments, args.segments
        )));
    }
    let layout = ChainLayout::uniform(args.degree, args.segments, args.continuity).map_err(|e| {
        usage(format!(
            "--degree {} --segments {}: {e}",
            args.degree, args.segments
        ))
    })?;
    if layout.design_count() > points {
        return Err(too_many(format!(
            "degree {} with {} segments has {} design points",
            args.degree,
            args.segments,
            layout.design_count()
        )));
    }
    Ok(layout)
}

/// Fit, report and plot.
pub fn run(args: Args) -> Result<()> {
    // Every output is checked (and its temporary file made) before the work.
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let svg = outs.add_opt("--svg", args.svg.as_deref())?;
    let cad = args.cad.add(&mut outs)?;
    let mut monitor = Monitor::new(&args.evo, &mut outs)?;
    let evolutionary = args.method.evolutionary();
    let (evo, resume) = args.evo.settings(evolutionary.is_some(), &args.method)?;
    let loaded = load(&args.input)?;
    let layout = check_segments(&args, loaded.points.len())?;
    args.evo
        .check_size(&evo, evolutionary.map(|e| e.0), 2 * layout.design_count())?;
    let opts = FitOptions {
        method: args.method,
        metric: args.metric,
        evo,
        ..FitOptions::default()
    };
    let outs_in_run = &mut outs;
    let monitor_in_run = &mut monitor;
    let mut on_generation = |run: &Evolution<'_>| monitor_in_run.generation(run, outs_in_run);
    let resume_path = args.evo.resume.clone();
    let mut hooks = EvoHooks {
        on_generation: if evolutionary.is_some() {
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
    monitor.close(&mut outs)?;
    if let Some(cap) = fit.stopped() {
        warn_cap(&args.input, &fit.method.to_string(), cap, &fit.report);
    }
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
    if let Some(o) = json {
        outs.put_json(o, &rep)?;
    }
    if args.cad.wanted() {
        let shape = bezchain::export::CadShape::from_curve_report(&rep)?;
        args.cad
            .put(&mut outs, &cad, &[shape], &super::export::stem(&args.input))?;
    }
    if let Some(o) = svg {
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
        outs.put(o, svg.as_bytes())?;
    }
    outs.commit()?;
    outs.say(&summary(&args.input, &loaded, &fit));
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
            "{}: population {}, {} generations ({}{}), {} individuals, {:.1} s; objective {:.4e} (f64, ends tied)\n",
            evo.stages[0].method,
            r.size,
            r.report.iterations,
            r.stop,
            match r.restarts {
                0 => String::new(),
                1 => ", after 1 restart".to_string(),
                k => format!(", after {k} restarts"),
            },
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
