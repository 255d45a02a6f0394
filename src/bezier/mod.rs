//! Single Bezier curves and tensor-product patches: Bernstein basis, evaluation, derivatives,
//! subdivision and degree elevation (paper eqs. 1-4).

mod basis;
mod curve;
mod patch;
mod point;

pub use basis::{bernstein, bernstein_deriv, binomial};
pub use curve::BezierCurve;
pub use patch::BezierPatch;
pub use point::Vector;
