//! CAD outputs: the `--step`/`--iges` flags shared by `fit`, `adapt`, `fit-surface` and
//! `adapt-surface`, and `bezchain export REPORT.json`, which writes them from a saved report.

use super::{usage, Target};
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
    /// The length unit the STEP/IGES files declare: m or mm (coordinates are written as they
    /// are, never scaled).
    #[arg(long, default_value = "m", value_parser = parse_unit)]
    pub cad_unit: CadUnit,
}

fn parse_unit(s: &str) -> std::result::Result<CadUnit, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

impl CadArgs {
    /// True when a STEP or IGES file is asked for.
    #[must_use]
    pub fn wanted(&self) -> bool {
        self.step.is_some() || self.iges.is_some()
    }

    /// Refuse, before any work, outputs that cannot be written: standard output, or a file in
    /// a folder that does not exist.
    pub fn check(&self) -> Result<()> {
        for (flag, path) in [("--step", &self.step), ("--iges", &self.iges)] {
            match path.as_deref().map(Target::parse) {
                Some(Target::Stdout) => return Err(usage(format!("{flag}: give a file name, not -"))),
                Some(Target::File(p)) => {
                    let dir = p
                        .parent()
                        .filter(|d| !d.as_os_str().is_empty())
                        .unwrap_or(Path::new("."));
                    if !dir.is_dir() {
                        return Err(usage(format!(
                            "{flag} {}: the folder {} does not exist",
                            p.display(),
                            dir.display()
                        )));
                    }
                }
                None => {}
            }
        }
        Ok(())
    }

    /// The files asked for, made in memory; `name` names the product inside them.
    pub fn files(&self, shapes: &[CadShape], name: &str) -> Result<Vec<(Target, Vec<u8>)>> {
        let now = utc_now();
        let mut out = Vec::new();
        if let Some(p) = &self.step {
            out.push((
                Target::parse(p),
                step_text(shapes, self.cad_unit, name, &now)?.into_bytes(),
            ));
        }
        if let Some(p) = &self.iges {
            out.push((
                Target::parse(p),
                iges_text(shapes, self.cad_unit, name, &now)?.into_bytes(),
            ));
        }
        Ok(out)
    }

    /// Write the files asked for (each whole or not at all); `name` names the product.
    pub fn write(&self, shapes: &[CadShape], name: &str) -> Result<()> {
        for (target, bytes) in self.files(shapes, name)? {
            target.write(&bytes)?;
        }
        Ok(())
    }
}

/// The stem of `path`, to name a product.
pub fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "bezchain".to_string(), |s| s.to_string_lossy().into_owned())
}

/// Arguments of `bezchain export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A JSON report of `fit`, `adapt`, `fit-surface` or `adapt-surface` (or an array of them).
    pub report: PathBuf,
    #[command(flatten)]
    pub cad: CadArgs,
}

/// Read the report and write the CAD files.
pub fn run(args: Args) -> Result<()> {
    if !args.cad.wanted() {
        return Err(usage("give --step FILE and/or --iges FILE"));
    }
    args.cad.check()?;
    let shapes = CadShape::read_reports(&args.report)?;
    args.cad
        .write(&shapes, &stem(&args.report))
        .with_context(|| format!("{}: exporting", args.report.display()))?;
    let what = |s: &CadShape| match s {
        CadShape::Curve(c) => format!(
            "B-spline curve, degree {}, {} control points",
            c.degree,
            c.ctrl.len()
        ),
        CadShape::Surface(s) => format!(
            "B-spline surface, degrees {} x {}, {} x {} control points",
            s.degree[0], s.degree[1], s.count[0], s.count[1]
        ),
    };
    let to: Vec<String> = [&args.cad.step, &args.cad.iges]
        .into_iter()
        .flatten()
        .map(|p| p.display().to_string())
        .collect();
    for s in &shapes {
        eprintln!("{}: {} → {}", args.report.display(), what(s), to.join(", "));
    }
    Ok(())
}
