//! NACA 4-digit and 5-digit aerofoils: the standard thickness and camber formulas, sampled
//! around the contour in Selig order.

use crate::error::{Error, Result};
use crate::keyword::keywords;
use glam::DVec2;
use std::f64::consts::PI;

/// How stations are spread along the chord.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Spacing {
    /// `x = (1 + cos φ) / 2` with φ uniform around the contour: dense at both edges.
    #[default]
    Cosine,
    /// `x` uniform along the chord on each surface.
    Uniform,
}
keywords!(Spacing, "spacing", { Cosine => "cosine", Uniform => "uniform" });

/// Options for sampling a NACA contour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NacaOptions {
    /// Total number of contour points (upper TE → LE → lower TE). Default 82.
    pub points: usize,
    /// Station spacing. Default cosine.
    pub spacing: Spacing,
    /// Use the closed-trailing-edge thickness coefficient (−0.1036 instead of −0.1015).
    /// Default false (the standard, slightly open trailing edge).
    pub closed_te: bool,
}

impl Default for NacaOptions {
    fn default() -> Self {
        NacaOptions {
            points: 82,
            spacing: Spacing::Cosine,
            closed_te: false,
        }
    }
}

/// The mean-line family of a NACA section.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Camber {
    /// 4-digit: maximum camber `m` (chord fraction) at `p`.
    Four { m: f64, p: f64 },
    /// 5-digit standard mean line: `r` and `k1` from the table, scaled by the design lift.
    Five { r: f64, k1: f64 },
    /// 5-digit reflex mean line: `r`, `k1` and `k2 / k1`.
    Reflex { r: f64, k1: f64, k21: f64 },
}

/// A NACA 4- or 5-digit section.
#[derive(Clone, Debug, PartialEq)]
pub struct Naca {
    code: String,
    camber: Camber,
    /// Maximum thickness as a fraction of the chord.
    thickness: f64,
}

/// Standard 5-digit mean lines (design lift 0.3): position digit → (r, k1).
const FIVE_STANDARD: [(f64, f64); 5] = [
    (0.0580, 361.400),
    (0.1260, 51.640),
    (0.2025, 15.957),
    (0.2900, 6.643),
    (0.3910, 3.230),
];
/// Reflex 5-digit mean lines (design lift 0.3): position digit 2..=5 → (r, k1, k2/k1).
#[allow(clippy::approx_constant)] // 0.3180 is the tabulated r of the 241 mean line, not 1/π
const FIVE_REFLEX: [(f64, f64, f64); 4] = [
    (0.1300, 51.990, 0.000764),
    (0.2170, 15.793, 0.00677),
    (0.3180, 6.520, 0.0303),
    (0.4410, 3.191, 0.1355),
];

/// The most points a generated contour may have (16 MB of points in memory).
pub const MAX_NACA_POINTS: usize = 1_000_000;

impl Naca {
    /// Parse a designation such as `4413`, `0012`, `23012` or `NACA 23112`.
    pub fn parse(code: &str) -> Result<Naca> {
        let trimmed = code.trim();
        let digits = trimmed
            .strip_prefix("NACA")
            .or_else(|| trimmed.strip_prefix("naca"))
            .unwrap_or(trimmed)
            .trim()
            .trim_start_matches('-');
        let bad = || Error::invalid(format!("'{code}' is not a NACA 4- or 5-digit designation"));
        if !digits.chars().all(|c| c.is_ascii_digit()) {
            return Err(bad());
        }
        let d: Vec<u32> = digits.chars().filter_map(|c| c.to_digit(10)).collect();
        let (camber, thickness) = match d.len() {
            4 => {
                let m = d[0] as f64 / 100.0;
                let p = d[1] as f64 / 10.0;
                if (m == 0.0) != (p == 0.0) {
                    return Err(Error::invalid(format!(
                        "NACA {digits}: camber and its position must both be zero or both non-zero"
                    )));
                }
                (Camber::Four { m, p }, (d[2] * 10 + d[3]) as f64 / 100.0)
            }
            5 => {
                let scale = d[0] as f64 / 2.0; // design lift 3L/20, tables are for 0.3
                let pos = d[1] as usize;
                let camber = match d[2] {
                    0 if (1..=5).contains(&pos) => {
                        let (r, k1) = FIVE_STANDARD[pos - 1];
                        Camber::Five { r, k1: k1 * scale }
                    }
                    1 if (2..=5).contains(&pos) => {
                        let (r, k1, k21) = FIVE_REFLEX[pos - 2];
                        Camber::Reflex {
                            r,
                            k1: k1 * scale,
                            k21,
                        }
                    }
                    _ => {
                        return Err(Error::invalid(format!(
                        "NACA {digits}: no standard 5-digit mean line for position {pos} and reflex digit {}",
                        d[2]
                    )))
                    }
                };
                (camber, (d[3] * 10 + d[4]) as f64 / 100.0)
            }
            _ => return Err(bad()),
        };
        if thickness <= 0.0 {
            return Err(Error::invalid(format!(
                "NACA {digits}: thickness must be positive"
            )));
        }
        Ok(Naca {
            code: digits.to_string(),
            camber,
            thickness,
        })
    }

    /// The designation, e.g. `NACA 4413`.
    #[must_use]
    pub fn name(&self) -> String {
        format!("NACA {}", self.code)
    }

    /// Half-thickness `y_t(x)` at chord fraction `x` in `[0, 1]`.
    #[must_use]
    pub fn half_thickness(&self, x: f64, closed_te: bool) -> f64 {
        let a4 = if closed_te { -0.1036 } else { -0.1015 };
        5.0 * self.thickness * (0.2969 * x.sqrt() + x * (-0.1260 + x * (-0.3516 + x * (0.2843 + x * a4))))
    }

    /// Mean line `y_c(x)` and its slope `dy_c/dx`.
    #[must_use]
    pub fn camber(&self, x: f64) -> (f64, f64) {
        match self.camber {
            Camber::Four { m, p } => {
                if m == 0.0 {
                    (0.0, 0.0)
                } else if x < p {
                    (m / (p * p) * (2.0 * p * x - x * x), 2.0 * m / (p * p) * (p - x))
                } else {
                    let q = (1.0 - p) * (1.0 - p);
                    (
                        m / q * (1.0 - 2.0 * p + 2.0 * p * x - x * x),
                        2.0 * m / q * (p - x),
                    )
                }
            }
            Camber::Five { r, k1 } => {
                if x < r {
                    (
                        k1 / 6.0 * (x * x * x - 3.0 * r * x * x + r * r * (3.0 - r) * x),
                        k1 / 6.0 * (3.0 * x * x - 6.0 * r * x + r * r * (3.0 - r)),
                    )
                } else {
                    (k1 * r * r * r / 6.0 * (1.0 - x), -k1 * r * r * r / 6.0)
                }
            }
            Camber::Reflex { r, k1, k21 } => {
                let r3 = r * r * r;
                let tail = k21 * (1.0 - r).powi(3);
                if x < r {
                    (
                        k1 / 6.0 * ((x - r).powi(3) - tail * x - r3 * x + r3),
                        k1 / 6.0 * (3.0 * (x - r).powi(2) - tail - r3),
                    )
                } else {
                    (
                        k1 / 6.0 * (k21 * (x - r).powi(3) - tail * x - r3 * x + r3),
                        k1 / 6.0 * (3.0 * k21 * (x - r).powi(2) - tail - r3),
                    )
                }
            }
        }
    }

    /// The upper (`upper = true`) or lower surface point at chord station `x`, thickness
    /// applied perpendicular to the mean line.
    #[must_use]
    pub fn surface(&self, x: f64, upper: bool, closed_te: bool) -> DVec2 {
        let yt = self.half_thickness(x, closed_te);
        let (yc, slope) = self.camber(x);
        let theta = slope.atan();
        let sign = if upper { 1.0 } else { -1.0 };
        DVec2::new(x - sign * yt * theta.sin(), yc + sign * yt * theta.cos())
    }

    /// The contour in Selig order: upper trailing edge → leading edge → lower trailing edge.
    ///
    /// Point `i` of `n` sits at contour angle `φ = 2π i / (n - 1)`; the first half is the upper
    /// surface. With an even `n` the leading edge itself falls between two points, so every
    /// point is distinct (82 points give 41 per surface).
    pub fn contour(&self, opts: &NacaOptions) -> Result<Vec<DVec2>> {
        if opts.points < 5 {
            return Err(Error::invalid(format!(
                "a NACA contour needs at least 5 points (got {})",
                opts.points
            )));
        }
        if opts.points > MAX_NACA_POINTS {
            return Err(Error::invalid(format!(
                "a NACA contour may have at most {MAX_NACA_POINTS} points (got {})",
                opts.points
            )));
        }
        let n = opts.points;
        let last = (n - 1) as f64;
        Ok((0..n)
            .map(|i| {
                let s = i as f64 / last; // 0 at upper TE, 1/2 at LE, 1 at lower TE
                let x = match opts.spacing {
                    Spacing::Cosine => 0.5 * (1.0 + (2.0 * PI * s).cos()),
                    Spacing::Uniform => (1.0 - 2.0 * s).abs(),
                };
                self.surface(x, s <= 0.5, opts.closed_te)
            })
            .collect())
    }
}

/// NACA `code`'s contour in `points` cosine-spaced points with an open trailing edge, for tests.
#[cfg(test)]
pub(crate) fn test_contour(code: &str, points: usize) -> Vec<DVec2> {
    Naca::parse(code)
        .unwrap()
        .contour(&NacaOptions {
            points,
            ..NacaOptions::default()
        })
        .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn naca_0012_is_symmetric_with_the_textbook_thickness() {
        let n = Naca::parse("0012").unwrap();
        // Maximum half-thickness 0.06 near x = 0.30.
        let yt = n.half_thickness(0.3, false);
        assert!((yt - 0.060).abs() < 2e-4, "{yt}");
        assert!((n.half_thickness(1.0, false) - 0.00126).abs() < 1e-5);
        assert!(n.half_thickness(1.0, true).abs() < 1e-4);
        let up = n.surface(0.4, true, false);
        let lo = n.surface(0.4, false, false);
        assert!((up.y + lo.y).abs() < 1e-15 && up.x == lo.x);
    }

    #[test]
    fn naca_4413_camber_peaks_at_p() {
        let n = Naca::parse("NACA 4413").unwrap();
        let (yc, slope) = n.camber(0.4);
        assert!((yc - 0.04).abs() < 1e-15 && slope.abs() < 1e-15);
        // Mean line slope is continuous at p.
        let (_, a) = n.camber(0.4 - 1e-9);
        let (_, b) = n.camber(0.4 + 1e-9);
        assert!((a - b).abs() < 1e-7);
    }

    #[test]
    fn five_digit_mean_lines_are_continuous_and_peak_near_p() {
        for code in ["23012", "21012", "24012", "23112", "22112"] {
            let n = Naca::parse(code).unwrap();
            let mut prev = n.camber(0.0);
            let mut peak = (0.0, f64::MIN);
            for i in 1..=2000 {
                let x = i as f64 / 2000.0;
                let c = n.camber(x);
                assert!((c.0 - prev.0).abs() < 1e-3, "{code}: jump at {x}");
                if c.0 > peak.1 {
                    peak = (x, c.0);
                }
                prev = c;
            }
            assert!(
                n.camber(1.0).0.abs() < 1e-4,
                "{code}: mean line ends at the chord"
            );
            // Position digit P: maximum camber near P/20 of the chord.
            let p = code[1..2].parse::<f64>().unwrap() / 20.0;
            assert!(
                (peak.0 - p).abs() < 0.03,
                "{code}: peak at {} not near {p}",
                peak.0
            );
        }
        // 230xx: design lift 0.3 gives maximum camber about 1.8 % of the chord.
        let max = (0..=1000)
            .map(|i| Naca::parse("23012").unwrap().camber(i as f64 / 1000.0).0)
            .fold(0.0, f64::max);
        assert!((max - 0.0184).abs() < 1e-3, "{max}");
    }

    #[test]
    fn contour_has_82_distinct_points_in_selig_order() {
        let pts = test_contour("4413", 82);
        assert_eq!(pts.len(), 82);
        for w in pts.windows(2) {
            assert!((w[1] - w[0]).length() > 1e-6);
        }
        assert!(pts[0].x > 0.99 && pts[81].x > 0.99 && pts[0].y > pts[81].y);
        let le = pts.iter().map(|p| p.x).fold(f64::MAX, f64::min);
        assert!(le < 1e-3 && le > -0.01);
        // Upper half above the lower half at the same station.
        for i in 0..41 {
            assert!(pts[i].y > pts[81 - i].y);
        }
    }

    #[test]
    fn bad_codes_are_refused() {
        for code in [
            "", "44", "441x", "4013", "0412", "26012", "21112", "4400", "123456",
        ] {
            assert!(Naca::parse(code).is_err(), "{code}");
        }
        assert!(Naca::parse("4413")
            .unwrap()
            .contour(&NacaOptions {
                points: 3,
                ..Default::default()
            })
            .is_err());
    }
}
