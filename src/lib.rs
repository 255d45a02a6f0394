//! bezchain: chained Bezier curves and patches as compact shape-optimisation variables.
//!
//! Dense aerofoil contours and 3D blade point clouds become a small set of design points:
//! chains of low-degree Bezier curves (2D) and grids of tensor-product Bezier patches (3D)
//! whose joins are generated from their neighbours, so continuity costs no variables
//! (WCE 2008, "Parameterization for Shape Optimization of Aerofoils").
//!
//! Modules:
//! - [`aero`]: the inviscid panel method (XFOIL's), its exact truth, and the batched form.
//! - [`bezier`]: Bernstein basis, single curves and patches (eval, deriv, split, elevate).
//! - [`chain`]: chain and grid layouts, the extraction map `expanded = E · design`,
//!   `CurveChain`, `PatchGrid`.
//! - [`closest`]: the one closest-point search on chains and grids (f64, global seeding,
//!   clamped Newton across cell borders), with its accuracy contract.
//! - [`geometry`]: aerofoil generators, `.dat`/CSV/XYZ readers and writers, blade lofting.
//! - [`problem`]: the fitting problem every solver consumes, offset metrics, foot-point starts.
//! - [`optim`]: Nelder-Mead, BFGS, Levenberg-Marquardt, GA, CMA-ES, hybrids, checkpoints.
//! - [`fit`]: fitting chains and grids to data with those optimisers.
//! - [`adaptive`]: the fewest stored scalars that meet a tolerance (the paper's Figs. 7, 8).
//! - [`eval`]: population evaluation on the CPU (rayon) and the GPU (wgpu).
//! - [`export`]: JSON reports, SVG plots, meshes and renders.
//! - [`error`]: the library's error type.
//! - [`team`]: the processes a run is spread over (MPI ranks) and how a batch is shared among them.

pub mod adaptive;
pub mod aero;
pub mod bench;
pub mod bezier;
pub mod chain;
pub mod closest;
pub mod error;
pub mod eval;
pub mod export;
pub mod fit;
pub mod geometry;
mod keyword;
pub mod numeric;
pub mod optim;
pub mod problem;
pub mod team;

pub use error::{Error, Result};
