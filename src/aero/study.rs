//! An aerodynamic optimisation from files to results, as `bezchain optimise` runs it: the start
//! (an aerofoil adapted to a tolerance, or an adapt report's encoding as it stands), the
//! objective ([`super::objectives`]) and the problem it makes ([`Setup::prepare`]); after the
//! run, the result's chain, its offsets, the report, the Selig points and the summary
//! ([`Study::outcome`]), the report being the result's curve report with an `optimise` block
//! (`docs/ARCHITECTURE.md` §5.9).

use super::batch::{flags, AeroBatch, AeroEval, AeroResult, Constraints};
use super::constraints::{active, Active, ExtraConstraints, Measures};
use super::contour::{panel_params, Paneling};
use super::design::DesignSpace;
use super::input::{samples, surface_report, Aerofoil, Warn};
use super::objectives::{chord_line, constraint_handling, AeroObjective, Conditions, Request, Target};
use super::operating::Condition;
use super::optimise::{per_second, Reasons};
use super::optimise::{AeroProblem, OptimiseOptions, OptimiseResult, ViscousScoring};
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
    /// Constraints on the shapes that the panel kernel checks.
    pub constraints: Constraints,
    /// Constraints checked after it.
    pub extra: ExtraConstraints,
    /// The Reynolds number (viscous objectives).
    pub re: Option<f64>,
    /// Ncrit of the e^N transition (viscous objectives; default 9).
    pub ncrit: f64,
    /// A design CL (`max-ld`, `min-cd`).
    pub cl: Option<f64>,
}

/// A variable of the result that sits on its box.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AtBound {
    /// Its name (`y3`).
    pub variable: String,
    /// `lower` or `upper`.
    pub side: &'static str,
}

/// A variable counts as on its box when within this fraction of the box's width of a bound.
pub const AT_BOUND_FRACTION: f64 = 1e-3;

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
        let (objective, _) = super::objectives::parse(&self.spec)
            .map_err(|e| Error::invalid(format!("--objective {}: {e}", self.spec)))?;
        self.extra.check()?;
        if let Some(re) = self.re {
            if !(1e4..=1e8).contains(&re) {
                return Err(Error::invalid("--re takes a Reynolds number between 1e4 and 1e8"));
            }
        }
        if !(self.ncrit > 0.0 && self.ncrit <= 20.0) {
            return Err(Error::invalid("--ncrit takes a number in (0, 20]"));
        }
        if self.cl.is_some_and(|c| !c.is_finite()) {
            return Err(Error::invalid("--cl must be a finite number"));
        }
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
        let constrained = self.constraints.min_thickness.is_some()
            || self.constraints.cm_min.is_some()
            || !self.extra.is_empty();
        if objective.needs_constraint() && !constrained {
            return Err(Error::invalid(format!(
                "--objective {} needs a constraint (--min-thickness, --min-thickness-at, --cm-min, --cl-min, \
--min-te-angle or --min-area): unconstrained it drives every variable to its box",
                objective.name()
            )));
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
        let conditions = Conditions {
            alpha: self.alpha,
            cl: self.cl,
            re: self.re,
            ncrit: self.ncrit,
        };
        let prepared = objective.prepare(Request {
            argument,
            on: &paneling,
            at: &conditions,
            warn,
        })?;
        // A viscous objective checks CM on the viscous CM, not the kernel's.
        let kernel_constraints = match prepared.viscous {
            Some(_) => Constraints {
                cm_min: None,
                ..self.constraints
            },
            None => self.constraints,
        };
        let batch = AeroBatch::new(
            space.map().clone(),
            self.alpha,
            prepared.objective,
            kernel_constraints,
        )?;
        let mut problem = AeroProblem {
            space,
            batch,
            extra: self.extra.clone(),
            viscous: None,
        };
        let invalid = |message: String| Error::Input {
            path: self.start.clone(),
            message,
        };
        let start = problem.reference(problem.space.start());
        if start.flags & flags::GEOMETRY != 0 {
            return Err(invalid(format!(
                "the start is not a usable shape on {} panel nodes ({})",
                self.panels,
                flag_names(start.flags).join(", ")
            )));
        }
        if let Some(goal) = prepared.viscous {
            goal.check()?;
            let nodes = problem.space.map().nodes(problem.space.start());
            let solved = goal.solve(&nodes, &[])?;
            if let Some(k) = solved.iter().position(Option::is_none) {
                let p = &goal.points[k];
                let at = match p.at {
                    Condition::Alpha(a) => format!("α {a}°"),
                    Condition::Cl(c) => format!("CL {c}"),
                };
                return Err(invalid(format!(
                    "the viscous analysis of the start does not converge at {at}, Re {:e} (its adapted chain on {} \
panel nodes): nothing to optimise from",
                    p.re, self.panels
                )));
            }
            problem.viscous = Some(ViscousScoring::new(goal, self.constraints.cm_min, solved));
        }
        Ok(Study {
            setup: self,
            objective,
            problem,
            start_points,
            start_what,
            target: prepared.target,
        })
    }
}

/// The names of the [`flags`] bits set in `bits`.
fn flag_names(bits: u32) -> Vec<&'static str> {
    flags::NAMES
        .iter()
        .filter(|(b, _)| bits & b != 0)
        .map(|(_, n)| *n)
        .collect()
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
        self.problem.reference(self.problem.space.start())
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
                re: self.problem.viscous.as_ref().and(s.re),
                ncrit: self.problem.viscous.as_ref().map(|_| s.ncrit),
                cl: s.cl,
                constraints: ConstraintBlock {
                    min_thickness: s.constraints.min_thickness,
                    min_thickness_at: s.extra.thickness_at.iter().map(|&(x, t)| [x, t]).collect(),
                    cm_min: s.constraints.cm_min,
                    cl_min: s.extra.cl_min,
                    min_te_angle: s.extra.min_te_angle,
                    min_area: s.extra.min_area,
                },
                constraint_handling: constraint_handling(),
                active_constraints: self.active_constraints(&result.design, &result.eval),
                at_bounds: self.at_bounds(&result.design),
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

    /// The constraints that `design` (measured as `eval`) sits on or breaks.
    #[must_use]
    pub fn active_constraints(&self, design: &[f64], eval: &AeroEval) -> Vec<Active> {
        let (c, x) = (&self.setup.constraints, &self.setup.extra);
        let m = Measures::of(&self.problem.space.map().nodes(design));
        let mut all = Vec::new();
        let mut add = |name: String, bound: Option<f64>, value: f64| {
            if let Some(b) = bound {
                all.push((name, b, value));
            }
        };
        add("min-thickness".into(), c.min_thickness, eval.thickness);
        for &(at, t) in &x.thickness_at {
            add(format!("min-thickness-at {at}"), Some(t), m.thickness_at(at));
        }
        add("cm-min".into(), c.cm_min, eval.cm);
        add("cl-min".into(), x.cl_min, eval.cl);
        add("min-te-angle".into(), x.min_te_angle, m.te_angle());
        add("min-area".into(), x.min_area, m.area());
        active(all)
    }

    /// The warning a result at `design` deserves when it sits on its box (the box of
    /// `--margin margin`): which variables, of how many; `None` inside the box.
    #[must_use]
    pub fn box_warning(&self, design: &[f64], margin: f64) -> Option<String> {
        let on_box = self.at_bounds(design);
        let names: Vec<String> = on_box
            .iter()
            .map(|b| format!("{} ({})", b.variable, b.side))
            .collect();
        (!on_box.is_empty()).then(|| {
            format!(
                "the result sits on the box bound of {} of {} variables: {}; the box (--margin {margin}) limits it",
                on_box.len(),
                self.problem.space.dim(),
                names.join(", ")
            )
        })
    }

    /// The variables of `design` that sit on their box.
    #[must_use]
    pub fn at_bounds(&self, design: &[f64]) -> Vec<AtBound> {
        let space = &self.problem.space;
        space
            .names()
            .into_iter()
            .zip(design.iter().zip(space.bounds()))
            .filter_map(|(variable, (&d, &[lo, hi]))| {
                let near = AT_BOUND_FRACTION * (hi - lo);
                let side = if d - lo <= near {
                    "lower"
                } else if hi - d <= near {
                    "upper"
                } else {
                    return None;
                };
                Some(AtBound { variable, side })
            })
            .collect()
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
            "{} generations, {} shapes in {:.1} s ({} shapes/s in the evaluator); stopped: {}",
            result.generations,
            result.evaluations,
            result.seconds,
            per_second(result.evaluations as f64 / result.eval_seconds.max(1e-12)),
            result.stop
        );
        let flagged = r.describe();
        let _ = writeln!(
            s,
            "flagged: {} (of {})",
            if flagged.is_empty() { "none" } else { &flagged },
            r.evaluated
        );
        if result.eval.cd.is_some() {
            let _ = writeln!(
                s,
                "            CL        CM       t/c         CD       L/D   objective   at α°"
            );
            for (name, v) in [("start ", &self.start), ("result", &result.eval)] {
                let cd = v.cd.unwrap_or(f64::NAN);
                let _ = writeln!(
                    s,
                    "{name}  {:8.5}  {:8.5}  {:8.5}  {:9.6}  {:8.2}  {:10.4e}  {:.3}",
                    v.cl,
                    v.cm,
                    v.thickness,
                    cd,
                    v.cl / cd,
                    v.objective,
                    v.alpha.unwrap_or(alpha)
                );
            }
        } else {
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
    #[serde(skip_serializing_if = "Option::is_none")]
    cd: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ld: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    alpha: Option<f64>,
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
            cd: e.cd,
            ld: e.cd.map(|cd| e.cl / cd),
            alpha: e.alpha,
            flags: flag_names(e.flags),
        }
    }
}

/// The constraints as given.
#[derive(Clone, Debug, PartialEq, Serialize)]
struct ConstraintBlock {
    min_thickness: Option<f64>,
    min_thickness_at: Vec<[f64; 2]>,
    cm_min: Option<f64>,
    cl_min: Option<f64>,
    min_te_angle: Option<f64>,
    min_area: Option<f64>,
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
    re: Option<f64>,
    ncrit: Option<f64>,
    cl: Option<f64>,
    constraints: ConstraintBlock,
    constraint_handling: String,
    active_constraints: Vec<Active>,
    at_bounds: Vec<AtBound>,
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
    use crate::geometry::{test_contour, write_selig};
    use crate::optim::Method;

    /// From a coordinate file to the report: the start adapted, the problem described, a short
    /// run's report carrying the curve report's keys and the `optimise` block, and the summary;
    /// a curve report without an encoding is refused as a start.
    #[test]
    fn a_study_runs_from_a_file_to_its_report() {
        let dir = tempfile::tempdir().unwrap();
        let start = dir.path().join("n0012.dat");
        let pts = test_contour("0012", 82);
        write_selig(&start, "NACA 0012", &pts).unwrap();
        let setup = Setup {
            start: start.clone(),
            spec: "max-cl".into(),
            alpha: 4.0,
            tol: 1e-3,
            margin: 0.1,
            panels: 60,
            constraints: Constraints {
                min_thickness: Some(0.1),
                cm_min: None,
            },
            extra: ExtraConstraints::default(),
            re: None,
            ncrit: 9.0,
            cl: None,
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
