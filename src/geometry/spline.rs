//! A cubic spline through raw aerofoil coordinates by chord length, with XFOIL's end
//! conditions: the contour the panel method runs on raw data, and the smooth interpolant the
//! adaptive search counts the data's curvature sign changes on.

use crate::error::{Error, Result};
use glam::DVec2;

/// A cubic spline through raw aerofoil coordinates, `x(s)` and `y(s)` over the chord-length
/// parameter `s`, with XFOIL's end conditions (zero third derivative: the end intervals are
/// parabolas), as `t = s / s_total`.
#[derive(Clone, Debug, PartialEq)]
pub struct SplineContour {
    s: Vec<f64>,
    x: Cubic,
    y: Cubic,
}

/// One coordinate of the spline: values and second derivatives at the knots.
#[derive(Clone, Debug, PartialEq)]
struct Cubic {
    v: Vec<f64>,
    m: Vec<f64>,
}

impl Cubic {
    /// The interpolating cubic spline with equal second derivatives in the first two and the
    /// last two knots (zero third derivative at both ends).
    fn new(s: &[f64], v: &[f64]) -> Cubic {
        let n = s.len();
        if n < 3 {
            return Cubic {
                v: v.to_vec(),
                m: vec![0.0; n],
            };
        }
        // Tridiagonal rows: sub a, diagonal b, super c, right-hand side d.
        let (mut a, mut b, mut c, mut d) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        b[0] = 1.0;
        c[0] = -1.0;
        for i in 1..n - 1 {
            let (h0, h1) = (s[i] - s[i - 1], s[i + 1] - s[i]);
            a[i] = h0;
            b[i] = 2.0 * (h0 + h1);
            c[i] = h1;
            d[i] = 6.0 * ((v[i + 1] - v[i]) / h1 - (v[i] - v[i - 1]) / h0);
        }
        a[n - 1] = -1.0;
        b[n - 1] = 1.0;
        Cubic {
            v: v.to_vec(),
            m: tridiagonal(&a, &b, &c, &d),
        }
    }

    fn eval(&self, s: &[f64], k: usize, u: f64) -> f64 {
        let h = s[k + 1] - s[k];
        let (a, b) = (1.0 - u, u);
        let (m0, m1) = (self.m[k], self.m[k + 1]);
        a * self.v[k] + b * self.v[k + 1] + h * h / 6.0 * ((a * a * a - a) * m0 + (b * b * b - b) * m1)
    }

    /// The first and second derivatives with respect to `s` at local parameter `u` of
    /// interval `k`.
    fn derivs(&self, s: &[f64], k: usize, u: f64) -> (f64, f64) {
        let h = s[k + 1] - s[k];
        let (a, b) = (1.0 - u, u);
        let (m0, m1) = (self.m[k], self.m[k + 1]);
        let d1 =
            (self.v[k + 1] - self.v[k]) / h + h / 6.0 * ((3.0 * b * b - 1.0) * m1 - (3.0 * a * a - 1.0) * m0);
        (d1, a * m0 + b * m1)
    }
}

/// The interval `k` holding `v` among the increasing knots `s`, and the local parameter there.
pub(crate) fn locate(s: &[f64], v: f64) -> (usize, f64) {
    let k = s.partition_point(|&x| x <= v).clamp(1, s.len() - 1) - 1;
    (k, (v - s[k]) / (s[k + 1] - s[k]))
}

/// One array splined over increasing knots with XFOIL's end conditions (its `SEGSPL`):
/// values and slopes anywhere between the first and last knot.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Spline1 {
    s: Vec<f64>,
    c: Cubic,
}

impl Spline1 {
    /// The spline through `(s[i], v[i])`; `s` strictly increasing, at least two knots.
    pub(crate) fn new(s: &[f64], v: &[f64]) -> Spline1 {
        Spline1 {
            s: s.to_vec(),
            c: Cubic::new(s, v),
        }
    }

    /// The value and the slope at `v`.
    pub(crate) fn at(&self, v: f64) -> (f64, f64) {
        let (k, u) = locate(&self.s, v);
        (self.c.eval(&self.s, k, u), self.c.derivs(&self.s, k, u).0)
    }
}

/// Solve a tridiagonal system (Thomas' algorithm): `a` below, `b` on, `c` above the diagonal.
pub(crate) fn tridiagonal(a: &[f64], b: &[f64], c: &[f64], d: &[f64]) -> Vec<f64> {
    let n = b.len();
    let (mut cp, mut dp) = (vec![0.0; n], vec![0.0; n]);
    cp[0] = c[0] / b[0];
    dp[0] = d[0] / b[0];
    for i in 1..n {
        let den = b[i] - a[i] * cp[i - 1];
        cp[i] = if i + 1 < n { c[i] / den } else { 0.0 };
        dp[i] = (d[i] - a[i] * dp[i - 1]) / den;
    }
    let mut x = vec![0.0; n];
    x[n - 1] = dp[n - 1];
    for i in (0..n - 1).rev() {
        x[i] = dp[i] - cp[i] * x[i + 1];
    }
    x
}

impl SplineContour {
    /// The spline through `points` (at least 4, consecutive points distinct).
    pub fn new(points: &[DVec2]) -> Result<Self> {
        if points.len() < 4 {
            return Err(Error::invalid(format!(
                "a contour needs at least 4 points, not {}",
                points.len()
            )));
        }
        if points.iter().any(|p| !p.is_finite()) {
            return Err(Error::invalid("contour points must be finite"));
        }
        let mut s = vec![0.0];
        for w in points.windows(2) {
            let h = (w[1] - w[0]).length();
            if h.is_nan() || h <= 0.0 {
                return Err(Error::invalid("consecutive contour points coincide"));
            }
            s.push(s[s.len() - 1] + h);
        }
        let xs: Vec<f64> = points.iter().map(|p| p.x).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.y).collect();
        Ok(SplineContour {
            x: Cubic::new(&s, &xs),
            y: Cubic::new(&s, &ys),
            s,
        })
    }
}

impl SplineContour {
    /// Points and signed curvatures (positive turning left) at `per` equal steps of every
    /// interval between data points, the data points included: the spline's second
    /// derivatives are linear in each interval, so a few steps see every sign change.
    #[must_use]
    pub fn curvature_samples(&self, per: usize) -> Vec<(DVec2, f64)> {
        let per = per.max(1);
        let n = self.s.len();
        let mut out = Vec::with_capacity((n - 1) * per + 1);
        for k in 0..n - 1 {
            let last = if k + 2 == n { per } else { per - 1 };
            for i in 0..=last {
                let u = i as f64 / per as f64;
                let p = DVec2::new(self.x.eval(&self.s, k, u), self.y.eval(&self.s, k, u));
                out.push((p, self.kappa(k, u)));
            }
        }
        out
    }

    /// The signed curvature at local parameter `u` of interval `k`.
    fn kappa(&self, k: usize, u: f64) -> f64 {
        let (x1, x2) = self.x.derivs(&self.s, k, u);
        let (y1, y2) = self.y.derivs(&self.s, k, u);
        let speed = x1.hypot(y1);
        if speed > 0.0 {
            (x1 * y2 - y1 * x2) / (speed * speed * speed)
        } else {
            0.0
        }
    }

    /// The spline's parameter at its knots (the data points), as `t = s / s_total`.
    #[must_use]
    pub fn knots(&self) -> Vec<f64> {
        let total = self.s[self.s.len() - 1];
        self.s.iter().map(|s| s / total).collect()
    }

    /// The spline's parameter at its last knot: the length of the polygon through the data.
    #[must_use]
    pub fn length(&self) -> f64 {
        self.s[self.s.len() - 1]
    }

    /// The signed curvature (positive turning left) at `t = s / s_total ∈ [0, 1]`.
    #[must_use]
    pub fn curvature(&self, t: f64) -> f64 {
        let (k, u) = locate(&self.s, t.clamp(0.0, 1.0) * self.s[self.s.len() - 1]);
        self.kappa(k, u)
    }
}

impl SplineContour {
    /// The point at `t = s / s_total ∈ [0, 1]`.
    #[must_use]
    pub fn at(&self, t: f64) -> DVec2 {
        let (k, u) = locate(&self.s, t.clamp(0.0, 1.0) * self.s[self.s.len() - 1]);
        DVec2::new(self.x.eval(&self.s, k, u), self.y.eval(&self.s, k, u))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spline_interpolates_its_points_and_parabolas_end_it() {
        let pts: Vec<DVec2> = (0..9)
            .map(|i| {
                let a = i as f64 * 0.4;
                DVec2::new(a.cos(), a.sin())
            })
            .collect();
        let sp = SplineContour::new(&pts).unwrap();
        let total = sp.s[sp.s.len() - 1];
        for (p, s) in pts.iter().zip(&sp.s) {
            assert!((sp.at(s / total) - *p).length() < 1e-12);
        }
        assert!((sp.x.m[0] - sp.x.m[1]).abs() < 1e-12 && (sp.y.m[7] - sp.y.m[8]).abs() < 1e-12);
        // Between the points the spline stays on the circle to the interpolation error.
        for k in 0..100 {
            let p = sp.at(k as f64 / 99.0);
            assert!((p.length() - 1.0).abs() < 2e-3, "{p}");
        }
    }
}
