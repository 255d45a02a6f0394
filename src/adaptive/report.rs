//! The JSON report of an adapted curve: the curve report (its keys intact)
//! with an `adapt` block: the stored scalars, how they are counted, the stored numbers
//! themselves, the held-out check and a summary of the search; and the same for an adapted
//! patch grid (the surface report with an `adapt` block). Formats: `docs/ARCHITECTURE.md`
//! §5.6 and §5.7.

use super::encoding::{Encoding, ScalarCount};
use super::surface::{
    AdaptedSurface, CheckedOffsets, FoldCheck, SurfaceAdaptOptions, SurfaceCount, SurfaceEncoding,
    SurfaceFamilyTrace,
};
use super::{AdaptOptions, AdaptedCurve, FamilyTrace, HeldOut, Norm};
use crate::export::{CurveReport, FitInfo, InputInfo, OffsetReport, SurfaceReport};
use serde::{Deserialize, Serialize};

/// How the stored scalars are counted, as the report states it.
pub const COUNTING: &str = "stored scalars = every stored design coordinate (x and y of each design \
point, or only y where x follows the aerofoil rule) + the numbers of the aerofoil rule when used (2, or 3 when the surfaces end at different x) + \
every stored break (breaks fixed by the layout integers, and the leading-edge break t = 1/2 of the \
aerofoil rule, are not stored); the layout integers (degree, segment counts, the continuity order \
of each join) are not counted";

/// The `adapt` block of the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdaptBlock {
    /// The tolerance, model units.
    pub tol: f64,
    /// `max` or `rms`.
    pub norm: Norm,
    /// True when the tolerance holds (closest-point offsets of every data point).
    pub met: bool,
    /// Why not, when it does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    /// The stored scalars.
    pub stored_scalars: usize,
    /// The stored scalars by kind.
    pub scalars: ScalarCount,
    /// How they are counted.
    pub counting: String,
    /// The stored numbers and the layout integers: regenerate `control_points` from these.
    pub encoding: Encoding,
    /// The winning family: x storage, degree, join continuity, breaks.
    pub family: String,
    /// The held-out check (refit on every other point, measured on the rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// Candidate fits run by the search.
    pub fits: usize,
    /// Every family of the outer search.
    pub search: Vec<FamilyTrace>,
}

/// A curve report with the adapt block.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdaptReport {
    /// The curve report (`docs/ARCHITECTURE.md` §5.4).
    #[serde(flatten)]
    pub curve: CurveReport,
    /// The adaptive search's block.
    pub adapt: AdaptBlock,
}

impl AdaptReport {
    /// The report of `result` for the data described by `input`.
    #[must_use]
    pub fn new(result: &AdaptedCurve, opts: &AdaptOptions, input: InputInfo) -> Self {
        let offset = OffsetReport::from(&result.offset);
        let steps = result.trace.iter().map(|t| t.steps as u64).sum();
        let fit = FitInfo::of_search(steps, result.fits as u64, result.seconds);
        AdaptReport {
            curve: CurveReport::new(&result.chain, offset, fit, input),
            adapt: AdaptBlock {
                tol: opts.tol,
                norm: opts.norm,
                met: result.met,
                message: result.message.clone(),
                stored_scalars: result.count.total,
                scalars: result.count,
                counting: COUNTING.into(),
                encoding: result.encoding.clone(),
                family: result.family.clone(),
                held_out: result.held_out,
                fits: result.fits,
                search: result.trace.clone(),
            },
        }
    }
}

/// How the stored scalars of an adapted patch grid are counted, as the report states it.
pub const SURFACE_COUNTING: &str = "stored scalars = every stored design-net coordinate (x, y and z of \
each design point, or the two besides the span axis where the span rule holds, or under the chord rule \
one thickness-direction offset y_ij per design point) + the 4 numbers of every design column's frame \
under the chord rule (leading edge O_j in the two in-plane axes, chord angle theta_j, chord length c_j; \
design point (i, j) = O_j + c_j x_i d_j + y_ij n_j with x_i the B-spline coefficient of (2u - 1)^2, d_j = (cos theta_j, sin theta_j), n_j = (-sin theta_j, cos theta_j)) \
+ the 2 numbers of the span rule when used + every stored break in either direction; the layout \
integers (degrees, patch counts, the continuity order of each join) are not counted";

/// The `adapt` block of a surface report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceAdaptBlock {
    /// The tolerance, model units.
    pub tol: f64,
    /// `max` or `rms`.
    pub norm: Norm,
    /// True when the tolerance holds (closest-point offsets of every data point).
    pub met: bool,
    /// Why not, when it does not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    /// The stored scalars.
    pub stored_scalars: usize,
    /// The stored scalars by kind.
    pub scalars: SurfaceCount,
    /// How they are counted.
    pub counting: String,
    /// The stored numbers and the layout integers: regenerate `control_net` from these.
    pub encoding: SurfaceEncoding,
    /// The winning family.
    pub family: String,
    /// The offsets the shared checker's sampled closest-point search (`verify.py`) finds.
    pub checked: CheckedOffsets,
    /// The held-out check (refit on every other point of each section, measured on the rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// The fold check: the largest turn of the surface normal between neighbouring samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fold: Option<FoldCheck>,
    /// The checker's max over the exact max (the projection check agrees within 10 % when at
    /// most 1.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projection_agreement: Option<f64>,
    /// Candidate fits run by the search.
    pub fits: usize,
    /// Every family of the outer search.
    pub search: Vec<SurfaceFamilyTrace>,
}

/// A surface report (`docs/ARCHITECTURE.md` §5.5) with the adapt block (§5.7).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceAdaptReport {
    /// The surface fit report.
    #[serde(flatten)]
    pub surface: SurfaceReport,
    /// The adaptive search's block.
    pub adapt: SurfaceAdaptBlock,
}

impl SurfaceAdaptReport {
    /// The report of `result` for the cloud described by `input`.
    #[must_use]
    pub fn new(result: &AdaptedSurface, opts: &SurfaceAdaptOptions, input: InputInfo) -> Self {
        let offset = OffsetReport::from(&result.offset);
        let fit = FitInfo::of_search(result.trace.len() as u64, result.fits as u64, result.seconds);
        SurfaceAdaptReport {
            surface: SurfaceReport::new(&result.grid, offset, fit, input),
            adapt: SurfaceAdaptBlock {
                tol: opts.tol,
                norm: opts.norm,
                met: result.met,
                message: result.message.clone(),
                stored_scalars: result.count.total,
                scalars: result.count,
                counting: SURFACE_COUNTING.into(),
                encoding: result.encoding.clone(),
                family: result.family.clone(),
                checked: result.checked,
                held_out: result.held_out,
                fold: Some(result.fold),
                projection_agreement: Some(result.agreement),
                fits: result.fits,
                search: result.trace.clone(),
            },
        }
    }
}
