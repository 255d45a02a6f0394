//! `BezierCurve`: one polynomial Bezier curve of any degree in the plane or in space.

use super::basis::{bernstein, casteljau, casteljau_with, combine};
use super::point::Vector;

/// A Bezier curve `P(u) = sum_i B_{i,n}(u) P_i`, `u` in `[0, 1]`, with `n + 1` control points.
#[derive(Clone, Debug, PartialEq)]
pub struct BezierCurve<P: Vector> {
    /// Control points `P_0 ..= P_n`.
    pub ctrl: Vec<P>,
}

impl<P: Vector> BezierCurve<P> {
    /// A curve from its control points (at least one).
    #[must_use]
    pub fn new(ctrl: Vec<P>) -> Self {
        debug_assert!(
            !ctrl.is_empty(),
            "a Bezier curve needs at least one control point"
        );
        BezierCurve { ctrl }
    }

    /// The polynomial degree `n` (one less than the number of control points).
    #[must_use]
    pub fn degree(&self) -> usize {
        self.ctrl.len() - 1
    }

    /// Evaluate the curve at parameter `u` by de Casteljau's algorithm.
    #[must_use]
    pub fn eval(&self, u: f64) -> P {
        let mut buf: smallbuf::Buf<P> = smallbuf::Buf::from_slice(&self.ctrl);
        casteljau(buf.as_mut_slice(), u)
    }

    /// Evaluate the curve at parameter `u` in Bernstein form (paper eq. 1).
    #[must_use]
    pub fn eval_bernstein(&self, u: f64) -> P {
        let n = self.degree();
        let mut b = [0.0; 33];
        debug_assert!(n <= 32, "eval_bernstein: degree {n} above 32");
        bernstein(n, u, &mut b);
        combine(&self.ctrl, &b)
    }

    /// The derivative curve (hodograph), of degree `n - 1` (paper eq. 2).
    ///
    /// A degree-0 curve has the zero curve as its derivative.
    #[must_use]
    pub fn deriv(&self) -> BezierCurve<P> {
        let n = self.degree();
        if n == 0 {
            return BezierCurve::new(vec![P::ZERO]);
        }
        let nf = n as f64;
        BezierCurve::new(self.ctrl.windows(2).map(|w| (w[1] - w[0]) * nf).collect())
    }

    /// The first derivative `dP/du` at `u`.
    #[must_use]
    pub fn eval_deriv(&self, u: f64) -> P {
        self.deriv().eval(u)
    }

    /// Split at `u` into the pieces over `[0, u]` and `[u, 1]`, each reparameterised to `[0, 1]`.
    #[must_use]
    pub fn split(&self, u: f64) -> (BezierCurve<P>, BezierCurve<P>) {
        // The edges of de Casteljau's triangle: each level's first point is the next control
        // point of the left piece, its last the one before of the right piece.
        let n = self.degree();
        let mut pts = self.ctrl.clone();
        let mut left = Vec::with_capacity(n + 1);
        let mut right = vec![P::ZERO; n + 1];
        left.push(pts[0]);
        right[n] = pts[n];
        casteljau_with(&mut pts, u, P::lerp_to, |level| {
            left.push(level[0]);
            right[level.len() - 1] = level[level.len() - 1];
        });
        (BezierCurve::new(left), BezierCurve::new(right))
    }

    /// The piece over `[u0, u1]`, reparameterised to `[0, 1]`.
    #[must_use]
    pub fn subcurve(&self, u0: f64, u1: f64) -> BezierCurve<P> {
        if u1 <= u0 {
            return BezierCurve::new(vec![self.eval(u0); self.ctrl.len()]);
        }
        let (_, right) = self.split(u0);
        if u0 >= 1.0 {
            return right;
        }
        let (piece, _) = right.split((u1 - u0) / (1.0 - u0));
        piece
    }

    /// The same curve with degree raised by one.
    #[must_use]
    pub fn elevate(&self) -> BezierCurve<P> {
        let n = self.degree();
        let m = (n + 1) as f64;
        let mut out = Vec::with_capacity(n + 2);
        out.push(self.ctrl[0]);
        for i in 1..=n {
            let a = i as f64 / m;
            out.push(self.ctrl[i - 1] * a + self.ctrl[i] * (1.0 - a));
        }
        out.push(self.ctrl[n]);
        BezierCurve::new(out)
    }
}

/// A fixed-capacity stack buffer for de Casteljau, falling back to the heap for high degrees.
mod smallbuf {
    use super::Vector;

    pub enum Buf<P: Vector> {
        Stack([P; 16], usize),
        Heap(Vec<P>),
    }

    impl<P: Vector> Buf<P> {
        pub fn from_slice(s: &[P]) -> Self {
            if s.len() <= 16 {
                let mut a = [P::ZERO; 16];
                a[..s.len()].copy_from_slice(s);
                Buf::Stack(a, s.len())
            } else {
                Buf::Heap(s.to_vec())
            }
        }

        pub fn as_mut_slice(&mut self) -> &mut [P] {
            match self {
                Buf::Stack(a, n) => &mut a[..*n],
                Buf::Heap(v) => v.as_mut_slice(),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    fn cubic() -> BezierCurve<DVec2> {
        BezierCurve::new(vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(0.3, 0.9),
            DVec2::new(0.8, -0.4),
            DVec2::new(1.0, 0.2),
        ])
    }

    #[test]
    fn casteljau_matches_bernstein() {
        let c = cubic();
        for i in 0..=50 {
            let u = i as f64 / 50.0;
            assert!((c.eval(u) - c.eval_bernstein(u)).length() < 1e-15);
        }
        assert_eq!(c.eval(0.0), c.ctrl[0]);
        assert_eq!(c.eval(1.0), c.ctrl[3]);
    }

    #[test]
    fn derivative_matches_finite_differences() {
        let c = cubic();
        let h = 1e-6;
        for i in 1..20 {
            let u = i as f64 / 20.0;
            let fd = (c.eval(u + h) - c.eval(u - h)) / (2.0 * h);
            assert!((c.eval_deriv(u) - fd).length() < 1e-8);
        }
        // Second derivative of the hodograph as well.
        let d = c.deriv();
        for i in 1..20 {
            let u = i as f64 / 20.0;
            let fd = (d.eval(u + h) - d.eval(u - h)) / (2.0 * h);
            assert!((d.eval_deriv(u) - fd).length() < 1e-7);
        }
    }

    #[test]
    fn split_then_rejoin_reproduces_the_curve() {
        let c = cubic();
        for &s in &[0.1, 0.37, 0.5, 0.9] {
            let (a, b) = c.split(s);
            assert_eq!(a.ctrl[3], b.ctrl[0]);
            for i in 0..=20 {
                let u = i as f64 / 20.0;
                assert!((a.eval(u) - c.eval(u * s)).length() < 1e-14);
                assert!((b.eval(u) - c.eval(s + u * (1.0 - s))).length() < 1e-14);
            }
        }
        let piece = c.subcurve(0.2, 0.7);
        for i in 0..=20 {
            let u = i as f64 / 20.0;
            assert!((piece.eval(u) - c.eval(0.2 + 0.5 * u)).length() < 1e-14);
        }
    }

    #[test]
    fn elevation_keeps_the_curve() {
        let c = cubic();
        let e = c.elevate().elevate();
        assert_eq!(e.degree(), 5);
        for i in 0..=30 {
            let u = i as f64 / 30.0;
            assert!((e.eval(u) - c.eval(u)).length() < 1e-14);
        }
    }
}
