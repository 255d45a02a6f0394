//! The report of a viscous polar run (`bezchain aero --re`, §5.9): the operating point and one
//! polar per aerofoil file, with its table (CSV), its readable summary and its plot.

use super::polar_plot::PolarPlot;
use crate::aero::input::Warn;
use crate::aero::{analyse_input, polars, AeroInput, Paneling, Viscous, ViscousOptions, ViscousPoint};
use crate::error::Result;
use std::fmt::Write as _;
use std::path::PathBuf;

/// One file's viscous polar as the JSON report holds it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FilePolar {
    /// The file, as named on the command line.
    pub file: String,
    /// What was read from it.
    pub input: AeroInput,
    /// Panel nodes of its paneling.
    pub nodes: usize,
    /// One point an angle, in the order asked.
    pub polar: Vec<ViscousPoint>,
    /// What the file held, in words (for the summary).
    #[serde(skip)]
    pub what: String,
}

/// The polars of one file or of several.
#[derive(Clone, Debug, serde::Serialize)]
#[serde(untagged)]
pub enum Polars {
    /// One file: its fields at the top of the report.
    One(FilePolar),
    /// Several: `{"aerofoils": [...]}`.
    Many {
        /// One entry a file, in the order given.
        aerofoils: Vec<FilePolar>,
    },
}

/// The JSON report of a viscous run: the operating point and one polar per file (one file:
/// its fields at the top).
#[derive(Clone, Debug, serde::Serialize)]
pub struct ViscousReport {
    /// Chord Reynolds number.
    pub re: f64,
    /// Mach number (the analysis is incompressible: 0).
    pub mach: f64,
    /// Critical amplification factor of the e^N transition model.
    pub ncrit: f64,
    /// Forced transition on the upper surface, chord fraction (1: free).
    pub xtr_top: f64,
    /// Forced transition on the lower surface, chord fraction (1: free).
    pub xtr_bottom: f64,
    /// The polars.
    #[serde(flatten)]
    pub polars: Polars,
}

impl ViscousReport {
    /// Read every file of `paths` (aerofoil coordinates or curve reports), panel it as
    /// `paneling` says and run its viscous polar at `alphas` (in parallel over the files);
    /// the readers' warnings go to `warn`.
    pub fn analyse(
        paths: &[PathBuf],
        alphas: &[f64],
        paneling: &Paneling,
        opts: &ViscousOptions,
        warn: Warn<'_>,
    ) -> Result<ViscousReport> {
        let mut bodies = Vec::new();
        let mut files = Vec::new();
        for path in paths {
            let (analysis, input, what) = analyse_input(path, paneling, warn)?;
            let nodes = analysis.solution.nodes();
            let body = Viscous::new(nodes).map_err(|e| e.in_file(path))?;
            bodies.push(body);
            files.push(FilePolar {
                file: path.display().to_string(),
                input,
                nodes: nodes.len(),
                polar: Vec::new(),
                what,
            });
        }
        for (f, polar) in files.iter_mut().zip(polars(&bodies, alphas, opts)) {
            f.polar = polar;
        }
        Ok(ViscousReport {
            re: opts.re,
            mach: 0.0,
            ncrit: opts.ncrit,
            xtr_top: opts.xtr_top,
            xtr_bottom: opts.xtr_bottom,
            polars: if files.len() == 1 {
                Polars::One(files.remove(0))
            } else {
                Polars::Many { aerofoils: files }
            },
        })
    }

    /// The files' polars, in order.
    #[must_use]
    pub fn files(&self) -> &[FilePolar] {
        match &self.polars {
            Polars::One(f) => std::slice::from_ref(f),
            Polars::Many { aerofoils } => aerofoils,
        }
    }

    /// Every point of every file as one CSV table (`file,alpha,cl,…,converged`; a point that
    /// did not converge has empty coefficients).
    #[must_use]
    pub fn table(&self) -> String {
        let opt = |v: Option<f64>, prec: usize| v.map_or(String::new(), |x| format!("{x:.prec$}"));
        let mut table = String::from("file,alpha,cl,cd,cdp,cm,xtr_top,xtr_bottom,converged\n");
        for f in self.files() {
            for p in &f.polar {
                let _ = writeln!(
                    table,
                    "{},{},{},{},{},{},{},{},{}",
                    f.file,
                    p.alpha,
                    opt(p.cl, 6),
                    opt(p.cd, 7),
                    opt(p.cdp, 7),
                    opt(p.cm, 6),
                    opt(p.xtr_top, 5),
                    opt(p.xtr_bottom, 5),
                    p.converged
                );
            }
        }
        table
    }

    /// The readable summary: per file a heading and a row an angle ("not converged" and the
    /// reason where Newton did not converge).
    #[must_use]
    pub fn summary(&self) -> String {
        let mut text = String::new();
        for f in self.files() {
            let _ = writeln!(
                text,
                "{}: {}, {} panel nodes, Re {:.3e}, Ncrit {}, transition forced at {} / {}",
                f.file, f.what, f.nodes, self.re, self.ncrit, self.xtr_top, self.xtr_bottom
            );
            let _ = writeln!(
                text,
                "   alpha        CL         CD        CDp         CM   xtr_top  xtr_bot"
            );
            for p in &f.polar {
                match (p.cl, p.cd, p.cdp, p.cm, p.xtr_top, p.xtr_bottom) {
                    (Some(cl), Some(cd), Some(cdp), Some(cm), Some(xt), Some(xb)) => {
                        let _ = writeln!(
                            text,
                            "{:8.3} {cl:9.5} {cd:10.6} {cdp:10.6} {cm:10.5} {xt:9.4} {xb:8.4}",
                            p.alpha
                        );
                    }
                    _ => {
                        let why = p.failure.as_deref().unwrap_or("no reason recorded");
                        let _ = writeln!(text, "{:8.3}   not converged: {why}", p.alpha);
                    }
                }
            }
        }
        text
    }

    /// The polars' plot (CL–α, CL–CD, CM–α), one colour a file.
    #[must_use]
    pub fn plot(&self) -> PolarPlot {
        PolarPlot {
            title: format!("viscous polar, Re {:.3e}, Ncrit {}", self.re, self.ncrit),
            polars: self
                .files()
                .iter()
                .map(|f| (f.file.clone(), f.polar.clone()))
                .collect(),
        }
    }
}
