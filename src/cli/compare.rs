//! `bezchain compare`: the paper's optimiser comparison on its three NACA 4413 cases, one table.

use super::fit::load;
use super::output::Outputs;
use super::{bounded, usage};
use anyhow::Result;
use bezchain::eval::Backend;
use bezchain::export::Schema;
use bezchain::fit::{compare, Method};
use bezchain::optim::evo::{
    CmaesOptions, EvoOptions, GA_GENERATIONS, GA_POPULATION, MAX_GENERATIONS, MAX_POPULATION,
};
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
    if args.population < 4 {
        return Err(usage(format!(
            "--population must be at least 4, not {}",
            args.population
        )));
    }
    if args.generations < 1 {
        return Err(usage(format!(
            "--generations must be at least 1, not {}",
            args.generations
        )));
    }
    bounded(
        "--population",
        args.population as u64,
        MAX_POPULATION as u64,
        &format!("the default is {GA_POPULATION}"),
    )?;
    bounded(
        "--generations",
        args.generations as u64,
        MAX_GENERATIONS as u64,
        &format!("the default is {GA_GENERATIONS}"),
    )?;
    let mut outs = Outputs::new();
    let json = outs.add_opt("--json", args.json.as_deref())?;
    let evo = EvoOptions {
        population: Some(args.population as usize),
        generations: Some(args.generations as usize),
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
    let mut table = String::new();
    table += &format!(
        "{}: {} points. Counts are the paper's; sum_sq is the closest-point sum of squares, re-measured.\n\n",
        args.input.display(),
        loaded.points.len()
    );
    if args.methods.iter().any(|m| m.evolutionary().is_some()) {
        table += &format!(
            "ga and cmaes: population {}, at most {} generations, seed {}; cmaes restarts {}; iterations are \
             generations and evaluations individuals.\n\n",
            args.population,
            args.generations,
            args.seed,
            match args.restarts {
                None => "while generations remain".to_string(),
                Some(r) => format!("at most {r} times"),
            }
        );
    }
    table += "| case | degree | segments | design / expanded points | method | variables | iterations | evaluations | seconds | sum_sq | max | paper's total offset | sum_sq / paper |\n";
    table += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    emit(&table);
    let (rows, backends) = compare(&loaded.points, &args.methods, &evo, &mut |row| emit(&row.line()))?;
    let mut tail = String::new();
    for b in &backends {
        tail += &format!("\nga and cmaes evaluated on {b}");
    }
    tail += &format!("\ntotal {:.1} s\n", clock.elapsed().as_secs_f64());
    emit(&tail);
    if let Some(o) = json {
        outs.put_json(o, Schema::Compare, &CompareReport { rows: &rows })?;
    }
    outs.commit()
}

/// The JSON report of `compare`: the table's rows, one a case and method.
#[derive(serde::Serialize)]
struct CompareReport<'a, T: serde::Serialize> {
    rows: &'a [T],
}
