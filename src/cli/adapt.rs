//! `bezchain adapt`: the chain with the fewest stored scalars whose offsets meet a tolerance
//! (the paper's Figs. 7 and 8), for one tolerance or a sweep.

use super::export::{CadArgs, CadOutputs};
use super::output::{Output, Outputs};
use super::usage;
use anyhow::{anyhow, Context, Result};
use bezchain::adaptive::{adapt_curve, AdaptOptions, Mode, Norm};
use bezchain::export::summary::{self, Adapted, SweepRow};
use bezchain::export::{AdaptReport, InputInfo, Schema, Sweep};
use std::path::{Path, PathBuf};

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
        outs.say(&summary::sweep_table(
            &input.display().to_string(),
            points,
            norm,
            &rows,
        ));
    }
    match (json, reports) {
        (None, _) => {}
        (Some(o), [one]) => outs.put_json(o, R::SCHEMA, one)?,
        (Some(o), many) => outs.put_json(o, Schema::Sweep, &Sweep::of(many))?,
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
    /// The norm the tolerance bounds: max (the largest closest-point offset of any data point)
    /// or rms (the root mean square of the offsets).
    #[arg(long, default_value = "max", value_parser = super::parse_word::<Norm>)]
    pub norm: Norm,
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
    /// How x may be stored: auto (both ways; the aerofoil rule where the data look like an
    /// aerofoil contour), aerofoil (only y stored, x following the aerofoil rule) or free (both
    /// coordinates of every design point stored, the paper's chains).
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<Mode>)]
    pub mode: Mode,
    /// Points the search runs on (the winner is refitted and checked on all); 0 for all.
    #[arg(long, default_value_t = 80)]
    pub search_points: usize,
    /// Write the JSON report (the curve report with an `adapt` block, `docs/ARCHITECTURE.md` §5.6;
    /// a sweep report for several tolerances, §5.10); `-` for standard output (the table then goes
    /// to standard error).
    #[arg(long)]
    pub json: Option<PathBuf>,
    // The plot (the last tolerance's chain) and the CAD files.
    #[command(flatten)]
    pub outputs: super::fit::ChainOutputArgs,
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

/// Run the search(es), print the table, write the outputs.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let (plots, cad) = args.outputs.add(&mut outs)?;
    let tols = args.tolerance.list("a chain")?;
    let loaded = super::fit::load(&args.input)?;
    let points = &loaded.points;
    let (min_degree, max_degree) = parse_degrees("--degrees", &args.degrees)?;
    let scale = if args.tolerance.relative {
        loaded.extent()
    } else {
        1.0
    };
    let base = AdaptOptions {
        norm: args.tolerance.norm,
        min_degree,
        max_degree,
        mode: args.mode,
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
        outs.say(&summary::adapted_curve(
            &name,
            points.len(),
            opts.tol,
            opts.norm,
            r,
        ));
    }
    if let (true, Some((opts, r))) = (plots.wanted(), results.last()) {
        let title = format!(
            "{} — adapt to {:.1e} ({}): {} stored scalars, {}",
            loaded.name, opts.tol, opts.norm, r.count.total, r.family
        );
        plots.put_chain(&mut outs, title, points, &r.chain)?;
    }
    finish(
        outs,
        json,
        (&args.outputs.cad, &cad),
        &args.input,
        points.len(),
        base.norm,
        &reports,
    )
}
