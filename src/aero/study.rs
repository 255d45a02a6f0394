//! An aerodynamic optimisation from files to results, as `bezchain optimise` runs it: the start
//! (an aerofoil adapted to a tolerance, or an adapt report's encoding as it stands), the
//! objective ([`super::objectives`]) and the problem it makes ([`Setup::prepare`]); after the
//! run, the result's chain, its offsets, the report, the Selig points and the summary
//! ([`Study::outcome`]), the report being the result's curve report with an `optimise` block
//! (`docs/ARCHITECTURE.md` §5.9).

use super::batch::{flags, AeroBatch, AeroEval, AeroResult, Constraints};
use super::contour::{panel_params, Paneling};
use super::design::DesignSpace;
use super::input::{samples, surface_report, Aerofoil, Warn};
use super::objectives::{chord_line, constraint_handling, AeroObjective, Target};
use super::optimise::Reasons;
use super::optimise::{AeroProblem, OptimiseOptions, OptimiseResult};
use crate::adaptive::{adapt_curve, chain_of, AdaptOptions, Encoding};
use crate::chain::CurveChain;
use crate::error::{Error, Result};
use crate::fit::report::{backend_label, CurveReport, FitInfo, InputInfo, OffsetReport};
use crate::problem::{offset_stats, OffsetStats};
use glam::DVec2;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Panel nodes of the Selig file written for a result.
pub const SELIG_NODES: usize = 241;

/// What an optimisation is asked to do.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// The start: an aerofoil file (adapted to `tol` first) or an adapt report.
    pub start: PathBuf,
    /// The objective as given (`max-cl`, `inverse:TARGET`).
    pub spec: String,
    /// Angle of attack, degrees.
    pub alpha: f64,
    /// Tolerance (largest closest-point offset, model units) of the start's adapted encoding.
    pub tol: f64,
    /// Every design variable within ± this fraction of the chord of its start value.
    pub margin: f64,
    /// Panel nodes per shape.
    pub panels: usize,
    /// Constraints on the shapes.
    pub constraints: Constraints,
}

/// An optimisation ready to run: the problem and what the report and picture need.
pub struct Study {
    /// What was asked.
    pub setup: Setup,
    /// The objective.
    pub objective: &'static dyn AeroObjective,
    /// The problem the optimisers run on.
    pub problem: AeroProblem,
    /// The start's points (an adapt report's chain at 401 even parameters).
    pub start_points: Vec<DVec2>,
    /// How the start was made (`adapted at 1e-4: …`, `the report's encoding`).
    pub start_what: String,
    /// The target of an objective that has one.
    pub target: Option<Target>,
}

impl Setup {
    /// `Ok` when `bezchain optimise` takes these settings: the objective one of
    /// [`super::objectives::parse`]'s, the angle within ±30°, [`super::batch::MAX_GPU_NODES`]
    /// nodes at most, a thickness bound in [0, 1), a finite CM bound and a positive tolerance;
    /// otherwise the error it prints, naming its options.
    pub fn check(&self) -> Result<()> {
        super::objectives::parse(&self.spec)
            .map_err(|e| Error::invalid(format!("--objective {}: {e}", self.spec)))?;
        if !self.alpha.is_finite() || self.alpha.abs() > 30.0 {
            return Err(Error::invalid(
                "--alpha takes an angle in degrees between -30 and 30",
            ));
        }
        if !(8..=super::batch::MAX_GPU_NODES).contains(&self.panels) {
            return Err(Error::invalid(format!(
                "--panels must be between 8 and {}",
                super::batch::MAX_GPU_NODES
            )));
        }
        if let Some(t) = self.constraints.min_thickness {
            if !(0.0..1.0).contains(&t) {
                return Err(Error::invalid(
                    "--min-thickness takes a thickness/chord between 0 and 1",
                ));
            }
        }
        if self.constraints.cm_min.is_some_and(|m| !m.is_finite()) {
            return Err(Error::invalid("--cm-min must be a finite number"));
        }
        if !self.tol.is_finite() || self.tol <= 0.0 {
            return Err(Error::invalid("--tol must be a positive length"));
        }
        Ok(())
    }

    /// Read the start and the objective's target and build the problem; `objective` is
    /// [`super::objectives::parse`]'s answer for [`spec`](Self::spec), the readers' and the
    /// adaptive search's warnings go to `warn`.
    pub fn prepare(
        self,
        (objective, argument): (&'static dyn AeroObjective, Option<&str>),
        warn: Warn<'_>,
    ) -> Result<Study> {
        let paneling = Paneling::with_nodes(self.panels);
        let (start_points, encoding, start_what) = start_encoding(&self.start, self.tol, warn)?;
        let space = DesignSpace::new(&encoding, &paneling, self.margin, objective.hold())?;
        let prepared = objective.prepare(argument, &paneling, self.alpha, warn)?;
        let batch = AeroBatch::new(
            space.map().clone(),
            self.alpha,
            prepared.objective,
            self.constraints,
        )?;
        Ok(Study {
            setup: self,
            objective,
            problem: AeroProblem { space, batch },
            start_points,
            start_what,
            target: prepared.target,
        })
    }
}

/// The start's points (for the report's offsets), its encoding and how it was made.
fn start_encoding(path: &Path, tol: f64, warn: Warn<'_>) -> Result<(Vec<DVec2>, Encoding, String)> {
    let loaded = match Aerofoil::read(path, warn)? {
        Aerofoil::Points(loaded) => loaded,
        Aerofoil::Curve(_, Some(encoding)) => {
            let pts = samples(&chain_of(&encoding)?);
            return Ok((pts, encoding, "the report's encoding".into()));
        }
        Aerofoil::Curve(_, None) => {
            return Err(Error::Input {
                path: path.into(),
                message: "a report without an adapt encoding (run `bezchain adapt` on the aerofoil, or give \
                          its file)"
                    .into(),
            })
        }
        Aerofoil::Surface => return Err(surface_report(path, ", not a curve")),
    };
    let adapted = adapt_curve(
        &loaded.points,
        &AdaptOptions {
            tol,
            ..AdaptOptions::default()
        },
    )?;
    if let Some(m) = &adapted.message {
        warn(path, &format!("{m}; optimising the closest layout found"));
    }
    let what = format!(
        "adapted at {tol:e}: {}, {} stored scalars, max offset {:.2e}",
        adapted.family, adapted.count.total, adapted.offset.max
    );
    Ok((loaded.points, adapted.encoding, what))
}

/// An optimisation's results, everything made before anything is written.
pub struct Outcome {
    /// The run's result.
    pub result: OptimiseResult,
    /// The report.
    pub report: OptimiseReport,
    /// The result at [`SELIG_NODES`] panel nodes, for a Selig file.
    pub selig: Vec<DVec2>,
    // For the summary: the start in f64, the closest-point offsets of the target's points (or
    // the start's) from the result, and whose points those are.
    start: AeroEval,
    offsets: OffsetStats<DVec2>,
    offsets_from: String,
}

impl Study {
    /// One line on the problem: the start, the design variables, the box, the paneling.
    #[must_use]
    pub fn describe(&self) -> String {
        format!(
            "{}: {}; {} design variables, box ±{} chord, {} panel nodes\n",
            self.setup.start.display(),
            self.start_what,
            self.problem.space.dim(),
            self.setup.margin,
            self.setup.panels
        )
    }

    /// The start measured in f64.
    #[must_use]
    pub fn start_eval(&self) -> AeroEval {
        self.problem.batch.reference(self.problem.space.start())
    }

    /// The outcome of `result`, a run under `options`.
    pub fn outcome(&self, result: OptimiseResult, options: &OptimiseOptions) -> Result<Outcome> {
        let chain = self.problem.space.chain(&result.design)?;
        let (offset_points, offsets_from) = match &self.target {
            Some(t) => (&t.points, format!("target {}", t.path.display())),
            None => (
                &self.start_points,
                format!("start {}", self.setup.start.display()),
            ),
        };
        let offsets = offset_stats(&chain, offset_points)?;
        let start = self.start_eval();
        let report = self.report(
            &result,
            options,
            &chain,
            &start,
            &offsets,
            &offsets_from,
            offset_points.len(),
        );
        let selig = {
            let t = panel_params(&chain, &Paneling::with_nodes(SELIG_NODES))?;
            t.iter().map(|&u| chain.eval(u)).collect()
        };
        Ok(Outcome {
            result,
            report,
            selig,
            start,
            offsets,
            offsets_from,
        })
    }

    /// The report: the result's curve report with the `optimise` block.
    #[allow(clippy::too_many_arguments)]
    fn report(
        &self,
        result: &OptimiseResult,
        options: &OptimiseOptions,
        chain: &CurveChain<DVec2>,
        start: &AeroEval,
        offsets: &OffsetStats<DVec2>,
        offsets_from: &str,
        points: usize,
    ) -> OptimiseReport {
        let shapes_per_second = result.evaluations as f64 / result.eval_seconds.max(1e-12);
        let fit = FitInfo {
            method: result.method.name().into(),
            iterations: result.generations,
            evaluations: result.evaluations,
            seconds: result.seconds,
            backend: backend_label(&result.backend),
            stages: Vec::new(),
            evals_per_second: Some(shapes_per_second),
            // A generation limit is the evolutionary run's own end, not a cap.
            stopped: None,
        };
        let input = InputInfo {
            path: self.setup.start.display().to_string(),
            points,
        };
        let s = &self.setup;
        let space = &self.problem.space;
        OptimiseReport {
            curve: CurveReport::new(chain, OffsetReport::from(offsets), fit, input),
            optimise: OptimiseBlock {
                objective: s.spec.clone(),
                alpha: s.alpha,
                method: result.method.name().into(),
                seed: options.seed,
                population: options.population,
                generations: result.generations,
                stop: result.stop.to_string(),
                constraints: ConstraintBlock {
                    min_thickness: s.constraints.min_thickness,
                    cm_min: s.constraints.cm_min,
                },
                constraint_handling: constraint_handling(),
                tol: s.tol,
                variables: space.names(),
                dependents: space.dependents(),
                chord_line: chord_line(),
                bounds: space.bounds().to_vec(),
                offsets: result.design.clone(),
                encoding: space.encoding(&result.design),
                panels: s.panels,
                start: ShapeFigures::of(start),
                result: ShapeFigures::of(&result.eval),
                kernel_best: result.kernel,
                reasons: result.reasons,
                offsets_measured_from: offsets_from.into(),
                seconds: result.seconds,
                eval_seconds: result.eval_seconds,
                shapes_per_second,
            },
        }
    }

    /// The name line of the result's Selig file.
    #[must_use]
    pub fn selig_name(&self) -> String {
        format!(
            "bezchain optimise {} {}",
            self.setup.spec,
            self.setup.start.display()
        )
    }
}

impl Outcome {
    /// The lines printed after the run; `elapsed` seconds in all.
    #[must_use]
    pub fn summary(&self, alpha: f64, elapsed: f64) -> String {
        let result = &self.result;
        let r = &result.reasons;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{} generations, {} shapes in {:.1} s ({:.0} shapes/s in the evaluator); stopped: {}",
            result.generations,
            result.evaluations,
            result.seconds,
            result.evaluations as f64 / result.eval_seconds.max(1e-12),
            result.stop
        );
        let _ = writeln!(
            s,
            "flagged: {} non-finite, {} fold, {} crossing, {} singular, {} thin, {} cm (of {})",
            r.non_finite, r.fold, r.crossing, r.singular, r.thin, r.cm, r.evaluated
        );
        let _ = writeln!(
            s,
            "            CL        CM       t/c   objective   at α = {alpha}°"
        );
        for (name, v) in [("start ", &self.start), ("result", &result.eval)] {
            let _ = writeln!(
                s,
                "{name}  {:8.5}  {:8.5}  {:8.5}  {:10.4e}",
                v.cl, v.cm, v.thickness, v.objective
            );
        }
        let _ = writeln!(
            s,
            "closest-point offsets of the {} points from the result: max {:.3e}, rms {:.3e}",
            self.offsets_from, self.offsets.max, self.offsets.rms
        );
        let _ = writeln!(s, "total {elapsed:.1} s");
        s
    }
}

/// CL, CM, t/c, objective, score and flags of one shape, as reported.
#[derive(Clone, Debug, PartialEq, Serialize)]
struct ShapeFigures {
    cl: f64,
    cm: f64,
    thickness: f64,
    objective: f64,
    score: f64,
    flags: Vec<&'static str>,
}

impl ShapeFigures {
    fn of(e: &AeroEval) -> ShapeFigures {
        ShapeFigures {
            cl: e.cl,
            cm: e.cm,
            thickness: e.thickness,
            objective: e.objective,
            score: e.score,
            flags: flags::NAMES
                .iter()
                .filter(|(b, _)| e.flags & b != 0)
                .map(|(_, n)| *n)
                .collect(),
        }
    }
}

/// The constraints as given.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
struct ConstraintBlock {
    min_thickness: Option<f64>,
    cm_min: Option<f64>,
}

/// The report's `optimise` block.
#[derive(Clone, Debug, PartialEq, Serialize)]
struct OptimiseBlock {
    objective: String,
    alpha: f64,
    method: String,
    seed: u64,
    population: Option<usize>,
    generations: u64,
    stop: String,
    constraints: ConstraintBlock,
    constraint_handling: String,
    tol: f64,
    variables: Vec<String>,
    dependents: Vec<String>,
    chord_line: String,
    bounds: Vec<[f64; 2]>,
    offsets: Vec<f64>,
    encoding: Encoding,
    panels: usize,
    start: ShapeFigures,
    result: ShapeFigures,
    kernel_best: AeroResult,
    reasons: Reasons,
    offsets_measured_from: String,
    seconds: f64,
    eval_seconds: f64,
    shapes_per_second: f64,
}

/// The optimise report: a curve report with the `optimise` block.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OptimiseReport {
    /// The result's curve report.
    #[serde(flatten)]
    pub curve: CurveReport,
    optimise: OptimiseBlock,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aero::objectives;
    use crate::aero::optimise::Optimisation;
    use crate::eval::Backend;
    use crate::geometry::{write_selig, Naca, NacaOptions};
    use crate::optim::Method;

    /// From a coordinate file to the report: the start adapted, the problem described, a short
    /// run's report carrying the curve report's keys and the `optimise` block, and the summary;
    /// a curve report without an encoding is refused as a start.
    #[test]
    fn a_study_runs_from_a_file_to_its_report() {
        let dir = tempfile::tempdir().unwrap();
        let start = dir.path().join("n0012.dat");
        let pts = Naca::parse("0012")
            .unwrap()
            .contour(&NacaOptions::default())
            .unwrap();
        write_selig(&start, "NACA 0012", &pts).unwrap();
        let setup = Setup {
            start: start.clone(),
            spec: "max-cl".into(),
            alpha: 4.0,
            tol: 1e-3,
            margin: 0.1,
            panels: 60,
            constraints: Constraints::default(),
        };
        let study = setup
            .prepare(objectives::parse("max-cl").unwrap(), &mut |_, _| {})
            .unwrap();
        assert!(study
            .describe()
            .starts_with(&format!("{}: adapted at 1e-3: ", start.display())));
        let options = OptimiseOptions {
            population: Some(8),
            generations: Some(2),
            backend: Backend::Cpu,
            ..OptimiseOptions::default()
        };
        let mut run = Optimisation::new(&study.problem, Method::Ga, &options).unwrap();
        let stop = run.run(|_| Ok(())).unwrap();
        let outcome = study.outcome(run.finish(stop).unwrap(), &options).unwrap();
        let v = serde_json::to_value(&outcome.report).unwrap();
        assert_eq!(v["kind"], "curve");
        assert_eq!(v["optimise"]["objective"], "max-cl");
        assert_eq!(v["optimise"]["population"], 8);
        assert_eq!(
            v["optimise"]["constraint_handling"],
            objectives::constraint_handling()
        );
        assert_eq!(
            v["optimise"]["offsets_measured_from"],
            format!("start {}", start.display())
        );
        assert_eq!(outcome.selig.len(), SELIG_NODES);
        assert_eq!(outcome.summary(4.0, 1.0).lines().count(), 7);
        let report = dir.path().join("fit.json");
        std::fs::write(&report, serde_json::to_string(&outcome.report.curve).unwrap()).unwrap();
        let refused = Setup {
            start: report.clone(),
            ..study.setup.clone()
        };
        let e = refused
            .prepare(objectives::parse("max-cl").unwrap(), &mut |_, _| {})
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.ends_with(
                "a report without an adapt encoding (run `bezchain adapt` on the aerofoil, or give its file)"
            ),
            "{e}"
        );
    }
}
