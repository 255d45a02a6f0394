//! Forward-mode dual numbers: a value and its partials in `N` variables, carried through the
//! closures and the interval equations by the chain rule, so that one evaluation gives a row
//! block's residuals and their exact partials (`N = 0`: the plain value, the same operations
//! and so the same bits as in `f64`).

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A value and its partials in `N` variables.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct D<const N: usize> {
    /// The value.
    pub v: f64,
    /// Its partials.
    pub d: [f64; N],
}

impl<const N: usize> D<N> {
    /// A constant (no partials).
    #[inline]
    pub fn c(v: f64) -> Self {
        D { v, d: [0.0; N] }
    }

    /// The variable `k` of the `N`, at `v`.
    #[inline]
    pub fn var(v: f64, k: usize) -> Self {
        let mut d = [0.0; N];
        d[k] = 1.0;
        D { v, d }
    }

    /// `g(v)` with `g'(v) = dg`.
    #[inline]
    fn chain(self, v: f64, dg: f64) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x *= dg;
        }
        D { v, d }
    }

    /// `op` on the two values and on each pair of partials: a sum or a difference, whose
    /// partials are the sum or the difference of the partials.
    #[inline]
    fn zip(self, o: Self, op: impl Fn(f64, f64) -> f64) -> Self {
        let mut d = self.d;
        for k in 0..N {
            d[k] = op(d[k], o.d[k]);
        }
        D {
            v: op(self.v, o.v),
            d,
        }
    }

    /// The larger, by value (`f64::max`'s choice, ties to `self`).
    #[inline]
    pub fn max(self, o: Self) -> Self {
        if self.v >= o.v || o.v.is_nan() {
            self
        } else {
            o
        }
    }

    /// The smaller, by value (`f64::min`'s choice, ties to `self`).
    #[inline]
    pub fn min(self, o: Self) -> Self {
        if self.v <= o.v || o.v.is_nan() {
            self
        } else {
            o
        }
    }

    /// [`D::max`] with a constant.
    #[inline]
    pub fn fmax(self, c: f64) -> Self {
        self.max(D::c(c))
    }

    /// [`D::min`] with a constant.
    #[inline]
    pub fn fmin(self, c: f64) -> Self {
        self.min(D::c(c))
    }

    #[inline]
    pub fn ln(self) -> Self {
        self.chain(self.v.ln(), 1.0 / self.v)
    }

    #[inline]
    pub fn log10(self) -> Self {
        self.chain(self.v.log10(), 1.0 / (self.v * std::f64::consts::LN_10))
    }

    #[inline]
    pub fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }

    #[inline]
    pub fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.chain(s, 0.5 / s)
    }

    #[inline]
    pub fn tanh(self) -> Self {
        let t = self.v.tanh();
        self.chain(t, 1.0 - t * t)
    }

    #[inline]
    pub fn abs(self) -> Self {
        if self.v < 0.0 {
            -self
        } else {
            self
        }
    }

    #[inline]
    pub fn powi(self, n: i32) -> Self {
        let p = self.v.powi(n);
        self.chain(p, f64::from(n) * self.v.powi(n - 1))
    }

    #[inline]
    pub fn powf(self, e: f64) -> Self {
        let p = self.v.powf(e);
        self.chain(p, e * self.v.powf(e - 1.0))
    }

    /// `self ^ e`, both varying.
    #[inline]
    pub fn pow(self, e: Self) -> Self {
        let p = self.v.powf(e.v);
        let (da, de) = (e.v * self.v.powf(e.v - 1.0), p * self.v.ln());
        let mut d = [0.0; N];
        for k in 0..N {
            d[k] = da * self.d[k] + de * e.d[k];
        }
        D { v: p, d }
    }
}

impl<const N: usize> Add for D<N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        self.zip(o, |a, b| a + b)
    }
}

impl<const N: usize> Sub for D<N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        self.zip(o, |a, b| a - b)
    }
}

impl<const N: usize> Mul for D<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; N];
        for k in 0..N {
            d[k] = self.d[k] * o.v + self.v * o.d[k];
        }
        D { v: self.v * o.v, d }
    }
}

impl<const N: usize> Div for D<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let v = self.v / o.v;
        let mut d = [0.0; N];
        for k in 0..N {
            d[k] = (self.d[k] - v * o.d[k]) / o.v;
        }
        D { v, d }
    }
}

impl<const N: usize> Neg for D<N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x = -*x;
        }
        D { v: -self.v, d }
    }
}

impl<const N: usize> Add<f64> for D<N> {
    type Output = Self;
    #[inline]
    fn add(self, c: f64) -> Self {
        D {
            v: self.v + c,
            d: self.d,
        }
    }
}

impl<const N: usize> Sub<f64> for D<N> {
    type Output = Self;
    #[inline]
    fn sub(self, c: f64) -> Self {
        D {
            v: self.v - c,
            d: self.d,
        }
    }
}

impl<const N: usize> Mul<f64> for D<N> {
    type Output = Self;
    #[inline]
    fn mul(self, c: f64) -> Self {
        self.chain(self.v * c, c)
    }
}

impl<const N: usize> Div<f64> for D<N> {
    type Output = Self;
    #[inline]
    fn div(self, c: f64) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x /= c;
        }
        D { v: self.v / c, d }
    }
}

impl<const N: usize> Add<D<N>> for f64 {
    type Output = D<N>;
    #[inline]
    fn add(self, o: D<N>) -> D<N> {
        D {
            v: self + o.v,
            d: o.d,
        }
    }
}

impl<const N: usize> Sub<D<N>> for f64 {
    type Output = D<N>;
    #[inline]
    fn sub(self, o: D<N>) -> D<N> {
        let mut d = o.d;
        for x in &mut d {
            *x = -*x;
        }
        D { v: self - o.v, d }
    }
}

impl<const N: usize> Mul<D<N>> for f64 {
    type Output = D<N>;
    #[inline]
    fn mul(self, o: D<N>) -> D<N> {
        o.chain(self * o.v, self)
    }
}

impl<const N: usize> Div<D<N>> for f64 {
    type Output = D<N>;
    #[inline]
    fn div(self, o: D<N>) -> D<N> {
        let v = self / o.v;
        o.chain(v, -v / o.v)
    }
}

/// A plain state as dual numbers without partials.
#[inline]
pub fn lift<const M: usize>(u: &[f64; M]) -> [D<0>; M] {
    u.map(D::c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partials_of_a_composite_match_central_differences() {
        let f = |x: D<2>, y: D<2>| (x * y).ln() + (x / y).sqrt().tanh() + x.pow(y) - 3.0 / (y + 1.0);
        let (x0, y0) = (1.3, 0.7);
        let r = f(D::var(x0, 0), D::var(y0, 1));
        let g = |x: f64, y: f64| f(D::c(x), D::c(y)).v;
        let h = 1e-6;
        let dx = (g(x0 + h, y0) - g(x0 - h, y0)) / (2.0 * h);
        let dy = (g(x0, y0 + h) - g(x0, y0 - h)) / (2.0 * h);
        assert!(
            (r.d[0] - dx).abs() < 1e-8 && (r.d[1] - dy).abs() < 1e-8,
            "{r:?} {dx} {dy}"
        );
    }
}
