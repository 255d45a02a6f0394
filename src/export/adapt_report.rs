//! The JSON report of an adapted curve: the curve report (its keys intact)
//! with an `adapt` block: the stored scalars, how they are counted, the stored numbers
//! themselves, the held-out check and a summary of the search; and the same for an adapted
//! patch grid (the surface report with an `adapt` block). Formats: `docs/ARCHITECTURE.md`
//! §5.6 and §5.7.

use crate::adaptive::encoding::{Encoding, ScalarCount};
use crate::adaptive::surface::{
    AdaptedSurface, BetweenSections, CheckedOffsets, DataScatter, FoldCheck, JoinedSections, SectionEnds,
    SpanFairness, SurfaceAdaptOptions, SurfaceCount, SurfaceEncoding, SurfaceFamilyTrace,
};
use crate::adaptive::{AdaptOptions, AdaptedCurve, FamilyTrace, Follows, HeldOut, Norm, SignChanges};
use crate::fit::report::{CurveReport, FitInfo, InputInfo, OffsetReport, SurfaceReport};
use serde::{Deserialize, Serialize};

/// How the stored scalars are counted, as the report states it.
pub const COUNTING: &str = "stored scalars = every stored design coordinate (x and y of each design \
point, or only y where x follows the aerofoil rule) + the numbers of the aerofoil rule when used (2, or 3 when the surfaces end at different x) + \
every stored break (breaks fixed by the layout integers, and the leading-edge break t = 1/2 of the \
aerofoil rule, are not stored); the layout integers (degree, segment counts, the continuity order \
of each join) are not counted";

/// What the `adapt` block of every adapted shape, curve or patch grid, states first: the
/// tolerance, whether it holds, the stored scalars (in all, by kind `C`, how they are counted),
/// the stored numbers `E` and the winning family.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdaptOutcome<C, E> {
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
    pub scalars: C,
    /// How they are counted.
    pub counting: String,
    /// The stored numbers and the layout integers: regenerate the control points (or net)
    /// from these.
    pub encoding: E,
    /// The winning family: x storage (or the span and chord rules), degree(s), join
    /// continuity, breaks.
    pub family: String,
}

/// The [`AdaptOutcome`] of `$r`, an adapted curve or patch grid (their result types name these
/// fields alike), searched with `$opts`; `$counting` says how its scalars are counted.
macro_rules! outcome {
    ($opts:expr, $r:expr, $counting:expr) => {
        AdaptOutcome {
            tol: $opts.tol,
            norm: $opts.norm,
            met: $r.met,
            message: $r.message.clone(),
            stored_scalars: $r.count.total,
            scalars: $r.count,
            counting: $counting.into(),
            encoding: $r.encoding.clone(),
            family: $r.family.clone(),
        }
    };
}

/// The `adapt` block of a curve report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdaptBlock {
    /// The tolerance, the stored scalars and numbers, the family.
    #[serde(flatten)]
    pub outcome: AdaptOutcome<ScalarCount, Encoding>,
    /// The held-out check (refit on every other point, measured on the rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// The held-out measure under the norm over the tolerance (met needs at most
    /// [`crate::adaptive::HELD_OUT_FACTOR`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out_ratio: Option<f64>,
    /// Curvature sign changes of the chain and of the source (met needs the chain's at most
    /// the source's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sign_changes: Option<SignChanges>,
    /// How the chain follows the source between the data points (met needs it within
    /// [`crate::adaptive::fairness::AWAY_FACTOR`] tolerances of it and turning at most
    /// [`crate::adaptive::fairness::EXTRA_TURN_DEG`] more).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub follows: Option<Follows>,
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
    /// The report of `r` for the data described by `input`.
    #[must_use]
    pub fn new(r: &AdaptedCurve, opts: &AdaptOptions, input: InputInfo) -> Self {
        let offset = OffsetReport::from(&r.offset);
        let steps = r.trace.iter().map(|t| t.steps as u64).sum();
        let fit = FitInfo::of_search(steps, r.fits as u64, r.seconds);
        AdaptReport {
            curve: CurveReport::new(&r.chain, offset, fit, input),
            adapt: AdaptBlock {
                outcome: outcome!(opts, r, COUNTING),
                held_out: r.held_out,
                held_out_ratio: r.held_out.map(|h| h.measure(opts.norm) / opts.tol),
                sign_changes: r.sign_changes,
                follows: r.follows,
                fits: r.fits,
                search: r.trace.clone(),
            },
        }
    }
}

/// How the stored scalars of an adapted patch grid are counted, as the report states it.
pub const SURFACE_COUNTING: &str = "stored scalars = every stored design-net coordinate (x, y and z of \
each design point, or the two besides the span axis where the span rule holds, or under the chord rule \
one thickness-direction offset y_ij per design point) + the 4 numbers of every design column's frame \
under the chord rule (leading edge O_j in the two in-plane axes, chord angle theta_j, chord length c_j; \
design point (i, j) = O_j + c_j x_i d_j + y_ij n_j with x_i the B-spline coefficient of (2u - 1)^2, d_j = (cos theta_j, sin theta_j), n_j = (-sin theta_j, cos theta_j)), \
5 with the trailing-edge term (te_term: a fifth number b_j, x_i + b_j w_i in place of x_i, w_i the B-spline coefficient of t^2 (1 - t^2), t = 2u - 1) \
+ the 2 numbers of the span rule when used + every stored break in either direction; the layout \
integers (degrees, patch counts, the continuity order of each join) are not counted";

/// The `adapt` block of a surface report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceAdaptBlock {
    /// The tolerance, the stored scalars and numbers, the family.
    #[serde(flatten)]
    pub outcome: AdaptOutcome<SurfaceCount, SurfaceEncoding>,
    /// The offsets the shared checker's sampled closest-point search (`verify.py`) finds.
    pub checked: CheckedOffsets,
    /// The held-out check (refit on every other point of each section, measured on the rest).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOut>,
    /// The fold check: the largest turn of the surface normal between neighbouring samples.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fold: Option<FoldCheck>,
    /// The sections' ends: how far a cut's end doubles back beyond its neighbouring
    /// sections' (`passes` at most [`crate::adaptive::surface::END_SLACK`] tolerances;
    /// reported, not part of `met`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section_ends: Option<SectionEnds>,
    /// The checker's max over the exact max (the projection check agrees within 10 % when at
    /// most 1.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub projection_agreement: Option<f64>,
    /// The cuts at the mid-stations against their neighbours (chord, thickness, centroid).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fairness: Option<SpanFairness>,
    /// The surface between the sections: against the blade definition's lofted
    /// mid-stations, or left one section out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub between_sections: Option<BetweenSections>,
    /// The data's own scatter (the most scattered section), and whether the tolerance is
    /// below what it allows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scatter: Option<DataScatter>,
    /// A blade definition's sections joined between its stations (held to three
    /// tolerances), and the stations' largest offset.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joined_sections: Option<JoinedSections>,
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
    /// The report of `r` for the cloud described by `input`.
    #[must_use]
    pub fn new(r: &AdaptedSurface, opts: &SurfaceAdaptOptions, input: InputInfo) -> Self {
        let offset = OffsetReport::from(&r.offset);
        let fit = FitInfo::of_search(r.trace.len() as u64, r.fits as u64, r.seconds);
        SurfaceAdaptReport {
            surface: SurfaceReport::new(&r.grid, offset, fit, input),
            adapt: SurfaceAdaptBlock {
                outcome: outcome!(opts, r, SURFACE_COUNTING),
                checked: r.checked,
                held_out: r.held_out,
                fold: Some(r.fold),
                section_ends: r.ends,
                projection_agreement: Some(r.agreement),
                fairness: r.fairness.clone(),
                between_sections: r.between.clone(),
                scatter: r.scatter.clone(),
                joined_sections: r.joined,
                fits: r.fits,
                search: r.trace.clone(),
            },
        }
    }
}
