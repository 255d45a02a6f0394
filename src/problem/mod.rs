//! The fitting problem every solver consumes, and what it is made of.
//!
//! - [`fit_problem`]: [`FitProblem`], data points, a shape (chain or grid layout), a metric,
//!   anchors, weights, held directions, linear constraints, start and bounds; its objective,
//!   gradient, residual blocks and linear least squares.
//! - [`constraint`]: [`Constraint`], linear rules on the design (aerofoil rule, span rule).
//! - [`offset`]: the metrics ([`Metric`]), [`OffsetStats`], chord-length parameters.
//! - [`objective`]: [`Objective`], what a general-purpose minimiser sees of a problem.
//! - [`frame`]: [`Frame`], the problem's coordinates as the f32 population methods see them.
//! - [`band`]: banded Cholesky for the large, sparse normal equations of patch grids.
//! - [`mod@param`]: initial `(u, v)` of 3D clouds, from sections or blade-aware.
//! - [`checker`]: the emulation of the outside checker `verify.py`'s closest-point search and
//!   the projection check built on it (kept apart from [`crate::closest`] on purpose).

// Index loops over small fixed dimensions mirror the formulas; `!(x > 0.0)` is meant: it is
// also true for NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod band;
pub mod checker;
pub mod constraint;
pub mod fit_problem;
pub mod frame;
pub mod objective;
pub mod offset;
pub mod param;

pub use constraint::{Constraint, CoordRule};
pub use fit_problem::{increment_start, CurveProblem, FitProblem, GridProblem, ProblemObjective, Residual};
pub use frame::Frame;
pub use objective::Objective;
pub use offset::{
    chord_length_params, corresponding_offsets, corresponding_stats, exponent_params, grid_offset_stats,
    offset_stats, point_offsets, shape_offsets, span_ratio, Metric, OffsetStats,
};
pub use param::{blade_params, section_params, span_axis, BladeParamOptions, SpanAxis, SpanDirection};
