//! The optimisers, shared by fitting and aerodynamics: Nelder-Mead and BFGS on any
//! [`Objective`](crate::problem::Objective), Levenberg-Marquardt on the closest-point fitting
//! problem, the genetic algorithm and CMA-ES on any [`evo::PopulationObjective`] (with
//! checkpoints), and the hybrids that polish an evolutionary result by least squares.
//!
//! - [`mod@nelder_mead`], [`mod@bfgs`]: general minimisers.
//! - [`mod@lsq`]: Levenberg-Marquardt over design points and foot points jointly.
//! - [`evo`]: the GA and CMA-ES, their options, limits and checkpoints.
//! - [`hybrid`]: `ga+lsq` and `cmaes+lsq`.
//! - [`method`]: [`Method`], the one enum of every method, and the sets each objective takes.
//! - [`report`]: [`SolveReport`] and [`StopReason`], what every solver reports back.

// Index loops over small fixed dimensions mirror the formulas; `!(x > 0.0)` is meant: it is
// also true for NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod bfgs;
pub mod evo;
pub mod hybrid;
pub mod lsq;
pub mod method;
pub mod nelder_mead;
pub mod report;

pub use bfgs::{bfgs, BfgsOptions};
pub use hybrid::{evolve_then_polish, polish, EvoSummary, Stage};
pub use lsq::{
    lsq, DampingScale, Guard, LsqFit, LsqHooks, LsqIterate, LsqMethod, LsqOptions, Observer, Start,
};
pub use method::Method;
pub use nelder_mead::{nelder_mead, Minimum, NelderMeadOptions};
pub use report::{SolveReport, StopReason};
