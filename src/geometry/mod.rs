//! Aerofoil and point-cloud geometry: NACA generators, Selig/Lednicer `.dat` and CSV/XYZ
//! readers and writers, blade lofting.

mod naca;

pub use naca::{Naca, NacaOptions, Spacing};
