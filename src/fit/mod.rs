//! Fitting chains and grids to data: offset metrics, foot points, least squares with
//! parameter correction, Nelder-Mead, BFGS and the evolutionary methods.
//!
//! - [`shape`]: the [`Shape`] trait (a chain or grid as a map linear in its design points),
//!   [`CurveShape`] (parameter dimension 1) and [`GridShape`] (dimension 2).
//! - [`offset`]: the metrics ([`Metric`]), [`OffsetStats`], chord-length parameters.
//! - [`problem`]: [`FitProblem`], the one problem every solver consumes (objective, gradient,
//!   residual blocks, linear least squares, the paper's start).
//! - [`mod@lsq`]: Levenberg-Marquardt over design points and foot points jointly, the default.
//! - [`band`]: banded Cholesky for the large, sparse normal equations of patch grids.
//! - [`mod@nelder_mead`], [`mod@bfgs`]: general minimisers of an [`Objective`].
//! - [`evo`]: the genetic algorithm and CMA-ES on any [`evo::PopulationObjective`], with
//!   checkpoints; `ga+lsq` / `cmaes+lsq` polish their result by least squares.
//! - [`population`]: the fitting problem as a population objective on the population
//!   evaluator (GPU or CPU), and `bezchain eval`'s batch evaluation.
//! - [`curve`]: [`fit_curve`], one call from data and layout to a fitted chain.
//! - [`mod@param`]: initial `(u, v)` of 3D clouds, from sections or blade-aware.
//! - [`surface`]: [`fit_surface`], one call from a cloud and a grid layout to a fitted grid.
//! - [`surface_breaks`]: the span-break search of fitted grids.
//! - [`checker`]: the emulation of the outside checker `verify.py`'s closest-point search and
//!   the projection check built on it (kept apart from [`crate::closest`] on purpose).

// Index loops over small fixed dimensions mirror the formulas; `!(x > 0.0)` is meant: it is
// also true for NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod band;
pub mod bfgs;
pub mod checker;
pub mod curve;
pub mod evo;
pub mod lsq;
pub mod nelder_mead;
pub mod objective;
pub mod offset;
pub mod paper;
pub mod param;
pub mod population;
pub mod problem;
pub mod surface;
pub mod surface_breaks;

pub use crate::chain::shape::{self, Basis, CurveShape, GridShape, Jet, Shape};
pub use crate::closest::{Foot, FootOptions};
pub use bfgs::{bfgs, BfgsOptions};
pub use curve::{fit_curve, fit_curve_with, CurveFit, FitOptions, Method};
pub use lsq::{
    lsq, DampingScale, Guard, LsqFit, LsqHooks, LsqIterate, LsqMethod, LsqOptions, Observer, Start,
};
pub use nelder_mead::{nelder_mead, Minimum, NelderMeadOptions};
pub use objective::{Objective, SolveReport, StopReason};
pub use offset::{
    chord_length_params, corresponding_offsets, corresponding_stats, exponent_params, grid_offset_stats,
    offset_stats, point_offsets, shape_offsets, span_ratio, Metric, OffsetStats,
};
pub use paper::{PaperCase, PAPER_CASES};
pub use param::{blade_params, section_params, span_axis, BladeParamOptions, SpanAxis};
pub use problem::{
    increment_start, Constraint, CoordRule, CurveProblem, FitProblem, GridProblem, ProblemObjective, Residual,
};
pub use surface::{
    fit_surface, fit_surface_with, initial_params, Breaks, ParamSource, SurfaceFit, SurfaceLayout,
    SurfaceMethod, SurfaceOptions, SurfaceProgress, SurfaceStage,
};
