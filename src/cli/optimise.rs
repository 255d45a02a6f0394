//! `bezchain optimise`: compress a start aerofoil to its adapted encoding, then optimise those
//! stored numbers for an aerodynamic objective with the GA or CMA-ES on the panel-method
//! evaluator; a curve report, a Selig file and a picture of the result.

use super::output::{Output, Outputs};
use super::progress::{Checkpoints, Generations};
use super::{usage, warn_all};
use anyhow::Result;
use bezchain::adaptive::{adapt_curve, AdaptOptions, Encoding};
use bezchain::aero::batch::flags;
use bezchain::aero::{
    AeroBatch, AeroEval, AeroProblem, Analysis, Constraints, DesignSpace, Hold, Method, Objective,
    Optimisation, OptimiseOptions, OptimiseResult, PanelSolution, Paneling, Reasons, TargetCp, DEFAULT_NODES,
};
use bezchain::chain::CurveChain;
use bezchain::eval::Backend;
use bezchain::export::{CpCurve, CpPlot, Outline};
use bezchain::export::{CurveReport, FitInfo, InputInfo, Report};
use bezchain::geometry::{read_curve, write_selig_to};
use bezchain::optim::evo::Checkpoint;
use bezchain::problem::offset_stats;
use glam::DVec2;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `bezchain optimise`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The start: an aerofoil file (adapted to `--tol` first) or an `adapt` report (its
    /// encoding is used as it stands).
    pub start: PathBuf,
    /// `max-cl` (maximise CL at --alpha) or `inverse:TARGET` (match TARGET's Cp at --alpha;
    /// TARGET an aerofoil file or a curve report).
    #[arg(long)]
    pub objective: String,
    /// Angle of attack, degrees.
    #[arg(long, default_value_t = 4.0, allow_negative_numbers = true)]
    pub alpha: f64,
    /// Method: ga, cmaes or ga+cmaes (the GA for half the generations, then CMA-ES from its
    /// best).
    #[arg(long, default_value = "cmaes", value_parser = |s: &str| Method::parse_among(s, Method::AERO).map_err(|e| e.to_string()))]
    pub method: Method,
    /// Individuals per generation [default: 256 for ga, 4 + 3 ln n for cmaes].
    #[arg(long)]
    pub population: Option<usize>,
    /// Generation limit [default: 200 for ga, 1000 for cmaes and ga+cmaes].
    #[arg(long)]
    pub generations: Option<usize>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Tolerance (max closest-point offset, model units) of the adapted encoding whose stored
    /// numbers are the design variables.
    #[arg(long, default_value_t = 1e-4)]
    pub tol: f64,
    /// Box: every design variable within ± this fraction of the chord of its start value.
    #[arg(long, default_value_t = 0.1)]
    pub margin: f64,
    /// Initial spread (ga) or step (cmaes), a fraction of the chord.
    #[arg(long, default_value_t = 0.01)]
    pub spread: f64,
    /// Stop after this many generations without a relative improvement of 1e-6 (0: never).
    #[arg(long, default_value_t = 0)]
    pub stall: usize,
    /// Panel nodes per shape.
    #[arg(long, default_value_t = DEFAULT_NODES)]
    pub panels: usize,
    /// Constraint: thickness/chord at least this.
    #[arg(long)]
    pub min_thickness: Option<f64>,
    /// Constraint: CM about the quarter chord at least this.
    #[arg(long, allow_negative_numbers = true)]
    pub cm_min: Option<f64>,
    /// Where populations are evaluated: auto, gpu or cpu.
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<Backend>)]
    pub backend: Backend,
    /// Write the curve report (with an `optimise` block) here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an SVG of the shapes and pressures before and after here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    /// Write the result as a Selig `.dat` file here.
    #[arg(long)]
    pub dat: Option<PathBuf>,
    /// Write a checkpoint here every --checkpoint-every generations and at the end.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// Generations between checkpoints.
    #[arg(long, default_value_t = 10)]
    pub checkpoint_every: u64,
    /// Continue the run saved in this checkpoint (same start, objective and options).
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// No progress bar or progress lines.
    #[arg(long)]
    pub quiet: bool,
}

/// The objective as given: `max-cl` or `inverse:TARGET`.
enum Goal {
    MaxCl,
    Inverse(PathBuf),
}

fn parse_goal(s: &str) -> Result<Goal> {
    if s.eq_ignore_ascii_case("max-cl") {
        return Ok(Goal::MaxCl);
    }
    match s.split_once(':') {
        Some((kind, target)) if kind.eq_ignore_ascii_case("inverse") && !target.is_empty() => {
            Ok(Goal::Inverse(PathBuf::from(target)))
        }
        _ => Err(usage(format!(
            "--objective {s}: expected max-cl or inverse:TARGET (an aerofoil file or curve report)"
        ))),
    }
}

/// The start's points (for the report's offsets) and encoding.
fn start_encoding(path: &Path, tol: f64) -> Result<(Vec<DVec2>, Encoding, String)> {
    if super::is_report(path)? {
        let text = std::fs::read_to_string(path).map_err(|source| bezchain::Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| usage(format!("{}:{}: not valid JSON: {e}", path.display(), e.line())))?;
        let encoding: Encoding = value
            .get("adapt")
            .and_then(|a| a.get("encoding"))
            .cloned()
            .map(serde_json::from_value)
            .transpose()
            .map_err(|e| usage(format!("{}: adapt.encoding: {e}", path.display())))?
            .ok_or_else(|| {
                usage(format!(
                    "{}: a report without an adapt encoding (run `bezchain adapt` on the aerofoil, or give its file)",
                    path.display()
                ))
            })?;
        let chain = bezchain::adaptive::chain_of(&encoding)?;
        let pts: Vec<DVec2> = (0..=400).map(|k| chain.eval(k as f64 / 400.0)).collect();
        return Ok((pts, encoding, "the report's encoding".into()));
    }
    let loaded = read_curve(path)?;
    warn_all(path, &loaded.warnings);
    let adapted = adapt_curve(
        &loaded.points,
        &AdaptOptions {
            tol,
            ..AdaptOptions::default()
        },
    )?;
    if let Some(m) = &adapted.message {
        eprintln!(
            "warning: {}: {m}; optimising the closest layout found",
            path.display()
        );
    }
    let what = format!(
        "adapted at {tol:e}: {}, {} stored scalars, max offset {:.2e}",
        adapted.family, adapted.count.total, adapted.offset.max
    );
    Ok((loaded.points, adapted.encoding, what))
}

/// The target's points and its paneled solution.
fn target(path: &Path, paneling: &Paneling) -> Result<(Vec<DVec2>, Analysis)> {
    if super::is_report(path)? {
        let chain = match Report::read(path)? {
            Report::Curve(rep) => rep.chain()?,
            Report::Surface(_) => {
                return Err(usage(format!(
                    "{}: a surface report, not a curve",
                    path.display()
                )))
            }
        };
        let pts: Vec<DVec2> = (0..=400).map(|k| chain.eval(k as f64 / 400.0)).collect();
        return Ok((pts, Analysis::of_chain(&chain, paneling)?));
    }
    let loaded = read_curve(path)?;
    warn_all(path, &loaded.warnings);
    let a = Analysis::of_points(&loaded.points, paneling)?;
    Ok((loaded.points, a))
}

/// Progress bar or lines, and checkpoints.
struct Monitor {
    progress: Generations,
    checkpoints: Checkpoints,
}

impl Monitor {
    fn new(args: &Args, run: &Optimisation<'_>, checkpoint: Option<Output>) -> Monitor {
        let mut progress = Generations::new(args.quiet);
        progress.start(
            &run.method().to_string(),
            run.generation(),
            run.generations() as u64,
        );
        Monitor {
            progress,
            checkpoints: Checkpoints::new(checkpoint, args.checkpoint_every),
        }
    }

    fn generation(&mut self, run: &Optimisation<'_>, outs: &mut Outputs) -> bezchain::Result<()> {
        let (_, best) = run.best();
        let Some(last) = run.history().last() else {
            return Ok(());
        };
        let r = run.reasons();
        let msg = format!(
            "best {:.5e} (CL {:.4}, CM {:.4}, t/c {:.4}) | {} stage | {:.0} shapes/s | {} flagged",
            last.best,
            best.cl,
            best.cm,
            best.thickness,
            run.stage(),
            last.evaluations as f64 / last.seconds.max(1e-9),
            r.non_finite + r.fold + r.crossing + r.singular + r.thin + r.cm
        );
        self.progress.show(
            &run.method().to_string(),
            last.generation,
            run.generations() as u64,
            msg,
        );
        self.checkpoints
            .after(outs, run.generation(), run.stop().is_some(), || {
                run.checkpoint().to_bytes()
            })
    }

    fn finish(&mut self) {
        self.progress.finish();
    }
}

/// CL, CM, t/c and objective of one shape, as reported.
#[derive(Clone, Debug, Serialize)]
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

/// The report's `optimise` block.
#[derive(Clone, Debug, Serialize)]
struct OptimiseBlock {
    objective: String,
    alpha: f64,
    method: String,
    seed: u64,
    population: Option<usize>,
    generations: u64,
    stop: String,
    constraints: ConstraintBlock,
    constraint_handling: &'static str,
    tol: f64,
    variables: Vec<String>,
    dependents: Vec<String>,
    chord_line: &'static str,
    bounds: Vec<[f64; 2]>,
    offsets: Vec<f64>,
    encoding: Encoding,
    panels: usize,
    start: ShapeFigures,
    result: ShapeFigures,
    kernel_best: bezchain::aero::AeroResult,
    reasons: Reasons,
    offsets_measured_from: String,
    seconds: f64,
    eval_seconds: f64,
    shapes_per_second: f64,
}

#[derive(Clone, Copy, Debug, Serialize)]
struct ConstraintBlock {
    min_thickness: Option<f64>,
    cm_min: Option<f64>,
}

/// The optimise report: a curve report with the `optimise` block.
#[derive(Clone, Debug, Serialize)]
struct OptimiseReport {
    #[serde(flatten)]
    curve: CurveReport,
    optimise: OptimiseBlock,
}

const CHORD_LINE: &str = "both trailing-edge points and the leading edge's x stay where the start has them \
(pressures do not change when a shape moves or scales, and an inviscid solver rewards a thick blunt base with \
lift real flow would not give), and for max-cl the leading edge's y too (turning the shape would change the \
angle of attack): the dependents are the stored numbers solved from those conditions, the variables the others";

const CONSTRAINT_HANDLING: &str = "penalties ranked as Deb's rules: a valid shape meeting the constraints \
scores its objective (max-cl: −CL; inverse: the arclength-weighted mean of (Cp − Cp_target)²); a valid shape \
breaking them 1e3 + the summed shortfalls (t/c below the minimum, CM below the minimum); an unusable shape \
(non-finite, a surface folding back in x by more than 1e-3 chord, upper below lower, coincident nodes or a \
singular system) 1e6 + how far it is from valid; so every feasible shape ranks before every infeasible one";

/// Optimise, report and write the outputs.
pub fn run(args: Args) -> Result<()> {
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let svg_out = outs.add_opt("--svg", args.svg.as_deref())?;
    let dat = outs.add_opt("--dat", args.dat.as_deref())?;
    let checkpoint = args
        .checkpoint
        .as_deref()
        .map(|p| outs.add_interim("--checkpoint", p))
        .transpose()?;
    let goal = parse_goal(&args.objective)?;
    if !args.alpha.is_finite() || args.alpha.abs() > 30.0 {
        return Err(usage("--alpha takes an angle in degrees between -30 and 30"));
    }
    if !(8..=bezchain::aero::batch::MAX_GPU_NODES).contains(&args.panels) {
        return Err(usage(format!(
            "--panels must be between 8 and {}",
            bezchain::aero::batch::MAX_GPU_NODES
        )));
    }
    if let Some(t) = args.min_thickness {
        if !(0.0..1.0).contains(&t) {
            return Err(usage("--min-thickness takes a thickness/chord between 0 and 1"));
        }
    }
    if args.cm_min.is_some_and(|m| !m.is_finite()) {
        return Err(usage("--cm-min must be a finite number"));
    }
    if !args.tol.is_finite() || args.tol <= 0.0 {
        return Err(usage("--tol must be a positive length"));
    }
    let resume = match &args.resume {
        Some(p) => Some(Checkpoint::read(p)?),
        None => None,
    };
    let clock = Instant::now();
    let paneling = Paneling::with_nodes(args.panels);
    let (start_points, encoding, start_what) = start_encoding(&args.start, args.tol)?;
    // Inverse design may turn the shape (that changes its pressures); max-CL may not.
    let hold = match goal {
        Goal::MaxCl => Hold::ChordLine,
        Goal::Inverse(_) => Hold::Similarity,
    };
    let space = DesignSpace::new(&encoding, &paneling, args.margin, hold)?;
    let (objective, target_data) = match &goal {
        Goal::MaxCl => (Objective::MaxCl, None),
        Goal::Inverse(path) => {
            let (pts, a) = target(path, &paneling)?;
            let table = TargetCp::of(&a.solution, args.alpha)?;
            (Objective::Inverse(table), Some((path.clone(), pts, a)))
        }
    };
    let constraints = Constraints {
        min_thickness: args.min_thickness,
        cm_min: args.cm_min,
    };
    let batch = AeroBatch::new(space.map().clone(), args.alpha, objective, constraints)?;
    let problem = AeroProblem { space, batch };
    let options = OptimiseOptions {
        population: args.population,
        generations: args.generations,
        seed: args.seed,
        backend: args.backend,
        spread: args.spread,
        stall_generations: args.stall,
        ..OptimiseOptions::default()
    };
    outs.say(&format!(
        "{}: {start_what}; {} design variables, box ±{} chord, {} panel nodes\n",
        args.start.display(),
        problem.space.dim(),
        args.margin,
        args.panels
    ));
    let start_eval = problem.batch.reference(problem.space.start());
    let mut run = match &resume {
        Some(c) => Optimisation::resume(&problem, args.method, &options, c)?,
        None => Optimisation::new(&problem, args.method, &options)?,
    };
    outs.say(&format!("{} on {}\n", args.method, run.info()));
    let mut monitor = Monitor::new(&args, &run, checkpoint);
    let stop = run.run(|r| monitor.generation(r, &mut outs));
    monitor.finish();
    let stop = stop?;
    if let Some(o) = checkpoint {
        outs.interim(o, &run.checkpoint().to_bytes())?;
    }
    let result = run.finish(stop)?;
    let chain = problem.space.chain(&result.design)?;
    // Everything is made before anything is written.
    let (offset_points, offsets_from) = match &target_data {
        Some((path, pts, _)) => (pts.clone(), format!("target {}", path.display())),
        None => (start_points.clone(), format!("start {}", args.start.display())),
    };
    let offsets = offset_stats(&chain, &offset_points)?;
    let report = build_report(
        &args,
        &problem,
        &result,
        &chain,
        &start_eval,
        &offsets,
        &offsets_from,
        &offset_points,
    );
    let dat_points: Vec<DVec2> = {
        let t = bezchain::aero::panel_params(&chain, &Paneling::with_nodes(241))?;
        t.iter().map(|&u| chain.eval(u)).collect()
    };
    let svg = match &args.svg {
        Some(_) => Some(picture(&args, &problem, &result, &target_data)?.to_svg()?),
        None => None,
    };
    let elapsed = clock.elapsed().as_secs_f64();
    if let Some(o) = json {
        outs.put_json(o, &report)?;
    }
    if let (Some(o), Some(svg)) = (svg_out, svg) {
        outs.put(o, svg.as_bytes())?;
    }
    if let Some(o) = dat {
        let name = format!("bezchain optimise {} {}", args.objective, args.start.display());
        let mut text = Vec::new();
        write_selig_to(&mut text, &name, &dat_points)?;
        outs.put(o, &text)?;
    }
    outs.commit()?;
    outs.say(&summary(
        &args,
        &start_eval,
        &result,
        &offsets,
        &offsets_from,
        elapsed,
    ));
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn build_report(
    args: &Args,
    problem: &AeroProblem,
    result: &OptimiseResult,
    chain: &CurveChain<DVec2>,
    start_eval: &AeroEval,
    offsets: &bezchain::problem::OffsetStats<DVec2>,
    offsets_from: &str,
    offset_points: &[DVec2],
) -> OptimiseReport {
    let fit = FitInfo {
        method: result.method.name().into(),
        iterations: result.generations,
        evaluations: result.evaluations,
        seconds: result.seconds,
        backend: bezchain::export::backend_label(&result.backend),
        stages: Vec::new(),
        evals_per_second: Some(result.evaluations as f64 / result.eval_seconds.max(1e-12)),
        // A generation limit is the evolutionary run's own end, not a cap.
        stopped: None,
    };
    let input = InputInfo {
        path: args.start.display().to_string(),
        points: offset_points.len(),
    };
    let curve = CurveReport::new(chain, bezchain::export::OffsetReport::from(offsets), fit, input);
    OptimiseReport {
        curve,
        optimise: OptimiseBlock {
            objective: args.objective.clone(),
            alpha: args.alpha,
            method: result.method.name().into(),
            seed: args.seed,
            population: args.population,
            generations: result.generations,
            stop: result.stop.to_string(),
            constraints: ConstraintBlock {
                min_thickness: args.min_thickness,
                cm_min: args.cm_min,
            },
            constraint_handling: CONSTRAINT_HANDLING,
            tol: args.tol,
            variables: problem.space.names(),
            dependents: problem.space.dependents(),
            chord_line: CHORD_LINE,
            bounds: problem.space.bounds().to_vec(),
            offsets: result.design.clone(),
            encoding: problem.space.encoding(&result.design),
            panels: args.panels,
            start: ShapeFigures::of(start_eval),
            result: ShapeFigures::of(&result.eval),
            kernel_best: result.kernel,
            reasons: result.reasons,
            offsets_measured_from: offsets_from.into(),
            seconds: result.seconds,
            eval_seconds: result.eval_seconds,
            shapes_per_second: result.evaluations as f64 / result.eval_seconds.max(1e-12),
        },
    }
}

/// The summary lines printed after the run.
fn summary(
    args: &Args,
    start: &AeroEval,
    result: &OptimiseResult,
    offsets: &bezchain::problem::OffsetStats<DVec2>,
    offsets_from: &str,
    elapsed: f64,
) -> String {
    let e = &result.eval;
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
        "            CL        CM       t/c   objective   at α = {}°",
        args.alpha
    );
    for (name, v) in [("start ", start), ("result", e)] {
        let _ = writeln!(
            s,
            "{name}  {:8.5}  {:8.5}  {:8.5}  {:10.4e}",
            v.cl, v.cm, v.thickness, v.objective
        );
    }
    let _ = writeln!(
        s,
        "closest-point offsets of the {offsets_from} points from the result: max {:.3e}, rms {:.3e}",
        offsets.max, offsets.rms
    );
    let _ = writeln!(s, "total {elapsed:.1} s");
    s
}

/// Shapes and Cp before and after (and the target's).
fn picture(
    args: &Args,
    problem: &AeroProblem,
    result: &OptimiseResult,
    target: &Option<(PathBuf, Vec<DVec2>, Analysis)>,
) -> Result<CpPlot> {
    let alpha = args.alpha;
    let start = PanelSolution::solve(&problem.space.map().nodes(problem.space.start()))?;
    let end = PanelSolution::solve(&problem.space.map().nodes(&result.design))?;
    let cp = |s: &PanelSolution| -> Vec<(f64, f64)> {
        s.nodes().iter().zip(s.cp(alpha)).map(|(p, c)| (p.x, c)).collect()
    };
    let mut curves = vec![
        CpCurve {
            label: format!("start: CL {:.4}", start.coefficients(alpha).cl),
            points: cp(&start),
        },
        CpCurve {
            label: format!("result: CL {:.4}", end.coefficients(alpha).cl),
            points: cp(&end),
        },
    ];
    let mut outlines = vec![
        Outline {
            label: format!("start ({})", args.start.display()),
            nodes: start.nodes().to_vec(),
        },
        Outline {
            label: "result".into(),
            nodes: end.nodes().to_vec(),
        },
    ];
    if let Some((path, _, a)) = target {
        curves.push(CpCurve {
            label: format!(
                "target {}: CL {:.4}",
                path.display(),
                a.solution.coefficients(alpha).cl
            ),
            points: cp(&a.solution),
        });
        outlines.push(Outline {
            label: format!("target ({})", path.display()),
            nodes: a.solution.nodes().to_vec(),
        });
    }
    Ok(CpPlot {
        title: format!("bezchain optimise --objective {} at α = {alpha}°", args.objective),
        curves,
        outlines,
    })
}
