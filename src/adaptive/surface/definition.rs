//! `adapt_blade`: a blade definition (not a cloud) to the patch grid with the fewest stored
//! scalars that follows it at and between its stations.
//!
//! The definition is lofted at its stations ([`Blade::loft_at`]) and searched as a sectioned
//! cloud, checked against sections lofted half-way between every two of them
//! ([`adapt_surface_with`]'s `between`). Where the surface meets the tolerance at the sections
//! but leaves the definition between two of them (a spline along the span overshoots where
//! the definition's monotone interpolation flattens, as at the NREL 5 MW's tip, whose last two
//! stations share one chord), the section lofted there joins the data and the search runs
//! again, checked half-way between the new neighbours: at most [`MAX_ROUNDS`] searches. The
//! data then holds the stations and only the sections the surface needed to follow the
//! definition between them.

use super::{adapt_surface_with, AdaptedSurface, SurfaceAdaptOptions, SurfaceProgress};
use crate::error::{Error, Result};
use crate::geometry::{Blade, Cloud, LoftOptions};

/// Searches of [`adapt_blade`]: the stations', and at most this many less one with lofted
/// sections added.
pub const MAX_ROUNDS: usize = 4;

/// The result of [`adapt_blade`].
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptedBlade {
    /// The search's result on the last data.
    pub surface: AdaptedSurface,
    /// The sections fitted: the stations and the sections added between them.
    pub cloud: Cloud,
    /// Their radii.
    pub radii: Vec<f64>,
    /// The stations of the definition (the first `radii` not added).
    pub stations: usize,
    /// The searches run.
    pub rounds: usize,
    /// The seconds of all of them.
    pub seconds: f64,
}

/// Adapt the blade definition `blade`, lofted with `loft` (its `sections` ignored), at
/// `opts` (see the module doc); `progress` as in [`adapt_surface_with`].
pub fn adapt_blade(
    blade: &Blade,
    loft: &LoftOptions,
    opts: &SurfaceAdaptOptions,
    progress: &(dyn Fn(&SurfaceProgress<'_>) + Sync),
) -> Result<AdaptedBlade> {
    let start = std::time::Instant::now();
    let mut radii: Vec<f64> = blade.stations.iter().map(|s| s.radius).collect();
    let stations = radii.len();
    let mut rounds = 0;
    // The rounds that add sections search without the mid-station checks (a layout that
    // meets the tolerance at the sections shows where it leaves the definition); the last
    // holds them.
    let mut checks = false;
    loop {
        rounds += 1;
        let cloud = blade.loft_at(&radii, loft)?;
        let grid = cloud
            .grid
            .ok_or_else(|| Error::invalid("adapt-surface: the lofted blade has no sections"))?;
        let mids: Vec<f64> = radii.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
        let between = blade.loft_at(&mids, loft)?;
        let round_opts = SurfaceAdaptOptions {
            span_checks: checks || !opts.span_checks,
            ..*opts
        };
        let surface = adapt_surface_with(&cloud.points, grid, Some(&between), &round_opts, progress)?;
        let done = |surface| AdaptedBlade {
            surface,
            cloud: cloud.clone(),
            radii: radii.clone(),
            stations,
            rounds,
            seconds: start.elapsed().as_secs_f64(),
        };
        if checks || !opts.span_checks {
            return Ok(done(surface));
        }
        if !surface.at_sections || surface.faults.is_empty() {
            // Nothing to add: without faults the result passes the checks, and one that does
            // not meet the tolerance at the sections will not with more of them.
            return Ok(done(surface));
        }
        if rounds + 1 >= MAX_ROUNDS {
            checks = true;
            continue;
        }
        // The mid-stations that fail, by their span coordinate (the radius: sections are
        // lofted in planes z = r).
        let add: Vec<f64> = mids
            .iter()
            .copied()
            .filter(|m| {
                surface
                    .faults
                    .iter()
                    .any(|f| (f - m).abs() <= 1e-9 * m.abs().max(1.0))
            })
            .collect();
        if add.is_empty() {
            checks = true;
            continue;
        }
        radii.extend(add);
        radii.sort_by(f64::total_cmp);
    }
}
