//! `BezierPatch`: a tensor-product Bezier surface patch (paper eqs. 3 and 4).

use super::basis::{bernstein, bernstein_jet, tensor_jet};
use super::curve::BezierCurve;
use super::point::Vector;

/// A tensor-product patch `P(u, v) = sum_i sum_j B_{i,du}(u) B_{j,dv}(v) P_{i,j}`.
///
/// Control points are stored row-major: row `i` (along u, `0..=du`) holds `P_{i,0} ..= P_{i,dv}`.
#[derive(Clone, Debug, PartialEq)]
pub struct BezierPatch<P: Vector> {
    /// Degree in u.
    pub du: usize,
    /// Degree in v.
    pub dv: usize,
    /// `(du + 1) * (dv + 1)` control points, row-major.
    pub ctrl: Vec<P>,
}

impl<P: Vector> BezierPatch<P> {
    /// A patch of degrees `(du, dv)` from `(du + 1) * (dv + 1)` row-major control points.
    #[must_use]
    pub fn new(du: usize, dv: usize, ctrl: Vec<P>) -> Self {
        debug_assert_eq!(ctrl.len(), (du + 1) * (dv + 1), "patch control point count");
        BezierPatch { du, dv, ctrl }
    }

    /// Control point `P_{i,j}`.
    #[must_use]
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> P {
        self.ctrl[i * (self.dv + 1) + j]
    }

    /// Row `i` as a curve in v.
    #[must_use]
    pub fn row(&self, i: usize) -> BezierCurve<P> {
        BezierCurve::new((0..=self.dv).map(|j| self.at(i, j)).collect())
    }

    /// Column `j` as a curve in u.
    #[must_use]
    pub fn column(&self, j: usize) -> BezierCurve<P> {
        BezierCurve::new((0..=self.du).map(|i| self.at(i, j)).collect())
    }

    /// Evaluate the patch at `(u, v)` in Bernstein form (eq. 3).
    #[must_use]
    pub fn eval(&self, u: f64, v: f64) -> P {
        let (mut bu, mut bv) = ([0.0; 33], [0.0; 33]);
        bernstein(self.du, u, &mut bu);
        bernstein(self.dv, v, &mut bv);
        self.jet([&bu], [&bv], 0)[0][0]
    }

    /// Evaluate as curves of curves (eq. 4): each row collapsed in v, then the column in u.
    #[must_use]
    pub fn eval_casteljau(&self, u: f64, v: f64) -> P {
        let col: Vec<P> = (0..=self.du).map(|i| self.row(i).eval(v)).collect();
        BezierCurve::new(col).eval(u)
    }

    /// The point and both first partial derivatives `(P, dP/du, dP/dv)` at `(u, v)`.
    #[must_use]
    pub fn partials(&self, u: f64, v: f64) -> (P, P, P) {
        let bu = bernstein_jet::<33, 2>(self.du, u);
        let bv = bernstein_jet::<33, 2>(self.dv, v);
        let jet = self.jet([&bu[0], &bu[1]], [&bv[0], &bv[1]], 1);
        (jet[0][0], jet[1][0], jet[0][1])
    }

    /// The patch's partials up to order `K - 1` from its bases along u and along v.
    fn jet<const K: usize>(&self, wu: [&[f64; 33]; K], wv: [&[f64; 33]; K], order: usize) -> [[P; K]; K] {
        let n = (self.du + 1, self.dv + 1);
        tensor_jet(&self.ctrl, self.dv + 1, n, wu, wv, order)
    }

    /// Split at `u = s` into the patches over `[0, s]` and `[s, 1]` in u.
    #[must_use]
    pub fn split_u(&self, s: f64) -> (BezierPatch<P>, BezierPatch<P>) {
        let (left, right): (Vec<_>, Vec<_>) = (0..=self.dv).map(|j| self.column(j).split(s)).unzip();
        let build = |pieces: &[BezierCurve<P>]| {
            let mut ctrl = Vec::with_capacity(self.ctrl.len());
            for i in 0..=self.du {
                for c in pieces {
                    ctrl.push(c.ctrl[i]);
                }
            }
            BezierPatch::new(self.du, self.dv, ctrl)
        };
        (build(&left), build(&right))
    }

    /// Split at `v = s` into the patches over `[0, s]` and `[s, 1]` in v.
    #[must_use]
    pub fn split_v(&self, s: f64) -> (BezierPatch<P>, BezierPatch<P>) {
        let (a, b) = self.transpose().split_u(s);
        (a.transpose(), b.transpose())
    }

    /// Raise the degree in u by one.
    #[must_use]
    pub fn elevate_u(&self) -> BezierPatch<P> {
        let cols: Vec<_> = (0..=self.dv).map(|j| self.column(j).elevate()).collect();
        let mut ctrl = Vec::with_capacity((self.du + 2) * (self.dv + 1));
        for i in 0..=self.du + 1 {
            for c in &cols {
                ctrl.push(c.ctrl[i]);
            }
        }
        BezierPatch::new(self.du + 1, self.dv, ctrl)
    }

    /// Raise the degree in v by one.
    #[must_use]
    pub fn elevate_v(&self) -> BezierPatch<P> {
        self.transpose().elevate_u().transpose()
    }

    /// The same surface with u and v exchanged.
    #[must_use]
    pub fn transpose(&self) -> BezierPatch<P> {
        let mut ctrl = Vec::with_capacity(self.ctrl.len());
        for j in 0..=self.dv {
            for i in 0..=self.du {
                ctrl.push(self.at(i, j));
            }
        }
        BezierPatch::new(self.dv, self.du, ctrl)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn patch() -> BezierPatch<DVec3> {
        let mut ctrl = Vec::new();
        for i in 0..=3 {
            for j in 0..=2 {
                let (x, y) = (i as f64 / 3.0, j as f64 / 2.0);
                ctrl.push(DVec3::new(
                    x + 0.1 * y,
                    y,
                    (3.0 * x).sin() * (1.0 + y * y) + 0.2 * (i * j) as f64,
                ));
            }
        }
        BezierPatch::new(3, 2, ctrl)
    }

    fn grid() -> impl Iterator<Item = (f64, f64)> {
        (0..=8).flat_map(|a| (0..=8).map(move |b| (a as f64 / 8.0, b as f64 / 8.0)))
    }

    #[test]
    fn bernstein_and_curve_of_curves_agree() {
        let p = patch();
        for (u, v) in grid() {
            assert!((p.eval(u, v) - p.eval_casteljau(u, v)).length() < 1e-14);
        }
        assert_eq!(p.eval(0.0, 0.0), p.at(0, 0));
        assert_eq!(p.eval(1.0, 1.0), p.at(3, 2));
    }

    #[test]
    fn partials_match_finite_differences() {
        let p = patch();
        let h = 1e-6;
        for (u, v) in grid() {
            let (u, v) = (0.05 + 0.9 * u, 0.05 + 0.9 * v);
            let (_, pu, pv) = p.partials(u, v);
            let fu = (p.eval(u + h, v) - p.eval(u - h, v)) / (2.0 * h);
            let fv = (p.eval(u, v + h) - p.eval(u, v - h)) / (2.0 * h);
            assert!((pu - fu).length() < 1e-8);
            assert!((pv - fv).length() < 1e-8);
        }
    }

    #[test]
    fn splits_and_elevations_keep_the_surface() {
        let p = patch();
        let (a, b) = p.split_u(0.3);
        let (c, d) = p.split_v(0.6);
        let e = p.elevate_u().elevate_v();
        for (u, v) in grid() {
            assert!((a.eval(u, v) - p.eval(0.3 * u, v)).length() < 1e-14);
            assert!((b.eval(u, v) - p.eval(0.3 + 0.7 * u, v)).length() < 1e-14);
            assert!((c.eval(u, v) - p.eval(u, 0.6 * v)).length() < 1e-14);
            assert!((d.eval(u, v) - p.eval(u, 0.6 + 0.4 * v)).length() < 1e-14);
            assert!((e.eval(u, v) - p.eval(u, v)).length() < 1e-14);
        }
        assert_eq!((e.du, e.dv), (4, 3));
    }
}
