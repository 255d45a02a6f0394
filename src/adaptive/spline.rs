//! `SplineLayout`: a chain of Bezier segments seen as a B-spline whose joins may be smoother
//! than C1 (each join its own continuity), with basis evaluation, knot insertion and the
//! extraction of the expanded Bezier control points.
//!
//! A join of continuity `Ck` in a chain of degree `d` is an interior knot of multiplicity
//! `d - k` (`docs/ARCHITECTURE.md` §2.2). The paper's chains have `k = 1` at every join; a join with `k > 1`
//! generates more of its neighbouring control points and so stores fewer. The expanded
//! Bezier control points are the B-spline's after every interior knot is raised to
//! multiplicity `d` (Boehm's insertion), so any such chain is also a C1 chain of the same
//! degree and breaks, and its report reads like every other.

use crate::bezier::Vector;
use crate::error::{Error, Result};

/// Highest degree the adaptive search uses (the fixed basis buffers hold `MAX_DEGREE + 1`).
pub const MAX_DEGREE: usize = 9;

/// Number of basis functions that are non-zero on a knot span, at most.
pub(crate) const MAX_SUPPORT: usize = MAX_DEGREE + 1;

/// Degree, breaks and the continuity of every join of a chain, with its clamped knot vector.
#[derive(Clone, Debug, PartialEq)]
pub struct SplineLayout {
    degree: usize,
    breaks: Vec<f64>,
    orders: Vec<usize>,
    knots: Vec<f64>,
    /// Knot-span index of every segment (the last knot `<=` the segment's start).
    spans: Vec<usize>,
    /// Per segment, the reciprocals of the knot differences the basis recurrence divides by,
    /// in the order it uses them (`d (d + 1) / 2` each).
    recip: Vec<f64>,
}

/// The non-zero basis functions at one parameter: the first design index and, for
/// `a = 0 ..= degree`, the values and the first and second derivatives of basis function
/// `first + a` with respect to the global parameter.
#[derive(Clone, Copy, Debug)]
pub struct SpanBasis {
    /// Index of the first non-zero basis function.
    pub first: usize,
    /// The segment holding the parameter.
    pub segment: usize,
    /// Values.
    pub value: [f64; MAX_SUPPORT],
    /// First derivatives.
    pub d1: [f64; MAX_SUPPORT],
    /// Second derivatives.
    pub d2: [f64; MAX_SUPPORT],
}

impl SplineLayout {
    /// A layout of `degree` (1 ..= [`MAX_DEGREE`]) over `breaks` (strictly increasing from 0 to
    /// 1) with continuity order `orders[k]` (0 ..= degree - 1) at interior break `k + 1`.
    pub fn new(degree: usize, breaks: Vec<f64>, orders: Vec<usize>) -> Result<Self> {
        if !(1..=MAX_DEGREE).contains(&degree) {
            return Err(Error::invalid(format!(
                "spline degree {degree} is outside 1 ..= {MAX_DEGREE}"
            )));
        }
        if breaks.len() < 2 || breaks[0] != 0.0 || breaks[breaks.len() - 1] != 1.0 {
            return Err(Error::invalid("breaks must run from 0 to 1"));
        }
        if breaks.iter().any(|b| !b.is_finite()) || breaks.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::invalid("breaks must be finite and strictly increasing"));
        }
        if orders.len() + 2 != breaks.len() {
            return Err(Error::invalid(format!(
                "{} join orders given for {} interior breaks",
                orders.len(),
                breaks.len() - 2
            )));
        }
        if let Some(&k) = orders.iter().find(|&&k| k >= degree) {
            return Err(Error::invalid(format!(
                "a join of continuity C{k} needs degree {} or more (got {degree})",
                k + 1
            )));
        }
        let mut knots = vec![0.0; degree + 1];
        let mut spans = vec![degree];
        for (&b, &k) in breaks[1..breaks.len() - 1].iter().zip(&orders) {
            knots.extend(std::iter::repeat_n(b, degree - k));
            spans.push(knots.len() - 1);
        }
        knots.extend(std::iter::repeat_n(1.0, degree + 1));
        let mut recip = Vec::with_capacity(spans.len() * degree * (degree + 1) / 2);
        for &span in &spans {
            for j in 1..=degree {
                for r in 0..j {
                    recip.push(1.0 / (knots[span + r + 1] - knots[span + 1 - j + r]));
                }
            }
        }
        Ok(SplineLayout {
            degree,
            breaks,
            orders,
            knots,
            spans,
            recip,
        })
    }

    /// A layout whose joins all have continuity order `order` (capped at `degree - 1`).
    pub fn with_order(degree: usize, breaks: Vec<f64>, order: usize) -> Result<Self> {
        let k = order.min(degree.saturating_sub(1));
        let joins = breaks.len().saturating_sub(2);
        Self::new(degree, breaks, vec![k; joins])
    }

    /// Polynomial degree of every segment.
    #[must_use]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Number of segments.
    #[must_use]
    pub fn segments(&self) -> usize {
        self.breaks.len() - 1
    }

    /// The breaks `0 = t0 < ... < ts = 1`.
    #[must_use]
    pub fn breaks(&self) -> &[f64] {
        &self.breaks
    }

    /// Continuity order of each interior break, in order.
    #[must_use]
    pub fn orders(&self) -> &[usize] {
        &self.orders
    }

    /// The clamped knot vector.
    #[must_use]
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// Number of B-spline coefficients (design points): `d + 1 + Σ (d - k_i)`.
    #[must_use]
    pub fn coeff_count(&self) -> usize {
        self.knots.len() - self.degree - 1
    }

    /// The segment holding `t` (clamped to `[0, 1]`).
    #[must_use]
    pub fn segment_of(&self, t: f64) -> usize {
        let s = self.segments();
        self.breaks[1..s].partition_point(|&b| b <= t)
    }

    /// The basis at `t` (clamped to `[0, 1]`): the `d + 1` functions non-zero on its knot span,
    /// with derivatives with respect to `t` (Piegl and Tiller's algorithm A2.3).
    #[must_use]
    pub fn basis(&self, t: f64) -> SpanBasis {
        let t = t.clamp(0.0, 1.0);
        let d = self.degree;
        let seg = self.segment_of(t);
        let span = self.spans[seg];
        let u = &self.knots;
        let mut ndu = [[0.0; MAX_SUPPORT]; MAX_SUPPORT];
        let mut left = [0.0; MAX_SUPPORT];
        let mut right = [0.0; MAX_SUPPORT];
        ndu[0][0] = 1.0;
        for j in 1..=d {
            left[j] = t - u[span + 1 - j];
            right[j] = u[span + j] - t;
            let mut saved = 0.0;
            for r in 0..j {
                ndu[j][r] = right[r + 1] + left[j - r];
                let temp = ndu[r][j - 1] / ndu[j][r];
                ndu[r][j] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            ndu[j][j] = saved;
        }
        let mut out = SpanBasis {
            first: span - d,
            segment: seg,
            value: [0.0; MAX_SUPPORT],
            d1: [0.0; MAX_SUPPORT],
            d2: [0.0; MAX_SUPPORT],
        };
        for j in 0..=d {
            out.value[j] = ndu[j][d];
        }
        // Derivatives of order 1 and 2 (A2.3 with n = 2), `a` holding two rows of coefficients.
        let n = 2.min(d);
        let di = d as isize;
        for r in 0..=d {
            let ri = r as isize;
            let mut a = [[0.0; MAX_SUPPORT]; 2];
            let (mut s1, mut s2) = (0, 1);
            a[0][0] = 1.0;
            for k in 1..=n {
                let ki = k as isize;
                let mut dd = 0.0;
                let rk = ri - ki;
                let pk = di - ki;
                if ri >= ki {
                    a[s2][0] = a[s1][0] / ndu[(pk + 1) as usize][rk as usize];
                    dd = a[s2][0] * ndu[rk as usize][pk as usize];
                }
                let j1 = if rk >= -1 { 1 } else { -rk };
                let j2 = if ri - 1 <= pk { ki - 1 } else { di - ri };
                let mut j = j1;
                while j <= j2 {
                    let ju = j as usize;
                    a[s2][ju] = (a[s1][ju] - a[s1][ju - 1]) / ndu[(pk + 1) as usize][(rk + j) as usize];
                    dd += a[s2][ju] * ndu[(rk + j) as usize][pk as usize];
                    j += 1;
                }
                if ri <= pk {
                    a[s2][k] = -a[s1][k - 1] / ndu[(pk + 1) as usize][r];
                    dd += a[s2][k] * ndu[r][pk as usize];
                }
                if k == 1 {
                    out.d1[r] = dd;
                } else {
                    out.d2[r] = dd;
                }
                std::mem::swap(&mut s1, &mut s2);
            }
        }
        let df = d as f64;
        for r in 0..=d {
            out.d1[r] *= df;
            out.d2[r] *= df * (df - 1.0);
        }
        out
    }

    /// The values of the `d + 1` basis functions non-zero at `t` (clamped to `[0, 1]`) and the
    /// index of the first (Piegl and Tiller's algorithm A2.2; no derivatives).
    #[must_use]
    pub fn basis_values(&self, t: f64) -> (usize, [f64; MAX_SUPPORT]) {
        let t = t.clamp(0.0, 1.0);
        let d = self.degree;
        let seg = self.segment_of(t);
        let span = self.spans[seg];
        let u = &self.knots;
        let recip = &self.recip[seg * d * (d + 1) / 2..];
        let mut n = [0.0; MAX_SUPPORT];
        let mut left = [0.0; MAX_SUPPORT];
        let mut right = [0.0; MAX_SUPPORT];
        n[0] = 1.0;
        let mut at = 0;
        for j in 1..=d {
            left[j] = t - u[span + 1 - j];
            right[j] = u[span + j] - t;
            let mut saved = 0.0;
            for r in 0..j {
                // right[r + 1] + left[j - r] is a knot difference: its reciprocal is stored.
                let temp = n[r] * recip[at];
                at += 1;
                n[r] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            n[j] = saved;
        }
        (span - d, n)
    }

    /// Evaluate the spline with coefficients `coeffs` at `t`.
    #[must_use]
    pub fn eval<P: Vector>(&self, coeffs: &[P], t: f64) -> P {
        let b = self.basis(t);
        (0..=self.degree).fold(P::ZERO, |acc, a| acc + coeffs[b.first + a] * b.value[a])
    }

    /// The layout with break `t` inserted with continuity order `order`, and `coeffs`
    /// re-expressed on it (the same curve, exactly: Boehm's knot insertion). `t` must lie
    /// strictly inside a segment.
    pub fn split<P: Vector>(&self, t: f64, order: usize, coeffs: &[P]) -> Result<(SplineLayout, Vec<P>)> {
        if !(t > 0.0 && t < 1.0) || self.breaks.contains(&t) {
            return Err(Error::invalid(format!(
                "split at {t}: not strictly inside a segment"
            )));
        }
        let k = self.segment_of(t);
        let mut breaks = self.breaks.clone();
        breaks.insert(k + 1, t);
        let mut orders = self.orders.clone();
        orders.insert(k, order);
        let layout = SplineLayout::new(self.degree, breaks, orders)?;
        let mut knots = self.knots.clone();
        let mut c = coeffs.to_vec();
        for _ in 0..layout.degree - order.min(layout.degree - 1) {
            insert_knot(&mut knots, &mut c, self.degree, t);
        }
        debug_assert_eq!(knots, layout.knots, "split: knot vectors differ");
        Ok((layout, c))
    }

    /// The expanded Bezier control points (`s * d + 1`) of the spline with `coeffs`:
    /// every interior knot raised to multiplicity `d`.
    #[must_use]
    pub fn bezier<P: Vector>(&self, coeffs: &[P]) -> Vec<P> {
        debug_assert_eq!(coeffs.len(), self.coeff_count(), "bezier: coefficient count");
        let mut knots = self.knots.clone();
        let mut c = coeffs.to_vec();
        for (&b, &k) in self.breaks[1..self.breaks.len() - 1].iter().zip(&self.orders) {
            for _ in 0..k {
                insert_knot(&mut knots, &mut c, self.degree, b);
            }
        }
        c
    }
}

/// A spline in Bezier form, for fast evaluation with derivatives: the expanded control
/// points and the breaks.
#[derive(Clone, Debug)]
pub(crate) struct BezierForm {
    degree: usize,
    breaks: Vec<f64>,
    inv_len: Vec<f64>,
    ctrl: Vec<glam::DVec2>,
}

impl BezierForm {
    /// The Bezier form of the spline with `coeffs` on `layout`.
    pub fn new(layout: &SplineLayout, coeffs: &[glam::DVec2]) -> Self {
        let breaks = layout.breaks().to_vec();
        let inv_len = breaks.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect();
        BezierForm {
            degree: layout.degree(),
            ctrl: layout.bezier(coeffs),
            breaks,
            inv_len,
        }
    }

    /// Point, first and second derivative with respect to the global parameter at `t`
    /// (clamped to `[0, 1]`).
    #[inline]
    pub fn jet(&self, t: f64) -> (glam::DVec2, glam::DVec2, glam::DVec2) {
        use glam::DVec2;
        let t = t.clamp(0.0, 1.0);
        let s = self.breaks.len() - 1;
        let k = self.breaks[1..s].partition_point(|&b| b <= t);
        let d = self.degree;
        let c = &self.ctrl[k * d..=(k + 1) * d];
        let u = ((t - self.breaks[k]) * self.inv_len[k]).clamp(0.0, 1.0);
        let v = 1.0 - u;
        // The control points' first and second differences: the hodographs' control points.
        let mut c1 = [DVec2::ZERO; MAX_SUPPORT];
        let mut c2 = [DVec2::ZERO; MAX_SUPPORT];
        for i in 0..d {
            c1[i] = c[i + 1] - c[i];
        }
        for i in 0..d.saturating_sub(1) {
            c2[i] = c1[i + 1] - c1[i];
        }
        let df = d as f64;
        let h = self.inv_len[k];
        let p = horner(c, u, v);
        let d1 = if d >= 1 {
            horner(&c1[..d], u, v) * (df * h)
        } else {
            DVec2::ZERO
        };
        let d2 = if d >= 2 {
            horner(&c2[..d - 1], u, v) * (df * (df - 1.0) * h * h)
        } else {
            DVec2::ZERO
        };
        (p, d1, d2)
    }

    /// The first derivative with respect to the global parameter at `t`.
    #[inline]
    pub fn tangent(&self, t: f64) -> glam::DVec2 {
        use glam::DVec2;
        let t = t.clamp(0.0, 1.0);
        let s = self.breaks.len() - 1;
        let k = self.breaks[1..s].partition_point(|&b| b <= t);
        let d = self.degree;
        if d == 0 {
            return DVec2::ZERO;
        }
        let c = &self.ctrl[k * d..=(k + 1) * d];
        let u = ((t - self.breaks[k]) * self.inv_len[k]).clamp(0.0, 1.0);
        let mut c1 = [DVec2::ZERO; MAX_SUPPORT];
        for i in 0..d {
            c1[i] = c[i + 1] - c[i];
        }
        horner(&c1[..d], u, 1.0 - u) * (d as f64 * self.inv_len[k])
    }

    /// The point at `t`.
    #[inline]
    pub fn eval(&self, t: f64) -> glam::DVec2 {
        self.jet(t).0
    }
}

/// The Bezier curve with control points `c` at `u` (`v = 1 - u`), by the Horner-like scheme
/// for Bernstein sums.
#[inline]
fn horner(c: &[glam::DVec2], u: f64, v: f64) -> glam::DVec2 {
    let row = &BINOMIAL[c.len() - 1];
    let mut acc = c[0];
    let mut pow = 1.0;
    for i in 1..c.len() {
        pow *= u;
        acc = acc * v + c[i] * (row[i] * pow);
    }
    acc
}

/// Binomial coefficients `C(n, i)` for `n <= MAX_DEGREE`.
const BINOMIAL: [[f64; MAX_SUPPORT]; MAX_SUPPORT] = binomials();

const fn binomials() -> [[f64; MAX_SUPPORT]; MAX_SUPPORT] {
    let mut t = [[0.0; MAX_SUPPORT]; MAX_SUPPORT];
    let mut n = 0;
    while n < MAX_SUPPORT {
        t[n][0] = 1.0;
        let mut i = 1;
        while i <= n {
            t[n][i] = t[n - 1][i - 1] + if i < n { t[n - 1][i] } else { 0.0 };
            i += 1;
        }
        n += 1;
    }
    t
}

/// Insert knot `t` once (Boehm) into a clamped B-spline of degree `p` with coefficients `c`.
pub(crate) fn insert_knot<P: Vector>(knots: &mut Vec<f64>, c: &mut Vec<P>, p: usize, t: f64) {
    // k: the last index with knots[k] <= t; `mult` the multiplicity of t already present.
    let k = knots.partition_point(|&x| x <= t) - 1;
    let mult = knots.iter().filter(|&&x| x == t).count();
    let mut out = Vec::with_capacity(c.len() + 1);
    for i in 0..=c.len() {
        if i + p <= k {
            out.push(c[i]);
        } else if i + mult > k {
            out.push(c[i - 1]);
        } else {
            let a = (t - knots[i]) / (knots[i + p] - knots[i]);
            out.push(c[i - 1] * (1.0 - a) + c[i] * a);
        }
    }
    knots.insert(k + 1, t);
    *c = out;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, CurveChain};
    use glam::DVec2;

    fn coeffs(n: usize) -> Vec<DVec2> {
        (0..n)
            .map(|i| DVec2::new(i as f64 * 0.3, (1.7 * i as f64).sin()))
            .collect()
    }

    #[test]
    fn counts_follow_the_multiplicities() {
        let l = SplineLayout::new(5, vec![0.0, 0.3, 0.5, 1.0], vec![1, 4]).unwrap();
        assert_eq!(l.coeff_count(), 6 + 4 + 1);
        let c1 = SplineLayout::with_order(3, vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0], 1).unwrap();
        assert_eq!(c1.coeff_count(), 12, "the paper's case 1");
        assert!(SplineLayout::new(3, vec![0.0, 0.5, 1.0], vec![3]).is_err());
        assert!(SplineLayout::new(3, vec![0.0, 0.5, 0.5, 1.0], vec![1, 1]).is_err());
        assert!(SplineLayout::new(0, vec![0.0, 1.0], vec![]).is_err());
    }

    #[test]
    fn c1_layouts_match_the_chain_extraction() {
        let breaks = vec![0.0, 0.15, 0.5, 0.8, 1.0];
        let l = SplineLayout::with_order(4, breaks.clone(), 1).unwrap();
        let chain_layout = ChainLayout::with_breaks(4, breaks, Continuity::C1).unwrap();
        let c = coeffs(l.coeff_count());
        let chain = CurveChain::new(chain_layout, c.clone()).unwrap();
        let ctrl = l.bezier(&c);
        assert_eq!(ctrl.len(), chain.ctrl().len());
        for (a, b) in ctrl.iter().zip(chain.ctrl()) {
            assert!((*a - *b).length() < 1e-13);
        }
    }

    #[test]
    fn basis_reproduces_the_bezier_chain_and_its_derivatives() {
        for orders in [vec![1, 3, 2], vec![3, 3, 3], vec![0, 1, 2]] {
            let l = SplineLayout::new(4, vec![0.0, 0.1, 0.45, 0.7, 1.0], orders.clone()).unwrap();
            let c = coeffs(l.coeff_count());
            let ctrl = l.bezier(&c);
            let chain =
                CurveChain::new(ChainLayout::uniform(4, 4, Continuity::C0).unwrap(), ctrl.clone()).unwrap();
            let h = 1e-6;
            for i in 0..=400 {
                let t = i as f64 / 400.0;
                let b = l.basis(t);
                let sum: f64 = b.value[..5].iter().sum();
                assert!((sum - 1.0).abs() < 1e-13);
                let p = l.eval(&c, t);
                // The Bezier segment from the extracted control points at the same t.
                let k = b.segment;
                let (t0, t1) = (l.breaks()[k], l.breaks()[k + 1]);
                let seg = crate::bezier::BezierCurve::new(ctrl[4 * k..=4 * k + 4].to_vec());
                let u = (t - t0) / (t1 - t0);
                assert!((seg.eval(u) - p).length() < 1e-13, "{orders:?} t={t}");
                let _ = chain.eval(t);
                // Derivatives by central differences inside a segment.
                if t - t0 > 2.0 * h && t1 - t > 2.0 * h {
                    let d1: DVec2 = (0..5).fold(DVec2::ZERO, |a, r| a + c[b.first + r] * b.d1[r]);
                    let d2: DVec2 = (0..5).fold(DVec2::ZERO, |a, r| a + c[b.first + r] * b.d2[r]);
                    let fd1 = (l.eval(&c, t + h) - l.eval(&c, t - h)) / (2.0 * h);
                    let fd2 = (l.eval(&c, t + h) - 2.0 * p + l.eval(&c, t - h)) / (h * h);
                    assert!((d1 - fd1).length() < 1e-6 * (1.0 + fd1.length()));
                    assert!((d2 - fd2).length() < 1e-3 * (1.0 + fd2.length()));
                }
            }
        }
    }

    #[test]
    fn bezier_form_and_values_agree_with_the_basis() {
        let l = SplineLayout::new(5, vec![0.0, 0.2, 0.5, 0.7, 1.0], vec![4, 1, 2]).unwrap();
        let c = coeffs(l.coeff_count());
        let f = BezierForm::new(&l, &c);
        for i in 0..=300 {
            let t = i as f64 / 300.0;
            let b = l.basis(t);
            let (first, v) = l.basis_values(t);
            assert_eq!(first, b.first);
            let (p, d1, d2) = f.jet(t);
            let (mut q, mut e1, mut e2) = (DVec2::ZERO, DVec2::ZERO, DVec2::ZERO);
            for a in 0..6 {
                assert!((v[a] - b.value[a]).abs() < 1e-15);
                q += c[first + a] * b.value[a];
                e1 += c[first + a] * b.d1[a];
                e2 += c[first + a] * b.d2[a];
            }
            assert!((p - q).length() < 1e-13);
            assert!((d1 - e1).length() < 1e-11 * (1.0 + e1.length()));
            assert!((d2 - e2).length() < 1e-9 * (1.0 + e2.length()));
        }
    }

    #[test]
    fn split_keeps_the_curve_exactly() {
        let l = SplineLayout::new(5, vec![0.0, 0.3, 1.0], vec![4]).unwrap();
        let c = coeffs(l.coeff_count());
        for order in [1, 2, 4] {
            let (l2, c2) = l.split(0.62, order, &c).unwrap();
            assert_eq!(l2.coeff_count(), l.coeff_count() + 5 - order);
            assert_eq!(l2.orders(), &[4, order]);
            for i in 0..=100 {
                let t = i as f64 / 100.0;
                assert!((l.eval(&c, t) - l2.eval(&c2, t)).length() < 1e-13);
            }
        }
        assert!(l.split(0.3, 1, &c).is_err());
        assert!(l.split(1.0, 1, &c).is_err());
    }

    #[test]
    fn expanded_points_are_c1_at_every_join() {
        let l = SplineLayout::new(3, vec![0.0, 0.2, 0.55, 1.0], vec![2, 1]).unwrap();
        let c = coeffs(l.coeff_count());
        let ctrl = l.bezier(&c);
        let b = l.breaks();
        for k in 1..l.segments() {
            let (hl, hr) = (b[k] - b[k - 1], b[k + 1] - b[k]);
            let dl = (ctrl[3 * k] - ctrl[3 * k - 1]) / hl;
            let dr = (ctrl[3 * k + 1] - ctrl[3 * k]) / hr;
            assert!((dl - dr).length() < 1e-12 * dl.length());
        }
    }
}
