//! `bezchain compare`: the paper's optimiser comparison on its three NACA 4413 cases, one table.

use super::evo::{generations_arg, population_arg};
use super::fit::load;
use super::output::Outputs;
use anyhow::Result;
use bezchain::eval::Backend;
use bezchain::export::Schema;
use bezchain::fit::paper::{compare_head, compare_tail, CompareReport};
use bezchain::fit::{compare, Method};
use bezchain::optim::evo::{CmaesOptions, EvoOptions, GA_GENERATIONS, GA_POPULATION};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `bezchain compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The contour (the paper used NACA 4413 with 82 points: `data/naca4413.dat`).
    pub input: PathBuf,
    /// Methods to compare, in table order (also ga+lsq, cmaes+lsq).
    #[arg(long, value_delimiter = ',', default_value = "nelder-mead,bfgs,ga,cmaes,lsq", value_parser = super::curve_method)]
    pub methods: Vec<Method>,
    /// Individuals per generation of the GA and CMA-ES.
    #[arg(long, default_value_t = GA_POPULATION as i64, allow_negative_numbers = true)]
    pub population: i64,
    /// Generation limit of the GA and CMA-ES (CMA-ES stops earlier once the objective is flat).
    #[arg(long, default_value_t = GA_GENERATIONS as i64, allow_negative_numbers = true)]
    pub generations: i64,
    /// CMA-ES restarts after it converges (from the start, with fresh random draws; the best
    /// of all runs counts) [default: as many as the generation limit leaves room for, so
    /// that the GA and CMA-ES spend the same budget].
    #[arg(long)]
    pub restarts: Option<usize>,
    /// Seed of the GA and CMA-ES.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Where the GA and CMA-ES evaluate their populations: auto, gpu or cpu.
    #[arg(long, default_value = "auto", value_parser = super::parse_word::<Backend>)]
    pub backend: Backend,
    /// Also write the rows as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Run every method on every case and print the table.
pub fn run(args: Args) -> Result<()> {
    let population = population_arg(args.population, &format!("the default is {GA_POPULATION}"))?;
    let generations = generations_arg(args.generations, &format!("the default is {GA_GENERATIONS}"))?;
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let evo = EvoOptions {
        population: Some(population),
        generations: Some(generations),
        seed: args.seed,
        backend: args.backend,
        cmaes: CmaesOptions {
            restarts: args.restarts.unwrap_or(usize::MAX),
            ..CmaesOptions::default()
        },
        ..EvoOptions::default()
    };
    evo.check()?;
    let clock = Instant::now();
    let loaded = load(&args.input)?;
    // Rows are printed as they finish: the whole table takes tens of seconds.
    let to_stderr = outs.uses_stdout();
    let emit = |text: &str| super::output::say(to_stderr, text);
    let input = args.input.display().to_string();
    emit(&compare_head(&input, loaded.points.len(), &args.methods, &evo));
    let (rows, backends) = compare(&loaded.points, &args.methods, &evo, &mut |row| emit(&row.line()))?;
    emit(&compare_tail(&backends, clock.elapsed().as_secs_f64()));
    if let Some(o) = json {
        outs.put_json(o, Schema::Compare, &CompareReport { rows: &rows })?;
    }
    outs.commit()
}
