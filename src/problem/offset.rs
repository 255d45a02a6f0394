//! Offset metrics (`docs/ARCHITECTURE.md` §2.4): the distance of every data point to a chain or
//! grid, and the summary figures reports carry (`sum_sq`, `sum`, `rms`, `max`, `max_at`).

use crate::bezier::Vector;
use crate::chain::shape::{Basis, CurveShape, GridShape, Shape};
use crate::chain::{CurveChain, PatchGrid};
use crate::closest::{Foot, FootOptions};
use crate::error::{Error, Result};
use crate::keyword::keywords;
use serde::{Deserialize, Serialize};

/// How the offset of a data point from the shape is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Metric {
    /// The true distance to the closest point of the shape (foot point by sampling, then
    /// Newton's method, parameters clamped to the domain). The default.
    #[default]
    Closest,
    /// The distance to the shape at a fixed parameter per data point (the paper's literal
    /// "corresponding points"). For curves the parameter is the normalised chord length,
    /// see [`chord_length_params`].
    Corresponding,
}

keywords!(Metric, "metric", { Closest => "closest", Corresponding => "corresponding" });

/// Summary of the offsets `e_j` of `n` data points from a shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffsetStats<P> {
    /// The metric the offsets were measured with.
    pub metric: Metric,
    /// Number of data points `n`.
    pub points: usize,
    /// `Σ e_j²`, in squared model units.
    pub sum_sq: f64,
    /// `Σ e_j`, in model units.
    pub sum: f64,
    /// `sqrt(sum_sq / n)`, in model units.
    pub rms: f64,
    /// `max e_j`, in model units.
    pub max: f64,
    /// Index of the data point with the largest offset.
    pub max_index: usize,
    /// The data point with the largest offset.
    pub max_at: P,
}

impl<P: Vector> OffsetStats<P> {
    /// The summary of the squared offsets `dist_sq[j]` of `points[j]` (at least one).
    #[must_use]
    pub fn from_dist_sq(metric: Metric, dist_sq: &[f64], points: &[P]) -> Self {
        debug_assert_eq!(dist_sq.len(), points.len(), "one offset per data point");
        debug_assert!(!points.is_empty(), "offset statistics of no points");
        let mut s = OffsetStats {
            metric,
            points: points.len(),
            sum_sq: 0.0,
            sum: 0.0,
            rms: 0.0,
            max: 0.0,
            max_index: 0,
            max_at: points.first().copied().unwrap_or(P::ZERO),
        };
        let mut worst = -1.0;
        for (j, &d2) in dist_sq.iter().enumerate() {
            s.sum_sq += d2;
            s.sum += d2.sqrt();
            if d2 > worst {
                worst = d2;
                s.max_index = j;
            }
        }
        s.max = worst.max(0.0).sqrt();
        s.max_at = points[s.max_index];
        s.rms = (s.sum_sq / points.len().max(1) as f64).sqrt();
        s
    }
}

/// Refuse empty point sets and points with non-finite coordinates.
pub(crate) fn check_points<P: Vector>(points: &[P]) -> Result<()> {
    if points.is_empty() {
        return Err(Error::invalid("no data points"));
    }
    if let Some(j) = points.iter().position(|p| !p.is_finite_point()) {
        return Err(Error::invalid(format!(
            "data point {j} has a non-finite coordinate"
        )));
    }
    Ok(())
}

/// Normalised chord-length parameters: `t_0 = 0`, `t_j = L_j / L` with `L_j` the length of the
/// polyline `q_0 … q_j` and `L` its total length, so `t_{n-1} = 1`. Coincident neighbours share
/// a parameter. These are the fixed parameters of [`Metric::Corresponding`] for curves and the
/// first start of every curve fit.
pub fn chord_length_params<P: Vector>(points: &[P]) -> Result<Vec<f64>> {
    exponent_params(points, 1.0)
}

/// Normalised parameters with exponent `alpha` (Lee 1989): `t_j` proportional to
/// `Σ_{i ≤ j} |q_i - q_{i-1}|^alpha`, from 0 to 1. `alpha = 1` is chord length, `0.5`
/// centripetal, `0` uniform (coincident neighbours always share a parameter).
pub fn exponent_params<P: Vector>(points: &[P], alpha: f64) -> Result<Vec<f64>> {
    check_points(points)?;
    if !(0.0..=1.0).contains(&alpha) {
        return Err(Error::invalid(format!(
            "parameter exponent {alpha} is outside [0, 1]"
        )));
    }
    let mut acc = Vec::with_capacity(points.len());
    let mut len = 0.0;
    acc.push(0.0);
    for w in points.windows(2) {
        let step = (w[1] - w[0]).length();
        if step > 0.0 {
            len += step.powf(alpha);
        }
        acc.push(len);
    }
    if !(len > 0.0) || !len.is_finite() {
        return Err(Error::invalid(
            "the data points all coincide: chord-length parameters are undefined",
        ));
    }
    for t in &mut acc {
        *t /= len;
    }
    if let Some(last) = acc.last_mut() {
        *last = 1.0;
    }
    Ok(acc)
}

/// The largest ratio, over consecutive data points `q_j`, `q_{j+1}`, of the chain's arc length
/// between their parameters `t_j`, `t_{j+1}` to their distance `|q_{j+1} - q_j|` (pairs closer
/// than `1e-12` times the chain's length are skipped).
///
/// A chain that follows ordered data has a ratio near 1 (a little above where the data are
/// sparse and curved). A closest-point fit can also leave a stretch of chain that no data point
/// claims, free to loop away from the data or fold back on itself: between the two data
/// points around it the arc is far longer than their distance, and the ratio shows it (loops
/// and folds seen on aerofoil fits gave 5 to 3000). Arc lengths come from 128 chords per
/// segment.
pub fn span_ratio<P: Vector>(chain: &CurveChain<P>, points: &[P], params: &[f64]) -> f64 {
    debug_assert_eq!(points.len(), params.len(), "span_ratio: one parameter per point");
    // Cumulative arc length on SPAN_CHORDS chords per segment, interpolated linearly in t.
    const SPAN_CHORDS: usize = 128;
    let layout = chain.layout();
    let segments = layout.segments();
    let per = SPAN_CHORDS * segments;
    let mut cum = Vec::with_capacity(per + 1);
    cum.push(0.0);
    let mut total = 0.0;
    for k in 0..segments {
        let seg = chain.segment(k);
        let mut prev = seg.eval(0.0);
        for i in 1..=SPAN_CHORDS {
            let p = seg.eval(i as f64 / SPAN_CHORDS as f64);
            total += (p - prev).length();
            cum.push(total);
            prev = p;
        }
    }
    // Global t to the chord table: segment k covers entries k*SPAN_CHORDS ..= (k+1)*SPAN_CHORDS.
    let arc = |t: f64| {
        let (k, u) = layout.locate(t);
        let x = (k as f64 + u) * SPAN_CHORDS as f64;
        let i = (x as usize).min(per - 1);
        cum[i] + (cum[i + 1] - cum[i]) * (x - i as f64)
    };
    let mut ratio: f64 = 0.0;
    for (w, t) in points.windows(2).zip(params.windows(2)) {
        let chord = (w[1] - w[0]).length();
        if chord > 1e-12 * total {
            ratio = ratio.max((arc(t[1]) - arc(t[0])).abs() / chord);
        }
    }
    ratio
}

/// `Ok` when `points` pass [`check_points`] and `design` has the design points of `shape`'s
/// layout: what every offset measure of a shape asks of its inputs.
fn check_shape_inputs<S: Shape<K>, const K: usize>(
    shape: &S,
    design: &[S::Point],
    points: &[S::Point],
) -> Result<()> {
    check_points(points)?;
    if design.len() != shape.design_count() {
        return Err(Error::invalid(format!(
            "{} design points given, the layout needs {}",
            design.len(),
            shape.design_count()
        )));
    }
    Ok(())
}

/// Closest-point offsets of `points` from any shape, with the foot points.
pub fn shape_offsets<S: Shape<K>, const K: usize>(
    shape: &S,
    design: &[S::Point],
    points: &[S::Point],
    opts: &FootOptions,
) -> Result<(OffsetStats<S::Point>, Vec<Foot<K>>)> {
    check_shape_inputs(shape, design, points)?;
    let feet = crate::closest::feet(shape, design, points, None, opts);
    let d2: Vec<f64> = feet.iter().map(|f| f.dist_sq).collect();
    Ok((OffsetStats::from_dist_sq(Metric::Closest, &d2, points), feet))
}

/// [`shape_offsets`] of `points` from a chain, every segment sampled at 48 parameters.
fn chain_offsets<P: Vector>(chain: &CurveChain<P>, points: &[P]) -> Result<(OffsetStats<P>, Vec<Foot<1>>)> {
    let opts = FootOptions {
        samples: 48,
        ..FootOptions::default()
    };
    shape_offsets(
        &CurveShape::<P>::new(chain.layout().clone()),
        chain.design(),
        points,
        &opts,
    )
}

/// The closest-point offset of every point from a chain, in the points' order (the same
/// foot-point search as [`offset_stats`]).
pub fn point_offsets<P: Vector>(chain: &CurveChain<P>, points: &[P]) -> Result<Vec<f64>> {
    let (_, feet) = chain_offsets(chain, points)?;
    Ok(feet.iter().map(|f| f.dist_sq.sqrt()).collect())
}

/// Closest-point offsets of `points` from a chain (true foot points: every segment sampled at
/// 48 parameters, then Newton's method, parameters clamped to `[0, 1]`).
pub fn offset_stats<P: Vector>(chain: &CurveChain<P>, points: &[P]) -> Result<OffsetStats<P>> {
    Ok(chain_offsets(chain, points)?.0)
}

/// Closest-point offsets of `points` from a patch grid (every patch sampled on a 13 x 13
/// grid, then Newton's method, parameters clamped to `[0, 1]²`).
pub fn grid_offset_stats<P: Vector>(grid: &PatchGrid<P>, points: &[P]) -> Result<OffsetStats<P>> {
    let opts = FootOptions {
        samples: 12,
        ..FootOptions::default()
    };
    let shape = GridShape::<P>::new(grid.layout().clone());
    Ok(shape_offsets(&shape, grid.design(), points, &opts)?.0)
}

/// Offsets at fixed parameters (the corresponding-points metric): `e_j = |C(t_j) - q_j|`.
pub fn corresponding_offsets<S: Shape<K>, const K: usize>(
    shape: &S,
    design: &[S::Point],
    points: &[S::Point],
    params: &[[f64; K]],
) -> Result<OffsetStats<S::Point>> {
    check_shape_inputs(shape, design, points)?;
    if params.len() != points.len() {
        return Err(Error::invalid(format!(
            "{} parameters given for {} data points",
            params.len(),
            points.len()
        )));
    }
    let mut b = Basis::new();
    let d2: Vec<f64> = points
        .iter()
        .zip(params)
        .map(|(&q, &t)| {
            shape.basis(t, 0, &mut b);
            (shape.jet(&b, design, 0).point - q).length_squared()
        })
        .collect();
    Ok(OffsetStats::from_dist_sq(Metric::Corresponding, &d2, points))
}

/// Corresponding-point offsets of `points` from a chain at their chord-length parameters.
pub fn corresponding_stats<P: Vector>(chain: &CurveChain<P>, points: &[P]) -> Result<OffsetStats<P>> {
    let params: Vec<[f64; 1]> = chord_length_params(points)?.into_iter().map(|t| [t]).collect();
    let shape = CurveShape::<P>::new(chain.layout().clone());
    corresponding_offsets(&shape, chain.design(), points, &params)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity};
    use glam::DVec2;

    #[test]
    fn stats_of_points_on_and_off_a_line() {
        // A straight chain from (0,0) to (1,0); points at known heights above it.
        let layout = ChainLayout::uniform(3, 2, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 / (layout.design_count() - 1) as f64, 0.0))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let pts = vec![
            DVec2::new(0.1, 0.0),
            DVec2::new(0.5, 0.03),
            DVec2::new(0.8, -0.04),
            DVec2::new(1.3, 0.0), // beyond the end: offset 0.3
        ];
        let s = offset_stats(&chain, &pts).unwrap();
        let exact = [0.0, 0.03, 0.04, 0.3];
        let sum_sq: f64 = exact.iter().map(|e| e * e).sum();
        assert!((s.sum_sq - sum_sq).abs() < 1e-15);
        assert!((s.sum - exact.iter().sum::<f64>()).abs() < 1e-14);
        assert!((s.max - 0.3).abs() < 1e-14 && s.max_index == 3 && s.max_at == pts[3]);
        assert!((s.rms - (sum_sq / 4.0).sqrt()).abs() < 1e-15);
        assert_eq!(s.metric, Metric::Closest);
    }

    #[test]
    fn chord_length_parameters() {
        let pts = vec![
            DVec2::ZERO,
            DVec2::new(3.0, 4.0),
            DVec2::new(3.0, 4.0),
            DVec2::new(3.0, 9.0),
        ];
        assert_eq!(chord_length_params(&pts).unwrap(), vec![0.0, 0.5, 0.5, 1.0]);
        assert_eq!(exponent_params(&pts, 0.0).unwrap(), vec![0.0, 0.5, 0.5, 1.0]);
        let c = exponent_params(&pts, 0.5).unwrap();
        assert!((c[1] - 5f64.sqrt() / (5f64.sqrt() + 5f64.sqrt())).abs() < 1e-15);
        assert!(exponent_params(&pts, 1.5).is_err());
        assert!(chord_length_params(&[DVec2::ONE; 3]).is_err());
        assert!(chord_length_params::<DVec2>(&[]).is_err());
        assert!(chord_length_params(&[DVec2::ZERO, DVec2::new(f64::NAN, 0.0)]).is_err());
    }

    #[test]
    fn corresponding_is_never_below_closest() {
        let layout = ChainLayout::uniform(3, 3, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.2, (i as f64).sin() * 0.3))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let pts: Vec<DVec2> = (0..40)
            .map(|i| {
                let t = i as f64 / 39.0;
                chain.eval(t) + DVec2::new(0.01 * (7.0 * t).sin(), 0.02 * (5.0 * t).cos())
            })
            .collect();
        let c = offset_stats(&chain, &pts).unwrap();
        let r = corresponding_stats(&chain, &pts).unwrap();
        assert!(r.sum_sq >= c.sum_sq && r.max >= c.max);
        assert_eq!(r.metric, Metric::Corresponding);
    }

    #[test]
    fn metric_names_round_trip() {
        for m in [Metric::Closest, Metric::Corresponding] {
            assert_eq!(m.to_string().parse::<Metric>().unwrap(), m);
        }
        assert!("nearest".parse::<Metric>().is_err());
    }
}
