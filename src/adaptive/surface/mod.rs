//! `adapt_surface`: the patch grid with the fewest stored scalars whose closest-point offsets
//! from a sectioned 3D cloud meet a tolerance (the paper's Fig. 8 for surfaces).
//!
//! The cloud is a grid of sections (a blade's stations: `section,index` columns). Each direction of
//! the tensor-product spline has its own [`ChainLayout`](crate::chain::ChainLayout): u around the
//! sections, v along the span. The section `k` sits at span parameter `v_k`; every data point has
//! its own `u`. A candidate is fitted by alternating a linear least-squares solve for the design
//! net (all points at their `(u, v_k)`) with a Newton correction of each point's `u` on the section
//! curve `S(·, v_k)` (Hoschek's parameter correction along u), then, for the max norm, by Lawson's
//! reweighting towards the minimax fit. Its offsets are judged as the distance from every point to
//! `S(u, v_k)`: a point of the surface, so never below the true closest-point distance. The winner
//! is re-measured by two global searches (the library's and the shared checker's, see
//! [`sampled_offsets`]); it is accepted only when the checker's own search confirms the tolerance.
//!
//! **Span rule.** When every section lies in a plane `x_a = s_k` of one coordinate axis `a`,
//! with `s_k` strictly monotone along the sections, the span coordinate of design column `j`
//! follows `s_first + g_j (s_last - s_first)` (`g_j` the Greville abscissa of column `j`) and
//! `v_k = (s_k - s_first) / (s_last - s_first)`. The surface's span coordinate is then exactly
//! linear in `v`, so section `k` of the surface lies in the plane of section `k` of the data;
//! only the two other coordinates of every design point and the two numbers of the rule are
//! stored (the surface counterpart of the curves' aerofoil rule, counted the same honest way).
//! Without it all three coordinates are stored and `v_k` follows the distance between the
//! sections' centroids.
//!
//! **Chord rule.** Where the span rule holds and every section looks like an aerofoil
//! section, each design column stores a frame (leading edge, chord angle, chord length) and
//! each design point one thickness-direction offset, x following the aerofoil rule in the
//! column's frame (`adaptive::blade`); [`ChordRule`] says when it is searched.
//!
//! **Search.** Families (degree and join continuity in each direction; breaks equal or split at
//! data-driven positions) run in parallel, and under MPI spread over the ranks. Each starts with
//! one patch and grows the direction that buys the most accuracy per stored scalar: a u split in
//! the segment holding the worst point, at the squared-error-weighted mean of its points' `u`; a v
//! split in the span holding the worst section, at the weighted mean of its sections' `v`. Once the
//! tolerance holds, it removes every break it can while the tolerance still holds. A family stops
//! when it would need more design points than the data allow (half the points of a section around,
//! the number of sections along the span) or after [`SurfaceAdaptOptions::max_family_fits`] fits.
//! The bulk families (`Search::grow_bulk`: a span break between every two sections, the sections'
//! ends anchored, every bad u segment split at once, the fold check part of meeting the tolerance;
//! under the chord rule these are its trailing-edge families) run first; the others then stop
//! growing at the fewest stored scalars those met the tolerance with, a bound fixed before they
//! start, so the result does not depend on thread timing.

#![allow(clippy::needless_range_loop)]

mod data;
mod definition;
mod encoding;
mod ends;
mod fitter;
mod search;
mod span;

use data::Data;
pub use definition::{adapt_blade, AdaptedBlade, MAX_ROUNDS};
pub use encoding::{SurfaceCount, SurfaceEncoding};
pub use ends::{SectionEnds, END_SLACK, END_WINDOWS};
use fitter::{closest_dist_sq, norm_of, scale_by, Fitter};
use search::{encode, store, Cand, Family, Growth, Search, Searched, SweepOrder};
pub use span::{
    BetweenSections, DataScatter, SpanFairness, BETWEEN_FACTOR, FAIR_CENTROID, FAIR_SHAPE, SCATTER_FACTOR,
};

use super::blade::TE_DEGREE;
use super::{HeldOut, Norm, HELD_OUT_FACTOR};
use crate::chain::PatchGrid;
use crate::error::{Error, Result};
pub use crate::problem::checker::{fold_check, sampled_offsets, FoldCheck};

/// Samples a patch in each direction of the result's fold check.
pub const FOLD_SAMPLES: usize = 16;

/// Equal u segments the bulk families start from (a break at the leading edge).
const BULK_START: usize = 8;
use crate::geometry::{Cloud, Grid};
use crate::keyword::keywords;
use crate::problem::{Metric, OffsetStats};
use crate::team;
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Options of [`adapt_surface`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceAdaptOptions {
    /// The tolerance, model units. No default: it must be set.
    pub tol: f64,
    /// The norm the tolerance bounds. Default [`Norm::Max`].
    pub norm: Norm,
    /// Degrees searched around the sections (u), inclusive. Default `[3, 6]`.
    pub degrees_u: [usize; 2],
    /// Degrees searched along the span (v), inclusive. Default `[2, 3]`.
    pub degrees_v: [usize; 2],
    /// Use the span rule where the sections are planar (see the module docs). Default true.
    pub span_rule: bool,
    /// The chord rule (`adaptive::blade`), where the span rule holds and every section looks
    /// like an aerofoil section. Default [`ChordRule::Auto`].
    pub chord_rule: ChordRule,
    /// Never report a result with more stored scalars than this. Default none.
    pub max_scalars: Option<usize>,
    /// Polish fits within twice the tolerance towards the minimax fit (Lawson's reweighting),
    /// for [`Norm::Max`]. Default true.
    pub minimax: bool,
    /// Refit the winning layout on every other point of each section and measure the rest.
    /// Default true.
    pub held_out: bool,
    /// A family gives up after this many fits. Default 80.
    pub max_family_fits: usize,
    /// Search the greedy families (one break at a time, where it buys the most) besides the
    /// bulk ones. Default true. For a blade definition ([`Lofted`]) the plain pass after a
    /// chord-rule pass that met nothing ([`ChordRule::Auto`]) never searches them, and the
    /// searches after its first run without them when none met the tolerance in the first
    /// ([`adapt_blade`]).
    pub greedy: bool,
    /// The search rejects layouts that fail the mid-station checks (`span`: fairness,
    /// and a blade definition's sections between the data's). Default true; the result's
    /// `met` holds them either way.
    pub span_checks: bool,
    /// Where the bulk families put their span breaks. Default [`SpanBreaks::Auto`].
    pub span_breaks: SpanBreaks,
}

impl Default for SurfaceAdaptOptions {
    fn default() -> Self {
        SurfaceAdaptOptions {
            tol: 1e-3,
            norm: Norm::Max,
            degrees_u: [3, 6],
            degrees_v: [2, 3],
            span_rule: true,
            chord_rule: ChordRule::Auto,
            max_scalars: None,
            minimax: true,
            held_out: true,
            max_family_fits: 80,
            greedy: true,
            span_checks: true,
            span_breaks: SpanBreaks::Auto,
        }
    }
}

/// Where the bulk families put their span breaks: they start with one span a section and
/// remove and merge breaks among these places only.
///
/// Which stores fewer scalars depends on the blade (`docs/GUIDE.md`, "Where the span
/// breaks go"): at 1e-3 of the chord, 160 points a section, [`SpanBreaks::Sections`] took the
/// IEA 10 MW from 851 stored scalars to 624 and met the BAR USC, but took the IEA 15 MW from
/// 608 to 1,329; [`SpanBreaks::ByDegree`] kept the IEA 15 MW's 608 and met the BAR USC too,
/// but took the NREL 5 MW from 466 to 491 and from 19 to 28 s (a third search).
/// [`SpanBreaks::Auto`] takes the IEA 10 MW to 624, meets the BAR USC (862) and keeps the
/// other blades' midway results.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpanBreaks {
    /// Midway; but in a blade definition's searches after the first (the first only finds
    /// where the surface leaves the definition between its stations), a trailing-edge family
    /// of odd span degree whose growth finds nothing left to split there grows again with its
    /// breaks at the sections, as [`SpanBreaks::ByDegree`] would put them. Not in a first
    /// search or a bare cloud's: every search so took the IEA 10 MW from 13.1 to 21.5 s, the
    /// later ones alone to 17.5 s, both to 624 stored scalars.
    #[default]
    Auto,
    /// Half-way between every two neighbouring sections: each span holds one section, on the
    /// middle row of the checker's 7 × 7 seeds a patch.
    Midway,
    /// At the sections (a lofted blade is only C1 at its stations): a span between two
    /// neighbouring sections, which lie on its first and last rows of seeds.
    Sections,
    /// At the sections for an odd span degree, half-way between them for an even one: where
    /// de Boor puts the knots of an interpolating spline (at the data for odd degrees, between
    /// them for even ones).
    ByDegree,
}

/// When the search uses the chord rule (`adaptive::blade`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChordRule {
    /// Never: every design point stores its coordinates.
    Off,
    /// Wherever it applies: only chord-rule families are searched.
    On,
    /// The chord-rule families first; when none meets the tolerance, the families without it
    /// too, and the fewest stored scalars of all that meet it win (or the closest layout).
    #[default]
    Auto,
}

impl SpanBreaks {
    /// The placement of a first search or a bare cloud's: [`SpanBreaks::Auto`]'s midway.
    #[must_use]
    pub(crate) fn first_search(self) -> SpanBreaks {
        match self {
            SpanBreaks::Auto => SpanBreaks::Midway,
            other => other,
        }
    }
}

keywords!(ChordRule, "chord rule", { Auto => "auto", On => "on", Off => "off" });
keywords!(SpanBreaks, "span-break placement", {
    Auto => "auto",
    Midway => "midway",
    Sections => "sections",
    ByDegree => "by-degree" | "by_degree",
});

/// The span rule: coordinate `axis` of design column `j` is `ends[0] + g_j (ends[1] - ends[0])`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpanRule {
    /// The coordinate axis (0 x, 1 y, 2 z) the sections are planes of.
    pub axis: usize,
    /// The span coordinate of the first and of the last section.
    pub ends: [f64; 2],
}

/// One family of the outer search and how far it got.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceFamilyTrace {
    /// The family: degrees, continuity, breaks.
    pub family: String,
    /// Layouts fitted.
    pub fits: usize,
    /// Stored scalars of its best layout meeting the tolerance, if any.
    pub best_scalars: Option<usize>,
    /// Its lowest measure (max or rms of the fit's offsets).
    pub best_measure: f64,
    /// How it ended.
    pub outcome: String,
    /// Wall-clock seconds of its search (families run in parallel, so these add up to more
    /// than the search's own seconds).
    #[serde(default)]
    pub seconds: f64,
}

/// A family of [`adapt_surface_with`]'s search has ended (called from the search's threads).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceProgress<'a> {
    /// The pass: `"chord rule"` or `"plain"` (`ChordRule::Auto` runs the second when the
    /// first meets nothing).
    pub pass: &'static str,
    /// Families of the pass ended, this one included.
    pub done: usize,
    /// Families of the pass.
    pub total: usize,
    /// How the family ended.
    pub family: &'a SurfaceFamilyTrace,
}

/// The offsets at a blade definition's sections joined between its stations
/// ([`Lofted::joined`]), which are held to [`BETWEEN_FACTOR`] tolerances as the surface is
/// between the stations, and at the stations themselves, held to the tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct JoinedSections {
    /// Sections joined.
    pub sections: usize,
    /// Their points' largest true closest-point offset, model units.
    pub max: f64,
    /// The span coordinate of the section holding it (the v parameter without the span
    /// rule).
    pub span: f64,
    /// The largest at the stations, model units.
    pub stations_max: f64,
}

/// The offsets found by the shared checker's search ([`sampled_offsets`]), model units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckedOffsets {
    /// The largest.
    pub max: f64,
    /// Their root mean square.
    pub rms: f64,
}

/// The result of [`adapt_surface`].
#[derive(Clone, Debug, PartialEq)]
pub struct AdaptedSurface {
    /// The stored numbers.
    pub encoding: SurfaceEncoding,
    /// Their count.
    pub count: SurfaceCount,
    /// The grid regenerated from them.
    pub grid: PatchGrid<DVec3>,
    /// True closest-point offsets of every point, re-measured in f64.
    pub offset: OffsetStats<DVec3>,
    /// The offsets the shared checker's sampled search finds ([`sampled_offsets`]).
    pub checked: CheckedOffsets,
    /// The held-out check.
    pub held_out: Option<HeldOut>,
    /// The fold check of the grid ([`fold_check`], [`FOLD_SAMPLES`] samples a patch).
    pub fold: FoldCheck,
    /// The check of the sections' ends ([`SectionEnds`]; `None` where the sections are not
    /// planes of one axis): reported, not part of `met`.
    pub ends: Option<SectionEnds>,
    /// The fairness of the surface's cuts at the mid-stations ([`SpanFairness`]; `None`
    /// where the sections are not planes of one axis).
    pub fairness: Option<SpanFairness>,
    /// The surface between the data's sections ([`BetweenSections`]): against a blade
    /// definition's lofted mid-stations, or left-one-section-out on a bare cloud (with
    /// [`SurfaceAdaptOptions::held_out`]).
    pub between: Option<BetweenSections>,
    /// The data's own scatter, where its sections are long enough to estimate it.
    pub scatter: Option<DataScatter>,
    /// The checker's max over the true closest-point max: the projection check agrees with
    /// the exact offsets within 10 % when it is at most 1.1.
    pub agreement: f64,
    /// A blade definition's sections joined between its stations ([`Lofted::joined`]), when
    /// any: their offsets and the stations'.
    pub joined: Option<JoinedSections>,
    /// True when the tolerance holds at the data's sections (at a blade definition's joined
    /// sections, [`BETWEEN_FACTOR`] tolerances), by the true closest-point offsets and by
    /// the checker's (the mid-stations aside).
    pub at_sections: bool,
    /// The span coordinates of the mid-stations where the surface fails the checks between
    /// the sections (`span`'s fairness, or a blade definition's lofted section there more
    /// than [`BETWEEN_FACTOR`] tolerances away); empty when it passes.
    pub faults: Vec<f64>,
    /// True when the tolerance holds (at a blade definition's joined sections,
    /// [`BETWEEN_FACTOR`] tolerances), by the true closest-point offsets and by the checker's,
    /// the mid-stations' cuts are fair, against a blade definition the surface is within
    /// [`BETWEEN_FACTOR`] tolerances of it between the sections, and (with
    /// [`SurfaceAdaptOptions::held_out`]) the held-out check is within [`HELD_OUT_FACTOR`]
    /// tolerances.
    pub met: bool,
    /// Why not, when it does not.
    pub message: Option<String>,
    /// The winning family.
    pub family: String,
    /// Every family of the search.
    pub trace: Vec<SurfaceFamilyTrace>,
    /// True when a greedy family ([`SurfaceAdaptOptions::greedy`]) met the tolerance.
    pub greedy_met: bool,
    /// Fits run.
    pub fits: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Find the patch grid with the fewest stored scalars whose closest-point offsets from the
/// sectioned cloud `points` (section-major, `grid` its shape) meet `opts.tol` under
/// `opts.norm`. When none does, the result holds the closest layout found, `met` false and a
/// message.
pub fn adapt_surface(points: &[DVec3], grid: Grid, opts: &SurfaceAdaptOptions) -> Result<AdaptedSurface> {
    adapt_surface_with(points, grid, None, opts, &|_| {})
}

/// A blade definition's part in the search of sections lofted from it ([`adapt_blade`]).
#[derive(Clone, Copy, Debug)]
pub struct Lofted<'a> {
    /// Sections lofted from the definition half-way between every two of the data's
    /// ([`crate::geometry::Blade::loft_at`]): the surface must lie within
    /// [`BETWEEN_FACTOR`] tolerances of them.
    pub between: &'a Cloud,
    /// The data's sections (0-based, in data order) lofted between the definition's stations
    /// rather than at them: held, as between the stations, to [`BETWEEN_FACTOR`] tolerances.
    pub joined: &'a [usize],
}

/// [`adapt_surface`], checked against a blade definition (`lofted`) when given, calling
/// `progress` as each family of the search ends.
pub fn adapt_surface_with(
    points: &[DVec3],
    grid: Grid,
    lofted: Option<Lofted<'_>>,
    opts: &SurfaceAdaptOptions,
    progress: &(dyn Fn(&SurfaceProgress<'_>) + Sync),
) -> Result<AdaptedSurface> {
    let start = Instant::now();
    // A bare cloud's one search is a first search ([`SpanBreaks::Auto`]).
    let bare = SurfaceAdaptOptions {
        span_breaks: opts.span_breaks.first_search(),
        ..*opts
    };
    let opts = if lofted.is_none() { &bare } else { opts };
    if !(opts.tol > 0.0) || !opts.tol.is_finite() {
        return Err(Error::invalid(format!(
            "adapt-surface: tolerance {} must be positive",
            opts.tol
        )));
    }
    let [u_lo, u_hi] = opts.degrees_u;
    let [v_lo, v_hi] = opts.degrees_v;
    if !(2..=u_hi).contains(&u_lo)
        || u_hi > super::MAX_DEGREE
        || !(2..=v_hi).contains(&v_lo)
        || v_hi > super::MAX_DEGREE
    {
        return Err(Error::invalid(format!(
            "adapt-surface: degrees {u_lo}-{u_hi} x {v_lo}-{v_hi} must lie in 2 ..= {}",
            super::MAX_DEGREE
        )));
    }
    let limit_scalars = opts.max_scalars.unwrap_or(usize::MAX).min(3 * points.len() - 1);
    let chord = opts.chord_rule != ChordRule::Off;
    let data_of = |chord: bool| -> Result<Data<'_>> {
        let data = Data::new(points, grid, opts.span_rule, chord)?;
        match lofted {
            None => Ok(data),
            Some(l) => {
                let per = l.between.grid.map_or(0, |g| g.per_section);
                data.with_between(&l.between.points, per)
                    .ok_or_else(|| {
                        Error::invalid(
                            "adapt-surface: the sections between the data's must be planes of the \
                             data sections' span axis, within their span",
                        )
                    })?
                    .with_joined(l.joined)
                    .ok_or_else(|| Error::invalid("adapt-surface: a joined section is not one of the data's"))
            }
        }
    };
    let mut data = data_of(chord)?;
    let (mut results, mut fits) = run_families(&data, opts, limit_scalars, progress)?;
    let mut trace: Vec<SurfaceFamilyTrace> = results.iter().map(|r| r.3.clone()).collect();
    let greedy_of = |r: &[FamilyResult]| r.iter().any(|r| !r.0.bulk() && r.1.is_some());
    let mut greedy_met = greedy_of(&results);
    let none_met = |r: &[FamilyResult]| r.iter().all(|r| r.1.is_none());
    if data.blade.is_some() && opts.chord_rule == ChordRule::Auto && none_met(&results) {
        let plain = data_of(false)?;
        // For a blade definition the plain pass, which runs after a chord-rule pass that met
        // nothing (its greedy families included), searches its bulk families alone. Where it
        // ran (the IEA 3.4 MW's AeroDyn, windIO v1 and v2 files, the BAR URC and USC at 1e-3)
        // no plain greedy family met the tolerance either, and they took two fifths of its
        // time. A bare cloud keeps them: on the paper blade's cloud at 24 points a section only
        // a plain greedy family meets 2e-3 of the chord at the sections.
        let plain_opts = SurfaceAdaptOptions {
            greedy: opts.greedy && lofted.is_none(),
            ..*opts
        };
        let (more, f) = run_families(&plain, &plain_opts, limit_scalars, progress)?;
        fits += f;
        trace.extend(more.iter().map(|r| r.3.clone()));
        greedy_met |= greedy_of(&more);
        let closest = |r: &[FamilyResult]| {
            r.iter()
                .filter_map(|r| r.2.as_ref().map(|c| c.fit.measure))
                .fold(f64::INFINITY, f64::min)
        };
        if !none_met(&more) || closest(&more) < closest(&results) {
            data = plain;
            results = more;
        }
    }
    let best = results
        .iter()
        .filter_map(|(f, w, _, _)| w.as_ref().map(|w| (f, w)))
        .min_by(|a, b| better(a.1, b.1));
    let (fam, cand, met) = match best {
        Some((f, w)) => (*f, w.clone(), true),
        None => {
            let (f, c) = results
                .iter()
                .filter_map(|(f, _, c, _)| c.as_ref().map(|c| (f, c)))
                .min_by(|a, b| a.1.fit.measure.total_cmp(&b.1.fit.measure))
                .ok_or_else(|| Error::invalid("adapt-surface: no layout could be fitted"))?;
            (*f, c.clone(), false)
        }
    };
    let encoding = encode(&data, &fam, &cand);
    let count = encoding.count();
    debug_assert_eq!(
        count.total, cand.scalars,
        "the encoding counts what the search counted"
    );
    let grid_fit = encoding.grid()?;
    let checked = sampled_offsets(&grid_fit, points);
    // The fit's own foot points `(u_p, v_k)`, on the regenerated grid.
    let own: Vec<f64> = (0..points.len())
        .map(|p| (grid_fit.eval(cand.fit.u[p], data.v[p / data.per]) - points[p]).length())
        .collect();
    let d2 = closest_dist_sq(&grid_fit, points, &checked, Some(&own))?;
    let offset = OffsetStats::from_dist_sq(Metric::Closest, &d2, points);
    // Each point's offset against its own share of the tolerance (joined sections are held
    // to [`BETWEEN_FACTOR`] of it), as the search measured it.
    let scale = data.scale_of(0..points.len());
    let scaled = |e: &[f64]| -> Vec<f64> {
        let mut e = e.to_vec();
        if let Some(s) = &scale {
            scale_by(&mut e, s);
        }
        e
    };
    let exact: Vec<f64> = d2.iter().map(|d| d.sqrt()).collect();
    let joined = (data.joined() > 0).then(|| {
        let (mut at, mut max, mut stations_max) = (0, 0.0_f64, 0.0_f64);
        for (p, &e) in exact.iter().enumerate() {
            if data.slack_at(p) == 1.0 {
                stations_max = stations_max.max(e);
            } else if e >= max {
                (at, max) = (p / data.per, e);
            }
        }
        JoinedSections {
            sections: data.joined(),
            max,
            span: span::span_at(&data, data.v[at]),
            stations_max,
        }
    });
    let measure = norm_of(&scaled(&exact), opts.norm);
    let checked_measure = norm_of(&scaled(&checked), opts.norm);
    let checked = CheckedOffsets {
        max: norm_of(&checked, Norm::Max),
        rms: norm_of(&checked, Norm::Rms),
    };
    let fold = fold_check(&grid_fit, FOLD_SAMPLES);
    let agreement = if offset.max > 0.0 {
        checked.max / offset.max
    } else {
        1.0
    };
    let span_check = span::check(&data, &grid_fit, opts.tol);
    let fairness = span_check.fairness;
    let fair = fairness.as_ref().is_none_or(|f| f.passes);
    let lofted = span_check
        .between
        .as_ref()
        .is_none_or(|b| b.max <= BETWEEN_FACTOR * opts.tol);
    // A bare cloud has no sections between its own: the leave-one-section-out check instead.
    let between = span_check.between.or_else(|| {
        opts.held_out
            .then(|| leave_one_out_check(&data, &fam, &cand, opts))
            .flatten()
    });
    let at_sections = met && measure <= opts.tol && checked_measure <= opts.tol;
    let faults: Vec<f64> = span_check
        .faults
        .iter()
        .map(|&v| span::span_at(&data, v))
        .collect();
    // Refitted on every other point of each section, the others within
    // [`HELD_OUT_FACTOR`] tolerances, as a chain's are.
    let held_out = if opts.held_out {
        held_out_check(&data, &fam, &cand, opts)
    } else {
        None
    };
    let held_measure = held_out.map(|h| h.measure(opts.norm));
    let held_ok = HeldOut::passes(held_out.as_ref(), opts.held_out, opts.norm, opts.tol);
    // Reported, not part of `met` (see `ends`).
    let ends = ends::check(&data, &grid_fit, opts.tol);
    let met = at_sections && fair && lofted && held_ok;
    let scatter = DataScatter::of(points, grid, opts.tol);
    // Said with every message when the tolerance is below the data's own scatter.
    let noisy = scatter
        .as_ref()
        .filter(|s| s.above_tolerance)
        .map_or(String::new(), |s| {
            format!(
                "; the data scatter by about {:.2e} ({:.1e} of the chord, section {}): a tolerance below \
             {SCATTER_FACTOR} times that fits their noise",
                s.sigma, s.relative, s.section
            )
        });
    // Why the held-out check fails, when it does.
    let held_why = (!held_ok).then(|| match held_measure {
        Some(m) => format!(
            "refitted on every other point of each section, the others are {} {m:.3e} away, {:.2} \
             tolerances (at most {HELD_OUT_FACTOR})",
            opts.norm,
            m / opts.tol
        ),
        None => "the held-out check is not possible: every other point of each section does not \
                 determine the layout"
            .to_string(),
    });
    let message = (!met).then(|| {
        if at_sections && fair && lofted {
            return format!(
                "tolerance {:e} met at every point but not held out: {}{noisy}",
                opts.tol,
                held_why.as_deref().unwrap_or_default()
            );
        }
        if at_sections {
            let mut why = Vec::new();
            if let Some(f) = fairness.as_ref().filter(|f| !f.passes) {
                why.push(format!(
                    "its cut at span {:.4} has its {} {:.2} times the allowance from its neighbours",
                    f.span, f.measure, f.worst
                ));
            }
            if let Some(b) = between.as_ref().filter(|_| !lofted) {
                why.push(format!(
                    "it is {:.3e} from the blade definition between the sections (span {:.4}), over \
                     {BETWEEN_FACTOR} times the tolerance",
                    b.max, b.span
                ));
            }
            let held = held_why
                .as_ref()
                .map_or(String::new(), |h| format!("; nor held out: {h}"));
            return format!(
                "tolerance {:e} met at the sections but not between them: {}{held}{noisy}",
                opts.tol,
                why.join("; ")
            );
        }
        format!(
            "tolerance {:e} ({}) not met: no family met it within the data's limits (at most half a \
             section's points around, one design column per section along the span, fewer stored \
             scalars than the data's numbers{}{}); the closest layout found ({}) has {} {:.3e} ({:.3e} by the \
             checker's search) with {} stored scalars{noisy}",
            opts.tol,
            opts.norm,
            opts.max_scalars
                .map_or(String::new(), |m| format!(", at most {m}")),
            if opts.span_checks {
                ", fair and, for a blade definition, within 3 tolerances of it between the sections"
            } else {
                ""
            },
            fam.name(),
            opts.norm,
            measure,
            checked_measure,
            count.total
        )
    });
    Ok(AdaptedSurface {
        encoding,
        count,
        grid: grid_fit,
        offset,
        checked,
        held_out,
        fold,
        ends,
        fairness,
        between,
        scatter,
        agreement,
        joined,
        at_sections,
        faults,
        met,
        message,
        family: fam.name(),
        trace,
        greedy_met,
        fits,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The order of two met layouts: the fewer stored scalars first, then the smaller measure.
fn better(a: &Cand, b: &Cand) -> std::cmp::Ordering {
    a.scalars
        .cmp(&b.scalars)
        .then(a.fit.measure.total_cmp(&b.fit.measure))
}

/// One family's result: its winner, its closest layout, its trace.
type FamilyResult = (Family, Option<Cand>, Option<Cand>, SurfaceFamilyTrace);

/// Every family of the search on `data`, in parallel and spread over the ranks of the run
/// ([`team::share_records`]: a family's search depends on nothing but the family and the
/// bound, so every rank gets the same results as one process alone), and the fits run;
/// `progress` is told of each family as it ends (of the other ranks' families, once their
/// results arrive).
fn run_families(
    data: &Data<'_>,
    opts: &SurfaceAdaptOptions,
    limit_scalars: usize,
    progress: &(dyn Fn(&SurfaceProgress<'_>) + Sync),
) -> Result<(Vec<FamilyResult>, usize)> {
    let pass = if data.blade.is_some() {
        "chord rule"
    } else {
        "plain"
    };
    let search = Search {
        data,
        opts,
        limit_u: data.per / 2,
        limit_scalars,
        loose: false,
    };
    let [u_lo, u_hi] = opts.degrees_u;
    let [v_lo, v_hi] = opts.degrees_v;
    let mut families = Vec::new();
    // [`SpanBreaks::Auto`]'s families start midway ([`Search::run`] may move a bulk one's).
    let sites = opts.span_breaks.first_search();
    // `adapt_surface` checked 2 <= u_lo <= u_hi: degree 2 is also the least the chord rule's
    // parabola needs around (`blade::MIN_DEGREE`).
    for du in u_lo..=u_hi {
        for dv in v_lo..=v_hi.min(data.sections - 1).max(v_lo) {
            // Under the chord rule only the smoothest joins at data-driven breaks: on the
            // paper's blade the C1 and equal-break families never won there.
            let mut ous = if data.blade.is_some() {
                vec![du - 1]
            } else {
                vec![du - 1, 1]
            };
            ous.dedup();
            let splits: &[bool] = if data.blade.is_some() {
                &[true]
            } else {
                &[true, false]
            };
            for ou in ous.into_iter().filter(|_| opts.greedy) {
                for &split in splits {
                    families.push(Family {
                        du,
                        dv,
                        ou,
                        ov: dv - 1,
                        split,
                        growth: Growth::Greedy,
                        sites,
                    });
                }
            }
            // The bulk families: under the chord rule the trailing-edge families, from the
            // degree that carries the term (round and blunt root sections, bulging ends);
            // without it every degree. On the IEA 3.4 MW cloud at 1e-3 the plain bulk d4x2
            // meets the tolerance with 1,194 stored scalars where no greedy plain family meets
            // it (their closest layouts overhung, the checker's max 13.6 times the fit's own).
            let te = data.u0_te.is_some() && du >= TE_DEGREE;
            if te || data.blade.is_none() {
                families.push(Family {
                    du,
                    dv,
                    ou: du - 1,
                    ov: dv - 1,
                    split: true,
                    growth: if te { Growth::TrailingEdge } else { Growth::Bulk },
                    sites,
                });
            }
        }
    }
    // The bulk families first: the others then stop growing at the fewest stored
    // scalars those met the tolerance with (as the curve search prunes by the batches before,
    // with a bound fixed while a batch runs, so the result does not depend on thread timing).
    // On the IEA 15 MW at 1e-3 the greedy chord-rule families spent 80 fits each beyond the
    // trailing-edge families' count (448 then) without meeting it.
    // Each result with its family's place in `families`, which orders the trace.
    let done = AtomicUsize::new(0);
    let tell = |t: &SurfaceFamilyTrace| {
        progress(&SurfaceProgress {
            pass,
            done: done.fetch_add(1, Ordering::Relaxed) + 1,
            total: families.len(),
            family: t,
        });
    };
    let run = |bulk: bool, bound: usize| -> Result<Vec<(usize, FamilyResult, Option<Cand>)>> {
        let mut picked: Vec<u64> = (0..families.len())
            .filter(|&k| families[k].bulk() == bulk)
            .map(|k| k as u64)
            .collect();
        // The rows of `picked` this rank searches.
        let mut here = 0..0;
        let searched = team::share_records(picked.len(), &mut picked, |rows, picked| {
            here = rows.clone();
            Ok(picked[rows]
                .par_iter()
                .map(|&k| {
                    let started = Instant::now();
                    let mut r = search.run(families[k as usize], bound);
                    r.2.seconds = started.elapsed().as_secs_f64();
                    tell(&r.2);
                    r
                })
                .collect())
        })?;
        Ok(picked
            .iter()
            .zip(searched)
            .enumerate()
            .map(|(row, (&k, Searched(w, c, t, g, sites)))| {
                if !here.contains(&row) {
                    tell(&t);
                }
                let k = k as usize;
                (k, (Family { sites, ..families[k] }, w, c, t), g)
            })
            .collect())
    };
    let mut results = run(true, usize::MAX)?;
    let bound = results
        .iter()
        .filter_map(|(_, r, _)| r.1.as_ref().map(|w| w.scalars))
        .min()
        .unwrap_or(usize::MAX);
    results.extend(run(false, bound)?);
    results.sort_by_key(|(k, _, _)| *k);
    // The winner, when a trailing-edge family's: its grown layout swept again with the span
    // breaks first, kept when that stores fewer scalars. Which order leaves fewer depends on
    // the blade: at 1e-3 the NREL 5 MW went from 532 to 514 and the IEA 10 MW from 1,176 to
    // 883, but the IEA 15 MW kept 861 (1,036 the other way). Sweeping every met family both
    // ways took the NREL 5 MW from 11 to 18 s; the winner alone costs one more sweep. The
    // plain bulk winners measured never gained (the IEA 3.4 MW AeroDyn blade 1,488 against
    // 1,390; its windIO v2 file and the BAR URC the same either way) and the IEA 3.4 MW's two
    // searches took 1.8 s longer, so they are swept once.
    let winner = results
        .iter()
        .enumerate()
        .filter_map(|(i, (_, r, _))| r.1.as_ref().map(|w| (i, w)))
        .min_by(|a, b| better(a.1, b.1))
        .map(|(i, _)| i);
    if let Some(i) = winner {
        let (_, (fam, w, _, trace), grown) = &mut results[i];
        if let (true, Some(g), Some(w)) = (fam.te(), grown.take(), w.as_mut()) {
            let started = Instant::now();
            let mut n = 0;
            let c = search.sweep_bulk(fam, g, &mut n, SweepOrder::VFirst);
            trace.fits += n;
            trace.seconds += started.elapsed().as_secs_f64();
            if c.scalars < w.scalars {
                trace.outcome = "met (span breaks removed first)".into();
                trace.best_scalars = Some(c.scalars);
                *w = c;
            }
        }
        // Every bulk winner is then polished ([`Search::polish`]).
        let (_, (fam, w, _, trace), _) = &mut results[i];
        if let (true, Some(w)) = (fam.bulk(), w.as_mut()) {
            let started = Instant::now();
            let mut n = 0;
            let c = search.polish(fam, w.clone(), &mut n);
            trace.fits += n;
            trace.seconds += started.elapsed().as_secs_f64();
            if c.scalars < w.scalars {
                trace.outcome = format!("{} and polished", trace.outcome);
                trace.best_scalars = Some(c.scalars);
                *w = c;
            }
        }
    }
    let fits = results.iter().map(|(_, r, _)| r.3.fits).sum();
    Ok((results.into_iter().map(|(_, r, _)| r).collect(), fits))
}

/// Refit the winner's layout on every other point of each section (both ends kept) and
/// measure the others' true closest-point offsets.
fn held_out_check(data: &Data<'_>, fam: &Family, c: &Cand, opts: &SurfaceAdaptOptions) -> Option<HeldOut> {
    let per = data.per;
    let (fitted, stats) = refit_without(data, fam, c, opts, &|p| {
        let i = p % per;
        i.is_multiple_of(2) || i == per - 1
    })?;
    Some(HeldOut {
        fitted,
        measured: stats.points,
        max: stats.max,
        rms: stats.rms,
    })
}

/// Refit the winner's layout without each interior section in turn and measure that
/// section's true closest-point offsets ([`span::leave_one_out`]).
fn leave_one_out_check(
    data: &Data<'_>,
    fam: &Family,
    c: &Cand,
    opts: &SurfaceAdaptOptions,
) -> Option<BetweenSections> {
    let per = data.per;
    span::leave_one_out(data, &|k| {
        refit_without(data, fam, c, opts, &|p| p / per != k).map(|r| r.1)
    })
}

/// Refit the winner's layout on the points `keep` says to and measure the others' true
/// closest-point offsets: the points fitted, and the others' offsets.
fn refit_without(
    data: &Data<'_>,
    fam: &Family,
    c: &Cand,
    opts: &SurfaceAdaptOptions,
    keep: &(dyn Fn(usize) -> bool + Sync),
) -> Option<(usize, OffsetStats<DVec3>)> {
    let lu = fam.layout(fam.du, fam.ou, &c.bu)?;
    let lv = fam.layout(fam.dv, fam.ov, &c.bv)?;
    let per = data.per;
    let (kept, rest): (Vec<usize>, Vec<usize>) = (0..data.points.len()).partition(|&p| keep(p));
    if rest.is_empty() {
        return None;
    }
    let points: Vec<DVec3> = kept.iter().map(|&p| data.points[p]).collect();
    let v = data.point_v();
    let ends: Vec<(usize, f64)> = (0..kept.len())
        .filter_map(|q| match kept[q] % per {
            0 => Some((q, 0.0)),
            i if i == per - 1 => Some((q, 1.0)),
            _ => None,
        })
        .collect();
    let mut f = Fitter::new(
        data,
        lu,
        lv,
        &points,
        kept.iter().map(|&p| v[p]).collect(),
        None,
        fam.bulk().then_some(&ends[..]),
    )?;
    let u0: Vec<f64> = kept.iter().map(|&p| data.u0(fam.te())[p]).collect();
    let fit = f.fit(&u0, opts)?;
    let enc = SurfaceEncoding {
        coords: store(data, fam, &c.bu, &c.bv, &fit.design)?,
        ..encode(data, fam, c)
    };
    let grid = enc.grid().ok()?;
    let rest: Vec<DVec3> = rest.iter().map(|&p| data.points[p]).collect();
    let checked = sampled_offsets(&grid, &rest);
    let d2 = closest_dist_sq(&grid, &rest, &checked, None).ok()?;
    let stats = OffsetStats::from_dist_sq(Metric::Closest, &d2, &rest);
    Some((kept.len(), stats))
}

#[cfg(test)]
mod tests {
    use super::fitter::span_maxima;
    use super::*;
    use crate::adaptive::Breaks;

    #[test]
    fn joined_sections_are_held_to_the_between_factor() {
        // Three circles of 8 points in the planes z = 0, 1, 2.
        let points: Vec<DVec3> = (0..3)
            .flat_map(|k| {
                (0..8).map(move |i| {
                    let a = std::f64::consts::TAU * i as f64 / 8.0;
                    DVec3::new(a.cos(), a.sin(), k as f64)
                })
            })
            .collect();
        let grid = Grid {
            sections: 3,
            per_section: 8,
        };
        let data = Data::new(&points, grid, true, false).unwrap();
        assert_eq!(data.slack, vec![1.0; 3]);
        assert!(
            data.scale_of(0..24).is_none(),
            "every point held to the tolerance"
        );
        let data = data.with_joined(&[1]).unwrap();
        assert_eq!(data.slack, vec![1.0, BETWEEN_FACTOR, 1.0]);
        let scale = data.scale_of([0, 7, 8, 15, 16].into_iter()).unwrap();
        assert_eq!(
            scale,
            vec![1.0, 1.0, 1.0 / BETWEEN_FACTOR, 1.0 / BETWEEN_FACTOR, 1.0]
        );
        assert!(data.with_joined(&[3]).is_none(), "no section 3");
    }

    #[test]
    fn auto_span_breaks_are_midway_in_a_first_search_and_named_where_they_move() {
        assert_eq!(SpanBreaks::default(), SpanBreaks::Auto);
        assert_eq!("auto".parse::<SpanBreaks>().unwrap(), SpanBreaks::Auto);
        assert_eq!(SpanBreaks::Auto.first_search(), SpanBreaks::Midway);
        for other in [SpanBreaks::Midway, SpanBreaks::Sections, SpanBreaks::ByDegree] {
            assert_eq!(other.first_search(), other);
        }
        // A bulk family whose breaks went to the sections says so; a greedy one has none.
        let fam = Family {
            du: 5,
            dv: 3,
            ou: 4,
            ov: 2,
            split: true,
            growth: Growth::TrailingEdge,
            sites: SpanBreaks::Midway,
        };
        assert_eq!(fam.name(), "d5x3 C4xC2 split trailing-edge");
        let at = Family {
            sites: SpanBreaks::Sections,
            ..fam
        };
        assert_eq!(
            at.name(),
            "d5x3 C4xC2 split trailing-edge, span breaks at the sections"
        );
        let greedy = Family {
            growth: Growth::Greedy,
            ..at
        };
        assert_eq!(greedy.name(), "d5x3 C4xC2 split");
    }

    #[test]
    fn span_breaks_go_midway_at_the_sections_or_by_the_span_degree() {
        // Four circles in the planes z = 0, 1, 3, 4: v = 0, 1/4, 3/4, 1.
        let points: Vec<DVec3> = [0.0, 1.0, 3.0, 4.0]
            .into_iter()
            .flat_map(|z| {
                (0..8).map(move |i| {
                    let a = std::f64::consts::TAU * i as f64 / 8.0;
                    DVec3::new(a.cos(), a.sin(), z)
                })
            })
            .collect();
        let grid = Grid {
            sections: 4,
            per_section: 8,
        };
        let data = Data::new(&points, grid, true, false).unwrap();
        let midway = vec![0.125, 0.5, 0.875];
        let sections = vec![0.25, 0.75];
        for dv in [2, 3] {
            assert_eq!(data.break_sites(dv, SpanBreaks::Midway), midway);
            assert_eq!(data.break_sites(dv, SpanBreaks::Sections), sections);
        }
        assert_eq!(data.break_sites(2, SpanBreaks::ByDegree), midway);
        assert_eq!(data.break_sites(3, SpanBreaks::ByDegree), sections);
    }

    #[test]
    fn span_maxima_take_each_spans_largest_offset() {
        let b = [0.0, 0.25, 0.5, 1.0];
        let pts = [
            (0.0, 1.0),
            (0.1, 3.0),
            (0.25, 2.0),
            (0.4, 0.5),
            (0.9, 4.0),
            (1.0, 5.0),
        ];
        assert_eq!(span_maxima(&b, pts.into_iter()), vec![3.0, 2.0, 5.0]);
        assert_eq!(
            span_maxima(&[0.0, 0.5, 1.0], [(0.7, 1.0)].into_iter()),
            vec![0.0, 1.0]
        );
    }

    #[test]
    fn the_span_rule_makes_the_span_coordinate_linear_in_v() {
        let enc = SurfaceEncoding {
            degree: [3, 2],
            joins_u: vec![2],
            joins_v: vec![1, 1],
            breaks_u: Breaks::Uniform { segments: 2 },
            breaks_v: Breaks::Stored(vec![0.3, 0.8]),
            span_rule: Some(SpanRule {
                axis: 2,
                ends: [0.5, 2.0],
            }),
            chord_rule: false,
            te_term: false,
            coords: (0..5 * 5 * 2).map(|k| (k as f64 * 0.37).sin()).collect(),
        };
        assert_eq!(enc.count().total, 50 + 2 + 2);
        let grid = enc.grid().unwrap();
        for i in 0..=20 {
            for j in 0..=20 {
                let (u, v) = (i as f64 / 20.0, j as f64 / 20.0);
                let z = grid.eval(u, v).z;
                assert!((z - (0.5 + 1.5 * v)).abs() < 1e-12, "z({u}, {v}) = {z}");
            }
        }
    }

    #[test]
    fn the_c1_view_regenerates_the_spline_surface() {
        let enc = SurfaceEncoding {
            degree: [4, 3],
            joins_u: vec![3, 1],
            joins_v: vec![2],
            breaks_u: Breaks::Stored(vec![0.25, 0.6]),
            breaks_v: Breaks::Uniform { segments: 2 },
            span_rule: None,
            chord_rule: false,
            te_term: false,
            coords: (0..9 * 5 * 3).map(|k| (k as f64 * 0.71).cos()).collect(),
        };
        let (lu, lv) = enc.layouts().unwrap();
        let design = enc.design().unwrap();
        let grid = enc.grid().unwrap();
        let nv = lv.design_count();
        for i in 0..=15 {
            for j in 0..=15 {
                let (u, v) = (i as f64 / 15.0, j as f64 / 15.0);
                let (bu, bv) = (lu.basis(u, 0), lv.basis(v, 0));
                let (fu, fv) = (bu.first, bv.first);
                let (bu, bv) = (bu.value, bv.value);
                let mut p = DVec3::ZERO;
                for a in 0..=4 {
                    for b in 0..=3 {
                        p += bu[a] * bv[b] * design[(fu + a) * nv + fv + b];
                    }
                }
                assert!((grid.eval(u, v) - p).length() < 1e-12);
            }
        }
    }
}
