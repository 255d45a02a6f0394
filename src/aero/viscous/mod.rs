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

/// The panel nodes of an aerofoil file shipped with the repository (`file` relative to it),
/// for the tests of the viscous analysis.
#[cfg(test)]
fn shipped_nodes(file: &str) -> Vec<glam::DVec2> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    let paneling = crate::aero::Paneling::default();
    let (_, a) = crate::aero::input::Aerofoil::analyse(&path, &paneling, "", &mut |_, _| {}).unwrap();
    a.solution.nodes().to_vec()
}
