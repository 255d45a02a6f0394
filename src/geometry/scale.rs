//! The magnitudes the arithmetic can hold: data whose squared distances would overflow (or
//! underflow) f64, or f32 on the population evaluator, are refused up front with a message that
//! says so, instead of ending in an infinite or meaningless offset.
//!
//! A fit sums `n` squared distances between points no farther apart than the data's extent
//! (the shape may overshoot the data, and intermediate terms such as a Newton step's
//! curvature product are a few times larger), so every coordinate must stay below
//! `sqrt(MAX / (HEADROOM · n))`, with `HEADROOM` = 1024. Below the other end, squares of the
//! extent must stay well inside the normal range so that relative tolerances keep meaning.

use crate::bezier::Vector;

/// Factor between the largest sum a computation forms and `n` squared coordinates.
const HEADROOM: f64 = 1024.0;

/// The smallest extent (largest side of the bounding box) of data fitted in f64.
pub const MIN_EXTENT_F64: f64 = 1e-100;

/// The smallest extent of data evaluated in f32 (squares of 1e-24 leave offsets of 1e-4 of
/// the extent inside f32's normal range).
pub const MIN_EXTENT_F32: f64 = 1e-12;

/// The arithmetic a computation runs in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// Geometry and fitting (f64).
    F64,
    /// The population evaluator (f32, coordinates taken about the data's centre).
    F32,
}

impl Precision {
    /// The largest coordinate magnitude for `n` points: `sqrt(MAX / (1024 n))`.
    #[must_use]
    pub fn max_coordinate(self, n: usize) -> f64 {
        let max = match self {
            Precision::F64 => f64::MAX,
            Precision::F32 => f64::from(f32::MAX),
        };
        (max / (HEADROOM * n.max(1) as f64)).sqrt()
    }

    fn name(self) -> &'static str {
        match self {
            Precision::F64 => "f64",
            Precision::F32 => "f32 (the population evaluator)",
        }
    }
}

/// Why `points` cannot be computed with at `precision`: a coordinate too large for their
/// squared distances to be summed (the index of the first such point and the message), or an
/// extent too small for its squares (no index). For f64 the coordinates are measured from the
/// origin (the fits work in absolute coordinates); for f32 from the centre of the bounding box
/// (the evaluator's reference).
pub fn check_scale<P: Vector>(points: &[P], precision: Precision) -> Result<(), (Option<usize>, String)> {
    if points.is_empty() {
        return Ok(());
    }
    let (lo, hi) = bounds(points);
    let extent = (0..P::DIM).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
    let centre: Vec<f64> = match precision {
        Precision::F64 => vec![0.0; P::DIM],
        Precision::F32 => (0..P::DIM).map(|i| 0.5 * lo[i] + 0.5 * hi[i]).collect(),
    };
    let limit = precision.max_coordinate(points.len());
    let reach = |p: &P| {
        (0..P::DIM)
            .map(|i| (p.coord(i) - centre[i]).abs())
            .fold(0.0, f64::max)
    };
    if let Some(k) = points.iter().position(|p| reach(p).is_nan() || reach(p) > limit) {
        return Err((
            Some(k),
            format!(
                "coordinates of {:.3e} (point {}): squared distances of {} points overflow {} \
                 beyond {limit:.2e}; rescale the data (e.g. to unit chord or to metres)",
                points[k].max_abs(),
                k + 1,
                points.len(),
                precision.name()
            ),
        ));
    }
    let min = match precision {
        Precision::F64 => MIN_EXTENT_F64,
        Precision::F32 => MIN_EXTENT_F32,
    };
    if extent > 0.0 && extent < min {
        return Err((
            None,
            format!(
                "the data span only {extent:.3e} (the largest side of their bounding box): squared \
                 distances underflow {} below {min:e}; rescale the data (e.g. to unit chord)",
                precision.name()
            ),
        ));
    }
    Ok(())
}

/// Why the design variables `values` (`dim` coordinates per design point, flattened) cannot
/// be evaluated in f32 against `data`: a value farther from the data's centre than the limit
/// of [`Precision::F32`] for the data's point count. Returns the index of the first such value
/// and the message.
pub fn check_design_scale<P: Vector>(values: &[f64], data: &[P]) -> Result<(), (usize, String)> {
    if data.is_empty() {
        return Ok(());
    }
    let (lo, hi) = bounds(data);
    let limit = Precision::F32.max_coordinate(data.len());
    let reach = |k: usize| (values[k] - (0.5 * lo[k % P::DIM] + 0.5 * hi[k % P::DIM])).abs();
    match (0..values.len()).find(|&k| reach(k).is_nan() || reach(k) > limit) {
        Some(k) => Err((
            k,
            format!(
                "value {:.3e} lies {:.3e} from the data's centre: squared distances overflow f32 \
                 (the population evaluator) beyond {limit:.2e} for {} points",
                values[k],
                reach(k),
                data.len()
            ),
        )),
        None => Ok(()),
    }
}

/// The bounding box of `points`, coordinate by coordinate.
fn bounds<P: Vector>(points: &[P]) -> (Vec<f64>, Vec<f64>) {
    let mut lo = vec![f64::INFINITY; P::DIM];
    let mut hi = vec![f64::NEG_INFINITY; P::DIM];
    for p in points {
        for i in 0..P::DIM {
            lo[i] = lo[i].min(p.coord(i));
            hi[i] = hi[i].max(p.coord(i));
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    #[test]
    fn ordinary_data_pass_at_every_scale_they_are_met() {
        for s in [1e-9, 1e-3, 1.0, 1e3, 1e9] {
            let pts: Vec<DVec2> = (0..82)
                .map(|i| DVec2::new(i as f64, (i as f64).sin()) * s)
                .collect();
            assert!(check_scale(&pts, Precision::F64).is_ok(), "{s}");
            assert!(check_scale(&pts, Precision::F32).is_ok(), "{s}");
        }
    }

    #[test]
    fn overflowing_squares_are_refused_with_the_point() {
        let mut pts: Vec<DVec2> = (0..82).map(|i| DVec2::new(i as f64, 0.5)).collect();
        pts[14] *= 1e200;
        let (at, msg) = check_scale(&pts, Precision::F64).unwrap_err();
        assert_eq!(at, Some(14));
        assert!(msg.contains("overflow f64") && msg.contains("point 15"), "{msg}");
        // The limit: n (2^5 limit)^2 stays below MAX.
        let l = Precision::F64.max_coordinate(82);
        assert!((82.0 * 1024.0 * l * l).is_finite());
        // f32 is about the centre: far from the origin but compact passes.
        let far: Vec<DVec3> = (0..10)
            .map(|i| DVec3::new(1e30 + i as f64 * 1e16, 0.0, 1.0))
            .collect();
        assert!(check_scale(&far, Precision::F32).is_ok());
        let wide: Vec<DVec3> = (0..10).map(|i| DVec3::new(i as f64 * 1e18, 0.0, 1.0)).collect();
        assert!(check_scale(&wide, Precision::F32).unwrap_err().1.contains("f32"));
    }

    #[test]
    fn underflowing_extents_are_refused() {
        let pts: Vec<DVec2> = (0..5).map(|i| DVec2::new(i as f64 * 1e-300, 0.0)).collect();
        let (at, msg) = check_scale(&pts, Precision::F64).unwrap_err();
        assert_eq!(at, None);
        assert!(msg.contains("underflow"), "{msg}");
        // Coincident data are another error, reported by the fits.
        assert!(check_scale(&[DVec2::ONE; 3], Precision::F64).is_ok());
    }

    #[test]
    fn designs_far_from_the_data_are_refused_for_f32() {
        let data: Vec<DVec2> = (0..82).map(|i| DVec2::new(i as f64 / 81.0, 0.0)).collect();
        assert!(check_design_scale(&[0.5, 0.1, 1.0, -0.2], &data).is_ok());
        let (k, msg) = check_design_scale(&[0.5, 3.4e38, 1.0, -0.2], &data).unwrap_err();
        assert_eq!(k, 1);
        assert!(msg.contains("overflow f32"), "{msg}");
    }
}
