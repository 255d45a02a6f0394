//! The shape numbers of a planar blade section that a blade engineer compares along the span:
//! chord, maximum thickness and centroid, measured the same way on a data section and on a cut
//! of a fitted surface.
//!
//! The section is an ordered contour that starts and ends at its trailing edge (an aerofoil in
//! Selig or reverse order, a root circle, a tip collapsed to a point). Its **trailing edge** is
//! the mid-point of its first and last points; its **leading edge** the point farthest from
//! it; the **chord** their distance. The **maximum thickness** is the largest extent, at right
//! angles to the chord, of the closed polygon's intersection with a line at right angles to
//! the chord (so a circle's is its diameter, an aerofoil's the usual t/c times c). The
//! **centroid** is the closed polygon's area centroid (the vertices' mean when it encloses no
//! area).

use glam::DVec2;

/// Stations along the chord at which the thickness is measured.
const THICKNESS_STATIONS: usize = 400;

/// Twice the signed area of the closed polygon through `points` (positive counter-clockwise).
pub(crate) fn twice_signed_area(points: &[DVec2]) -> f64 {
    let n = points.len();
    (0..n).map(|i| points[i].perp_dot(points[(i + 1) % n])).sum()
}

/// Chord, maximum thickness and centroid of a section (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SectionShape {
    /// Leading edge to trailing edge.
    pub chord: f64,
    /// The largest extent at right angles to the chord.
    pub thickness: f64,
    /// The area centroid.
    pub centroid: DVec2,
}

impl SectionShape {
    /// The shape numbers of the contour `points` (at least one point; `None` when empty or
    /// not finite).
    #[must_use]
    pub fn of(points: &[DVec2]) -> Option<SectionShape> {
        let n = points.len();
        if n == 0 || points.iter().any(|p| !p.is_finite()) {
            return None;
        }
        let te = 0.5 * (points[0] + points[n - 1]);
        let le = points
            .iter()
            .copied()
            .max_by(|a, b| (*a - te).length_squared().total_cmp(&(*b - te).length_squared()))?;
        let chord = (te - le).length();
        let mean = points.iter().copied().sum::<DVec2>() / n as f64;
        let a2 = twice_signed_area(points);
        let centroid = if a2.abs() > 1e-12 * chord * chord {
            let mut c = DVec2::ZERO;
            for i in 0..n {
                let (p, q) = (points[i], points[(i + 1) % n]);
                c += (p + q) * p.perp_dot(q);
            }
            c / (3.0 * a2)
        } else {
            mean
        };
        let thickness = if chord > 0.0 {
            let d = (te - le) / chord;
            let local: Vec<DVec2> = points
                .iter()
                .map(|p| DVec2::new((*p - le).dot(d), d.perp_dot(*p - le)))
                .collect();
            extent_across(&local, chord)
        } else {
            0.0
        };
        Some(SectionShape {
            chord,
            thickness,
            centroid,
        })
    }
}

/// The largest extent in y of the closed polygon `local` (x along the chord from 0 to
/// `chord`) cut by the lines `x = const` at [`THICKNESS_STATIONS`] stations.
fn extent_across(local: &[DVec2], chord: f64) -> f64 {
    let n = local.len();
    let mut best = 0.0_f64;
    for s in 0..THICKNESS_STATIONS {
        let x = chord * (s as f64 + 0.5) / THICKNESS_STATIONS as f64;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..n {
            let (p, q) = (local[i], local[(i + 1) % n]);
            if (p.x - x) * (q.x - x) <= 0.0 && p.x != q.x {
                let y = p.y + (q.y - p.y) * (x - p.x) / (q.x - p.x);
                lo = lo.min(y);
                hi = hi.max(y);
            }
        }
        if hi > lo {
            best = best.max(hi - lo);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    #[test]
    fn a_circle_has_its_diameter_for_chord_and_thickness_and_its_centre() {
        let c = DVec2::new(2.0, -1.0);
        let pts: Vec<DVec2> = (0..=720)
            .map(|k| c + 0.5 * DVec2::from_angle(TAU * k as f64 / 720.0))
            .collect();
        let s = SectionShape::of(&pts).unwrap();
        assert!((s.chord - 1.0).abs() < 1e-9, "{s:?}");
        assert!((s.thickness - 1.0).abs() < 1e-4, "{s:?}");
        assert!((s.centroid - c).length() < 1e-6, "{s:?}");
    }

    #[test]
    fn a_turned_ellipse_keeps_its_axes() {
        // Semi-axes 2 (chord direction) and 0.3, turned by 0.4 rad, starting at the
        // "trailing edge" end of the long axis.
        let (a, b, turn) = (2.0, 0.3, DVec2::from_angle(0.4));
        let pts: Vec<DVec2> = (0..=2000)
            .map(|k| {
                let t = TAU * k as f64 / 2000.0;
                turn.rotate(DVec2::new(a * t.cos(), b * t.sin()))
            })
            .collect();
        let s = SectionShape::of(&pts).unwrap();
        assert!((s.chord - 2.0 * a).abs() < 1e-9, "{s:?}");
        assert!((s.thickness - 2.0 * b).abs() < 1e-4, "{s:?}");
        assert!(s.centroid.length() < 1e-9, "{s:?}");
    }

    #[test]
    fn a_point_has_no_chord_and_empty_input_no_shape() {
        let s = SectionShape::of(&[DVec2::new(1.0, 2.0); 5]).unwrap();
        assert_eq!((s.chord, s.thickness), (0.0, 0.0));
        assert_eq!(s.centroid, DVec2::new(1.0, 2.0));
        assert!(SectionShape::of(&[]).is_none());
    }
}
