//! The workloads of `bezchain bench`, apart from the library's core: the population
//! evaluator's throughput against the machine's measured peak ([`population`], [`peak`]) and
//! the batched panel method's ([`aero`]) and the viscous analysis' ([`viscous`]).

pub mod aero;
pub mod peak;
pub mod population;
pub mod viscous;

use crate::error::{Error, Result};

/// Refuse a benchmark population outside `1..=most`.
fn check_population(population: usize, most: usize) -> Result<()> {
    if population == 0 || population > most {
        return Err(Error::invalid(format!(
            "the population must be between 1 and {most}, not {population}"
        )));
    }
    Ok(())
}
