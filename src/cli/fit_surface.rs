//! `bezchain fit-surface`: fit a grid of chained Bezier patches to a 3D point cloud and write
//! the report, meshes and a picture.

use super::evo::{EvoArgs, Monitor};
use super::output::Outputs;
use super::progress::spinner;
use super::{parse_pair, usage, warn, warn_all};
use anyhow::{Context, Result};
use bezchain::chain::Continuity;
use bezchain::export::{summary, InputInfo, RenderOptions, Schema, SurfaceMesh, SurfaceReport};
use bezchain::fit::surface_breaks::{auto_breaks_v, check_fit, AutoBreaks, BreakSearch};
use bezchain::fit::{
    fit_surface_with, parse_surface_method, Breaks, Method, ParamSource, SurfaceFit, SurfaceLayout,
    SurfaceOptions, SurfaceProgress,
};
use bezchain::geometry::read_cloud;
use bezchain::optim::evo::Checkpoint;
use bezchain::problem::SpanDirection;
use glam::DVec3;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Arguments of `bezchain fit-surface`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Point cloud: CSV/XYZ rows of `x y z`, or CSV whose header names `x`, `y`, `z` (any order,
    /// other columns ignored); `section` (or `station`) and `index` (or `point`) columns with
    /// equal sections make a structured cloud whose parameters come from its sections.
    pub cloud: PathBuf,
    /// Degrees around the section (u) and along the span (v), as DUxDV (e.g. 3x3).
    #[arg(long, value_parser = parse_pair)]
    pub degree: [usize; 2],
    /// Patches around the section and along the span, as PUxPV (e.g. 4x2).
    #[arg(long, value_parser = parse_pair)]
    pub patches: [usize; 2],
    /// Continuity across patch borders: c0, c1 or c2 in both directions, or CUxCV (e.g. c1xc2).
    #[arg(long, default_value = "c1", value_parser = parse_continuity)]
    pub continuity: [Continuity; 2],
    /// Breaks around the section: `uniform`, or parameters in [0, 1] (the PU-1 interior ones,
    /// or all PU+1), comma-separated.
    #[arg(long, default_value = "uniform")]
    pub breaks_u: String,
    /// Breaks along the span: `uniform`; parameters in [0, 1] as for --breaks-u; `span:R1,R2,...`,
    /// positions along the span axis in model units (e.g. radii); or `stations:BLADE.json`, the
    /// station radii of a blade file (a lofted blade is only C1 there, so its patches should
    /// end there); or `auto` (the default): the breaks that give the smallest closest-point
    /// sum of squares among candidates whose closest points a coarse sampled search also finds
    /// (least-squares fits of clouds up to --subsample points; uniform above).
    #[arg(long, default_value = "auto")]
    pub breaks_v: String,
    /// Method: lsq, ga, cmaes, ga+lsq or cmaes+lsq (the evolutionary ones on the population
    /// evaluator, from the linear least-squares start, on the subsample of a large cloud).
    #[arg(long, default_value = "lsq", value_parser = |s: &str| parse_surface_method(s).map_err(|e| e.to_string()))]
    pub method: Method,
    /// Initial parameters: auto (sections when the cloud has them, else blade-aware), sections
    /// or blade.
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<ParamSource>)]
    pub params: ParamSource,
    /// Span axis: x, y, z, or auto (the cloud's principal axis).
    #[arg(long, default_value = "z", value_parser = super::parse_word::<SpanDirection>)]
    pub span: SpanDirection,
    /// Clouds larger than this are fitted on a subsample of about this many points first
    /// (0: never).
    #[arg(long, default_value_t = SurfaceOptions::default().subsample)]
    pub subsample: usize,
    /// Joint iterations on the whole cloud after the subsample fit.
    #[arg(long, default_value_t = SurfaceOptions::default().polish_iterations)]
    pub polish: usize,
    /// Most Levenberg-Marquardt iterations of the main fit.
    #[arg(long, default_value_t = SurfaceOptions::default().lsq.max_iterations)]
    pub max_iterations: usize,
    /// Seed of the subsample.
    #[arg(long, default_value_t = 0)]
    pub subsample_seed: u64,
    /// Write the JSON report here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    #[command(flatten)]
    pub cad: super::export::CadArgs,
    /// Write the fitted surface as a Wavefront OBJ mesh here.
    #[arg(long)]
    pub obj: Option<PathBuf>,
    /// Write the fitted surface as a binary STL mesh here.
    #[arg(long)]
    pub stl: Option<PathBuf>,
    /// Mesh samples per patch side for --obj and --stl.
    #[arg(long, default_value_t = 16)]
    pub mesh_density: usize,
    #[command(flatten)]
    pub picture: super::picture::PictureArgs,
    #[command(flatten)]
    pub evo: EvoArgs,
}

fn parse_continuity(s: &str) -> std::result::Result<[Continuity; 2], String> {
    let one = |t: &str| t.parse::<Continuity>().map_err(|e| e.to_string());
    match s.split_once(['x', 'X']) {
        Some((a, b)) => Ok([one(a)?, one(b)?]),
        None => one(s).map(|c| [c, c]),
    }
}

/// Breaks from `--breaks-u` / `--breaks-v` text (`flag` names the option in errors).
fn parse_breaks(text: &str, flag: &str) -> Result<Breaks> {
    Breaks::parse(text, &mut warn).with_context(|| flag.to_string())
}

/// Fit, report, mesh and draw.
pub fn run(args: Args) -> Result<()> {
    let clock = Instant::now();
    // Every argument is checked before the (possibly long) read and fit.
    let auto_v = args.breaks_v.trim().eq_ignore_ascii_case("auto");
    let mut layout = SurfaceLayout {
        degree: args.degree,
        patches: args.patches,
        continuity: args.continuity,
        breaks_u: parse_breaks(&args.breaks_u, "--breaks-u")?,
        breaks_v: if auto_v {
            Breaks::Uniform
        } else {
            parse_breaks(&args.breaks_v, "--breaks-v")?
        },
    };
    // Layouts that do not depend on the cloud are checked now, not after a long read.
    if !matches!(layout.breaks_v, Breaks::Span(_)) {
        layout.unit_layout().map_err(|e| {
            usage(format!(
                "--patches {}x{} --breaks-u {} --breaks-v {}: {e}",
                args.patches[0], args.patches[1], args.breaks_u, args.breaks_v
            ))
        })?;
    }
    let evolutionary = args.method.evolutionary().is_some();
    let (evo, resume) = args.evo.settings(evolutionary, &args.method)?;
    if args.mesh_density == 0 || args.mesh_density > 1024 {
        return Err(usage("--mesh-density must be between 1 and 1024"));
    }
    // Every output is checked (and its temporary file made) now, not after a long fit.
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let obj = outs.add_opt("--obj", args.obj.as_deref())?;
    let stl = outs.add_opt("--stl", args.stl.as_deref())?;
    let pictures = args.picture.add(&mut outs)?;
    let cad = args.cad.add(&mut outs)?;
    let mut monitor = Monitor::new(&args.evo, &mut outs)?;
    let loaded = read_cloud(&args.cloud)?;
    warn_all(&args.cloud, &loaded.warnings);
    let n = loaded.points.len();
    // Refused before the fit: a net with more design points than the cloud can determine.
    layout
        .check_points(n, &args.cloud)
        .map_err(|e| usage(format!("--patches {}x{}: {e}", args.patches[0], args.patches[1])))?;
    args.evo.check_size(
        &evo,
        args.method.evolutionary().map(|e| e.0),
        3 * layout.design_shape().map_or(0, |(nu, nv)| nu * nv),
    )?;
    let structure = match loaded.grid {
        Some(g) => format!("{} sections x {} points", g.sections, g.per_section),
        None => "unordered".into(),
    };
    tell!(
        "{}: {n} points ({structure}), read in {:.2} s",
        args.cloud.display(),
        clock.elapsed().as_secs_f64()
    );
    let mut opts = SurfaceOptions {
        method: args.method,
        params: args.params,
        subsample: args.subsample,
        polish_iterations: args.polish,
        seed: args.subsample_seed,
        evo,
        ..SurfaceOptions::default()
    };
    opts.lsq.max_iterations = args.max_iterations;
    opts.blade.span = args.span.dir();
    // Span breaks (`span:` or `stations:FILE`) depend on the cloud's span: an error in them
    // names the option and its file, not the cloud.
    if matches!(layout.breaks_v, Breaks::Span(_)) {
        let (_, axis, _) = bezchain::fit::initial_params(&loaded.points, loaded.grid, &opts)?;
        layout
            .grid_layout(&axis)
            .map_err(|e| usage(format!("--breaks-v {}: {e}", args.breaks_v.trim())))?;
    }

    let searched = if auto_v {
        choose_breaks_v(&args, &loaded.points, loaded.grid, &layout, &opts)?
    } else {
        None
    };
    if let Some(search) = &searched {
        layout.breaks_v = Breaks::Params(search.fit.grid.layout().v.breaks().to_vec());
    }

    // A least-squares break search has already made (and checked) the fit it chose.
    let (fit, check) = match searched {
        Some(search) if !evolutionary => (search.fit, Some(search.check)),
        _ => (
            fit_with_progress(
                &args,
                &loaded.points,
                loaded.grid,
                &layout,
                &opts,
                resume,
                (&mut monitor, &mut outs),
            )?,
            None,
        ),
    };

    if let Some(w) = check_fit(&fit, &loaded.points, check).and_then(|c| summary::checker_warning(&fit, &c)) {
        warn(&args.cloud, &w);
    }
    if let Some(cap) = fit.stopped() {
        warn(
            &args.cloud,
            &summary::cap_warning(args.method.name(), cap, &fit.report),
        );
    }
    let rep = SurfaceReport::from_fit(
        &fit,
        args.method,
        InputInfo {
            path: args.cloud.display().to_string(),
            points: n,
        },
    );
    let name = args
        .cloud
        .file_stem()
        .map_or_else(|| "surface".to_string(), |s| s.to_string_lossy().into_owned());
    // Every output is made into its temporary file; all are put in place together at the end.
    if let Some(o) = json {
        outs.put_json(o, Schema::Surface, &rep)?;
    }
    if obj.is_some() || stl.is_some() {
        let mesh = SurfaceMesh::from_grid(&fit.grid, args.mesh_density)?;
        if let Some(o) = obj {
            outs.put(o, mesh.to_obj(&name).as_bytes())?;
        }
        if let Some(o) = stl {
            outs.put(o, &mesh.to_stl(&name))?;
        }
    }
    if pictures.wanted() {
        let [w, h] = pictures.size();
        pictures.put(
            &mut outs,
            &fit.grid,
            &RenderOptions::of_fit(&fit, &loaded.points, loaded.grid, w, h),
        )?;
    }
    if args.cad.wanted() {
        let shape = bezchain::export::CadShape::from_surface_report(&rep)?;
        args.cad.put(&mut outs, &cad, &[shape], &name)?;
    }
    outs.commit()?;
    outs.say(&summary::surface_fit(
        args.method,
        &fit,
        n,
        clock.elapsed().as_secs_f64(),
    ));
    Ok(())
}

/// `--breaks-v auto` ([`auto_breaks_v`]) with a progress bar; `None` (uniform breaks) when the
/// library's policy skips the search.
fn choose_breaks_v(
    args: &Args,
    points: &[DVec3],
    grid: Option<bezchain::geometry::Grid>,
    layout: &SurfaceLayout,
    opts: &SurfaceOptions,
) -> Result<Option<BreakSearch>> {
    let bar = spinner("{spinner} {elapsed:>4} breaks v: fit {pos}/{len}", false);
    let decided = auto_breaks_v(points, grid, layout, opts, &mut |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("{}: searching the span breaks", args.cloud.display()))?;
    bar.finish_and_clear();
    let search = match decided {
        AutoBreaks::Searched(search) => *search,
        AutoBreaks::SinglePatch => return Ok(None),
        AutoBreaks::TooLarge { limit } => {
            tell!(
                "breaks v: uniform (the automatic break search runs on clouds of up to {limit} points; \
                 give --breaks-v for this one, e.g. stations:BLADE.json)"
            );
            return Ok(None);
        }
    };
    tell!("{}", search.describe());
    Ok(Some(search))
}

/// The fit itself, with a spinner for least squares or the monitor's bar for an evolutionary
/// run.
fn fit_with_progress(
    args: &Args,
    points: &[DVec3],
    grid: Option<bezchain::geometry::Grid>,
    layout: &SurfaceLayout,
    opts: &SurfaceOptions,
    resume: Option<Checkpoint>,
    (monitor, outs): (&mut Monitor, &mut Outputs),
) -> Result<SurfaceFit> {
    let evolutionary = args.method.evolutionary().is_some();
    // The spinner for least squares; an evolutionary run has the monitor's bar instead.
    let bar = spinner("{spinner} {elapsed:>4} {msg}", evolutionary);
    bar.enable_steady_tick(Duration::from_millis(120));
    let mut stage = "";
    let mut stage_points = 0usize;
    let fit = monitor.run(
        outs,
        (&args.evo, evolutionary, resume),
        (&args.cloud, points.len()),
        |hooks| {
            fit_surface_with(
                points,
                grid,
                layout,
                opts,
                &mut |p| match p {
                    SurfaceProgress::Params { source, seconds } => {
                        bar.suspend(|| tell!("parameters: {source} ({seconds:.2} s)"));
                    }
                    SurfaceProgress::Stage { name, points } => {
                        stage = name;
                        stage_points = points;
                        let what = if matches!(name, "ga" | "cmaes") {
                            "evolution"
                        } else {
                            "least squares"
                        };
                        bar.suspend(|| tell!("{name}: {what} on {points} points"));
                    }
                    SurfaceProgress::Iteration(it) => {
                        let rms = (it.sum_sq / stage_points.max(1) as f64).sqrt();
                        bar.set_message(format!("{stage}: iteration {}, rms {rms:.3e}", it.iteration));
                    }
                    SurfaceProgress::Offsets { points } => {
                        bar.set_message(format!("closest points of all {points} points"));
                    }
                },
                hooks,
            )
        },
    );
    bar.finish_and_clear();
    fit
}
