//! Chains of Bezier curves and grids of Bezier patches whose joins are generated from their
//! neighbours (`docs/ARCHITECTURE.md` §2.2, §2.3): the layout, the sparse extraction map `expanded = E · design`,
//! `CurveChain` and `PatchGrid`.

mod curve_chain;
mod layout;
mod map;
mod patch_grid;

pub use curve_chain::CurveChain;
pub use layout::{ChainLayout, Continuity};
pub use map::ExtractionMap;
pub use patch_grid::{GridLayout, PatchGrid};
