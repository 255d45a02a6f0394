//! An aerofoil as the commands name one: a coordinate file (a spline runs through its points)
//! or a saved curve report (its chain; an adapt report's encoding too), read by the one reader
//! of saved reports ([`crate::fit::report`]).

use super::analysis::{AeroInput, Analysis};
use super::contour::Paneling;
use crate::adaptive::Encoding;
use crate::chain::CurveChain;
use crate::error::{Error, Result};
use crate::fit::report::{is_report, read_report, CurveReport, Saved};
use crate::geometry::{read_curve, Loaded2};
use glam::DVec2;
use std::path::Path;

/// Where the warnings of a file's reader go: the file and the warning.
pub type Warn<'a> = &'a mut dyn FnMut(&Path, &str);

/// What a file that should hold an aerofoil holds.
#[derive(Clone, Debug, PartialEq)]
pub enum Aerofoil {
    /// Coordinates (its reader's warnings already handed on).
    Points(Loaded2),
    /// A curve report, with the encoding of an adapt report.
    Curve(CurveReport, Option<Encoding>),
    /// A surface report: no aerofoil (each command says so in its own words).
    Surface,
}

impl Aerofoil {
    /// Read `path`: a JSON report by the report reader, anything else as coordinates, whose
    /// reader's warnings go to `warn`.
    pub fn read(path: &Path, warn: Warn<'_>) -> Result<Aerofoil> {
        if is_report(path)? {
            return Ok(match read_report(path)? {
                Saved::Curve(r, encoding) => Aerofoil::Curve(r, encoding),
                Saved::Surface(..) => Aerofoil::Surface,
            });
        }
        let loaded = read_curve(path)?;
        loaded.warnings.iter().for_each(|w| warn(path, w));
        Ok(Aerofoil::Points(loaded))
    }

    /// The aerofoil of `path` as a shape to analyse: its points (a report's chain at 401 even
    /// parameters) and its analysis on `paneling`; a surface report is refused with
    /// `surface`, the message's tail.
    pub fn analyse(
        path: &Path,
        paneling: &Paneling,
        surface: &str,
        warn: Warn<'_>,
    ) -> Result<(Vec<DVec2>, Analysis)> {
        match Aerofoil::read(path, warn)? {
            Aerofoil::Points(loaded) => {
                let a = Analysis::of_points(&loaded.points, paneling).map_err(|e| e.in_file(path))?;
                closed_note(path, &a, warn);
                Ok((loaded.points, a))
            }
            Aerofoil::Curve(r, _) => {
                let chain = r.chain()?;
                let a = Analysis::of_chain(&chain, paneling).map_err(|e| e.in_file(path))?;
                closed_note(path, &a, warn);
                Ok((samples(&chain), a))
            }
            Aerofoil::Surface => Err(surface_report(path, surface)),
        }
    }
}

/// Tell `warn` when the analysis closed the trailing edge where its two ends overlapped.
fn closed_note(path: &Path, a: &Analysis, warn: Warn<'_>) {
    if let Some(d) = a.te_closed {
        warn(
            path,
            &format!(
                "the trailing edge's two ends overlap: closed where its first and last panels cross \
                 ({d:.2e} from the farther end)"
            ),
        );
    }
}

/// `bezchain aero`'s input: the analysis, what the report says was read, and one phrase saying
/// it (`82 points (NACA 4413)`, `curve report, degree 3, 5 segments`).
pub fn analyse_input(
    path: &Path,
    paneling: &Paneling,
    warn: Warn<'_>,
) -> Result<(Analysis, AeroInput, String)> {
    let text = path.display().to_string();
    match Aerofoil::read(path, warn)? {
        Aerofoil::Points(loaded) => {
            let what = format!("{} points ({})", loaded.points.len(), loaded.name);
            let input = AeroInput {
                path: text,
                kind: "coordinates".into(),
                points: loaded.points.len(),
            };
            let a = Analysis::of_points(&loaded.points, paneling).map_err(|e| e.in_file(path))?;
            closed_note(path, &a, warn);
            Ok((a, input, what))
        }
        Aerofoil::Curve(r, _) => {
            let chain = r.chain()?;
            let what = format!(
                "curve report, degree {}, {} segments",
                chain.layout().degree(),
                chain.layout().segments()
            );
            let input = AeroInput {
                path: text,
                kind: "curve report".into(),
                points: chain.ctrl().len(),
            };
            let a = Analysis::of_chain(&chain, paneling).map_err(|e| e.in_file(path))?;
            closed_note(path, &a, warn);
            Ok((a, input, what))
        }
        Aerofoil::Surface => Err(surface_report(path, "; aero needs a curve")),
    }
}

/// 401 points of `chain` at even parameters, ends included.
#[must_use]
pub fn samples(chain: &CurveChain<DVec2>) -> Vec<DVec2> {
    (0..=400).map(|k| chain.eval(k as f64 / 400.0)).collect()
}

/// The error for a surface report where an aerofoil was wanted; `tail` ends the message.
pub fn surface_report(path: &Path, tail: &str) -> Error {
    Error::Input {
        path: path.into(),
        message: format!("a surface report{tail}"),
    }
}
