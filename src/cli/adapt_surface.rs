//! `bezchain adapt-surface`: the patch grid with the fewest stored scalars whose offsets from a
//! sectioned 3D cloud meet a tolerance, for one tolerance or a sweep.

use super::adapt::{finish, parse_degrees, search_each, Tolerances};
use super::output::Outputs;
use super::progress::Generations;
use super::{note_all, usage, warn_all};
use anyhow::{Context, Result};
use bezchain::adaptive::{
    adapt_blade, adapt_surface_with, ChordRule, SpanBreaks, SurfaceAdaptOptions, SurfaceProgress,
};
use bezchain::export::{summary, SurfaceAdaptReport};
use bezchain::export::{InputInfo, RenderOptions};
use bezchain::geometry::{read_cloud, Blade, Grid, LoftOptions};
use glam::DVec3;
use std::path::PathBuf;
use std::sync::Mutex;

/// Arguments of `bezchain adapt-surface`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Cloud: a CSV whose header names `x`, `y`, `z` and `section` (or `station`) columns, the
    /// points of a section ordered by `index` (or `point`), every section alike (e.g. from
    /// `bezchain blade`). Or a blade definition (windIO YAML, bezchain JSON, an AeroDyn 15
    /// primary file): lofted at its stations, and the surface also checked against sections
    /// lofted half-way between them.
    pub cloud: PathBuf,
    /// Points per section when lofting a blade definition (default: its aerofoils' own count).
    #[arg(long)]
    pub points_per_section: Option<usize>,
    #[command(flatten)]
    pub tolerance: Tolerances,
    /// Degrees searched around the sections, `LO-HI` or one degree (2 to 7).
    #[arg(long, default_value = "3-6")]
    pub degrees_u: String,
    /// Degrees searched along the span, `LO-HI` or one degree (2 to 7).
    #[arg(long, default_value = "2-3")]
    pub degrees_v: String,
    /// Store all three coordinates of every design point even where the sections are planar.
    #[arg(long)]
    pub no_span_rule: bool,
    /// The chord rule (a frame per design column and one thickness-direction number per
    /// design point, the aerofoil rule's x around; where the span rule holds and every section
    /// looks like an aerofoil section starting and ending at its trailing edge): `auto` tries
    /// it first and searches without it too when it meets nothing, `on` only with it, `off`
    /// never.
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<ChordRule>)]
    pub chord_rule: ChordRule,
    /// Where the bulk families' span breaks may go (the greedy families split where the
    /// offsets are): `midway` between neighbouring sections, at the `sections`, `by-degree` (at
    /// the sections for odd span degrees, midway for even), or `auto`: midway, but in a blade
    /// definition's searches after the first, the trailing-edge families of odd span degree
    /// that find nothing to split there try the sections. Which stores fewer scalars depends on
    /// the blade (`docs/GUIDE.md`).
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<SpanBreaks>)]
    pub span_breaks: SpanBreaks,
    /// Write the JSON report (the surface report with an `adapt` block, `docs/ARCHITECTURE.md`
    /// §5.7; a sweep report for several tolerances, §5.10); `-` for standard output (the summary
    /// then goes to standard error).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// The pictures of the surface (of the last tolerance's, with several).
    #[command(flatten)]
    pub picture: super::picture::PictureArgs,
    #[command(flatten)]
    pub cad: super::export::CadArgs,
}

/// The sectioned cloud to fit (for a blade definition, lofted at its stations), and the
/// definition with its loft options.
type Input = (Vec<DVec3>, Grid, Option<(Blade, LoftOptions)>);

/// Read the input: a sectioned cloud or a blade definition.
fn read_input(args: &Args) -> Result<Input> {
    let path = &args.cloud;
    if Blade::is_definition(path) {
        super::bounded(
            "--points-per-section",
            args.points_per_section.unwrap_or(0) as u64,
            100_000,
            "a few hundred points a section resolve an aerofoil",
        )?;
        let blade = Blade::from_file(path)?;
        warn_all(path, &blade.warnings);
        note_all(path, &blade.notes);
        let opts = LoftOptions {
            points_per_section: args.points_per_section,
            ..LoftOptions::default()
        };
        let cloud = blade
            .loft(&opts)
            .with_context(|| format!("{}: lofting", path.display()))?;
        let grid = cloud
            .grid
            .ok_or_else(|| usage(format!("{}: the lofted cloud has no sections", path.display())))?;
        return Ok((cloud.points, grid, Some((blade, opts))));
    }
    if args.points_per_section.is_some() {
        return Err(usage(format!(
            "{}: --points-per-section lofts a blade definition; this is a point cloud",
            path.display()
        )));
    }
    let loaded = read_cloud(path)?;
    warn_all(path, &loaded.warnings);
    let Some(grid) = loaded.grid else {
        return Err(usage(format!(
            "{}: adapt-surface needs a sectioned cloud (CSV with complete section,index columns) or a \
             blade definition",
            path.display()
        )));
    };
    Ok((loaded.points, grid, None))
}

/// Run the search(es), print the summary, write the report.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let cad = args.cad.add(&mut outs)?;
    let pictures = args.picture.add(&mut outs)?;
    let tols = args.tolerance.list("a patch grid")?;
    let (points, grid, definition) = read_input(&args)?;
    let points = &points;
    let scale = if args.tolerance.relative {
        grid.largest_chord(points)
    } else {
        1.0
    };
    let base = SurfaceAdaptOptions {
        norm: args.tolerance.norm,
        degrees_u: parse_degrees("--degrees-u", &args.degrees_u)?.into(),
        degrees_v: parse_degrees("--degrees-v", &args.degrees_v)?.into(),
        span_rule: !args.no_span_rule,
        chord_rule: args.chord_rule,
        max_scalars: args.tolerance.max_scalars,
        span_breaks: args.span_breaks,
        ..SurfaceAdaptOptions::default()
    };
    if let Some(t) = tols
        .iter()
        .find(|t| !(*t * scale > 0.0 && (*t * scale).is_finite()))
    {
        return Err(usage(format!("--tol {t}: the tolerance must be positive")));
    }
    let name = args.cloud.display().to_string();
    let input = InputInfo {
        path: name.clone(),
        points: points.len(),
    };
    let mut last = None;
    let reports = search_each(&tols, scale, &args.cloud, |tol| {
        let opts = SurfaceAdaptOptions { tol, ..base };
        let label = format!("{name} at {:.3e}", opts.tol);
        let bar = Mutex::new(Generations::counting(("family", "family")));
        let shown = |p: &SurfaceProgress<'_>| {
            let Ok(mut bar) = bar.lock() else { return };
            if !bar.started() {
                bar.start(&label, 0, p.total as u64);
            }
            let f = p.family;
            let best = f
                .best_scalars
                .map_or(String::new(), |n| format!(", {n} stored scalars"));
            let msg = format!("{} pass: {} {}{best}", p.pass, f.family, f.outcome);
            bar.show(&label, p.done as u64, p.total as u64, msg);
        };
        let r = match &definition {
            None => adapt_surface_with(points, grid, None, &opts, &shown).map(|r| (r, None)),
            Some((blade, loft)) => adapt_blade(blade, loft, &opts, &shown).map(|b| {
                let added = b.radii.len() - b.stations;
                (b.surface, Some((b.cloud, added, b.rounds)))
            }),
        };
        if let Ok(mut bar) = bar.lock() {
            bar.finish();
        }
        let (r, refined) = r?;
        let fitted = refined.as_ref().map_or(&points[..], |c| &c.0.points[..]);
        if let Some((_, added, rounds)) = &refined {
            if let Some(note) = summary::joined_sections(&name, *added, *rounds) {
                outs.say(&note);
            }
        }
        if tols.len() == 1 {
            outs.say(&summary::adapted_surface(
                &name,
                fitted.len(),
                opts.tol,
                opts.norm,
                &r,
            ));
        }
        if let Some(w) = summary::ends_warning(r.ends.as_ref(), opts.tol) {
            super::warn(&args.cloud, &w);
        }
        let input = InputInfo {
            points: fitted.len(),
            ..input.clone()
        };
        let report = SurfaceAdaptReport::new(&r, &opts, input);
        // The surface, and for a blade definition the cloud it was fitted to (the input's
        // otherwise), for the picture.
        let remark = summary::ends_remark(r.ends.as_ref(), opts.tol);
        last = Some((r.grid, refined.map(|c| c.0), remark));
        Ok(report)
    })?;
    if let (true, Some((surface, cloud, remark))) = (pictures.wanted(), &last) {
        let (points, grid) = match cloud {
            Some(c) => (&c.points[..], c.grid.unwrap_or(grid)),
            None => (&points[..], grid),
        };
        let [w, h] = pictures.size();
        let ropts = RenderOptions {
            remarks: remark.iter().cloned().collect(),
            ..RenderOptions::of_sectioned(surface, points, grid, w, h)?
        };
        pictures.put(&mut outs, surface, &ropts)?;
    }
    finish(
        outs,
        json,
        (&args.cad, &cad),
        &args.cloud,
        points.len(),
        base.norm,
        &reports,
    )
}
