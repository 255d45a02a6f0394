//! `bezchain adapt`: the chain with the fewest stored scalars whose offsets meet a tolerance
//! (the paper's Figs. 7 and 8), for one tolerance or a sweep.

use super::export::{CadArgs, CadOutputs};
use super::output::{Output, Outputs};
use super::{usage, warn_all};
use anyhow::{anyhow, Context, Result};
use bezchain::adaptive::{adapt_curve, AdaptOptions, AdaptedCurve, Breaks, HeldOut, Mode, Norm, XStore};
use bezchain::export::{AdaptOutcome, AdaptReport, SurfaceAdaptReport};
use bezchain::export::{CadShape, CurvePlot, FitInfo, InputInfo, OffsetReport};
use bezchain::geometry::read_curve;
use clap::ValueEnum;
use glam::DVec2;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The norm the tolerance bounds.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum NormArg {
    /// The largest closest-point offset of any data point.
    Max,
    /// The root mean square of the offsets.
    Rms,
}

impl From<NormArg> for Norm {
    fn from(n: NormArg) -> Norm {
        match n {
            NormArg::Max => Norm::Max,
            NormArg::Rms => Norm::Rms,
        }
    }
}

/// One row of a `--sweep` table.
pub(crate) struct SweepRow<'a> {
    tol: f64,
    met: bool,
    scalars: usize,
    max: f64,
    rms: f64,
    held_out_max: Option<f64>,
    seconds: f64,
    family: &'a str,
    /// Why the tolerance does not hold, when it does not (the error says it, not the table).
    failure: Option<&'a str>,
}

impl<'a> SweepRow<'a> {
    /// The row of a report whose shape report has `offset` and `fit`, with `outcome` and
    /// `held_out` from its adapt block.
    fn new<C, E>(
        outcome: &'a AdaptOutcome<C, E>,
        offset: &OffsetReport,
        fit: &FitInfo,
        held_out: Option<HeldOut>,
    ) -> Self {
        SweepRow {
            tol: outcome.tol,
            met: outcome.met,
            scalars: outcome.stored_scalars,
            max: offset.max,
            rms: offset.rms,
            held_out_max: held_out.map(|h| h.max),
            seconds: fit.seconds,
            family: &outcome.family,
            failure: outcome.message.as_deref(),
        }
    }
}

/// The `--sweep` table of `adapt` and `adapt-surface`: stored scalars against tolerance.
fn sweep_table(name: &str, points: usize, norm: Norm, rows: &[SweepRow<'_>]) -> String {
    let mut s = format!("{name}: {points} points, stored scalars against tolerance ({norm})\n");
    let _ = writeln!(
        s,
        "{:>10} {:>4} {:>8} {:>11} {:>11} {:>13} {:>8}  layout",
        "tol", "met", "scalars", "max", "rms", "held-out max", "seconds"
    );
    for r in rows {
        let held = r.held_out_max.map_or("n/a".to_string(), |m| format!("{m:.3e}"));
        let _ = writeln!(
            s,
            "{:>10.3e} {:>4} {:>8} {:>11.3e} {:>11.3e} {:>13} {:>8.3}  {}",
            r.tol,
            if r.met { "yes" } else { "NO" },
            r.scalars,
            r.max,
            r.rms,
            held,
            r.seconds,
            r.family
        );
    }
    s
}

/// The report of an adapted chain or patch grid, as `adapt` and `adapt-surface` write it.
pub(crate) trait Adapted: serde::Serialize {
    /// Its row of the `--sweep` table.
    fn row(&self) -> SweepRow<'_>;
    /// The shape for the STEP and IGES files.
    fn cad_shape(&self) -> bezchain::Result<CadShape>;
}

impl Adapted for AdaptReport {
    fn row(&self) -> SweepRow<'_> {
        SweepRow::new(
            &self.adapt.outcome,
            &self.curve.offset,
            &self.curve.fit,
            self.adapt.held_out,
        )
    }
    fn cad_shape(&self) -> bezchain::Result<CadShape> {
        CadShape::from_adapt_report(self)
    }
}

impl Adapted for SurfaceAdaptReport {
    fn row(&self) -> SweepRow<'_> {
        SweepRow::new(
            &self.adapt.outcome,
            &self.surface.offset,
            &self.surface.fit,
            self.adapt.held_out,
        )
    }
    fn cad_shape(&self) -> bezchain::Result<CadShape> {
        CadShape::from_surface_adapt_report(self)
    }
}

/// The searches of `adapt` and `adapt-surface`: `search` at each of `tols` times `scale`
/// (model units), an error naming `input` and the tolerance.
pub(crate) fn search_each<T>(
    tols: &[f64],
    scale: f64,
    input: &Path,
    mut search: impl FnMut(f64) -> bezchain::Result<T>,
) -> Result<Vec<T>> {
    tols.iter()
        .map(|&t| {
            let tol = t * scale;
            search(tol).with_context(|| format!("{}: adapting to {tol:.3e}", input.display()))
        })
        .collect()
}

/// The end of `adapt` and `adapt-surface`, their reports one a tolerance: the `--sweep` table
/// (for several; `norm` the tolerances bound, `points` in `input`), the JSON report (an array
/// for several) and the STEP and IGES files (named after `input`) are written, whether or not
/// the tolerance was met; the error says where it was not.
pub(crate) fn finish<R: Adapted>(
    mut outs: Outputs,
    json: Option<Output>,
    (cad_args, cad): (&CadArgs, &CadOutputs),
    input: &Path,
    points: usize,
    norm: Norm,
    reports: &[R],
) -> Result<()> {
    let rows: Vec<SweepRow<'_>> = reports.iter().map(R::row).collect();
    if rows.len() > 1 {
        outs.say(&sweep_table(&input.display().to_string(), points, norm, &rows));
    }
    match (json, reports) {
        (None, _) => {}
        (Some(o), [one]) => outs.put_json(o, one)?,
        (Some(o), many) => outs.put_json(o, &many)?,
    }
    if cad_args.wanted() {
        let shapes = reports
            .iter()
            .map(R::cad_shape)
            .collect::<bezchain::Result<Vec<_>>>()?;
        cad_args.put(&mut outs, cad, &shapes, &super::export::stem(input))?;
    }
    outs.commit()?;
    let failures: Vec<&str> = rows.iter().filter_map(|r| r.failure).collect();
    if !failures.is_empty() {
        return Err(anyhow!("{}", failures.join("; ")));
    }
    Ok(())
}

/// How x may be stored.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ModeArg {
    /// Both ways; the aerofoil rule where the data look like an aerofoil contour.
    Auto,
    /// Only y stored, x following the aerofoil rule.
    Aerofoil,
    /// Both coordinates of every design point stored (the paper's chains).
    Free,
}

/// The tolerance arguments `adapt` and `adapt-surface` share.
#[derive(clap::Args, Debug)]
pub struct Tolerances {
    /// Tolerance in the data's units (with `--relative`, a fraction of the data's size: the
    /// extent of a contour, the largest section chord of a cloud).
    #[arg(long, required_unless_present = "sweep", allow_negative_numbers = true)]
    pub tol: Option<f64>,
    /// Several tolerances, comma-separated: one search each, a table of stored scalars
    /// against tolerance (the plot is that of the last; the report is an array).
    #[arg(
        long,
        value_delimiter = ',',
        conflicts_with = "tol",
        allow_negative_numbers = true
    )]
    pub sweep: Vec<f64>,
    /// The norm the tolerance bounds.
    #[arg(long, value_enum, default_value_t = NormArg::Max)]
    pub norm: NormArg,
    /// Read the tolerance as a fraction of the data's size (see `--tol`).
    #[arg(long)]
    pub relative: bool,
    /// Never report more stored scalars than this.
    #[arg(long)]
    pub max_scalars: Option<usize>,
}

impl Tolerances {
    /// The tolerances asked for, each checked positive, after checking `--max-scalars`
    /// (`what`: the shape, for the message).
    pub fn list(&self, what: &str) -> Result<Vec<f64>> {
        if self.max_scalars == Some(0) {
            return Err(usage(format!(
                "--max-scalars 0: {what} stores at least a few scalars; give a positive count"
            )));
        }
        let tols: Vec<f64> = match self.tol {
            Some(t) => vec![t],
            None => self.sweep.clone(),
        };
        if tols.is_empty() {
            return Err(usage("give --tol T or --sweep T1,T2,..."));
        }
        if let Some(t) = tols.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            return Err(usage(format!(
                "--tol {t}: the tolerance must be a positive number"
            )));
        }
        Ok(tols)
    }
}

/// Arguments of `bezchain adapt`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Contour: Selig or Lednicer `.dat`, CSV/XYZ rows of `x y`, or CSV whose header names `x`
    /// and `y` columns; ordered along the curve (or by an `index` or `point` column).
    pub input: PathBuf,
    #[command(flatten)]
    pub tolerance: Tolerances,
    /// Degrees searched, `LO-HI` or one degree (2 to 7).
    #[arg(long, default_value = "2-7")]
    pub degrees: String,
    /// How x may be stored.
    #[arg(long, value_enum, default_value_t = ModeArg::Auto)]
    pub mode: ModeArg,
    /// Points the search runs on (the winner is refitted and checked on all); 0 for all.
    #[arg(long, default_value_t = 80)]
    pub search_points: usize,
    /// Write the JSON report (the curve report with an `adapt` block, `docs/ARCHITECTURE.md`
    /// §5.6; an array for a sweep); `-` for standard output (the table then goes to standard
    /// error).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an SVG plot of the chain and its offsets.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    #[command(flatten)]
    pub cad: super::export::CadArgs,
}

/// `LO-HI` or one degree, the value of `flag`.
pub(crate) fn parse_degrees(flag: &str, text: &str) -> Result<(usize, usize)> {
    let bad = || usage(format!("{flag} '{text}': expected LO-HI or one degree, e.g. 2-7"));
    let degree = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
    match text.split_once('-') {
        Some((a, b)) => Ok((degree(a)?, degree(b)?)),
        None => degree(text).map(|d| (d, d)),
    }
}

/// The largest side of the points' bounding box.
fn extent(points: &[DVec2]) -> f64 {
    let (lo, hi) = points.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    (hi - lo).max_element()
}

/// One line describing the breaks of a result.
fn describe_breaks(r: &AdaptedCurve) -> String {
    let segments = r.chain.layout().segments();
    match &r.encoding.breaks {
        Breaks::Uniform { .. } => format!("{segments} equal segments"),
        Breaks::UniformPerSide { first, second } => {
            format!("{first} + {second} equal segments per surface")
        }
        Breaks::Stored(b) => format!(
            "{segments} segments, stored breaks [{}]",
            b.iter().map(|x| format!("{x:.4}")).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// The readable summary of one result.
fn summary(name: &str, points: usize, tol: f64, norm: Norm, r: &AdaptedCurve) -> String {
    let c = &r.count;
    let mut s = String::new();
    let _ = writeln!(s, "{name}: {points} points, tolerance {tol:.3e} ({norm})");
    let _ = writeln!(s, "  met            {}", if r.met { "yes" } else { "NO" });
    let mut kinds = vec![format!("y {}", c.y)];
    if c.x > 0 {
        kinds.insert(0, format!("x {}", c.x));
    }
    if c.rule > 0 {
        kinds.push(format!("aerofoil rule {}", c.rule));
    }
    kinds.push(format!("breaks {}", c.breaks));
    let _ = writeln!(s, "  stored scalars {} ({})", c.total, kinds.join(", "));
    let joins: Vec<String> = r.encoding.joins.iter().map(|k| format!("C{k}")).collect();
    let _ = writeln!(
        s,
        "  layout         {}: degree {}, {}, joins [{}]",
        r.family,
        r.encoding.degree,
        describe_breaks(r),
        joins.join(" ")
    );
    if let XStore::AerofoilRule(theta) = &r.encoding.x {
        let _ = match theta.as_slice() {
            [le, te] => writeln!(s, "  aerofoil rule  x_le {le:.6}, x_te {te:.6} (both surfaces)"),
            [le, a, b] => writeln!(
                s,
                "  aerofoil rule  x_le {le:.6}, x_te {a:.6} (first surface), {b:.6} (second)"
            ),
            _ => Ok(()),
        };
    }
    let _ = writeln!(
        s,
        "  offsets        max {:.3e} at ({:.5}, {:.5}), rms {:.3e}",
        r.offset.max, r.offset.max_at.x, r.offset.max_at.y, r.offset.rms
    );
    let met = r.trace.iter().filter(|t| t.best_scalars.is_some()).count();
    held_out_and_search(&mut s, r.held_out.as_ref(), r.trace.len(), met, r.fits, r.seconds);
    s
}

/// The summary's `held out` and `search` lines, shared with `adapt-surface`.
pub(crate) fn held_out_and_search(
    s: &mut String,
    held_out: Option<&HeldOut>,
    families: usize,
    met: usize,
    fits: usize,
    seconds: f64,
) {
    match held_out {
        Some(h) => {
            let _ = writeln!(
                s,
                "  held out       max {:.3e}, rms {:.3e} (refitted on {} points, measured on the other {})",
                h.max, h.rms, h.fitted, h.measured
            );
        }
        None => {
            let _ = writeln!(s, "  held out       not possible (too few points for the layout)");
        }
    }
    let _ = writeln!(
        s,
        "  search         {families} families ({met} met the tolerance), {fits} fits, {seconds:.3} s"
    );
}

/// Run the search(es), print the table, write the outputs.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let svg = outs.add_opt("--svg", args.svg.as_deref())?;
    let cad = args.cad.add(&mut outs)?;
    let tols = args.tolerance.list("a chain")?;
    let loaded = read_curve(&args.input)?;
    warn_all(&args.input, &loaded.warnings);
    let points = &loaded.points;
    let (min_degree, max_degree) = parse_degrees("--degrees", &args.degrees)?;
    let scale = if args.tolerance.relative {
        extent(points)
    } else {
        1.0
    };
    let base = AdaptOptions {
        norm: args.tolerance.norm.into(),
        min_degree,
        max_degree,
        mode: match args.mode {
            ModeArg::Auto => Mode::Auto,
            ModeArg::Aerofoil => Mode::Aerofoil,
            ModeArg::Free => Mode::Free,
        },
        max_scalars: args.tolerance.max_scalars,
        search_points: args.search_points,
        ..AdaptOptions::default()
    };
    let name = args.input.display().to_string();
    let input = InputInfo {
        path: name.clone(),
        points: points.len(),
    };
    let (reports, results): (Vec<_>, Vec<_>) = search_each(&tols, scale, &args.input, |tol| {
        let opts = AdaptOptions { tol, ..base };
        let r = adapt_curve(points, &opts)?;
        Ok((AdaptReport::new(&r, &opts, input.clone()), (opts, r)))
    })?
    .into_iter()
    .unzip();
    if let [(opts, r)] = &results[..] {
        outs.say(&summary(&name, points.len(), opts.tol, opts.norm, r));
    }
    if let (Some(o), Some((opts, r))) = (svg, results.last()) {
        let offsets = bezchain::problem::shape_offsets(
            &bezchain::chain::CurveShape::new(r.chain.layout().clone()),
            r.chain.design(),
            points,
            &bezchain::closest::FootOptions {
                samples: 48,
                ..Default::default()
            },
        )?
        .1
        .iter()
        .map(|f| f.dist_sq.sqrt())
        .collect::<Vec<f64>>();
        let plot = CurvePlot {
            title: format!(
                "{} — adapt to {:.1e} ({}): {} stored scalars, {}",
                loaded.name, opts.tol, opts.norm, r.count.total, r.family
            ),
            data: points,
            chain: &r.chain,
            offsets: &offsets,
        };
        outs.put(o, plot.to_svg()?.as_bytes())?;
    }
    finish(
        outs,
        json,
        (&args.cad, &cad),
        &args.input,
        points.len(),
        base.norm,
        &reports,
    )
}
