//! `bezchain fit`: fit a chain of Bezier curves to a 2D contour and report it; the evolutionary
//! methods with a progress bar, a history file and checkpoints.

use super::output::{Output, Outputs};
use super::{usage, warn_all};
use anyhow::{Context, Result};
use bezchain::chain::{ChainLayout, Continuity};
use bezchain::eval::{Backend, BackendInfo};
use bezchain::export::{CurvePlot, CurveReport, FitInfo, InputInfo, OffsetReport};
use bezchain::fit::evo::{
    Algorithm, Checkpoint, EvoHooks, EvoOptions, Evolution, MAX_GENERATIONS, MAX_POPULATION,
};
use bezchain::fit::{
    fit_curve_with, point_offsets, CurveFit, FitOptions, Method, Metric, OffsetStats, SolveReport,
};
use bezchain::geometry::{read_curve, Loaded2};
use glam::DVec2;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Arguments of `bezchain fit`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Contour: Selig or Lednicer `.dat`, CSV/XYZ rows of `x y`, or CSV whose header names `x`
    /// and `y` columns (any order, other columns ignored) (detected).
    pub input: PathBuf,
    /// Degree of every segment (1 to 7).
    #[arg(long)]
    pub degree: usize,
    /// Number of chained segments.
    #[arg(long)]
    pub segments: usize,
    /// Continuity at the joins: c0, c1 or c2.
    #[arg(long, default_value = "c1", value_parser = parse_continuity)]
    pub continuity: Continuity,
    /// Method: lsq, nelder-mead, bfgs, ga, cmaes, ga+lsq or cmaes+lsq.
    #[arg(long, default_value = "lsq", value_parser = parse_method)]
    pub method: Method,
    /// Offset metric minimised and reported: closest or corresponding.
    #[arg(long, default_value = "closest", value_parser = parse_metric)]
    pub metric: Metric,
    /// Write the JSON report here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write an SVG plot (data, chain, design and generated points, offsets) here.
    #[arg(long)]
    pub svg: Option<PathBuf>,
    #[command(flatten)]
    pub cad: super::export::CadArgs,
    #[command(flatten)]
    pub evo: EvoArgs,
}

/// Options of the evolutionary methods (ga, cmaes, ga+lsq, cmaes+lsq).
#[derive(clap::Args, Debug, Default, Clone)]
pub struct EvoArgs {
    /// Where populations are evaluated: auto (the GPU when one is found), gpu or cpu.
    #[arg(long, value_parser = super::parse_backend)]
    pub backend: Option<Backend>,
    /// Seed of the random streams [default: 1].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Individuals per generation, at least 4 [default: 1024 for ga, 4 + 3 ln n for cmaes].
    #[arg(long, allow_negative_numbers = true)]
    pub population: Option<i64>,
    /// Generation limit [default: 500 for ga; 100 + 150 (n+3)²/√λ for cmaes].
    #[arg(long, allow_negative_numbers = true)]
    pub generations: Option<i64>,
    /// Stop once the best sum of squares is at most this.
    #[arg(long, allow_negative_numbers = true)]
    pub target: Option<f64>,
    /// Stop after this many generations without a relative improvement of 1e-6.
    #[arg(long)]
    pub stall: Option<usize>,
    /// Foot-point Newton steps per point and individual [default: 3].
    #[arg(long)]
    pub newton: Option<u32>,
    /// Initial spread (ga) or step size (cmaes), a fraction of the data extent [default: 0.02].
    #[arg(long, allow_negative_numbers = true)]
    pub spread: Option<f64>,
    /// Box bounds: the data's bounding box grown by this fraction of its extent [default: 0.1].
    #[arg(long, allow_negative_numbers = true)]
    pub margin: Option<f64>,
    /// GA: probability that a pair is recombined by SBX [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    pub crossover_rate: Option<f64>,
    /// GA: probability that a variable is mutated [default: 1/n].
    #[arg(long, allow_negative_numbers = true)]
    pub mutation_rate: Option<f64>,
    /// GA: individuals per tournament [default: 4].
    #[arg(long)]
    pub tournament: Option<usize>,
    /// Write one line per generation here: generation,best,mean,evaluations,seconds.
    #[arg(long)]
    pub history: Option<PathBuf>,
    /// Write a checkpoint here every `--checkpoint-every` generations and at the end.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// Generations between checkpoints [default: 10].
    #[arg(long)]
    pub checkpoint_every: Option<usize>,
    /// Continue the run saved in this checkpoint (same input, layout, method and options).
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// No progress bar or progress lines.
    #[arg(long)]
    pub quiet: bool,
}

impl EvoArgs {
    /// The evolutionary options and the checkpoint to resume from, for `method`; the
    /// evolutionary flags are refused (a usage error) for a method that is not evolutionary.
    pub fn settings(
        &self,
        evolutionary: bool,
        method: &dyn std::fmt::Display,
    ) -> Result<(EvoOptions, Option<Checkpoint>)> {
        let given = self.given();
        if !evolutionary && !given.is_empty() {
            return Err(usage(format!(
                "{} {} only to the evolutionary methods (ga, cmaes, ga+lsq, cmaes+lsq), not {method}",
                given.join(", "),
                if given.len() == 1 { "applies" } else { "apply" },
            )));
        }
        let evo = if evolutionary {
            self.options()?
        } else {
            EvoOptions::default()
        };
        let resume = match &self.resume {
            Some(path) => Some(Checkpoint::read(path)?),
            None => None,
        };
        Ok((evo, resume))
    }

    /// Refuse, before the run, a population whose generation would not fit in memory for
    /// `n` design variables of `algorithm` (`None`: not evolutionary).
    pub fn check_size(&self, opts: &EvoOptions, algorithm: Option<Algorithm>, n: usize) -> Result<()> {
        match algorithm {
            Some(a) => opts.check_size(a, n).map_err(|e| {
                usage(format!(
                    "--population {}: {e}; ask for fewer individuals or a smaller layout",
                    opts.size(a, n)
                ))
            }),
            None => Ok(()),
        }
    }

    /// The flags given, by name (to refuse them for methods that do not use them).
    pub fn given(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        let mut add = |on: bool, name| {
            if on {
                v.push(name);
            }
        };
        add(self.backend.is_some(), "--backend");
        add(self.seed.is_some(), "--seed");
        add(self.population.is_some(), "--population");
        add(self.generations.is_some(), "--generations");
        add(self.target.is_some(), "--target");
        add(self.stall.is_some(), "--stall");
        add(self.newton.is_some(), "--newton");
        add(self.spread.is_some(), "--spread");
        add(self.margin.is_some(), "--margin");
        add(self.crossover_rate.is_some(), "--crossover-rate");
        add(self.mutation_rate.is_some(), "--mutation-rate");
        add(self.tournament.is_some(), "--tournament");
        add(self.history.is_some(), "--history");
        add(self.checkpoint.is_some(), "--checkpoint");
        add(self.checkpoint_every.is_some(), "--checkpoint-every");
        add(self.resume.is_some(), "--resume");
        v
    }

    /// The library's options (checked by the library when the run starts).
    pub fn options(&self) -> Result<EvoOptions> {
        let mut o = EvoOptions::default();
        if let Some(p) = self.population {
            if p < 4 {
                return Err(usage(format!("--population must be at least 4, not {p}")));
            }
            super::bounded(
                "--population",
                p as u64,
                MAX_POPULATION as u64,
                "a few thousand individuals are plenty for these problems",
            )?;
            o.population = Some(p as usize);
        }
        if let Some(g) = self.generations {
            if g < 1 {
                return Err(usage(format!("--generations must be at least 1, not {g}")));
            }
            super::bounded(
                "--generations",
                g as u64,
                MAX_GENERATIONS as u64,
                "stop on --target or --stall instead, or continue with --resume",
            )?;
            o.generations = Some(g as usize);
        }
        if let Some(b) = self.backend {
            o.backend = b;
        }
        if let Some(s) = self.seed {
            o.seed = s;
        }
        if let Some(t) = self.target {
            o.target = t;
        }
        if let Some(s) = self.stall {
            o.stall_generations = s;
        }
        if let Some(k) = self.newton {
            o.newton = k;
        }
        if let Some(s) = self.spread {
            o.spread = s;
        }
        if let Some(m) = self.margin {
            o.margin = m;
        }
        if let Some(r) = self.crossover_rate {
            o.ga.crossover_rate = r;
        }
        if let Some(r) = self.mutation_rate {
            o.ga.mutation_rate = Some(r);
        }
        if let Some(t) = self.tournament {
            o.ga.tournament = t;
        }
        if self.checkpoint_every == Some(0) {
            return Err(usage("--checkpoint-every must be at least 1"));
        }
        o.check()?;
        Ok(o)
    }
}

fn parse_continuity(s: &str) -> Result<Continuity, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

fn parse_method(s: &str) -> Result<Method, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

fn parse_metric(s: &str) -> Result<Metric, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

/// Read a contour, printing the reader's warnings.
pub fn load(path: &Path) -> Result<Loaded2> {
    let loaded = read_curve(path)?;
    warn_all(path, &loaded.warnings);
    Ok(loaded)
}

/// The report's `offset` block from the library's statistics.
pub fn offset_report(stats: &OffsetStats<DVec2>) -> OffsetReport {
    OffsetReport {
        metric: stats.metric.to_string(),
        sum_sq: stats.sum_sq,
        sum: stats.sum,
        rms: stats.rms,
        max: stats.max,
        max_at: stats.max_at.to_array().to_vec(),
    }
}

/// `cpu`, or the GPU adapter.
pub fn backend_name(info: &BackendInfo) -> String {
    match info.backend {
        Backend::Gpu => info.adapter.clone(),
        _ => "cpu".to_string(),
    }
}

/// The report's `fit` block: the method's effort, and for the evolutionary methods the
/// backend, the evaluator's throughput and the stages.
pub fn fit_info(fit: &CurveFit<DVec2>) -> FitInfo {
    let mut info = FitInfo {
        method: fit.method.name().to_string(),
        iterations: fit.report.iterations as u64,
        evaluations: fit.report.evaluations as u64,
        seconds: fit.report.seconds,
        backend: "cpu".to_string(),
        stages: Vec::new(),
        evals_per_second: None,
        stopped: curve_cap(fit).map(String::from),
    };
    if let Some(evo) = &fit.evolution {
        info.backend = backend_name(&evo.run.backend);
        info.evals_per_second = Some(evo.run.evals_per_second);
        if evo.stages.len() > 1 {
            info.stages = evo
                .stages
                .iter()
                .enumerate()
                .map(|(k, s)| FitInfo {
                    method: s.method.clone(),
                    iterations: s.report.iterations as u64,
                    evaluations: s.report.evaluations as u64,
                    seconds: s.report.seconds,
                    backend: if k == 0 {
                        info.backend.clone()
                    } else {
                        "cpu".to_string()
                    },
                    stages: Vec::new(),
                    evals_per_second: (k == 0).then_some(evo.run.evals_per_second),
                    // A generation limit is the evolutionary stage's own end, not a cap.
                    stopped: if k == 0 {
                        None
                    } else {
                        s.report.cap().map(String::from)
                    },
                })
                .collect();
        }
    }
    info
}

/// The cap that cut a curve fit short: the solver's, or an evolutionary method's polish's (a
/// generation limit is the evolutionary stage's own end, not a cap).
fn curve_cap(fit: &CurveFit<DVec2>) -> Option<&'static str> {
    match &fit.evolution {
        Some(evo) => evo.stages[1..].iter().find_map(|s| s.report.cap()),
        None => fit.report.cap(),
    }
}

/// The report of a finished curve fit.
pub fn report(fit: &CurveFit<DVec2>, input: &Path, points: usize) -> CurveReport {
    let input = InputInfo {
        path: input.display().to_string(),
        points,
    };
    CurveReport::new(&fit.chain, offset_report(&fit.offset), fit_info(fit), input)
}

/// Progress display, history file and checkpoints of an evolutionary run.
pub struct Monitor {
    bar: Option<ProgressBar>,
    plain: bool,
    last_line: Instant,
    /// The history file, written to its temporary file as the run goes and put in place with
    /// the run's other outputs.
    history: Option<Output>,
    written: usize,
    /// The checkpoint, replaced during the run (and put back as it was if the run fails).
    checkpoint: Option<Output>,
    every: u64,
}

impl Monitor {
    /// A monitor for the runs that `args` ask for; their `--history` and `--checkpoint` paths
    /// are checked now and join the run's outputs.
    pub fn new(args: &EvoArgs, outs: &mut Outputs) -> Result<Self> {
        Ok(Monitor {
            bar: None,
            plain: !args.quiet && !std::io::stderr().is_terminal(),
            last_line: Instant::now(),
            history: outs.add_opt("--history", args.history.as_deref())?,
            written: 0,
            checkpoint: args
                .checkpoint
                .as_deref()
                .map(|p| outs.add_interim("--checkpoint", p))
                .transpose()?,
            every: args.checkpoint_every.unwrap_or(10) as u64,
        })
    }

    /// Start the progress bar (unless quiet or not on a terminal).
    pub fn start_bar(&mut self, run: &Evolution<'_>, quiet: bool) {
        if quiet || self.plain {
            return;
        }
        let bar = ProgressBar::new(run.generations() as u64);
        bar.set_style(
            ProgressStyle::with_template("{prefix} [{elapsed_precise}] {bar:30} gen {pos}/{len} {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_prefix(run.algorithm().to_string());
        bar.set_position(run.generation());
        bar.enable_steady_tick(Duration::from_millis(250));
        self.bar = Some(bar);
    }

    /// After a generation: the bar (or an occasional line), new history lines, a checkpoint
    /// when due.
    pub fn generation(&mut self, run: &Evolution<'_>, outs: &mut Outputs) -> bezchain::Result<()> {
        let h = run.history();
        let Some(last) = h.last() else { return Ok(()) };
        let ips = last.evaluations as f64 / last.seconds.max(1e-9);
        let msg = format!(
            "best {:.4e} mean {:.3e} | {:.3e} individuals/s, {:.3e} point evals/s",
            last.best,
            last.mean,
            ips,
            run.evals_per_second()
        );
        if let Some(bar) = &self.bar {
            if bar.length() != Some(run.generations() as u64) {
                bar.set_length(run.generations() as u64);
            }
            bar.set_position(last.generation);
            bar.set_message(msg);
        } else if self.plain && (self.last_line.elapsed() >= Duration::from_secs(5) || last.generation == 1) {
            eprintln!(
                "{} generation {}/{}: {msg}",
                run.algorithm(),
                last.generation,
                run.generations()
            );
            self.last_line = Instant::now();
        }
        if let Some(o) = self.history {
            let path = outs.path(o).to_path_buf();
            let io = |source| bezchain::Error::Io {
                path: path.clone(),
                source,
            };
            let w = outs.writer(o)?;
            if self.written == 0 {
                writeln!(w, "generation,best,mean,evaluations,seconds").map_err(io)?;
            }
            for p in &h[self.written..] {
                writeln!(
                    w,
                    "{},{:e},{:e},{},{:.6}",
                    p.generation, p.best, p.mean, p.evaluations, p.seconds
                )
                .map_err(io)?;
            }
            self.written = h.len();
        }
        if let Some(o) = self.checkpoint {
            if run.generation() % self.every == 0 || run.stop().is_some() {
                outs.interim(o, &run.checkpoint().to_bytes())?;
            }
        }
        Ok(())
    }

    /// Clear the progress bar.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
    }

    /// After a finished run: a history file with no generation in it still gets its header.
    pub fn close(&mut self, outs: &mut Outputs) -> Result<()> {
        if let (Some(o), 0) = (self.history, self.written) {
            outs.put(o, b"generation,best,mean,evaluations,seconds\n")?;
        }
        Ok(())
    }
}

/// Say on the terminal that a method stopped at its evaluation or iteration cap (the report
/// says so too, as `"stopped"`).
pub fn warn_cap(input: &Path, method: &str, cap: &str, report: &SolveReport) {
    eprintln!(
        "warning: {}: {method} stopped at its {cap} ({} iterations, {} evaluations, {:.1} s) \
         before converging: the result is the best found so far",
        input.display(),
        report.iterations,
        report.evaluations,
        report.seconds
    );
}

/// Refuse, before the fit, a layout with more design points than the data can determine; the
/// message gives the most segments that fit.
fn check_segments(args: &Args, points: usize) -> Result<ChainLayout> {
    let fits = |s: usize| {
        ChainLayout::uniform(args.degree, s, args.continuity).is_ok_and(|l| l.design_count() <= points)
    };
    let too_many = |design: String| {
        // Design points grow with the segments: the most that fit, by bisection.
        let (mut lo, mut hi) = (0, points.min(args.segments));
        while lo < hi {
            let mid = (lo + hi).div_ceil(2);
            if fits(mid) {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        let hint = match lo {
            0 => "use a lower --degree or more data points".to_string(),
            s => format!("use at most --segments {s} at degree {}", args.degree),
        };
        usage(format!(
            "--segments {}: {design}, more than the {points} data points of {} can determine; {hint}",
            args.segments,
            args.input.display()
        ))
    };
    // Each segment adds at least one design point: far too many are refused before the layout
    // is built.
    if args.segments > 4 * points.max(64) {
        return Err(too_many(format!(
            "{} segments need more than {} design points",
            args.segments, args.segments
        )));
    }
    let layout = ChainLayout::uniform(args.degree, args.segments, args.continuity).map_err(|e| {
        usage(format!(
            "--degree {} --segments {}: {e}",
            args.degree, args.segments
        ))
    })?;
    if layout.design_count() > points {
        return Err(too_many(format!(
            "degree {} with {} segments has {} design points",
            args.degree,
            args.segments,
            layout.design_count()
        )));
    }
    Ok(layout)
}

/// Fit, report and plot.
pub fn run(args: Args) -> Result<()> {
    // Every output is checked (and its temporary file made) before the work.
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let svg = outs.add_opt("--svg", args.svg.as_deref())?;
    let cad = args.cad.add(&mut outs)?;
    let mut monitor = Monitor::new(&args.evo, &mut outs)?;
    let evolutionary = args.method.evolutionary();
    let (evo, resume) = args.evo.settings(evolutionary.is_some(), &args.method)?;
    let loaded = load(&args.input)?;
    let layout = check_segments(&args, loaded.points.len())?;
    args.evo
        .check_size(&evo, evolutionary.map(|e| e.0), 2 * layout.design_count())?;
    let opts = FitOptions {
        method: args.method,
        metric: args.metric,
        evo,
        ..FitOptions::default()
    };
    let quiet = args.evo.quiet;
    let mut started = false;
    let outs_in_run = &mut outs;
    let monitor_in_run = &mut monitor;
    let mut on_generation = |run: &Evolution<'_>| {
        if !started {
            monitor_in_run.start_bar(run, quiet);
            started = true;
        }
        monitor_in_run.generation(run, outs_in_run)
    };
    let resume_path = args.evo.resume.clone();
    let mut hooks = EvoHooks {
        on_generation: if evolutionary.is_some() {
            Some(&mut on_generation)
        } else {
            None
        },
        resume,
    };
    let fit = fit_curve_with(&loaded.points, layout, &opts, &mut hooks);
    drop(hooks);
    monitor.finish();
    let fit = fit.with_context(|| match &resume_path {
        Some(p) => format!("{}: resuming from {}", args.input.display(), p.display()),
        None => format!("{}: fitting {} points", args.input.display(), loaded.points.len()),
    })?;
    monitor.close(&mut outs)?;
    if let Some(cap) = curve_cap(&fit) {
        warn_cap(&args.input, &fit.method.to_string(), cap, &fit.report);
    }
    if fit.span_ratio > FitOptions::default().max_span_ratio {
        eprintln!(
            "warning: {}: the fitted chain doubles back on itself (span ratio {:.1}): its closest-point \
             offsets are small but neighbouring data points are far apart along the chain; try \
             another degree or number of segments",
            args.input.display(),
            fit.span_ratio
        );
    }
    let rep = report(&fit, &args.input, loaded.points.len());
    if let Some(o) = json {
        outs.put_json(o, &rep)?;
    }
    if args.cad.wanted() {
        let shape = bezchain::export::CadShape::from_curve_report(&rep)?;
        args.cad
            .put(&mut outs, &cad, &[shape], &super::export::stem(&args.input))?;
    }
    if let Some(o) = svg {
        let offsets = point_offsets(&fit.chain, &loaded.points)?;
        let l = fit.chain.layout();
        let title = format!(
            "{} — degree {}, {} segments, {}, {}: {} design points, sum_sq {:.3e}, max {:.3e}",
            loaded.name,
            l.degree(),
            l.segments(),
            l.continuity(),
            fit.method,
            l.design_count(),
            fit.closest.sum_sq,
            fit.closest.max
        );
        let svg = CurvePlot {
            title,
            data: &loaded.points,
            chain: &fit.chain,
            offsets: &offsets,
        }
        .to_svg()?;
        outs.put(o, svg.as_bytes())?;
    }
    outs.commit()?;
    outs.say(&summary(&args.input, &loaded, &fit));
    Ok(())
}

/// A few readable lines about the fit.
fn summary(input: &Path, loaded: &Loaded2, fit: &CurveFit<DVec2>) -> String {
    let l = fit.chain.layout();
    let c = &fit.closest;
    let mut s = format!(
        "{}: {} points ({:?}, {})\n",
        input.display(),
        loaded.points.len(),
        loaded.format,
        loaded.name
    );
    s += &format!(
        "chain: degree {}, {} segments, {}: {} design points ({} variables), {} control points\n",
        l.degree(),
        l.segments(),
        l.continuity(),
        l.design_count(),
        2 * l.design_count(),
        l.expanded_count()
    );
    s += &format!(
        "{}: sum_sq {:.4e}  rms {:.3e}  max {:.3e} at ({:.4}, {:.4})  [closest point]\n",
        fit.method, c.sum_sq, c.rms, c.max, c.max_at.x, c.max_at.y
    );
    if fit.metric == Metric::Corresponding {
        s += &format!(
            "corresponding-point sum_sq {:.4e}, max {:.3e}\n",
            fit.offset.sum_sq, fit.offset.max
        );
    }
    if let Some(evo) = &fit.evolution {
        let r = &evo.run;
        s += &format!(
            "{}: population {}, {} generations ({}), {} individuals, {:.1} s; objective {:.4e} (f64, ends tied)\n",
            evo.stages[0].method,
            r.size,
            r.report.iterations,
            r.stop,
            r.report.evaluations,
            r.report.seconds,
            r.sum_sq
        );
        s += &format!(
            "backend {}: {:.3e} point evaluations/s ({:.3e} individuals/s) in the evaluator ({:.2} s of {:.2} s)\n",
            r.backend,
            r.evals_per_second,
            r.report.evaluations as f64 / r.eval_seconds.max(1e-12),
            r.eval_seconds,
            r.report.seconds
        );
        for st in &evo.stages[1..] {
            let from = match evo.polish_from_evolved {
                Some(true) => " (the polish of the evolved design won)",
                Some(false) => " (one of lsq's own starts beat the polish of the evolved design)",
                None => "",
            };
            s += &format!(
                "{}: {} iterations, {} evaluations, {:.1} ms{from}\n",
                st.method,
                st.report.iterations,
                st.report.evaluations,
                st.report.seconds * 1e3
            );
        }
        s += &format!("total {:.2} s\n", fit.report.seconds);
    } else {
        s += &format!(
            "{} iterations, {} evaluations, {:.1} ms\n",
            fit.report.iterations,
            fit.report.evaluations,
            fit.report.seconds * 1e3
        );
    }
    s
}
