//! Chains of Bezier curves and grids of Bezier patches whose joins are generated from their
//! neighbours (`docs/ARCHITECTURE.md` §2.2, §2.3): the one spline kernel [`ChainLayout`]
//! (degree, breaks, the continuity of every join, knot insertion, the basis), the sparse
//! extraction map `expanded = E · design`, `CurveChain` and `PatchGrid`.

#![allow(clippy::needless_range_loop)]

mod curve_chain;
mod layout;
mod map;
mod patch_grid;
pub mod shape;

pub use curve_chain::CurveChain;
pub use layout::{samples, ChainLayout, Continuity, SpanBasis, MAX_DEGREE, MAX_SUPPORT};
pub use map::ExtractionMap;
pub use patch_grid::{GridLayout, PatchGrid};
pub use shape::{Basis, CurveShape, GridShape, Jet, Shape};

/// `Ok` when the control points a C1 form regenerated from its design points are the
/// original's (`to_c1` of a `what`, chain or grid); they cannot differ beyond rounding.
fn check_regenerated<P: crate::bezier::Vector>(
    regenerated: &[P],
    original: &[P],
    what: &str,
) -> crate::error::Result<()> {
    if crate::bezier::same_points(regenerated, original) {
        Ok(())
    } else {
        Err(crate::error::Error::Numerical(format!(
            "the {what}'s joins are not C1 (internal inconsistency)"
        )))
    }
}
