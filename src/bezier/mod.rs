//! Single Bezier curves and tensor-product patches: Bernstein basis, evaluation, derivatives,
//! subdivision and degree elevation (paper eqs. 1-4).

// Index loops over the Bernstein weights mirror the formulas they implement.
#![allow(clippy::needless_range_loop)]

mod basis;
mod curve;
mod patch;
mod point;

pub use basis::{bernstein, bernstein_deriv, binomial};
pub use curve::BezierCurve;
pub use patch::BezierPatch;
pub use point::{same_points, Vector};
