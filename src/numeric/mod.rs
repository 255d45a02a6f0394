//! Numerical kernels the solvers share: a blocked dense LU and matrix products in
//! `matrixmultiply`'s kernels ([`lu`]), and a fast `atan2` for the panel influences ([`angle`]).

pub mod angle;
pub mod lu;

pub use angle::atan2;
pub use lu::{gemm, Lu};
