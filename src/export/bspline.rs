//! The B-spline shapes a CAD file holds: a chain as one B-spline curve, a patch grid as one
//! tensor-product B-spline surface (exactly, over the layouts' own knot vectors), their
//! evaluation for checks, and the length unit they are written in.

use crate::adaptive::{Encoding, SurfaceEncoding};
use crate::bezier::tensor_jet;
use crate::chain::{ChainLayout, CurveChain, PatchGrid};
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

/// The length unit of the CAD files. The shapes are in the data's units, taken to be metres;
/// the files declare this unit and hold the coordinates in it (× 1000 in millimetres).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CadUnit {
    /// Metres (default): the coordinates as they are.
    #[default]
    Metre,
    /// Millimetres (what OpenCASCADE writes unless told otherwise): the coordinates × 1000.
    Millimetre,
}

keywords!(CadUnit, "CAD unit", { Metre => "m", Millimetre => "mm" });

impl CadUnit {
    /// How many of this unit make a metre: the factor from the data's units (metres) to the
    /// file's coordinates.
    #[must_use]
    pub fn per_metre(self) -> f64 {
        match self {
            CadUnit::Metre => 1.0,
            CadUnit::Millimetre => 1000.0,
        }
    }

    /// The smallest length the files resolve, 0.1 µm, in this unit (the STEP uncertainty and
    /// the IGES minimum resolution).
    #[must_use]
    pub fn resolution(self) -> f64 {
        self.per_metre() / 1e7
    }
}

impl CadShape {
    /// What the shape is, in words: `B-spline curve, degree 3, 8 control points`.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            CadShape::Curve(c) => format!(
                "B-spline curve, degree {}, {} control points",
                c.degree,
                c.ctrl.len()
            ),
            CadShape::Surface(s) => format!(
                "B-spline surface, degrees {} x {}, {} x {} control points",
                s.degree[0], s.degree[1], s.count[0], s.count[1]
            ),
        }
    }

    /// The shape with its control points in `unit` (knots unchanged): what the files hold.
    #[must_use]
    pub fn in_unit(&self, unit: CadUnit) -> CadShape {
        let mut out = self.clone();
        let ctrl = match &mut out {
            CadShape::Curve(c) => &mut c.ctrl,
            CadShape::Surface(s) => &mut s.ctrl,
        };
        for p in ctrl {
            *p *= unit.per_metre();
        }
        out
    }
}

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

/// The chain whose B-spline form has `degree` and `knots`: its layout (the knots' distinct
/// values mapped from `[lo, hi]` to the breaks in `[0, 1]`, an interior knot of multiplicity
/// `m` a join of continuity order `degree - m`) with `lo` and `hi`. `None` where the knots are
/// not a chain's (clamped ends of multiplicity `degree + 1`, degree 1 to
/// [`MAX_DEGREE`](crate::chain::MAX_DEGREE), interior multiplicities 1 to `degree`).
///
/// The exported B-splines are evaluated as these chains, through their Bezier extraction and
/// the one Bernstein evaluator ([`ChainLayout::basis`]): exactly the curves and surfaces the
/// reports hold.
fn chain_layout(degree: usize, knots: &[f64]) -> Option<(ChainLayout, f64, f64)> {
    let (values, mults) = distinct_knots(knots);
    let (&lo, &hi) = (values.first()?, values.last()?);
    let clamped = |m: &usize| *m == degree + 1;
    if values.len() < 2 || !mults.first().is_some_and(clamped) || !mults.last().is_some_and(clamped) {
        return None;
    }
    let breaks = values.iter().map(|k| (k - lo) / (hi - lo)).collect();
    let orders = mults[1..mults.len() - 1]
        .iter()
        .map(|&m| degree.checked_sub(m))
        .collect::<Option<Vec<_>>>()?;
    let layout = ChainLayout::with_orders(degree, breaks, orders).ok()?;
    Some((layout, lo, hi))
}

/// The layout's parameter of `t` in `[lo, hi]`.
fn to_unit(t: f64, lo: f64, hi: f64) -> f64 {
    (t - lo) / (hi - lo)
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

    /// The point at parameter `t` (clamped to the knot range), evaluated as the chain the
    /// B-spline is; NaN where the knots are not a chain's (clamped, degree 1 to 7, interior
    /// multiplicities 1 to the degree).
    #[must_use]
    pub fn eval(&self, t: f64) -> DVec3 {
        let Some((layout, lo, hi)) = chain_layout(self.degree, &self.knots) else {
            debug_assert!(false, "BsplineCurve::eval: the knots are not a chain's");
            return DVec3::NAN;
        };
        layout.eval(&self.ctrl, to_unit(t, lo, hi))
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

    /// The point at `(u, v)` (clamped to the knot ranges), evaluated as the patch grid the
    /// B-spline surface is; NaN where either knot vector is not a chain's.
    #[must_use]
    pub fn eval(&self, u: f64, v: f64) -> DVec3 {
        let along = |d: usize, knots: &[f64], t: f64| {
            chain_layout(d, knots).map(|(l, lo, hi)| (l.basis(to_unit(t, lo, hi), 0), d + 1))
        };
        let (Some((bu, nu)), Some((bv, nv))) = (
            along(self.degree[0], &self.knots_u, u),
            along(self.degree[1], &self.knots_v, v),
        ) else {
            debug_assert!(false, "BsplineSurface::eval: the knots are not a grid's");
            return DVec3::NAN;
        };
        let net = &self.ctrl[bu.first * self.count[1] + bv.first..];
        tensor_jet(net, self.count[1], (nu, nv), [&bu.value], [&bv.value], 0)[0][0]
    }

    /// The boundary curve at `u = knots_u` start (`side` 0) or end (1), running along v.
    #[must_use]
    pub fn u_boundary(&self, side: usize) -> BsplineCurve {
        let i = if side == 0 { 0 } else { self.count[0] - 1 };
        self.curve_along(1, |j| self.at(i, j))
    }

    /// The boundary curve at the start (`side` 0) or end (1) of v, running along u.
    #[must_use]
    pub fn v_boundary(&self, side: usize) -> BsplineCurve {
        let j = if side == 0 { 0 } else { self.count[1] - 1 };
        self.curve_along(0, |i| self.at(i, j))
    }

    /// The curve running along u (`dir` 0) or v (1) whose `k`-th control point is `ctrl(k)`.
    fn curve_along(&self, dir: usize, ctrl: impl Fn(usize) -> DVec3) -> BsplineCurve {
        BsplineCurve {
            degree: self.degree[dir],
            knots: [&self.knots_u, &self.knots_v][dir].clone(),
            ctrl: (0..self.count[dir]).map(ctrl).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shape_says_its_kind_degrees_and_control_points() {
        let curve = CadShape::Curve(BsplineCurve {
            degree: 3,
            knots: vec![0.0; 8],
            ctrl: vec![DVec3::ZERO; 4],
        });
        assert_eq!(curve.describe(), "B-spline curve, degree 3, 4 control points");
        let surface = CadShape::Surface(BsplineSurface {
            degree: [3, 2],
            knots_u: Vec::new(),
            knots_v: Vec::new(),
            count: [4, 3],
            ctrl: vec![DVec3::ZERO; 12],
        });
        assert_eq!(
            surface.describe(),
            "B-spline surface, degrees 3 x 2, 4 x 3 control points"
        );
    }
}
