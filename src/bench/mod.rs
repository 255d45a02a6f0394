//! The workloads of `bezchain bench`, apart from the library's core: the population
//! evaluator's throughput against the machine's measured peak ([`population`], [`peak`]) and
//! the batched panel method's ([`aero`]) and the viscous analysis' ([`viscous`]).

pub mod aero;
pub mod peak;
pub mod population;
pub mod viscous;
