//! The sectioned cloud a surface search runs on: its points, sections, span parameters, the
//! blade's chord rule and trailing-edge data, and the held-out split.

use super::super::blade::{section_frame, section_params, SectionFrame};
use super::{SpanBreaks, SpanRule};
use crate::error::{Error, Result};
use crate::geometry::Grid;
use crate::geometry::SectionShape;
use glam::{DVec2, DVec3};

/// The cloud's sections, their span parameters and initial point parameters.
pub(super) struct Data<'a> {
    pub(super) points: &'a [DVec3],
    /// Points of section `k`: `k * per ..(k + 1) * per`.
    pub(super) per: usize,
    pub(super) sections: usize,
    /// `v_k`.
    pub(super) v: Vec<f64>,
    pub(super) span: Option<SpanRule>,
    /// The coordinates fitted (all three, or the two besides the span axis).
    pub(super) axes: Vec<usize>,
    /// Initial `u` of every point.
    pub(super) u0: Vec<f64>,
    /// Initial `u` of every point in the trailing-edge families (with the chord rule).
    pub(super) u0_te: Option<Vec<f64>>,
    /// Every section's frame, when the chord rule is used.
    pub(super) blade: Option<Vec<SectionFrame>>,
    /// The sections' shapes and mid-stations, when the span rule holds.
    pub(super) stations: Option<Stations>,
    /// Sections lofted between the data's, from a blade definition ([`Data::with_between`]).
    pub(super) between: Option<Between>,
    /// Per section, the tolerances its points are held to: 1 at the data's own sections,
    /// [`super::BETWEEN_FACTOR`] at sections a blade definition lofted between its stations
    /// ([`Data::with_joined`]).
    pub(super) slack: Vec<f64>,
}

pub(super) fn chord_params(pts: &[DVec3]) -> Option<Vec<f64>> {
    let mut acc = vec![0.0];
    for w in pts.windows(2) {
        acc.push(acc.last().copied().unwrap_or(0.0) + (w[1] - w[0]).length());
    }
    let total = *acc.last()?;
    (total > 0.0).then(|| acc.iter().map(|a| a / total).collect())
}

impl<'a> Data<'a> {
    pub(super) fn new(points: &'a [DVec3], grid: Grid, span_rule: bool, chord_rule: bool) -> Result<Self> {
        let (sections, per) = (grid.sections, grid.per_section);
        if sections < 2 || per < 4 || sections * per != points.len() {
            return Err(Error::invalid(format!(
                "adapt-surface: needs a grid of at least 2 sections of 4 points ({} x {} for {} points)",
                sections,
                per,
                points.len()
            )));
        }
        let extent = points.iter().fold(0.0_f64, |m, p| m.max(p.abs().max_element()));
        let sec = |k: usize| &points[k * per..(k + 1) * per];
        // A span axis: a coordinate constant within every section, strictly monotone across.
        let span = span_rule
            .then(|| {
                (0..3).find_map(|a| {
                    let s: Vec<f64> = (0..sections).map(|k| sec(k)[0][a]).collect();
                    let planar = (0..sections).all(|k| in_plane(sec(k), a, extent));
                    let up = s.windows(2).all(|w| w[1] > w[0]);
                    let down = s.windows(2).all(|w| w[1] < w[0]);
                    (planar && (up || down)).then(|| SpanRule {
                        axis: a,
                        ends: [s[0], s[sections - 1]],
                    })
                })
            })
            .flatten();
        let v: Vec<f64> = match span {
            Some(r) => (0..sections)
                .map(|k| (sec(k)[0][r.axis] - r.ends[0]) / (r.ends[1] - r.ends[0]))
                .collect(),
            None => {
                let c: Vec<DVec3> = (0..sections)
                    .map(|k| sec(k).iter().copied().sum::<DVec3>() / per as f64)
                    .collect();
                chord_params(&c)
                    .ok_or_else(|| Error::invalid("adapt-surface: every section has the same centroid"))?
            }
        };
        let axes: Vec<usize> = (0..3).filter(|&a| span.is_none_or(|r| r.axis != a)).collect();
        // Initial u per section: the aerofoil rule's parameters in the section's plane when
        // the section looks like an aerofoil, chord length otherwise; a section collapsed to a
        // point borrows the nearest other section's.
        let mut per_sec: Vec<Option<Vec<f64>>> = (0..sections)
            .map(|k| {
                let s = sec(k);
                let flat: Vec<glam::DVec2> = s
                    .iter()
                    .map(|p| glam::DVec2::new(p[axes[0]], p[axes[1]]))
                    .collect();
                let aero = if span.is_some() {
                    super::super::aerofoil_params(&flat)
                } else {
                    None
                };
                aero.or_else(|| chord_params(s))
            })
            .collect();
        if per_sec.iter().all(Option::is_none) {
            return Err(Error::invalid("adapt-surface: every section is a single point"));
        }
        for k in 0..sections {
            if per_sec[k].is_none() {
                let near = (0..sections)
                    .filter(|&o| per_sec[o].is_some())
                    .min_by_key(|&o| o.abs_diff(k))
                    .unwrap_or(0);
                per_sec[k] = per_sec[near].clone();
            }
        }
        let mut u0: Vec<f64> = per_sec.into_iter().flatten().flatten().collect();
        let mut u0_te = None;
        // The chord rule: every section's own leading-edge frame, and its points' parameters
        // in that frame.
        let blade = (chord_rule && span.is_some())
            .then(|| {
                let flat = |k: usize| -> Vec<glam::DVec2> {
                    sec(k)
                        .iter()
                        .map(|p| glam::DVec2::new(p[axes[0]], p[axes[1]]))
                        .collect()
                };
                // A section collapsed to a point (a blade tip) is a frame of zero chord
                // there.
                let frames = (0..sections)
                    .map(|k| {
                        let f = flat(k);
                        let size = f.iter().fold(0.0_f64, |m, p| m.max((*p - f[0]).length()));
                        if size <= 1e-12 * extent.max(1e-300) {
                            Some(SectionFrame {
                                le: f[0],
                                chord: glam::DVec2::ZERO,
                                le_index: per / 2,
                                te: 0.0,
                            })
                        } else {
                            section_frame(&f)
                        }
                    })
                    .collect::<Option<Vec<SectionFrame>>>()?;
                frames
                    .iter()
                    .any(|f| f.chord != glam::DVec2::ZERO)
                    .then_some(frames)
            })
            .flatten();
        if let Some(frames) = &blade {
            // Each section's parameters in its own frame; a collapsed one borrows the
            // nearest other section's.
            let params = |te: bool| -> Vec<f64> {
                let own: Vec<Option<Vec<f64>>> = (0..sections)
                    .map(|k| {
                        let flat: Vec<glam::DVec2> = sec(k)
                            .iter()
                            .map(|p| glam::DVec2::new(p[axes[0]], p[axes[1]]))
                            .collect();
                        (frames[k].chord != glam::DVec2::ZERO).then(|| section_params(&flat, &frames[k], te))
                    })
                    .collect();
                (0..sections)
                    .flat_map(|k| {
                        (0..sections)
                            .filter(|&o| own[o].is_some())
                            .min_by_key(|&o| o.abs_diff(k))
                            .and_then(|o| own[o].clone())
                            .unwrap_or_default()
                    })
                    .collect()
            };
            u0 = params(false);
            u0_te = Some(params(true));
        }
        let stations = span.and_then(|_| Stations::new(points, per, &v, [axes[0], axes[1]]));
        Ok(Data {
            points,
            per,
            sections,
            v,
            span,
            axes,
            u0,
            u0_te,
            blade,
            stations,
            between: None,
            slack: vec![1.0; sections],
        })
    }

    /// With sections lofted between the data's (`points`, `per` a section, each in a plane of
    /// the span axis within the data's span): the search then checks the surface against them.
    /// `None` when the span rule does not hold or they do not fit it.
    pub(super) fn with_between(mut self, points: &[DVec3], per: usize) -> Option<Self> {
        let rule = self.span?;
        if per == 0 || points.is_empty() || !points.len().is_multiple_of(per) {
            return None;
        }
        let (lo, hi) = (rule.ends[0].min(rule.ends[1]), rule.ends[0].max(rule.ends[1]));
        let extent = points.iter().fold(0.0_f64, |m, p| m.max(p.abs().max_element()));
        let v = points
            .chunks(per)
            .map(|sec| {
                let s = sec[0][rule.axis];
                (in_plane(sec, rule.axis, extent) && (lo..=hi).contains(&s))
                    .then(|| (s - rule.ends[0]) / (rule.ends[1] - rule.ends[0]))
            })
            .collect::<Option<Vec<f64>>>()?;
        self.between = Some(Between {
            points: points.to_vec(),
            per,
            v,
        });
        Some(self)
    }

    /// With the sections `joined` (lofted from a blade definition between its stations) held
    /// to [`super::BETWEEN_FACTOR`] tolerances, as the surface is between the stations.
    pub(super) fn with_joined(mut self, joined: &[usize]) -> Option<Self> {
        for &k in joined {
            *self.slack.get_mut(k)? = super::BETWEEN_FACTOR;
        }
        Some(self)
    }

    /// Per point of `points` (indices into the data's), the share of the tolerance its offset
    /// is measured against: its offset times this is held to the tolerance. `None` when every
    /// point is held to the tolerance itself.
    pub(super) fn scale_of(&self, points: impl Iterator<Item = usize>) -> Option<Vec<f64>> {
        (self.joined() > 0).then(|| points.map(|p| 1.0 / self.slack_at(p)).collect())
    }

    /// The tolerances point `p` is held to ([`Data::slack`]).
    pub(super) fn slack_at(&self, p: usize) -> f64 {
        self.slack[p / self.per]
    }

    /// The sections held to more than the tolerance ([`Data::with_joined`]).
    pub(super) fn joined(&self) -> usize {
        self.slack.iter().filter(|&&s| s != 1.0).count()
    }

    /// The initial `u` of every point, for a trailing-edge family (`te`) or another.
    pub(super) fn u0(&self, te: bool) -> &[f64] {
        match (&self.u0_te, te) {
            (Some(u), true) => u,
            _ => &self.u0,
        }
    }

    /// Where the bulk families of span degree `dv` put their span breaks, increasing
    /// ([`SpanBreaks`]): the middles between every two neighbouring sections' `v`, or the
    /// sections' own `v` but the first and the last.
    pub(super) fn break_sites(&self, dv: usize, rule: SpanBreaks) -> Vec<f64> {
        let mut sorted = self.v.clone();
        sorted.sort_by(f64::total_cmp);
        sorted.dedup();
        let at_sections = match rule {
            SpanBreaks::Auto | SpanBreaks::Midway => false,
            SpanBreaks::Sections => true,
            SpanBreaks::ByDegree => dv % 2 == 1,
        };
        if at_sections {
            sorted
                .get(1..sorted.len().saturating_sub(1))
                .unwrap_or_default()
                .to_vec()
        } else {
            sorted.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect()
        }
    }

    /// The span parameter `v_k` of every point.
    pub(super) fn point_v(&self) -> Vec<f64> {
        (0..self.points.len()).map(|p| self.v[p / self.per]).collect()
    }
}

/// Sections lofted between the data's sections, each in a plane of the span axis.
pub(super) struct Between {
    pub(super) points: Vec<DVec3>,
    pub(super) per: usize,
    /// The span parameter of every section.
    pub(super) v: Vec<f64>,
}

/// The data sections' shapes and the mid-stations, when the span rule holds.
pub(super) struct Stations {
    /// Neighbouring data sections `(a, b)` in span order, and the mid-station's `v`.
    pub(super) pairs: Vec<(usize, usize, f64)>,
    pub(super) shapes: Vec<SectionShape>,
    pub(super) samples: usize,
}

impl Stations {
    pub(super) fn new(points: &[DVec3], per: usize, v: &[f64], axes: [usize; 2]) -> Option<Stations> {
        let shapes = (0..v.len())
            .map(|k| SectionShape::of(&flat(&points[k * per..(k + 1) * per], axes)))
            .collect::<Option<Vec<_>>>()?;
        let mut order: Vec<usize> = (0..v.len()).collect();
        order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let pairs = order
            .windows(2)
            .map(|w| (w[0], w[1], 0.5 * (v[w[0]] + v[w[1]])))
            .collect();
        Some(Stations {
            pairs,
            shapes,
            samples: (CUT_DENSITY * per).max(64),
        })
    }
}

/// Samples of a cut per data point of a section.
const CUT_DENSITY: usize = 4;

/// The points of a section in its two in-plane axes.
pub(super) fn flat(points: &[DVec3], axes: [usize; 2]) -> Vec<DVec2> {
    points
        .iter()
        .map(|p| DVec2::new(p[axes[0]], p[axes[1]]))
        .collect()
}

/// Whether coordinate `axis` of every point of the section `sec` equals its first point's, to
/// 1e-12 of the cloud's `extent` (the section lies in a plane of that axis).
fn in_plane(sec: &[DVec3], axis: usize, extent: f64) -> bool {
    sec.iter()
        .all(|p| (p[axis] - sec[0][axis]).abs() <= 1e-12 * extent.max(1e-300))
}
