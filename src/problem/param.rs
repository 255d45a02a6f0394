//! Initial surface parameters `(u, v)` for 3D clouds: from the sections of a structured cloud,
//! or, for an unordered cloud, by a blade-aware parameterisation (v along the span axis, u by
//! arc length around each slice's section).
//!
//! Conventions, shared by both so that a structured and an unordered cloud of the same blade
//! give the same surface orientation: `v` runs along the span from 0 to 1; `u` runs around the
//! section from 0 to 1, counter-clockwise about the span direction, starting just past the
//! trailing edge. For the lofted blades of [`crate::geometry`] (span along +z, sections in
//! Selig order) that is the file order: upper trailing edge (u = 0), leading edge
//! (u ≈ 0.5), lower trailing edge (u = 1). The trailing edge is open, so `u` is an open
//! parameter and the surface has two free edges there.

use crate::error::{Error, Result};
use crate::geometry::Grid;
use crate::keyword::keywords;
use glam::{DVec2, DVec3};
use nalgebra::{Matrix3, SymmetricEigen};
use rayon::prelude::*;

/// The span direction and the extent of a cloud along it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpanAxis {
    /// Unit vector along the span (v grows along it).
    pub dir: DVec3,
    /// Smallest span coordinate `dir · p` of the cloud (v = 0).
    pub lo: f64,
    /// Largest span coordinate (v = 1).
    pub hi: f64,
}

impl SpanAxis {
    /// The parameter `v` of span coordinate `s`, clamped to `[0, 1]`.
    #[must_use]
    pub fn v(&self, s: f64) -> f64 {
        ((s - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
    }

    /// The span axis of an unordered cloud: its principal axis of largest variance, oriented so
    /// that its largest component is positive (a blade along z gets +z).
    pub fn principal(points: &[DVec3]) -> Result<SpanAxis> {
        let (_, axes) = principal_axes(points)?;
        let mut dir = axes[0];
        let big = if dir.x.abs() >= dir.y.abs() && dir.x.abs() >= dir.z.abs() {
            dir.x
        } else if dir.y.abs() >= dir.z.abs() {
            dir.y
        } else {
            dir.z
        };
        if big < 0.0 {
            dir = -dir;
        }
        SpanAxis::along(dir, points)
    }

    /// The span axis along `dir` (normalised), with the cloud's extent along it.
    pub fn along(dir: DVec3, points: &[DVec3]) -> Result<SpanAxis> {
        let dir = dir
            .try_normalize()
            .ok_or_else(|| Error::invalid("the span direction is zero"))?;
        let (lo, hi) = points
            .par_iter()
            .map(|p| {
                let s = dir.dot(*p);
                (s, s)
            })
            .reduce(
                || (f64::INFINITY, f64::NEG_INFINITY),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        if !(hi > lo) {
            return Err(Error::invalid(
                "the cloud has no extent along its span: a surface needs points spread along two directions",
            ));
        }
        Ok(SpanAxis { dir, lo, hi })
    }
}

/// Centroid and principal axes (unit vectors, by decreasing variance) of a cloud.
fn principal_axes(points: &[DVec3]) -> Result<(DVec3, [DVec3; 3])> {
    if points.len() < 3 {
        return Err(Error::invalid(format!(
            "{} points cannot span a surface (at least 3 are needed)",
            points.len()
        )));
    }
    let n = points.len() as f64;
    let sum = points.par_iter().copied().reduce(|| DVec3::ZERO, |a, b| a + b);
    let c = sum / n;
    let cov = points
        .par_iter()
        .map(|p| {
            let d = *p - c;
            [d.x * d.x, d.x * d.y, d.x * d.z, d.y * d.y, d.y * d.z, d.z * d.z]
        })
        .reduce(
            || [0.0; 6],
            |a, b| {
                let mut s = a;
                for (x, y) in s.iter_mut().zip(b) {
                    *x += y;
                }
                s
            },
        );
    let m = Matrix3::new(
        cov[0], cov[1], cov[2], cov[1], cov[3], cov[4], cov[2], cov[4], cov[5],
    ) / n;
    let eig = SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let col = |i: usize| {
        let v = eig.eigenvectors.column(order[i]);
        DVec3::new(v[0], v[1], v[2])
    };
    let axes = [col(0), col(1), col(2)];
    if axes.iter().any(|a| !a.is_finite()) || !(eig.eigenvalues[order[0]] > 0.0) {
        return Err(Error::invalid(
            "the cloud's principal axes are undefined (all points coincide?)",
        ));
    }
    Ok((c, axes))
}

/// The span axis along `span`, or the cloud's principal axis when `span` is `None`.
pub fn span_axis(points: &[DVec3], span: Option<DVec3>) -> Result<SpanAxis> {
    match span {
        Some(d) => SpanAxis::along(d, points),
        None => SpanAxis::principal(points),
    }
}

/// Parameters of a structured cloud, one `(u, v)` per point in file order: `u` is the
/// normalised chord length along each section (the sections' own point order; a section
/// collapsed to a point gets evenly spaced `u`), `v` the position of the section's centroid
/// along the span direction (`None`: the line from the first section's centroid to the last
/// one's), normalised so that the first section has `v = 0` and the last `v = 1`.
pub fn section_params(
    points: &[DVec3],
    grid: Grid,
    span: Option<DVec3>,
) -> Result<(Vec<[f64; 2]>, SpanAxis)> {
    let (m, n) = (grid.sections, grid.per_section);
    if m < 2 || n < 2 || m.checked_mul(n) != Some(points.len()) {
        return Err(Error::invalid(format!(
            "a structured cloud needs at least 2 sections of at least 2 points and sections x points = \
             {} (got {m} x {n})",
            points.len()
        )));
    }
    let centroid = |k: usize| points[k * n..(k + 1) * n].iter().copied().sum::<DVec3>() / n as f64;
    let centroids: Vec<DVec3> = (0..m).map(centroid).collect();
    let axis = match span {
        Some(d) => SpanAxis::along(d, points)?,
        None => match SpanAxis::along(centroids[m - 1] - centroids[0], points) {
            Ok(a) => a,
            // The first and last sections share a centroid (a closed sweep): the cloud's axis.
            Err(_) => SpanAxis::principal(points)?,
        },
    };
    let (s0, s1) = (axis.dir.dot(centroids[0]), axis.dir.dot(centroids[m - 1]));
    let mut params = Vec::with_capacity(points.len());
    for (k, c) in centroids.iter().enumerate() {
        let v = if s1 > s0 {
            ((axis.dir.dot(*c) - s0) / (s1 - s0)).clamp(0.0, 1.0)
        } else {
            k as f64 / (m - 1) as f64
        };
        let sec = &points[k * n..(k + 1) * n];
        let u = chord_fractions(sec.iter().copied());
        params.extend(u.into_iter().map(|u| [u, v]));
    }
    // The surface spans the sections, so v is measured between the first and last centroids.
    let axis = SpanAxis {
        lo: s0.min(s1),
        hi: s0.max(s1),
        ..axis
    };
    Ok((params, axis))
}

/// Normalised cumulative chord length of a polyline (evenly spaced when it has no length).
fn chord_fractions(pts: impl ExactSizeIterator<Item = DVec3>) -> Vec<f64> {
    let n = pts.len();
    let mut acc = Vec::with_capacity(n);
    let mut prev: Option<DVec3> = None;
    let mut len = 0.0;
    for p in pts {
        if let Some(q) = prev {
            len += (p - q).length();
        }
        acc.push(len);
        prev = Some(p);
    }
    if len > 0.0 && len.is_finite() {
        acc.iter_mut().for_each(|t| *t /= len);
    } else {
        let last = (n.max(2) - 1) as f64;
        acc.iter_mut().enumerate().for_each(|(i, t)| *t = i as f64 / last);
    }
    acc
}

/// Options of the blade-aware parameterisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BladeParamOptions {
    /// Points per slice across the span (slices follow the cloud's own sections where its span
    /// coordinates come in well-separated levels). Default 2000.
    pub slice_points: usize,
    /// The span direction. `None` takes the cloud's principal axis, which a tapered blade
    /// tilts away from the direction its sections are stacked along (by about 2° for the
    /// paper's blade), so slices would cut across sections. Default +z, the span axis of
    /// lofted blades.
    pub span: Option<DVec3>,
}

/// A span direction by name: a coordinate axis, or `auto`, the cloud's principal axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpanDirection {
    X,
    Y,
    Z,
    Auto,
}
keywords!(SpanDirection, "span axis", { X => "x", Y => "y", Z => "z", Auto => "auto" });

impl SpanDirection {
    /// The direction as [`BladeParamOptions::span`] takes it (`None` for `Auto`).
    #[must_use]
    pub fn dir(self) -> Option<DVec3> {
        match self {
            SpanDirection::X => Some(DVec3::X),
            SpanDirection::Y => Some(DVec3::Y),
            SpanDirection::Z => Some(DVec3::Z),
            SpanDirection::Auto => None,
        }
    }
}

impl Default for BladeParamOptions {
    fn default() -> Self {
        BladeParamOptions {
            slice_points: 2000,
            span: Some(DVec3::Z),
        }
    }
}

/// Fewest points a slice may have; smaller levels are merged with their neighbours.
const MIN_SLICE: usize = 16;

/// Blade-aware parameters of an unordered cloud, one `(u, v)` per point in input order.
///
/// `v` is the normalised span coordinate. The cloud is cut across the span into slices (at
/// the gaps between sections when the cloud has them, otherwise every `slice_points` points);
/// in each slice the trailing edge is the point farthest from the slice's centroid and the
/// leading edge the point farthest from the trailing edge; the points are sorted by their
/// angle about a centre on the chord (35% from the leading edge), counter-clockwise about the
/// span from the trailing edge, and `u` is the normalised arc length along that order,
/// measured on a lightly smoothed polyline so that noise does not stretch it.
pub fn blade_params(points: &[DVec3], opts: &BladeParamOptions) -> Result<(Vec<[f64; 2]>, SpanAxis)> {
    let axis = span_axis(points, opts.span)?;
    let n = points.len();
    let mut order: Vec<(f64, u32)> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| (axis.dir.dot(*p), i as u32))
        .collect();
    order.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let slices = cut_slices(&order, opts.slice_points.max(MIN_SLICE));
    // A frame across the span: e1 ⟂ span, e2 = span × e1 (so (e1, e2, span) is right-handed
    // and angles in (e1, e2) grow counter-clockwise about the span).
    let e1 = axis.dir.any_orthonormal_vector();
    let e2 = axis.dir.cross(e1);
    let mut params = vec![[0.0; 2]; n];
    let us: Vec<Vec<(u32, f64)>> = slices
        .par_iter()
        .map(|r| {
            let flat: Vec<(DVec2, u32)> = order[r.clone()]
                .iter()
                .map(|&(_, i)| {
                    let p = points[i as usize];
                    (DVec2::new(e1.dot(p), e2.dot(p)), i)
                })
                .collect();
            slice_u(&flat)
        })
        .collect();
    for (s, i) in &order {
        params[*i as usize][1] = axis.v(*s);
    }
    for slice in us {
        for (i, u) in slice {
            params[i as usize][0] = u;
        }
    }
    Ok((params, axis))
}

/// Cut the span-sorted points into slices: first into levels (the cloud's sections, when its
/// span coordinates come in levels), then each level into pieces of about `target` points.
///
/// Levels are separated by the `k` largest gaps between consecutive span coordinates when
/// the `k`-th largest gap is more than 10 times the next one (the largest such ratio over `k`
/// wins, with every level at least [`MIN_SLICE`] points on average). For span coordinates
/// spread continuously (a scan) no ratio comes near 10 and the cloud is one level.
fn cut_slices(order: &[(f64, u32)], target: usize) -> Vec<std::ops::Range<usize>> {
    let n = order.len();
    let mut gaps: Vec<(f64, usize)> = order
        .windows(2)
        .enumerate()
        .map(|(i, w)| (w[1].0 - w[0].0, i + 1))
        .collect();
    gaps.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let most = (n / MIN_SLICE).min(gaps.len().saturating_sub(1));
    let mut best = (10.0, 0);
    for k in 1..=most {
        let (big, next) = (gaps[k - 1].0, gaps[k].0);
        if big > best.0 * next.max(f64::MIN_POSITIVE) {
            best = (big / next.max(f64::MIN_POSITIVE), k);
        }
    }
    let mut cuts: Vec<usize> = gaps[..best.1].iter().map(|g| g.1).collect();
    cuts.sort_unstable();
    let mut slices = Vec::new();
    let mut start = 0;
    for end in cuts.into_iter().chain(std::iter::once(n)) {
        let len = end - start;
        if len == 0 {
            continue;
        }
        let pieces = (len / target).max(1);
        for k in 0..pieces {
            slices.push(start + k * len / pieces..start + (k + 1) * len / pieces);
        }
        start = end;
    }
    slices
}

/// The spread across the chord (unit direction `x` from `from`, length `chord`) of the points
/// within `w` chords of chordwise position `s0`: (lowest, highest, count).
fn band_at(pts: &[(DVec2, u32)], from: DVec2, x: DVec2, chord: f64, s0: f64, w: f64) -> (f64, f64, usize) {
    let (mut lo, mut hi, mut k) = (f64::INFINITY, f64::NEG_INFINITY, 0);
    for p in pts {
        let d = p.0 - from;
        if (x.dot(d) / chord - s0).abs() <= w {
            let across = x.perp_dot(d);
            lo = lo.min(across);
            hi = hi.max(across);
            k += 1;
        }
    }
    if k == 0 {
        (0.0, 0.0, 0)
    } else {
        (lo, hi, k)
    }
}

/// One surface of a section followed towards the trailing edge: its last point and the
/// slope of the line from a point at least 2% of the chord before it.
struct Track {
    /// (chordwise position, across-chord position) of the points so far.
    pts: Vec<(f64, f64)>,
    slope: f64,
}

impl Track {
    fn new(s: f64, a: f64, slope: f64) -> Track {
        Track {
            pts: vec![(s, a)],
            slope: if slope.is_finite() { slope } else { 0.0 },
        }
    }

    /// The across-chord position the surface is expected at, at chordwise position `s`.
    fn predict(&self, s: f64, chord: f64) -> f64 {
        let (s0, a0) = self.pts[self.pts.len() - 1];
        a0 + self.slope * (s - s0) * chord
    }

    fn push(&mut self, s: f64, a: f64, chord: f64) {
        self.pts.push((s, a));
        let back = self.pts.iter().rev().find(|p| s - p.0 >= 0.02);
        if let Some(&(s0, a0)) = back {
            self.slope = (a - a0) / ((s - s0) * chord);
        }
    }
}

/// `u` of every point of one slice (points in the plane across the span, with their indices).
///
/// The section's ends are its diameter's end points; the trailing edge is the thin one. Points
/// ahead of a centre on the mean line at 35% chord are ordered by their angle about it, where
/// the contour faces the centre; points behind it by their chordwise position, upper and lower
/// surface apart (each surface followed from the centre to the trailing edge). Angles alone
/// would scramble the aft surfaces, which run almost radially from any inner centre.
fn slice_u(pts: &[(DVec2, u32)]) -> Vec<(u32, f64)> {
    let n = pts.len();
    let even = |order: &mut dyn Iterator<Item = u32>| -> Vec<(u32, f64)> {
        order
            .enumerate()
            .map(|(k, i)| (i, k as f64 / (n.max(2) - 1) as f64))
            .collect()
    };
    if n < 3 {
        return even(&mut pts.iter().map(|p| p.1));
    }
    let c = pts.iter().map(|p| p.0).sum::<DVec2>() / n as f64;
    let far = |from: DVec2| {
        pts.iter()
            .map(|p| p.0)
            .max_by(|a, b| {
                (*a - from)
                    .length_squared()
                    .total_cmp(&(*b - from).length_squared())
            })
            .unwrap_or(from)
    };
    let (a, b) = {
        let a = far(c);
        (a, far(a))
    };
    let chord = (b - a).length();
    let Some(x_ab) = (b - a).try_normalize() else {
        return even(&mut pts.iter().map(|p| p.1));
    };
    // The trailing edge is the thinner end.
    let (lo_a, hi_a, _) = band_at(pts, a, x_ab, chord, 0.05, 0.05);
    let (lo_b, hi_b, _) = band_at(pts, a, x_ab, chord, 0.95, 0.05);
    let (le, te) = if hi_b - lo_b <= hi_a - lo_a {
        (a, b)
    } else {
        (b, a)
    };
    let x = (te - le) / chord;
    let s_of = |p: DVec2| x.dot(p - le) / chord;
    let across = |p: DVec2| x.perp_dot(p - le);
    // A centre on the mean line at 35% chord (midway between the surfaces there).
    let s_c = 0.35;
    let (lo_c, hi_c, _) = band_at(pts, le, x, chord, s_c, 0.03);
    let centre = le + x * (s_c * chord) + x.perp() * (0.5 * (lo_c + hi_c));
    let (mut upper, mut front, mut aft) = (Vec::new(), Vec::new(), Vec::new());
    for &(p, i) in pts {
        let s = s_of(p);
        if s < s_c {
            // Angle from the chord direction, counter-clockwise, in [0, 2π).
            let d = p - centre;
            let mut ang = x.perp_dot(d).atan2(x.dot(d));
            if ang < 0.0 {
                ang += std::f64::consts::TAU;
            }
            front.push((ang, p, i));
        } else {
            aft.push((s, across(p), p, i));
        }
    }
    // Behind the centre, follow the two surfaces towards the trailing edge: each point (by
    // increasing chordwise position) joins the surface whose line through its last points
    // passes nearer, so the split needs no mean line (which bends down sharply at the
    // trailing edge of a cambered section).
    aft.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let (lo_n, hi_n, _) = band_at(pts, le, x, chord, s_c + 0.1, 0.03);
    let mut tracks = [
        Track::new(s_c, hi_c, (hi_n - hi_c) / (0.1 * chord)),
        Track::new(s_c, lo_c, (lo_n - lo_c) / (0.1 * chord)),
    ];
    let mut lower = Vec::new();
    for &(s, a, p, i) in &aft {
        let (eu, el) = (
            (tracks[0].predict(s, chord) - a).abs(),
            (tracks[1].predict(s, chord) - a).abs(),
        );
        if eu <= el {
            tracks[0].push(s, a, chord);
            upper.push((-s, p, i));
        } else {
            tracks[1].push(s, a, chord);
            lower.push((s, p, i));
        }
    }
    for part in [&mut upper, &mut front, &mut lower] {
        part.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    }
    let ordered: Vec<(DVec2, u32)> = upper
        .iter()
        .chain(&front)
        .chain(&lower)
        .map(|&(_, p, i)| (p, i))
        .collect();
    // Arc length on a decimated polyline: a point is kept when it is at least 0.5% of the
    // chord from the last one kept, so that noise across the contour (which zigzags between
    // close neighbours) adds no length; the points between two kept ones get their u by rank.
    let step = 0.005 * chord;
    let mut kept = vec![(0usize, 0.0)];
    let mut last = ordered[0].0;
    let mut len = 0.0;
    for (k, &(p, _)) in ordered.iter().enumerate().skip(1) {
        let d = (p - last).length();
        if d >= step || k + 1 == n {
            len += d;
            kept.push((k, len));
            last = p;
        }
    }
    if !(len > 1e-9 * chord) || !(len > 0.0) {
        return even(&mut ordered.iter().map(|p| p.1));
    }
    let mut out = Vec::with_capacity(n);
    for w in kept.windows(2) {
        let ((k0, l0), (k1, l1)) = (w[0], w[1]);
        for k in k0..k1 {
            let f = (k - k0) as f64 / (k1 - k0) as f64;
            out.push((ordered[k].1, ((l0 + f * (l1 - l0)) / len).clamp(0.0, 1.0)));
        }
    }
    out.push((ordered[n - 1].1, 1.0));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn span_directions_name_the_axes_and_auto_none() {
        let dirs: Vec<Option<DVec3>> = ["x", "Y", "z", "auto"]
            .iter()
            .map(|w| w.parse::<SpanDirection>().unwrap().dir())
            .collect();
        assert_eq!(dirs, [Some(DVec3::X), Some(DVec3::Y), Some(DVec3::Z), None]);
        let e = "w".parse::<SpanDirection>().unwrap_err().to_string();
        assert!(
            e.contains("unknown span axis 'w' (expected x, y, z or auto)"),
            "{e}"
        );
    }
    use crate::geometry::{Blade, LoftOptions};
    use std::path::Path;

    fn paper_blade() -> Blade {
        Blade::from_file(Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/blade_paper.json"
        )))
        .unwrap()
    }

    #[test]
    fn sections_give_chord_length_u_and_span_v() {
        let cloud = paper_blade().loft(&LoftOptions::default()).unwrap();
        let grid = cloud.grid.unwrap();
        let (params, axis) = section_params(&cloud.points, grid, Some(DVec3::Z)).unwrap();
        assert_eq!(axis.dir, DVec3::Z);
        let (_, tilted) = section_params(&cloud.points, grid, None).unwrap();
        assert!(
            (tilted.dir - DVec3::Z).length() < 0.05,
            "span axis {}",
            tilted.dir
        );
        let n = grid.per_section;
        for k in 0..grid.sections {
            let sec = &params[k * n..(k + 1) * n];
            assert_eq!(sec[0][0], 0.0);
            assert!((sec[n - 1][0] - 1.0).abs() < 1e-15);
            assert!(sec.windows(2).all(|w| w[1][0] > w[0][0]));
            assert!(sec.iter().all(|t| t[1] == sec[0][1]));
        }
        assert_eq!(params[0][1], 0.0);
        assert_eq!(params[params.len() - 1][1], 1.0);
        // Same shape at every section: the same u at the same index (the tip is a point).
        for i in 0..n {
            assert!((params[i][0] - params[5 * n + i][0]).abs() < 1e-12);
        }
    }

    #[test]
    fn blade_params_of_a_shuffled_cloud_match_the_sections() {
        let blade = paper_blade();
        let opts = LoftOptions {
            points_per_section: Some(200),
            sections: Some(60),
            ..LoftOptions::default()
        };
        let cloud = blade.loft(&opts).unwrap();
        let (want, _) = section_params(&cloud.points, cloud.grid.unwrap(), Some(DVec3::Z)).unwrap();
        // The same points in a random order, with noise: parameters must follow the points.
        let noisy = blade
            .loft(&LoftOptions {
                noise: 1e-4,
                shuffle: true,
                seed: 3,
                ..opts
            })
            .unwrap();
        let (got, axis) = blade_params(&noisy.points, &BladeParamOptions::default()).unwrap();
        assert_eq!(axis.dir, DVec3::Z);
        // Match every noisy point to its clean one by nearest neighbour in its section.
        let n = 200;
        let mut worst_u: f64 = 0.0;
        let mut sum_u = 0.0;
        let mut count = 0;
        for (q, t) in noisy.points.iter().zip(&got) {
            let k = ((t[1] * 59.0).round() as usize).min(59);
            let chord = cloud.points[k * n..(k + 1) * n]
                .iter()
                .map(|p| (*p - cloud.points[k * n]).length())
                .fold(0.0, f64::max);
            if chord < 0.02 {
                continue; // the last sections before the tip point
            }
            let (j, _) = cloud.points[k * n..(k + 1) * n]
                .iter()
                .enumerate()
                .map(|(j, p)| (j, (*p - *q).length_squared()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            let e = (t[0] - want[k * n + j][0]).abs();
            worst_u = worst_u.max(e);
            sum_u += e;
            count += 1;
            assert!(
                (t[1] - want[k * n][1]).abs() < 1e-3,
                "v {} vs {}",
                t[1],
                want[k * n][1]
            );
        }
        // Measured: largest 8.6e-4, mean 8.4e-5.
        assert!(worst_u < 3e-3, "largest u error {worst_u}");
        assert!(
            sum_u / (count as f64) < 3e-4,
            "mean u error {}",
            sum_u / count as f64
        );
    }

    #[test]
    fn degenerate_clouds_are_refused() {
        assert!(blade_params(&[DVec3::ONE; 10], &BladeParamOptions::default()).is_err());
        assert!(blade_params(&[DVec3::ZERO, DVec3::X], &BladeParamOptions::default()).is_err());
        let grid = Grid {
            sections: 2,
            per_section: 3,
        };
        assert!(section_params(&[DVec3::ZERO; 5], grid, None).is_err());
    }
}
