//! The command line's shared pieces for the evolutionary methods: their options ([`EvoArgs`],
//! flattened into `fit`, `fit-surface` and `compare`'s commands) and the [`Monitor`] that shows
//! a run's progress and writes its history file and checkpoints.

use super::output::{Output, Outputs};
use super::progress::Generations;
use super::usage;
use anyhow::{Context, Result};
use bezchain::eval::Backend;
use bezchain::export::RunRecord;
use bezchain::optim::evo::{
    check_generation_size, default_population, Checkpoint, EvoHooks, EvoOptions, Evolution, Watched,
    MAX_GENERATIONS, MAX_POPULATION,
};
use bezchain::optim::Method;
use std::path::{Path, PathBuf};

/// Options of the evolutionary methods (ga, cmaes, ga+lsq, cmaes+lsq).
#[derive(clap::Args, Debug, Default, Clone)]
pub struct EvoArgs {
    /// Where populations are evaluated: auto (a hardware GPU when one is found, else the CPU),
    /// gpu (lavapipe too) or cpu.
    #[arg(long, value_parser = super::parse_word::<Backend>)]
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
    /// GA: individuals per tournament [default: 8].
    #[arg(long)]
    pub tournament: Option<usize>,
    /// GA: probability that a child takes the covariance step (a normal step with the
    /// covariance of the population's best) instead of polynomial mutation [default: 0.8].
    #[arg(long, allow_negative_numbers = true)]
    pub covariance_rate: Option<f64>,
    /// GA: fraction of the population, its best, whose covariance that step has [default: 0.1].
    #[arg(long, allow_negative_numbers = true)]
    pub covariance_pool: Option<f64>,
    /// CMA-ES: restarts from the start (same mean and step, fresh random draws) after it
    /// converges while generations remain; the best of all runs is the result [default: 0].
    #[arg(long)]
    pub restarts: Option<usize>,
    /// Write one line per generation here: generation,best,mean,evaluations,seconds.
    #[arg(long)]
    pub history: Option<PathBuf>,
    #[command(flatten)]
    pub run: RunArgs,
}

/// How a long run (an evolutionary fit, an aerodynamic optimisation) is watched and saved: its
/// checkpoints, the checkpoint it continues, its progress display.
#[derive(clap::Args, Debug, Default, Clone)]
pub struct RunArgs {
    /// Write a checkpoint here every `--checkpoint-every` generations and at the end.
    #[arg(long)]
    pub checkpoint: Option<PathBuf>,
    /// Generations between checkpoints [default: 10].
    #[arg(long)]
    pub checkpoint_every: Option<u64>,
    /// Continue the run saved in this checkpoint (same input and options: a fit's layout and
    /// method, an optimisation's objective).
    #[arg(long)]
    pub resume: Option<PathBuf>,
}

impl RunArgs {
    /// The checkpoint file, checked now and joined to the run's outputs as an interim output
    /// (none when not asked for), and the generations between checkpoints.
    pub fn add(&self, outs: &mut Outputs) -> Result<(Option<Output>, u64)> {
        let checkpoint = self
            .checkpoint
            .as_deref()
            .map(|p| outs.add_interim("--checkpoint", p))
            .transpose()?;
        Ok((checkpoint, self.checkpoint_every.unwrap_or(10)))
    }
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
        let resume = match &self.run.resume {
            Some(path) => Some(Checkpoint::read(path)?),
            None => None,
        };
        Ok((evo, resume))
    }

    /// Refuse, before the run, a population whose generation would not fit in memory for
    /// `n` design variables of `algorithm` (`None`: not evolutionary).
    pub fn check_size(&self, opts: &EvoOptions, algorithm: Option<Method>, n: usize) -> Result<()> {
        let Some(a) = algorithm else { return Ok(()) };
        let size = opts.population.unwrap_or_else(|| default_population(a, n));
        check_generation_size(size, n).map_err(|e| {
            usage(format!(
                "--population {size}: {e}; ask for fewer individuals or a smaller layout"
            ))
        })
    }

    /// The flags given, by name (to refuse them for methods that do not use them).
    pub fn given(&self) -> Vec<&'static str> {
        [
            (self.backend.is_some(), "--backend"),
            (self.seed.is_some(), "--seed"),
            (self.population.is_some(), "--population"),
            (self.generations.is_some(), "--generations"),
            (self.target.is_some(), "--target"),
            (self.stall.is_some(), "--stall"),
            (self.newton.is_some(), "--newton"),
            (self.spread.is_some(), "--spread"),
            (self.margin.is_some(), "--margin"),
            (self.crossover_rate.is_some(), "--crossover-rate"),
            (self.mutation_rate.is_some(), "--mutation-rate"),
            (self.tournament.is_some(), "--tournament"),
            (self.covariance_rate.is_some(), "--covariance-rate"),
            (self.covariance_pool.is_some(), "--covariance-pool"),
            (self.restarts.is_some(), "--restarts"),
            (self.history.is_some(), "--history"),
            (self.run.checkpoint.is_some(), "--checkpoint"),
            (self.run.checkpoint_every.is_some(), "--checkpoint-every"),
            (self.run.resume.is_some(), "--resume"),
        ]
        .into_iter()
        .filter_map(|(given, name)| given.then_some(name))
        .collect()
    }

    /// The library's options (checked by the library when the run starts).
    pub fn options(&self) -> Result<EvoOptions> {
        let mut o = EvoOptions::default();
        if let Some(p) = self.population {
            o.population = Some(population_arg(
                p,
                "a few thousand individuals are plenty for these problems",
            )?);
        }
        if let Some(g) = self.generations {
            o.generations = Some(generations_arg(
                g,
                "stop on --target or --stall instead, or continue with --resume",
            )?);
        }
        // Each option given replaces the library's default.
        o.backend = self.backend.unwrap_or(o.backend);
        o.seed = self.seed.unwrap_or(o.seed);
        o.target = self.target.unwrap_or(o.target);
        o.stall_generations = self.stall.unwrap_or(o.stall_generations);
        o.newton = self.newton.unwrap_or(o.newton);
        o.spread = self.spread.unwrap_or(o.spread);
        o.margin = self.margin.unwrap_or(o.margin);
        o.ga.crossover_rate = self.crossover_rate.unwrap_or(o.ga.crossover_rate);
        o.ga.mutation_rate = self.mutation_rate.or(o.ga.mutation_rate);
        o.ga.tournament = self.tournament.unwrap_or(o.ga.tournament);
        o.ga.covariance_rate = self.covariance_rate.unwrap_or(o.ga.covariance_rate);
        o.ga.covariance_pool = self.covariance_pool.unwrap_or(o.ga.covariance_pool);
        o.cmaes.restarts = self.restarts.unwrap_or(o.cmaes.restarts);
        if self.run.checkpoint_every == Some(0) {
            return Err(usage("--checkpoint-every must be at least 1"));
        }
        o.check()?;
        Ok(o)
    }
}

/// `flag`'s count `n` checked: at least `least`, at most `most` (else `suggestion`).
fn count_arg(flag: &str, n: i64, [least, most]: [usize; 2], suggestion: &str) -> Result<usize> {
    if n < least as i64 {
        return Err(usage(format!("{flag} must be at least {least}, not {n}")));
    }
    super::bounded(flag, n as u64, most as u64, suggestion)?;
    Ok(n as usize)
}

/// `--population` checked: at least 4, at most [`MAX_POPULATION`] (else `suggestion`).
pub fn population_arg(p: i64, suggestion: &str) -> Result<usize> {
    count_arg("--population", p, [4, MAX_POPULATION], suggestion)
}

/// `--generations` checked: at least 1, at most [`MAX_GENERATIONS`] (else `suggestion`).
pub fn generations_arg(g: i64, suggestion: &str) -> Result<usize> {
    count_arg("--generations", g, [1, MAX_GENERATIONS], suggestion)
}

/// Progress display, history file and checkpoints of a run: an evolutionary fit, or an
/// aerodynamic optimisation.
pub struct Monitor {
    progress: Generations,
    started: bool,
    /// The history file and checkpoints.
    record: RunRecord,
}

impl Monitor {
    /// A monitor for the runs that `args` ask for; their `--history` and `--checkpoint` paths
    /// are checked now and join the run's outputs.
    pub fn new(args: &EvoArgs, outs: &mut Outputs) -> Result<Self> {
        let history = outs.add_opt("--history", args.history.as_deref())?;
        let (checkpoint, every) = args.run.add(outs)?;
        Ok(Monitor::with(history, checkpoint, every))
    }

    /// A monitor showing progress unless `--quiet`, writing `history` and a `checkpoint` every
    /// `every` generations (and when the run stops) where given.
    pub fn with(history: Option<Output>, checkpoint: Option<Output>, every: u64) -> Self {
        Monitor {
            progress: Generations::new(),
            started: false,
            record: RunRecord::new(history, checkpoint, every),
        }
    }

    /// After a generation: the progress (a bar from the first generation on), new history
    /// lines, a checkpoint when due.
    pub fn generation(&mut self, run: &dyn Watched, outs: &mut Outputs) -> bezchain::Result<()> {
        let name = run.label();
        if !self.started {
            self.progress.start(&name, run.generation(), run.limit());
            self.started = true;
        }
        if let Some(last) = run.history().last() {
            self.progress
                .show(&name, last.generation, run.limit(), run.status());
        }
        self.record.generation(run, outs)
    }

    /// Clear the progress bar.
    pub fn finish(&mut self) {
        self.progress.finish();
    }

    /// Run `fit` with this monitor on its generations when `evolutionary`, from `args`'s
    /// checkpoint `resume` when given. A failure names the `input` and what was running (the
    /// fit of its `points` points, or the resumption); after a run, a history file with no
    /// generation in it still gets its header.
    pub fn run<T>(
        &mut self,
        outs: &mut Outputs,
        (args, evolutionary, resume): (&EvoArgs, bool, Option<Checkpoint>),
        (input, points): (&Path, usize),
        fit: impl FnOnce(&mut EvoHooks<'_>) -> bezchain::Result<T>,
    ) -> Result<T> {
        let result = {
            let mut on_generation = |run: &Evolution<'_>| self.generation(run, outs);
            let mut hooks = EvoHooks {
                on_generation: if evolutionary {
                    Some(&mut on_generation)
                } else {
                    None
                },
                resume,
            };
            fit(&mut hooks)
        };
        self.finish();
        let done = result.with_context(|| match &args.run.resume {
            Some(p) => format!("{}: resuming from {}", input.display(), p.display()),
            None => format!("{}: fitting {points} points", input.display()),
        })?;
        self.close(outs)?;
        Ok(done)
    }

    /// After a finished run: a history file with no generation in it still gets its header.
    pub fn close(&mut self, outs: &mut Outputs) -> Result<()> {
        Ok(self.record.close(outs)?)
    }
}
