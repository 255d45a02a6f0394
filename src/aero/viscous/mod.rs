//! Viscous–inviscid analysis at Mach 0: the panel method coupled to an integral boundary layer
//! on both surfaces and the wake with XFOIL's closures and e^N transition, all unknowns solved
//! together by Newton (Drela 1989; mfoil's global formulation). `docs/ARCHITECTURE.md §2.14`.
//!
//! - [`closures`]: the laminar and turbulent closures and the amplification rate.
//! - [`equations`]: the discrete equations of an interval, the similarity station, the
//!   transition interval and the wake junction.
//! - [`coupling`]: the factored panel system, the wake streamline and the edge speeds'
//!   response to the boundary layer's sources.
//! - [`newton`]: the coupled system at one angle and its Newton solution.
//! - [`polar`]: [`Viscous`], polars by continuation along α, over populations with rayon.

pub mod closures;
pub mod coupling;
pub mod dual;
pub mod equations;
pub mod newton;
pub mod polar;

pub use polar::{polars, polars_around, Viscous, ViscousOptions, ViscousPoint, Warm};
