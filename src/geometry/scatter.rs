//! The scatter of sampled data: an estimate of the standard deviation of the noise normal to an
//! ordered contour (an aerofoil, a section of a blade cloud), so that a report can say when a
//! tolerance asks for more than the data holds (`docs/ARCHITECTURE.md §2.13`).
//!
//! **Method.** A smooth curve is locally a polynomial; noise is not. Around every point `p_i`
//! with [`HALF_WINDOW`] neighbours on each side (`m = 2 HALF_WINDOW + 1` points), the window is
//! put in a local frame: `s` along the chord `p_{i+k} - p_{i-k}` of the window, `h` normal to
//! it, both from `p_i` and divided by the window's half chord `w`. A polynomial `h(s)` of even
//! degree [`DEGREE`] is fitted by least squares to the `m` points, and the residual at the
//! centre, `r_i = h_i - ĥ(s_i)`, is divided by `sqrt(1 - H_ii)` (`H_ii` the centre's leverage,
//! the diagonal of the hat matrix `X (XᵀX)⁻¹ Xᵀ`): for independent noise of deviation `σ`
//! normal to the curve, `r_i / sqrt(1 - H_ii)` has deviation `σ` whatever the spacing, so the
//! fit's degrees of freedom and non-uniform spacing are accounted for. Noise along the curve
//! moves a point along the fitted polynomial and changes `h` only by the local slope, which the
//! frame keeps small. The scale of the scaled residuals is their root mean square after
//! clipping at 3 deviations (corrected for the clip, iterated from the median absolute
//! deviation's scale): consistent for Gaussian and for rounding noise, as efficient as the
//! root mean square, blind to a few outliers.
//!
//! **Curvature.** Where the window is large against the curve's own length scale (the leading
//! edge of a file with 60 points a side) the polynomial leaves a bias, which grows
//! geometrically towards the leading edge and, in 20 % of the windows, would lift the median
//! by half. Each window therefore also carries a bias indicator: the change of the centre's
//! fitted value from degree `DEGREE - 2` to `DEGREE`, divided by its noise deviation
//! `sqrt(H_ii - H'_ii)`. The two fits are nested, so under pure noise the indicator and the
//! residual are orthogonal projections of the noise (independent for Gaussian noise), both of
//! deviation `σ`, and selecting windows by the indicator does not bias the residuals. Where the
//! lower degree misses the curve by more than [`BIAS_CUT`] deviations, the higher degree cannot
//! be trusted to a deviation either, and the window is left out. The estimate iterates (the
//! scale of the residuals of the windows whose indicator is within `BIAS_CUT` of the last
//! scale) until the kept set stops changing, but always keeps at least half the windows, those
//! of the smallest indicators: a noiseless contour then reports the bias that remains, an
//! upper bound of its scatter (about 1e-13 of the chord on a 200-point NACA contour).
//!
//! A window is left out when the contour folds back in its frame (`s` not strictly
//! increasing: a sharp corner, a leading edge sampled too coarsely, duplicated points, noise
//! larger than the spacing) or its two halves turn by more than 90°. The first and last
//! `HALF_WINDOW` points are never centres, so the trailing edge, sharp or blunt, does not enter
//! as a corner.
//!
//! **Rounding.** A file printed with `d` decimals carries a rounding error uniform over one
//! unit of the last decimal, `q = 10^-d`: a scatter of `q / √12` per coordinate (2.9e-7 for the
//! UIUC files' 6 decimals), which the estimator measures like any noise (the residual mixes
//! several rounding errors; the clipped root mean square is consistent for it). The
//! coarsest such `q` that every coordinate is a multiple of is reported as
//! [`Scatter::resolution`], so that a caller can tell a rounding floor from measurement noise.
//!
//! **Sections.** A section of a 3D cloud is a planar curve: [`section_scatter`] projects it onto
//! its best-fit plane (the two leading principal axes of its points) and applies the same
//! estimator. Noise normal to the plane is not counted; for isotropic noise its in-plane
//! normal part has the same deviation.
//!
//! **Truth** (the tests below, NACA 0012, 4412 and 23015 at 200 points with cosine, uniform and
//! jittered spacing): noiseless f64 contours give under 1e-9 of the chord, contours rounded to 6
//! decimals their rounding scatter within 30 % (in practice 10 %), and added Gaussian noise of
//! 1e-5, 1e-4 and 1e-3 of the chord is recovered within 30 % (in practice within 10 %).

use super::points::Grid;
use glam::{DVec2, DVec3};
use nalgebra::{DMatrix, DVector, Matrix3};

/// Neighbours on each side of a window's centre point.
pub const HALF_WINDOW: usize = 5;

/// Degree of the local polynomial (even: the bias indicator compares it with `DEGREE - 2`,
/// since on a symmetric window an odd term leaves the centre's fitted value as it is).
pub const DEGREE: usize = 6;

/// The fewest usable windows for an estimate: below it [`Scatter::sigma`] is `None`.
pub const MIN_WINDOWS: usize = 5;

/// How far, in estimated deviations, a window's bias indicator may be for its residual to
/// count.
pub const BIAS_CUT: f64 = 3.0;

/// Residuals past this many deviations are outliers, not noise.
const CLIP: f64 = 3.0;

/// The variance of the standard normal clipped to `±CLIP`: `1 - 2 CLIP φ(CLIP) / (2 Φ(CLIP) - 1)`.
const CLIPPED_VARIANCE: f64 = 0.973_336_924_662_541_5;

/// Median absolute deviation → standard deviation for Gaussian data (`1 / Φ⁻¹(3/4)`).
const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;

/// Above this many points a contour's chord is found by two farthest-point sweeps, not by all
/// pairs.
const EXACT_CHORD_POINTS: usize = 2048;

/// The estimated scatter of one contour or section.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scatter {
    /// The noise's standard deviation normal to the curve, in model units; `None` when fewer
    /// than `MIN_WINDOWS` windows could be used (a contour of fewer than
    /// `2 HALF_WINDOW + MIN_WINDOWS` points, or one that folds everywhere).
    pub sigma: Option<f64>,
    /// The contour's chord: the largest distance between two of its points, in model units.
    pub chord: f64,
    /// Windows (centre points) the estimate used; 0 without an estimate.
    pub used: usize,
    /// Whether more than half the windows departed from their polynomial by more than
    /// `BIAS_CUT` deviations, so that only the floor of half, the smoothest, was used: the
    /// contour is rough or curved beyond the windows' resolution over most of its length, and
    /// `sigma` is the scatter of its smoothest half (an upper bound of a noiseless contour's,
    /// a lower bound of a contour rough everywhere).
    pub limited: bool,
    /// Points of the contour.
    pub points: usize,
    /// The coarsest step `10^-d` (`d` = 0 … 9 decimals) that every coordinate of the input is
    /// a multiple of, if any: the printing's resolution, whose rounding alone is a scatter of
    /// `resolution / √12` ([`Scatter::rounding`]).
    pub resolution: Option<f64>,
}

impl Scatter {
    /// The scatter as a fraction of the chord.
    #[must_use]
    pub fn relative(&self) -> Option<f64> {
        self.sigma.filter(|_| self.chord > 0.0).map(|s| s / self.chord)
    }

    /// The scatter the input's rounding alone makes, `resolution / √12`, in model units.
    #[must_use]
    pub fn rounding(&self) -> Option<f64> {
        self.resolution.map(|q| q / 12f64.sqrt())
    }
}

/// The scatter of an ordered contour (see the module doc for the method).
#[must_use]
pub fn curve_scatter(points: &[DVec2]) -> Scatter {
    let pairs = windows(points, HALF_WINDOW, DEGREE);
    let (sigma, used, limited) = if pairs.len() >= MIN_WINDOWS {
        let (sigma, used, limited) = estimate(&pairs);
        (Some(sigma), used, limited)
    } else {
        (None, 0, false)
    };
    Scatter {
        sigma,
        chord: chord(points),
        used,
        limited,
        points: points.len(),
        resolution: resolution(points.iter().flat_map(|p| [p.x, p.y])),
    }
}

/// The scatter of every section of a sectioned cloud (`points` section-major, `grid`'s
/// shape, each section in its order around the contour), each projected onto its best-fit
/// plane and estimated as a contour; the resolution is that of the 3D coordinates.
#[must_use]
pub fn section_scatter(points: &[DVec3], grid: Grid) -> Vec<Scatter> {
    points
        .chunks(grid.per_section.max(1))
        .take(grid.sections)
        .map(|section| Scatter {
            resolution: resolution(section.iter().flat_map(|p| [p.x, p.y, p.z])),
            ..curve_scatter(&project_to_plane(section))
        })
        .collect()
}

/// Every usable window's scaled centre residual and bias indicator (see [`centre_residual`]).
fn windows(points: &[DVec2], k: usize, degree: usize) -> Vec<(f64, f64)> {
    if points.len() < 2 * k + 1 {
        return Vec::new();
    }
    (k..points.len() - k)
        .filter_map(|i| centre_residual(&points[i - k..=i + k], k, degree))
        .collect()
}

/// The estimate from windows' `(residual, indicator)` pairs: the scale ([`scale`]) of the
/// residuals of the windows whose indicator is within `BIAS_CUT` of the last scale, iterated;
/// at least half of the windows, those of the smallest indicators, are kept. Returns
/// `(sigma, used, limited)`, `limited` when that floor held.
fn estimate(pairs: &[(f64, f64)]) -> (f64, usize, bool) {
    let mut by_indicator = pairs.to_vec();
    by_indicator.sort_by(|a, b| a.1.total_cmp(&b.1));
    let least = pairs.len().div_ceil(2);
    let mut sigma = scale(pairs);
    let mut kept = pairs.len();
    let mut limited = false;
    for _ in 0..32 {
        let within = by_indicator.partition_point(|p| p.1 <= BIAS_CUT * sigma);
        limited = within < least;
        let n = within.max(least);
        sigma = scale(&by_indicator[..n]);
        if n == kept {
            break;
        }
        kept = n;
    }
    (sigma, kept, limited)
}

/// The scale of the residuals (the first of each pair): their root mean square after clipping
/// at `CLIP` deviations, divided by the root of the clipped standard normal's variance, the
/// clip iterated from the median absolute deviation's scale. Consistent for Gaussian noise and
/// for any other noise without tails past the clip (rounding), as efficient as the root mean
/// square, and blind to a minority of outliers.
fn scale(pairs: &[(f64, f64)]) -> f64 {
    let mut r: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    let mut sigma = MAD_TO_SIGMA * median(&mut r);
    for _ in 0..32 {
        let (sum, n) = r
            .iter()
            .filter(|&&x| x <= CLIP * sigma)
            .fold((0.0, 0usize), |(s, n), &x| (s + x * x, n + 1));
        if n == 0 {
            break;
        }
        let next = (sum / n as f64 / CLIPPED_VARIANCE).sqrt();
        if next == sigma {
            break;
        }
        sigma = next;
    }
    sigma
}

/// The scaled residual at `window[centre]` of the local polynomial fit of `degree` (even),
/// `|r| / sqrt(1 - H_cc)`, and its bias indicator, `|ŷ_d - ŷ_(d-2)| / sqrt(H_cc - H'_cc)`
/// (the centre's fitted values and leverages at `degree` and `degree - 2`), both in model
/// units; `None` for a window that folds, turns too far or is degenerate.
fn centre_residual(window: &[DVec2], centre: usize, degree: usize) -> Option<(f64, f64)> {
    let (first, last) = (window[0], window[window.len() - 1]);
    let span = last - first;
    let w = 0.5 * span.length();
    if !(w > 0.0 && w.is_finite()) {
        return None;
    }
    let t = span / (2.0 * w);
    let n = t.perp();
    let origin = window[centre];
    // Turning: the chords of the window's two halves may not point more than 90° apart.
    if (origin - first).dot(last - origin) <= 0.0 {
        return None;
    }
    let q = degree + 1;
    let mut gram = DMatrix::<f64>::zeros(q, q);
    let mut rhs = DVector::<f64>::zeros(q);
    let mut prev = f64::NEG_INFINITY;
    let mut x = DVector::<f64>::zeros(q);
    for p in window {
        let d = *p - origin;
        let (s, h) = (d.dot(t) / w, d.dot(n) / w);
        if s <= prev {
            return None;
        }
        prev = s;
        let mut power = 1.0;
        for j in 0..q {
            x[j] = power;
            power *= s;
        }
        gram.ger(1.0, &x, &x, 1.0);
        rhs.axpy(h, &x, 1.0);
    }
    // The centre sits at s = 0: its fitted value is beta[0], its basis row e_0, its leverage
    // the (0, 0) entry of the inverse Gram matrix. The monomials nest, so the lower degree's
    // Gram matrix is the leading block.
    let fit = |m: usize| -> Option<(f64, f64)> {
        let chol = gram.view((0, 0), (m, m)).into_owned().cholesky()?;
        let beta = chol.solve(&rhs.rows(0, m).into_owned());
        let mut e0 = DVector::<f64>::zeros(m);
        e0[0] = 1.0;
        Some((beta[0], chol.solve(&e0)[0]))
    };
    let (value, leverage) = fit(q)?;
    let (low_value, low_leverage) = fit(q - 2)?;
    let (free, extra) = (1.0 - leverage, leverage - low_leverage);
    if !(free > 1e-9 && extra > 1e-9) {
        return None;
    }
    // h = 0 at the centre: the residual is -value.
    let r = value.abs() / free.sqrt() * w;
    let indicator = (value - low_value).abs() / extra.sqrt() * w;
    (r.is_finite() && indicator.is_finite()).then_some((r, indicator))
}

/// The median of `v` (reordered), 0 for an empty slice.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let m = *v.select_nth_unstable_by(mid, f64::total_cmp).1;
    if v.len() % 2 == 1 {
        m
    } else {
        let below = v[..mid].iter().copied().fold(f64::NEG_INFINITY, f64::max);
        0.5 * (below + m)
    }
}

/// The largest distance between two points: all pairs up to [`EXACT_CHORD_POINTS`] points,
/// otherwise two farthest-point sweeps (exact for an aerofoil, whose farthest pair is the
/// trailing and the leading edge).
fn chord(points: &[DVec2]) -> f64 {
    let Some(&p0) = points.first() else {
        return 0.0;
    };
    if points.len() <= EXACT_CHORD_POINTS {
        return points
            .iter()
            .enumerate()
            .flat_map(|(i, a)| points[i + 1..].iter().map(move |b| a.distance(*b)))
            .fold(0.0, f64::max);
    }
    let farthest = |from: DVec2| {
        points
            .iter()
            .copied()
            .max_by(|a, b| a.distance_squared(from).total_cmp(&b.distance_squared(from)))
            .unwrap_or(from)
    };
    let a = farthest(p0);
    let b = farthest(a);
    a.distance(b)
}

/// The coarsest decimal step `10^-d`, `d` = 0 … 9, that every value is a multiple of.
fn resolution(values: impl Iterator<Item = f64> + Clone) -> Option<f64> {
    (0..=9).find_map(|d| {
        let scale = 10f64.powi(d);
        values
            .clone()
            .all(|v| {
                let x = v * scale;
                x.abs() < 1e12 && (x - x.round()).abs() <= (4.0 * f64::EPSILON * x.abs()).max(1e-6)
            })
            .then(|| 10f64.powi(-d))
    })
}

/// The points in the frame of their best-fit plane: coordinates along its two leading
/// principal axes, from the centroid, in the points' order.
fn project_to_plane(points: &[DVec3]) -> Vec<DVec2> {
    if points.is_empty() {
        return Vec::new();
    }
    let c = points.iter().copied().sum::<DVec3>() / points.len() as f64;
    let mut cov = Matrix3::<f64>::zeros();
    for p in points {
        let d = *p - c;
        let v = nalgebra::Vector3::new(d.x, d.y, d.z);
        cov += v * v.transpose();
    }
    let eig = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let axis = |k: usize| {
        let v = eig.eigenvectors.column(order[k]);
        DVec3::new(v[0], v[1], v[2])
    };
    let (e1, e2) = (axis(0), axis(1));
    points
        .iter()
        .map(|p| {
            let d = *p - c;
            DVec2::new(d.dot(e1), d.dot(e2))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Gaussian, Naca, NacaOptions, Spacing};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn naca(code: &str, points: usize, spacing: Spacing) -> Vec<DVec2> {
        Naca::parse(code)
            .unwrap()
            .contour(&NacaOptions {
                points,
                spacing,
                closed_te: false,
            })
            .unwrap()
    }

    /// NACA `code` in the four spacings the scatter tests run on: 200 points cosine, uniform and
    /// irregular (drawn with `seed`), and 122 points cosine.
    fn spacings(code: &str, seed: u64) -> [(&'static str, Vec<DVec2>); 4] {
        [
            ("cosine", naca(code, 200, Spacing::Cosine)),
            ("uniform", naca(code, 200, Spacing::Uniform)),
            ("irregular", irregular(code, 200, seed)),
            ("coarse", naca(code, 122, Spacing::Cosine)),
        ]
    }

    /// A contour whose stations are drawn irregularly: cosine spacing with every station's
    /// angle jittered by up to 40 % of a step.
    fn irregular(code: &str, points: usize, seed: u64) -> Vec<DVec2> {
        let n = Naca::parse(code).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let last = (points - 1) as f64;
        (0..points)
            .map(|i| {
                let jitter = if i == 0 || i + 1 == points {
                    0.0
                } else {
                    rng.random_range(-0.4..0.4)
                };
                let s = (i as f64 + jitter) / last;
                let x = 0.5 * (1.0 + (2.0 * std::f64::consts::PI * s).cos());
                n.surface(x, s <= 0.5, false)
            })
            .collect()
    }

    fn noisy(points: &[DVec2], sd: f64, seed: u64) -> Vec<DVec2> {
        let g = Gaussian::new(sd).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        points
            .iter()
            .map(|p| *p + DVec2::new(g.sample(&mut rng), g.sample(&mut rng)))
            .collect()
    }

    fn rounded(points: &[DVec2], decimals: i32) -> Vec<DVec2> {
        let s = 10f64.powi(decimals);
        points
            .iter()
            .map(|p| DVec2::new((p.x * s).round() / s, (p.y * s).round() / s))
            .collect()
    }

    /// Noiseless f64 contours scatter under 1e-9 of the chord: what the local polynomials
    /// leave of the curvature where it is smallest.
    #[test]
    fn scatter_of_noiseless_contours_is_negligible() {
        for code in ["0012", "4412", "23015"] {
            for (name, pts) in [
                ("cosine", naca(code, 200, Spacing::Cosine)),
                ("uniform", naca(code, 200, Spacing::Uniform)),
                ("irregular", irregular(code, 200, 7)),
            ] {
                let s = curve_scatter(&pts);
                let rel = s.relative().unwrap();
                eprintln!("scatter noiseless {code} {name}: {rel:.3e} ({} windows)", s.used);
                assert!(rel < 1e-9 && s.limited, "{code} {name}: {rel:e}");
                assert!(s.used >= 85 && (s.chord - 1.0).abs() < 1e-2);
            }
        }
    }

    /// Rounded to 6 decimals (the UIUC files), a contour scatters at its rounding,
    /// 1e-6 / √12: within 30 % on average over four placements of the grid of decimals, within
    /// 50 % each, and the resolution is found.
    #[test]
    fn scatter_of_rounded_contours_is_the_rounding() {
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        for code in ["0012", "4412", "23015"] {
            for (name, pts) in spacings(code, 11) {
                let mut mean = 0.0;
                for _ in 0..4 {
                    let shift = DVec2::new(rng.random_range(0.0..1e-3), rng.random_range(0.0..1e-3));
                    let moved: Vec<DVec2> = pts.iter().map(|p| *p + shift).collect();
                    let s = curve_scatter(&rounded(&moved, 6));
                    assert_eq!(s.resolution, Some(1e-6));
                    let ratio = s.sigma.unwrap() / s.rounding().unwrap();
                    assert!((ratio - 1.0).abs() < 0.5, "{code} {name}: {ratio}");
                    mean += ratio / 4.0;
                }
                eprintln!("scatter rounded {code} {name}: {mean:.3} of the rounding");
                assert!((mean - 1.0).abs() < 0.3, "{code} {name}: {mean}");
            }
        }
    }

    /// Gaussian noise of 1e-5, 1e-4 and 1e-3 of the chord is recovered within 30 %, on cosine,
    /// uniform, irregular and coarse spacing, for every one of several seeds.
    #[test]
    fn scatter_recovers_gaussian_noise() {
        let mut worst: f64 = 0.0;
        for code in ["0012", "4412", "23015"] {
            for (name, pts) in spacings(code, 5) {
                for sd in [1e-5, 1e-4, 1e-3] {
                    for seed in 0..4 {
                        let s = curve_scatter(&noisy(&pts, sd, seed));
                        let ratio = s.sigma.unwrap() / sd;
                        eprintln!(
                            "scatter {code} {name} sd {sd:e} seed {seed}: ratio {ratio:.3} ({} windows)",
                            s.used
                        );
                        worst = worst.max((ratio - 1.0).abs());
                        assert!(!s.limited, "{code} {name} {sd:e} {seed}");
                        assert!((ratio - 1.0).abs() < 0.3, "{code} {name} {sd:e} {seed}: {ratio}");
                    }
                }
            }
        }
        eprintln!("scatter worst relative error {worst:.3}");
    }

    /// Too few points give no estimate; the chord and the count are still reported.
    #[test]
    fn scatter_of_short_contours_is_unknown() {
        let pts = naca("0012", 12, Spacing::Cosine);
        let s = curve_scatter(&pts);
        assert_eq!((s.sigma, s.points, s.used), (None, 12, 0));
        assert!(s.chord > 0.95);
        assert_eq!(curve_scatter(&[]).sigma, None);
    }

    /// A contour placed in space as a blade section (scaled, turned, in a plane tilted out of
    /// the coordinate planes) with 3D noise: the section estimator recovers the noise, per
    /// section, in model units, with the section's chord.
    #[test]
    fn section_scatter_recovers_noise_in_space() {
        let base = naca("4412", 160, Spacing::Cosine);
        let base_chord = curve_scatter(&base).chord;
        let g = Gaussian::standard();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (chords, sds) = ([3.0, 2.0, 1.5], [3e-4, 2e-3, 1e-5]);
        let mut cloud = Vec::new();
        for (k, (&c, &sd)) in chords.iter().zip(&sds).enumerate() {
            let (sa, ca) = (0.3 * k as f64 + 0.2f64).sin_cos();
            let (sb, cb) = 0.2f64.sin_cos();
            let (e1, e2) = (DVec3::new(ca, sa, 0.0), DVec3::new(-sa * cb, ca * cb, sb));
            let origin = DVec3::new(0.1, -0.2, 10.0 * k as f64);
            for p in &base {
                let e = DVec3::new(g.sample(&mut rng), g.sample(&mut rng), g.sample(&mut rng));
                cloud.push(origin + c * (p.x * e1 + p.y * e2) + sd * e);
            }
        }
        let grid = Grid {
            sections: 3,
            per_section: base.len(),
        };
        let s = section_scatter(&cloud, grid);
        assert_eq!(s.len(), 3);
        for ((s, &c), &sd) in s.iter().zip(&chords).zip(&sds) {
            let ratio = s.sigma.unwrap() / sd;
            eprintln!("scatter section chord {:.3}: ratio {ratio:.3}", s.chord);
            assert!((ratio - 1.0).abs() < 0.3, "{ratio}");
            assert!((s.chord / (c * base_chord) - 1.0).abs() < 0.01, "{}", s.chord);
            assert_eq!((s.points, s.resolution), (base.len(), None));
        }
    }
}
