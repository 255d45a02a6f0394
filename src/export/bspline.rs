//! The B-spline shapes a CAD file holds: a chain as one B-spline curve, a patch grid as one
//! tensor-product B-spline surface (exactly, over the layouts' own knot vectors), their
//! evaluation for checks, and the length unit they are written in.

use crate::adaptive::{Encoding, SurfaceEncoding};
use crate::chain::{CurveChain, PatchGrid};
use crate::error::Result;
use crate::keyword::keywords;
use glam::{DVec2, DVec3};

/// A non-rational B-spline curve over a clamped knot vector.
#[derive(Clone, Debug, PartialEq)]
pub struct BsplineCurve {
    /// Polynomial degree.
    pub degree: usize,
    /// The full knot vector (`degree + 1` equal knots at each end), non-decreasing.
    pub knots: Vec<f64>,
    /// Control points, `knots.len() - degree - 1` of them.
    pub ctrl: Vec<DVec3>,
}

/// A non-rational tensor-product B-spline surface over clamped knot vectors.
#[derive(Clone, Debug, PartialEq)]
pub struct BsplineSurface {
    /// Degrees `[du, dv]`.
    pub degree: [usize; 2],
    /// Knot vector along u.
    pub knots_u: Vec<f64>,
    /// Knot vector along v.
    pub knots_v: Vec<f64>,
    /// Number of control points along u and along v.
    pub count: [usize; 2],
    /// Control points, row-major: point `(i, j)` (i along u) at `i * count[1] + j`.
    pub ctrl: Vec<DVec3>,
}

/// One exported entity.
#[derive(Clone, Debug, PartialEq)]
pub enum CadShape {
    /// A curve (a chain; 2D chains lie in z = 0).
    Curve(BsplineCurve),
    /// A surface (a patch grid).
    Surface(BsplineSurface),
}

/// The length unit written into the files (the coordinates themselves are never scaled).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CadUnit {
    /// Metres (default).
    #[default]
    Metre,
    /// Millimetres (what OpenCASCADE writes unless told otherwise).
    Millimetre,
}

keywords!(CadUnit, "CAD unit", { Metre => "m", Millimetre => "mm" });

/// The knots that differ and how often each occurs (STEP's form).
#[must_use]
pub fn distinct_knots(knots: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut values: Vec<f64> = Vec::new();
    let mut mults: Vec<usize> = Vec::new();
    for &k in knots {
        if values.last() == Some(&k) {
            if let Some(m) = mults.last_mut() {
                *m += 1;
            }
        } else {
            values.push(k);
            mults.push(1);
        }
    }
    (values, mults)
}

/// The B-spline basis functions of `degree` over `knots` that are non-zero at `t` (clamped to
/// the knot range): the index of the first and their values (Cox-de Boor).
fn basis(degree: usize, knots: &[f64], t: f64) -> (usize, Vec<f64>) {
    let n = knots.len() - degree - 1;
    let (lo, hi) = (knots[degree], knots[n]);
    let t = t.clamp(lo, hi);
    // The span: knots[span] <= t < knots[span + 1], the last non-empty span at the end.
    let span = if t >= hi {
        (degree..n)
            .rev()
            .find(|&s| knots[s] < knots[s + 1])
            .unwrap_or(degree)
    } else {
        knots.partition_point(|&k| k <= t) - 1
    };
    let mut values = vec![0.0; degree + 1];
    let mut left = vec![0.0; degree + 1];
    let mut right = vec![0.0; degree + 1];
    values[0] = 1.0;
    for j in 1..=degree {
        left[j] = t - knots[span + 1 - j];
        right[j] = knots[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = values[r] / (right[r + 1] + left[j - r]);
            values[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        values[j] = saved;
    }
    (span - degree, values)
}

impl BsplineCurve {
    /// The B-spline form of a chain (exact).
    #[must_use]
    pub fn from_chain(chain: &CurveChain<DVec2>) -> Self {
        let knots = chain.layout().knots().to_vec();
        let ctrl: Vec<DVec3> = chain.design().iter().map(|p| p.extend(0.0)).collect();
        debug_assert_eq!(
            ctrl.len(),
            knots.len() - chain.layout().degree() - 1,
            "one design point per basis function"
        );
        BsplineCurve {
            degree: chain.layout().degree(),
            knots,
            ctrl,
        }
    }

    /// The B-spline an adapted curve's encoding stores (each join its own continuity).
    pub fn from_encoding(enc: &Encoding) -> Result<Self> {
        let layout = enc.layout()?;
        Ok(BsplineCurve {
            degree: layout.degree(),
            knots: layout.knots().to_vec(),
            ctrl: enc.coeffs()?.iter().map(|p| p.extend(0.0)).collect(),
        })
    }

    /// The point at parameter `t` (clamped to the knot range).
    #[must_use]
    pub fn eval(&self, t: f64) -> DVec3 {
        let (first, b) = basis(self.degree, &self.knots, t);
        b.iter().enumerate().map(|(a, w)| self.ctrl[first + a] * *w).sum()
    }
}

impl BsplineSurface {
    /// The B-spline form of a patch grid (exact).
    #[must_use]
    pub fn from_grid(grid: &PatchGrid<DVec3>) -> Self {
        let l = grid.layout();
        let (nu, nv) = l.design_shape();
        BsplineSurface {
            degree: [l.u.degree(), l.v.degree()],
            knots_u: l.u.knots().to_vec(),
            knots_v: l.v.knots().to_vec(),
            count: [nu, nv],
            ctrl: grid.design().to_vec(),
        }
    }

    /// The B-spline surface an adapted grid's encoding stores.
    pub fn from_encoding(enc: &SurfaceEncoding) -> Result<Self> {
        let (lu, lv) = enc.layouts()?;
        Ok(BsplineSurface {
            degree: [lu.degree(), lv.degree()],
            knots_u: lu.knots().to_vec(),
            knots_v: lv.knots().to_vec(),
            count: [lu.design_count(), lv.design_count()],
            ctrl: enc.design()?,
        })
    }

    /// The control point `(i, j)`.
    #[must_use]
    pub fn at(&self, i: usize, j: usize) -> DVec3 {
        self.ctrl[i * self.count[1] + j]
    }

    /// The point at `(u, v)` (clamped to the knot ranges).
    #[must_use]
    pub fn eval(&self, u: f64, v: f64) -> DVec3 {
        let (fu, bu) = basis(self.degree[0], &self.knots_u, u);
        let (fv, bv) = basis(self.degree[1], &self.knots_v, v);
        let mut p = DVec3::ZERO;
        for (a, wu) in bu.iter().enumerate() {
            for (b, wv) in bv.iter().enumerate() {
                p += self.at(fu + a, fv + b) * (wu * wv);
            }
        }
        p
    }

    /// The boundary curve at `u = knots_u` start (`side` 0) or end (1), running along v.
    #[must_use]
    pub fn u_boundary(&self, side: usize) -> BsplineCurve {
        let i = if side == 0 { 0 } else { self.count[0] - 1 };
        BsplineCurve {
            degree: self.degree[1],
            knots: self.knots_v.clone(),
            ctrl: (0..self.count[1]).map(|j| self.at(i, j)).collect(),
        }
    }

    /// The boundary curve at the start (`side` 0) or end (1) of v, running along u.
    #[must_use]
    pub fn v_boundary(&self, side: usize) -> BsplineCurve {
        let j = if side == 0 { 0 } else { self.count[1] - 1 };
        BsplineCurve {
            degree: self.degree[0],
            knots: self.knots_u.clone(),
            ctrl: (0..self.count[0]).map(|i| self.at(i, j)).collect(),
        }
    }
}
