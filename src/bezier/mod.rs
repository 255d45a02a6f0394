//! Single Bezier curves and tensor-product patches: the one f64 evaluator of Bernstein bases,
//! curves and patches (points and derivatives), subdivision and degree elevation (paper
//! eqs. 1-4).

// Index loops over the Bernstein weights mirror the formulas they implement.
#![allow(clippy::needless_range_loop)]

mod basis;
mod curve;
mod patch;
mod point;

pub use basis::{
    bernstein, bernstein_deriv, bernstein_jet, bernstein_levels, binomial, casteljau, casteljau_with,
    combine, curve_jet, tensor_jet,
};
pub use curve::BezierCurve;
pub use patch::BezierPatch;
pub use point::{same_points, Vector};
