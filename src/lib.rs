//! bezchain: chained Bezier curves and patches as compact shape-optimisation variables.
//!
//! Dense aerofoil contours and 3D blade point clouds become a small set of design points:
//! chains of low-degree Bezier curves (2D) and grids of tensor-product Bezier patches (3D)
//! whose joins are generated from their neighbours, so continuity costs no variables
//! (WCE 2008, "Parameterization for Shape Optimization of Aerofoils").
//!
//! Modules:
//! - [`bezier`]: Bernstein basis, single curves and patches (eval, deriv, split, elevate).
//! - [`chain`]: chain and grid layouts, the extraction map `expanded = E · design`,
//!   `CurveChain`, `PatchGrid`.
//! - [`error`]: the library's error type.

pub mod bezier;
pub mod chain;
pub mod error;

pub use error::{Error, Result};
