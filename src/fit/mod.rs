//! Fitting chains and grids to data: the objective that ties a [`crate::problem::FitProblem`]
//! to the optimisers of [`crate::optim`].
//!
//! - [`population`]: the fitting problem as a population objective on the population
//!   evaluator (GPU or CPU), and `bezchain eval`'s batch evaluation.
//! - [`curve`]: [`fit_curve`], one call from data and layout to a fitted chain.
//! - [`surface`]: [`fit_surface`], one call from a cloud and a grid layout to a fitted grid.
//! - [`surface_breaks`]: the span-break search of fitted grids.
//! - [`segments`]: how many segments the data can determine.
//! - [`grid_evo`]: a patch grid fitted by the GA or CMA-ES, polished by least squares.
//! - [`paper`]: the paper's three NACA 4413 cases and its optimiser comparison.
//! - [`report`]: the JSON reports of fitted curves and surfaces, and the one reader of saved
//!   reports.

// Index loops over small fixed dimensions mirror the formulas; `!(x > 0.0)` is meant: it is
// also true for NaN.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod curve;
pub mod grid_evo;
pub mod paper;
pub mod population;
pub mod report;
pub mod segments;
pub mod surface;
pub mod surface_breaks;

pub use crate::optim::Method;
pub use curve::{fit_curve, fit_curve_with, CurveFit, FitOptions};
pub use grid_evo::{fit_grid_evo, GridEvoFit};
pub use paper::{compare, CompareRow, PaperCase, PAPER_CASES};
pub use report::{
    backend_label, is_report, parse_report, read_report, read_reports, CurveReport, FitInfo, InputInfo,
    OffsetReport, Report, Saved, SurfaceReport,
};
pub use surface::{
    fit_surface, fit_surface_with, initial_params, parse_surface_method, Breaks, ParamSource, SurfaceFit,
    SurfaceLayout, SurfaceOptions, SurfaceProgress, SurfaceStage,
};
