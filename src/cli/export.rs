//! CAD outputs: the `--step`/`--iges` flags shared by `fit`, `adapt`, `fit-surface` and
//! `adapt-surface`, and `bezchain export REPORT.json`, which writes them from a saved report.

use super::output::{Output, Outputs};
use super::usage;
use anyhow::{Context, Result};
use bezchain::export::{iges_text, step_text, utc_now, CadShape, CadUnit};
use std::path::{Path, PathBuf};

/// STEP and IGES outputs: the chain as one B-spline curve, the grid as one B-spline surface.
#[derive(clap::Args, Debug, Clone)]
pub struct CadArgs {
    /// Write the result as a STEP AP214 B-spline (curve or surface) here.
    #[arg(long)]
    pub step: Option<PathBuf>,
    /// Write the result as an IGES 5.3 B-spline (entity 126 or 128) here.
    #[arg(long)]
    pub iges: Option<PathBuf>,
    /// The length unit of the STEP/IGES files: m or mm. The data are taken to be in metres;
    /// mm writes the coordinates × 1000 (the JSON stays in the data's units).
    #[arg(long, default_value = "m", value_parser = super::parse_word::<CadUnit>)]
    pub cad_unit: CadUnit,
}

impl CadArgs {
    /// True when a STEP or IGES file is asked for.
    #[must_use]
    pub fn wanted(&self) -> bool {
        self.step.is_some() || self.iges.is_some()
    }

    /// Check the outputs asked for before any work (a file name, not `-`; see
    /// [`Outputs::add`]) and add them to the run's outputs.
    pub fn add(&self, outs: &mut Outputs) -> Result<CadOutputs> {
        let mut add = |flag: &str, path: &Option<PathBuf>| match path.as_deref() {
            Some(p) if p.as_os_str() == "-" => Err(usage(format!("{flag}: give a file name, not -"))),
            Some(p) => Ok(Some(outs.add(flag, p)?)),
            None => Ok(None),
        };
        Ok(CadOutputs {
            step: add("--step", &self.step)?,
            iges: add("--iges", &self.iges)?,
        })
    }

    /// Make the files asked for into their outputs; `name` names the product inside them.
    pub fn put(&self, outs: &mut Outputs, to: &CadOutputs, shapes: &[CadShape], name: &str) -> Result<()> {
        let now = utc_now();
        if let Some(o) = to.step {
            outs.put(o, step_text(shapes, self.cad_unit, name, &now)?.as_bytes())?;
        }
        if let Some(o) = to.iges {
            outs.put(o, iges_text(shapes, self.cad_unit, name, &now)?.as_bytes())?;
        }
        Ok(())
    }
}

/// The STEP and IGES outputs of a run, from [`CadArgs::add`].
#[derive(Clone, Copy, Debug)]
pub struct CadOutputs {
    step: Option<Output>,
    iges: Option<Output>,
}

/// The stem of `path`, to name a product.
pub fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "bezchain".to_string(), |s| s.to_string_lossy().into_owned())
}

/// Arguments of `bezchain export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A JSON report of `fit`, `adapt`, `fit-surface` or `adapt-surface` (or a sweep report of
    /// several).
    pub report: PathBuf,
    #[command(flatten)]
    pub cad: CadArgs,
}

/// Read the report and write the CAD files.
pub fn run(args: Args) -> Result<()> {
    if !args.cad.wanted() {
        return Err(usage("give --step FILE and/or --iges FILE"));
    }
    let mut outs = Outputs::new();
    let cad = args.cad.add(&mut outs)?;
    let shapes = CadShape::read_reports(&args.report)?;
    args.cad
        .put(&mut outs, &cad, &shapes, &stem(&args.report))
        .with_context(|| format!("{}: exporting", args.report.display()))?;
    outs.commit()?;
    let to: Vec<String> = [&args.cad.step, &args.cad.iges]
        .into_iter()
        .flatten()
        .map(|p| p.display().to_string())
        .collect();
    for s in &shapes {
        tell!("{}: {} → {}", args.report.display(), s.describe(), to.join(", "));
    }
    Ok(())
}
