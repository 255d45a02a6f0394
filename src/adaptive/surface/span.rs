//! Where a blade engineer looks between the sections: cuts of the surface at mid-stations.
//!
//! With the span rule every section of the surface at `v` lies in the plane of span coordinate
//! `s(v)`, so the cut at a mid-station (half-way in span between two neighbouring data
//! sections) is the iso-curve `S(·, v_mid)`. Two checks look at it, both part of meeting the
//! tolerance in the search ([`super::search::Search::met`]) and in the result's `met`:
//!
//! - **Fairness** (every surface): the cut's chord and maximum thickness
//!   ([`SectionShape`]) lie within the two neighbours' range widened by
//!   `FAIR_SHAPE · c + tol`, and its centroid within `FAIR_CENTROID · c + tol` of the
//!   mid-point of the neighbours' centroids (the straight line between them at the
//!   mid-station), `c` the mean of the neighbours' chords. A layout that overshoots between
//!   sections (a wave), folds or hooks fails it.
//! - **Between-section offsets** (a blade definition): sections lofted from the definition at
//!   the mid-stations ([`crate::geometry::Blade::loft_at`]) must lie within
//!   `BETWEEN_FACTOR · tol` of the cut. Each offset is the distance to a point of the cut
//!   (the nearest of its samples, then Gauss-Newton along `u`), so never below the true
//!   closest-point distance.
//!
//! A bare cloud has no truth between its sections: its result reports a leave-one-section-out
//! check instead ([`leave_one_out`]), not part of `met` (a section left out is a data gap the
//! search never had, so the check measures the data's spacing as much as the surface).

use super::data::{flat, Between, Data};
use crate::chain::PatchGrid;
use crate::geometry::SectionShape;
use crate::problem::OffsetStats;
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The chord and thickness slack at a mid-station, as a fraction of the local chord.
pub const FAIR_SHAPE: f64 = 0.02;
/// The centroid slack at a mid-station, as a fraction of the local chord.
pub const FAIR_CENTROID: f64 = 0.05;
/// Between the sections the surface may be this many tolerances from the blade definition.
pub const BETWEEN_FACTOR: f64 = 3.0;

/// The fairness of the surface's cuts at the mid-stations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpanFairness {
    /// Mid-stations cut.
    pub stations: usize,
    /// The largest ratio of a deviation to its allowance (chord or thickness outside the
    /// neighbours' range, centroid off their line): at most 1 passes.
    pub worst: f64,
    /// What the worst is: `chord`, `thickness` or `centroid`.
    pub measure: String,
    /// The span coordinate of its mid-station (model units; the v parameter without the span
    /// rule's planes, where nothing is cut).
    pub span: f64,
    /// True when every mid-station passes.
    pub passes: bool,
}

/// The surface's offsets from where the data has no points, between its sections.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BetweenSections {
    /// `loft` (sections lofted from the blade definition at the mid-stations) or
    /// `leave one section out` (the layout refitted without each interior section in turn,
    /// measured at it).
    pub method: String,
    /// Sections measured.
    pub sections: usize,
    /// Points measured.
    pub points: usize,
    /// The largest offset, model units.
    pub max: f64,
    /// Their root mean square.
    pub rms: f64,
    /// The span coordinate of the section with the largest.
    pub span: f64,
    /// Sections that could not be refitted without them (leave one out only).
    #[serde(default)]
    pub skipped: usize,
}

/// The tolerance below this many times the data's scatter fits its noise
/// ([`DataScatter`]): the largest of `n` independent normal errors is about 3 deviations.
pub const SCATTER_FACTOR: f64 = 3.0;

/// The data's own scatter ([`crate::geometry::section_scatter`]): the section that scatters
/// most.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DataScatter {
    /// Its estimated standard deviation normal to the section, model units.
    pub sigma: f64,
    /// As a fraction of that section's chord.
    pub relative: f64,
    /// The section (0-based, in data order).
    pub section: usize,
    /// True when the tolerance is below [`SCATTER_FACTOR`] times it: a surface within the
    /// tolerance of every point then follows the data's noise.
    pub above_tolerance: bool,
}

impl DataScatter {
    /// The most scattered section of the sectioned cloud `points` at tolerance `tol`.
    pub(super) fn of(points: &[DVec3], grid: crate::geometry::Grid, tol: f64) -> Option<DataScatter> {
        crate::geometry::section_scatter(points, grid)
            .iter()
            .enumerate()
            .filter_map(|(k, s)| Some((k, s.sigma?, s.relative()?)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(section, sigma, relative)| DataScatter {
                sigma,
                relative,
                section,
                above_tolerance: tol < SCATTER_FACTOR * sigma,
            })
    }
}

/// The cut `S(·, v)` sampled at `n` parameters uniform in u.
fn cut(grid: &PatchGrid<DVec3>, v: f64, n: usize) -> Vec<(f64, DVec3)> {
    (0..n)
        .map(|i| {
            let u = i as f64 / (n - 1) as f64;
            (u, grid.eval(u, v))
        })
        .collect()
}

/// The span coordinate at `v` (the v itself without the span rule).
pub(super) fn span_at(data: &Data<'_>, v: f64) -> f64 {
    data.span.map_or(v, |r| r.ends[0] + v * (r.ends[1] - r.ends[0]))
}

/// Every mid-station's fairness ratio (at most 1 passes), what it measures, and its `v`.
fn pair_scores(data: &Data<'_>, grid: &PatchGrid<DVec3>, tol: f64) -> Option<Vec<(f64, &'static str, f64)>> {
    let st = data.stations.as_ref()?;
    let axes = [data.axes[0], data.axes[1]];
    let scored = st
        .pairs
        .par_iter()
        .map(|&(a, b, v)| {
            let pts: Vec<DVec3> = cut(grid, v, st.samples).into_iter().map(|c| c.1).collect();
            let Some(m) = SectionShape::of(&flat(&pts, axes)) else {
                return (f64::INFINITY, "chord", v);
            };
            let (sa, sb) = (st.shapes[a], st.shapes[b]);
            let c = 0.5 * (sa.chord + sb.chord);
            let allow = FAIR_SHAPE * c + tol;
            let outside = |x: f64, p: f64, q: f64| (x - p.max(q)).max(p.min(q) - x).max(0.0) / allow;
            let centroid =
                (m.centroid - 0.5 * (sa.centroid + sb.centroid)).length() / (FAIR_CENTROID * c + tol);
            let all = [
                (outside(m.chord, sa.chord, sb.chord), "chord"),
                (outside(m.thickness, sa.thickness, sb.thickness), "thickness"),
                (centroid, "centroid"),
            ];
            let (x, what) = all
                .into_iter()
                .max_by(|p, q| p.0.total_cmp(&q.0))
                .unwrap_or((0.0, "chord"));
            (x, what, v)
        })
        .collect();
    Some(scored)
}

/// The distance from `p` to the cut `S(·, v)` sampled as `samples`: the nearest sample, then
/// Gauss-Newton along u; a distance to a point of the surface, never below the true one.
fn to_cut(grid: &PatchGrid<DVec3>, v: f64, samples: &[(f64, DVec3)], p: DVec3) -> f64 {
    let Some(&(mut u, q)) = samples
        .iter()
        .min_by(|a, b| (a.1 - p).length_squared().total_cmp(&(b.1 - p).length_squared()))
    else {
        return f64::INFINITY;
    };
    let mut best = (q - p).length();
    for _ in 0..6 {
        let (s, su, _) = grid.partials(u, v);
        let g = su.length_squared();
        if !(g > 0.0) {
            break;
        }
        u = (u - (s - p).dot(su) / g).clamp(0.0, 1.0);
        best = best.min((grid.eval(u, v) - p).length());
    }
    best
}

/// Every lofted section's largest offset from `grid`'s cut at its `v`, the sum of its
/// squared offsets, and its `v`.
fn between_scores(grid: &PatchGrid<DVec3>, between: &Between, samples: usize) -> Vec<(f64, f64, f64)> {
    let per = between.per;
    between
        .v
        .par_iter()
        .enumerate()
        .map(|(k, &v)| {
            let s = cut(grid, v, samples);
            let d: Vec<f64> = between.points[k * per..(k + 1) * per]
                .iter()
                .map(|&p| to_cut(grid, v, &s, p))
                .collect();
            let max = d.iter().fold(0.0_f64, |m, x| m.max(*x));
            (max, d.iter().map(|x| x * x).sum::<f64>(), v)
        })
        .collect()
}

/// [`between_scores`] of a blade definition's lofted mid-stations, when `data` has them.
fn between_of(data: &Data<'_>, grid: &PatchGrid<DVec3>) -> Option<Vec<(f64, f64, f64)>> {
    let between = data.between.as_ref()?;
    let samples = data.stations.as_ref().map_or(4 * between.per, |s| s.samples);
    Some(between_scores(grid, between, samples))
}

/// The mid-station checks of one grid, every cut made once.
pub(super) struct SpanCheck {
    /// The fairness of the cuts (`None` without the span rule).
    pub(super) fairness: Option<SpanFairness>,
    /// A blade definition's lofted mid-stations' offsets, when `data` has them.
    pub(super) between: Option<BetweenSections>,
    /// The `v` of every failing mid-station (the cut not fair, or a lofted section there more
    /// than [`BETWEEN_FACTOR`] tolerances away), in order; empty when the grid passes.
    pub(super) faults: Vec<f64>,
    /// The `v` of the worst failing mid-station (by its ratio to the allowance).
    pub(super) worst: Option<f64>,
}

/// The mid-station checks of `grid` on `data` at `tol`.
pub(super) fn check(data: &Data<'_>, grid: &PatchGrid<DVec3>, tol: f64) -> SpanCheck {
    let pairs = pair_scores(data, grid, tol);
    let between = between_of(data, grid);
    let fairness = data.stations.as_ref().zip(pairs.as_ref()).map(|(st, scored)| {
        let (worst, what, v) = scored
            .iter()
            .copied()
            .max_by(|p, q| p.0.total_cmp(&q.0))
            .unwrap_or((0.0, "chord", 0.0));
        SpanFairness {
            stations: st.pairs.len(),
            worst,
            measure: what.into(),
            span: span_at(data, v),
            passes: worst <= 1.0,
        }
    });
    // Every mid-station's ratio to its allowance (at most 1 passes), and its `v`.
    let ratios: Vec<(f64, f64)> = pairs
        .iter()
        .flatten()
        .map(|s| (s.0, s.2))
        .chain(
            between
                .iter()
                .flatten()
                .map(|s| (s.0 / BETWEEN_FACTOR / tol, s.2)),
        )
        .collect();
    let worst = ratios
        .iter()
        .filter(|s| !(s.0 <= 1.0))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|s| s.1);
    let mut faults: Vec<f64> = ratios.iter().filter(|s| !(s.0 <= 1.0)).map(|s| s.1).collect();
    faults.sort_by(f64::total_cmp);
    faults.dedup_by(|a, b| (*a - *b).abs() <= 1e-12);
    let between = between.map(|scores| {
        let (max, v) = scores
            .iter()
            .map(|s| (s.0, s.2))
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap_or((0.0, 0.0));
        let n = data.between.as_ref().map_or(0, |b| b.points.len());
        BetweenSections {
            method: "loft".into(),
            sections: scores.len(),
            points: n,
            max,
            rms: (scores.iter().map(|s| s.1).sum::<f64>() / n.max(1) as f64).sqrt(),
            span: span_at(data, v),
            skipped: 0,
        }
    });
    SpanCheck {
        fairness,
        between,
        faults,
        worst,
    }
}

/// The leave-one-section-out check of a bare cloud: for every interior section `k` (in span
/// order), `refit` fits the layout to the other sections and returns the offsets of section
/// `k`'s points (`None` when the layout cannot be fitted without it).
pub(super) fn leave_one_out(
    data: &Data<'_>,
    refit: &(dyn Fn(usize) -> Option<OffsetStats<DVec3>> + Sync),
) -> Option<BetweenSections> {
    let mut order: Vec<usize> = (0..data.sections).collect();
    order.sort_by(|&a, &b| data.v[a].total_cmp(&data.v[b]));
    let inner = order.get(1..order.len().saturating_sub(1))?;
    let results: Vec<(usize, Option<OffsetStats<DVec3>>)> =
        inner.par_iter().map(|&k| (k, refit(k))).collect();
    let measured: Vec<(usize, &OffsetStats<DVec3>)> = results
        .iter()
        .filter_map(|(k, d)| d.as_ref().map(|d| (*k, d)))
        .collect();
    let (k, worst) = measured.iter().max_by(|a, b| a.1.max.total_cmp(&b.1.max))?;
    let n: usize = measured.iter().map(|m| m.1.points).sum();
    let ss: f64 = measured.iter().map(|m| m.1.sum_sq).sum();
    Some(BetweenSections {
        method: "leave one section out".into(),
        sections: measured.len(),
        points: n,
        max: worst.max,
        rms: (ss / n.max(1) as f64).sqrt(),
        span: span_at(data, data.v[*k]),
        skipped: results.len() - measured.len(),
    })
}
