//! The `Shape` trait: a chain or a patch grid seen as a map from parameters to points that is
//! linear in its design points, with the basis and its derivatives that fitting needs.
//!
//! A shape of parameter dimension `K` (1 for curves, 2 for patch grids) evaluates as
//! `C(t) = Σ_i φ_i(t) x_i` over its design points `x_i`. The domain `[0, 1]^K` is cut into
//! cells (segments or patches); in each cell only a few design points (its *support*) have a
//! non-zero `φ_i`. Every fitting routine (foot points, least squares, gradients) works through
//! this trait, so the curve and the surface fits share one implementation.

use super::{ChainLayout, GridLayout, SpanBasis};
use crate::bezier::{combine, tensor_jet, Vector};
use std::marker::PhantomData;

/// The basis of a shape at one parameter: the cell holding it and, over that cell's support,
/// the values `φ_i`, first derivatives `∂φ_i/∂t_k` and second derivatives `∂²φ_i/∂t_k∂t_l`
/// with respect to the global parameters.
#[derive(Clone, Debug, Default)]
pub struct Basis<const K: usize> {
    /// The cell (segment or patch) that holds the parameter.
    pub cell: usize,
    /// `φ_i` over the cell's support.
    pub value: Vec<f64>,
    /// `∂φ_i/∂t_k` (filled when the requested order is at least 1).
    pub d1: Vec<[f64; K]>,
    /// `∂²φ_i/∂t_k∂t_l` (filled when the requested order is 2).
    pub d2: Vec<[[f64; K]; K]>,
}

impl<const K: usize> Basis<K> {
    /// An empty basis, to be filled by [`Shape::basis`].
    #[must_use]
    pub fn new() -> Self {
        Basis {
            cell: 0,
            value: Vec::new(),
            d1: Vec::new(),
            d2: Vec::new(),
        }
    }

    fn resize(&mut self, len: usize, order: usize) {
        self.value.resize(len, 0.0);
        if order >= 1 {
            self.d1.resize(len, [0.0; K]);
        }
        if order >= 2 {
            self.d2.resize(len, [[0.0; K]; K]);
        }
    }
}

/// A point with its first and second derivatives with respect to the global parameters.
#[derive(Clone, Copy, Debug)]
pub struct Jet<P, const K: usize> {
    /// The point `C(t)`.
    pub point: P,
    /// `∂C/∂t_k`.
    pub d1: [P; K],
    /// `∂²C/∂t_k∂t_l`.
    pub d2: [[P; K]; K],
}

/// A parametric shape linear in its design points (see the module docs).
pub trait Shape<const K: usize>: Sync {
    /// The point type, `DVec2` or `DVec3`.
    type Point: Vector;

    /// Number of design points.
    fn design_count(&self) -> usize;

    /// Number of cells (segments or patches).
    fn cell_count(&self) -> usize;

    /// The design indices supporting cell `cell`, ascending.
    fn support(&self, cell: usize) -> &[u32];

    /// The box `[lo, hi]` of global parameters covered by cell `cell`.
    fn cell_box(&self, cell: usize) -> ([f64; K], [f64; K]);

    /// The basis at global parameter `t` (each coordinate clamped to `[0, 1]`), with
    /// derivatives up to `order` (0, 1 or 2).
    fn basis(&self, t: [f64; K], order: usize, out: &mut Basis<K>);

    /// A bound, in model units, on the distance between cell `cell` and the piecewise
    /// multilinear interpolant of its values on a regular grid of `samples` intervals per
    /// direction, so that the cell lies within that distance of the samples' bounding box.
    /// `None` (the default) when the shape offers none; the foot-point search then falls back
    /// to a bound of 1.5 sample spacings.
    fn sample_deviation(&self, _cell: usize, _design: &[Self::Point], _samples: usize) -> Option<f64> {
        None
    }

    /// The point and its derivatives up to `order` at global parameter `t` for the design
    /// points `design`; `scratch` is working space. The default fills `scratch` with the
    /// basis and applies [`Shape::jet`]; shapes may evaluate more directly.
    #[must_use]
    fn eval_jet(
        &self,
        t: [f64; K],
        order: usize,
        design: &[Self::Point],
        scratch: &mut Basis<K>,
    ) -> Jet<Self::Point, K> {
        self.basis(t, order, scratch);
        self.jet(scratch, design, order)
    }

    /// A design prepared for evaluation at many parameters (see [`Shape::prepare`]).
    type Prepared<'d>: Sync
    where
        Self: 'd;

    /// Prepare `design` for [`Shape::jet_at`]: chains keep their expanded Bezier control
    /// points, so that each evaluation is a Horner scheme on one segment's points; grids keep
    /// the design as it is.
    fn prepare<'d>(&self, design: &'d [Self::Point]) -> Self::Prepared<'d>;

    /// The point and its derivatives up to `order` at global parameter `t` of a prepared
    /// design (the same as [`Shape::eval_jet`] to rounding); `scratch` is working space.
    fn jet_at(
        &self,
        prepared: &Self::Prepared<'_>,
        t: [f64; K],
        order: usize,
        scratch: &mut Basis<K>,
    ) -> Jet<Self::Point, K>;

    /// The curve of the first parameter with the others held at `t`'s values: its shape and
    /// its design points, where the shape is a tensor product (a patch grid's row through
    /// `v`, on the grid's u layout); `None` (the default) where it has no such restriction.
    /// A foot-point search that holds every other parameter then searches the curve, whose
    /// evaluation is a Horner scheme on one segment instead of a tensor-product sum.
    fn first_curve(&self, _design: &[Self::Point], _t: [f64; K]) -> Option<FirstCurve<'_, Self::Point>> {
        None
    }

    /// Orders of the design points (`order[k]`: the point at position `k`) in which a
    /// least-squares system on them may be narrower than in their own numbering: a grid's
    /// points column by column, which on a net with fewer columns than rows beats both the
    /// row-major numbering and reverse Cuthill-McKee (band 82 against 95 and 146 on a 26 x 23
    /// net of degrees 4 x 3). None by default.
    fn narrow_orders(&self) -> Vec<Vec<u32>> {
        Vec::new()
    }

    /// For a tensor-product shape, the basis values at `t` as the product of the first
    /// parameter's (`first`) and the other parameters' (`rest`): value `a * rest.len() + b`
    /// of the cell's support is `first[a] rest[b]`. Returns the cell, `None` (the default)
    /// where the basis is no such product. A least-squares sum over points that share the
    /// other parameters (a section of a sectioned cloud) then adds the first factor's small
    /// products and expands them once per cell. `same`: the cell of the previous call, whose
    /// other parameters were these (a run along a section), so that `rest` already holds
    /// their factor and only the first is computed.
    fn product_basis(
        &self,
        _t: [f64; K],
        _first: &mut Vec<f64>,
        _rest: &mut Vec<f64>,
        _same: Option<usize>,
    ) -> Option<usize> {
        None
    }

    /// The basis at `t` (its values; shapes may fill more) and the point with its first
    /// derivatives there, the design given both prepared and as it is: what a residual and
    /// its Jacobian take. The default fills the basis with first derivatives and applies
    /// [`Shape::jet`].
    fn basis_and_jet(
        &self,
        _prepared: &Self::Prepared<'_>,
        design: &[Self::Point],
        t: [f64; K],
        out: &mut Basis<K>,
    ) -> Jet<Self::Point, K> {
        self.basis(t, 1, out);
        self.jet(out, design, 1)
    }

    /// Evaluate the shape from its basis at some parameter and the design points.
    #[must_use]
    fn jet(&self, basis: &Basis<K>, design: &[Self::Point], order: usize) -> Jet<Self::Point, K> {
        let zero = Self::Point::ZERO;
        let mut jet = Jet {
            point: zero,
            d1: [zero; K],
            d2: [[zero; K]; K],
        };
        let support = self.support(basis.cell);
        for (a, &i) in support.iter().enumerate() {
            let x = design[i as usize];
            jet.point += x * basis.value[a];
            if order >= 1 {
                for k in 0..K {
                    jet.d1[k] += x * basis.d1[a][k];
                }
            }
            if order >= 2 {
                for k in 0..K {
                    for l in 0..K {
                        jet.d2[k][l] += x * basis.d2[a][k][l];
                    }
                }
            }
        }
        jet
    }
}

/// A curve of a shape's first parameter ([`Shape::first_curve`]): its shape and its design.
pub type FirstCurve<'s, P> = (&'s CurveShape<P>, Vec<P>);

/// A chain of Bezier curves as a [`Shape`] of parameter dimension 1.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveShape<P> {
    layout: ChainLayout,
    _point: PhantomData<fn() -> P>,
}

impl<P: Vector> CurveShape<P> {
    /// The shape of chains with this layout.
    #[must_use]
    pub fn new(layout: ChainLayout) -> Self {
        CurveShape {
            layout,
            _point: PhantomData,
        }
    }

    /// The layout.
    #[must_use]
    pub fn layout(&self) -> &ChainLayout {
        &self.layout
    }
}

impl<P: Vector> Shape<1> for CurveShape<P> {
    type Point = P;
    type Prepared<'d> = Vec<P>;

    fn prepare(&self, design: &[P]) -> Vec<P> {
        self.layout.bezier(design)
    }

    /// The basis values, and the point and tangent by Horner's scheme, the parameter located
    /// once for both.
    fn basis_and_jet(&self, ctrl: &Vec<P>, _design: &[P], t: [f64; 1], out: &mut Basis<1>) -> Jet<P, 1> {
        let (k, u) = self.layout.locate(t[0]);
        fill_basis(&self.layout.basis_in(k, u, 0), self.layout.degree() + 1, 0, out);
        let [point, d1, d2] = self.layout.segment_jet_in(ctrl, k, u, 1);
        Jet {
            point,
            d1: [d1],
            d2: [[d2]],
        }
    }

    /// Horner's scheme on the segment's Bezier control points and their differences.
    fn jet_at(&self, ctrl: &Vec<P>, t: [f64; 1], order: usize, _scratch: &mut Basis<1>) -> Jet<P, 1> {
        let [point, d1, d2] = self.layout.segment_jet(ctrl, t[0], order);
        Jet {
            point,
            d1: [d1],
            d2: [[d2]],
        }
    }

    fn design_count(&self) -> usize {
        self.layout.design_count()
    }

    fn cell_count(&self) -> usize {
        self.layout.segments()
    }

    fn support(&self, cell: usize) -> &[u32] {
        self.layout.support(cell)
    }

    fn cell_box(&self, cell: usize) -> ([f64; 1], [f64; 1]) {
        let b = self.layout.breaks();
        ([b[cell]], [b[cell + 1]])
    }

    /// From the layout's basis on the stack, without filling `scratch`.
    fn eval_jet(&self, t: [f64; 1], order: usize, design: &[P], _scratch: &mut Basis<1>) -> Jet<P, 1> {
        let b = self.layout.basis(t[0], order);
        let x = &design[b.first..=b.first + self.layout.degree()];
        let at = |k: usize, w: &[f64]| if order >= k { combine(x, w) } else { P::ZERO };
        Jet {
            point: combine(x, &b.value),
            d1: [at(1, &b.d1)],
            d2: [[at(2, &b.d2)]],
        }
    }

    fn basis(&self, t: [f64; 1], order: usize, out: &mut Basis<1>) {
        fill_basis(
            &self.layout.basis(t[0], order),
            self.layout.degree() + 1,
            order,
            out,
        );
    }
}

/// `out` from a chain's basis `b` of `n` functions, with derivatives up to `order`.
#[inline]
fn fill_basis(b: &SpanBasis, n: usize, order: usize, out: &mut Basis<1>) {
    out.resize(n, order);
    out.cell = b.segment;
    out.value.copy_from_slice(&b.value[..n]);
    if order >= 1 {
        for (o, &x) in out.d1.iter_mut().zip(&b.d1[..n]) {
            *o = [x];
        }
    }
    if order >= 2 {
        for (o, &x) in out.d2.iter_mut().zip(&b.d2[..n]) {
            *o = [[x]];
        }
    }
}

/// A grid of tensor-product Bezier patches as a [`Shape`] of parameter dimension 2.
///
/// Design point `(i, j)` of the row-major design net has index `i * nv + j`; cell `(a, b)`
/// (patch `a` along u, `b` along v) has index `a * pv + b`.
#[derive(Clone, Debug, PartialEq)]
pub struct GridShape<P> {
    u: ChainLayout,
    v: ChainLayout,
    supports: Vec<Vec<u32>>,
    /// The chains of the u layout: the grid's rows at fixed `v` ([`Shape::first_curve`]).
    rows: CurveShape<P>,
    _point: PhantomData<fn() -> P>,
}

impl<P: Vector> GridShape<P> {
    /// The shape of patch grids with this layout.
    #[must_use]
    pub fn new(layout: GridLayout) -> Self {
        let (u, v) = (layout.u, layout.v);
        let nv = v.design_count() as u32;
        let mut supports = Vec::new();
        for a in 0..u.segments() {
            for b in 0..v.segments() {
                let s: Vec<u32> = u
                    .support(a)
                    .iter()
                    .flat_map(|&i| v.support(b).iter().map(move |&j| i * nv + j))
                    .collect();
                supports.push(s);
            }
        }
        GridShape {
            rows: CurveShape::new(u.clone()),
            u,
            v,
            supports,
            _point: PhantomData,
        }
    }

    /// The layout.
    #[must_use]
    pub fn layout(&self) -> GridLayout {
        GridLayout::new(self.u.clone(), self.v.clone())
    }
}

impl<P: Vector> Shape<2> for GridShape<P> {
    type Point = P;
    type Prepared<'d> = &'d [P];

    fn prepare<'d>(&self, design: &'d [P]) -> &'d [P] {
        design
    }

    fn jet_at(&self, design: &&[P], t: [f64; 2], order: usize, scratch: &mut Basis<2>) -> Jet<P, 2> {
        self.eval_jet(t, order, design, scratch)
    }

    fn narrow_orders(&self) -> Vec<Vec<u32>> {
        let (nu, nv) = (self.u.design_count() as u32, self.v.design_count() as u32);
        vec![(0..nv).flat_map(|j| (0..nu).map(move |i| i * nv + j)).collect()]
    }

    fn product_basis(
        &self,
        t: [f64; 2],
        first: &mut Vec<f64>,
        rest: &mut Vec<f64>,
        same: Option<usize>,
    ) -> Option<usize> {
        // Each factor's values read off one basis filled in place ([`ChainLayout::basis_into`]).
        let mut b = SpanBasis::default();
        let (ku, u) = self.u.locate(t[0]);
        self.u.basis_into(ku, u, 0, &mut b);
        first.clear();
        first.extend_from_slice(&b.value[..self.u.support(ku).len()]);
        let pv = self.v.segments();
        let kv = match same {
            Some(cell) => cell % pv,
            None => {
                let (kv, v) = self.v.locate(t[1]);
                self.v.basis_into(kv, v, 0, &mut b);
                rest.clear();
                rest.extend_from_slice(&b.value[..self.v.support(kv).len()]);
                kv
            }
        };
        Some(ku * pv + kv)
    }

    /// Row `i` of the curve's design is `Σ_j B_j(v) x_ij` over the v basis at `t[1]`.
    fn first_curve(&self, design: &[P], t: [f64; 2]) -> Option<FirstCurve<'_, P>> {
        let bv = self.v.basis(t[1], 0);
        let (nv, first) = (self.v.design_count(), bv.first);
        let row = (0..self.u.design_count())
            .map(|i| {
                combine(
                    &design[i * nv + first..=i * nv + first + self.v.degree()],
                    &bv.value,
                )
            })
            .collect();
        Some((&self.rows, row))
    }

    fn design_count(&self) -> usize {
        self.u.design_count() * self.v.design_count()
    }

    fn cell_count(&self) -> usize {
        self.supports.len()
    }

    fn support(&self, cell: usize) -> &[u32] {
        &self.supports[cell]
    }

    fn cell_box(&self, cell: usize) -> ([f64; 2], [f64; 2]) {
        let pv = self.v.segments();
        let (a, b) = (cell / pv, cell % pv);
        let (bu, bv) = (self.u.breaks(), self.v.breaks());
        ([bu[a], bv[b]], [bu[a + 1], bv[b + 1]])
    }

    /// The Bezier patch's second differences bound its second derivatives (each is a convex
    /// combination of `d (d - 1) Δ²P`), and the bilinear interpolant on a grid of local spacing
    /// `h` is within `h² (max|S_uu| + max|S_vv|) / 8` of the patch.
    fn sample_deviation(&self, cell: usize, design: &[P], samples: usize) -> Option<f64> {
        let pv = self.v.segments();
        let (a, b) = (cell / pv, cell % pv);
        let (du, dv) = (self.u.degree(), self.v.degree());
        let (su, sv) = (self.u.support(a), self.v.support(b));
        let (lu, lv) = (self.u.local(a), self.v.local(b));
        let nv = self.v.design_count();
        let (wu, wv) = (du + 1, dv + 1);
        // T[i][c] = Σ_j Lv[j][c] x[su[i], sv[j]], then net[r][c] = Σ_i Lu[i][r] T[i][c].
        let mut half = vec![P::ZERO; su.len() * wv];
        for (i, &ri) in su.iter().enumerate() {
            for (j, &cj) in sv.iter().enumerate() {
                let x = design[ri as usize * nv + cj as usize];
                for c in 0..wv {
                    half[i * wv + c] += x * lv[j * wv + c];
                }
            }
        }
        let mut net = vec![P::ZERO; wu * wv];
        for i in 0..su.len() {
            for r in 0..wu {
                let w = lu[i * wu + r];
                if w == 0.0 {
                    continue;
                }
                for c in 0..wv {
                    net[r * wv + c] += half[i * wv + c] * w;
                }
            }
        }
        let mut m_uu: f64 = 0.0;
        let mut m_vv: f64 = 0.0;
        for r in 0..wu {
            for c in 0..wv {
                let at = |r: usize, c: usize| net[r * wv + c];
                if r + 2 < wu {
                    m_uu = m_uu.max((at(r + 2, c) - at(r + 1, c) * 2.0 + at(r, c)).length());
                }
                if c + 2 < wv {
                    m_vv = m_vv.max((at(r, c + 2) - at(r, c + 1) * 2.0 + at(r, c)).length());
                }
            }
        }
        let h = 1.0 / samples.max(1) as f64;
        let dev = h * h / 8.0
            * ((du * du.saturating_sub(1)) as f64 * m_uu + (dv * dv.saturating_sub(1)) as f64 * m_vv);
        // A hair more, so that rounding in the samples never makes the bound too tight.
        dev.is_finite()
            .then_some(dev * (1.0 + 1e-9) + 1e-15 * net.iter().fold(0.0_f64, |m, p| m.max(p.length())))
    }

    /// By the tensor structure: each supporting row of design points is combined with the v
    /// basis, then the rows with the u basis (about half the work of the 16-term sums).
    fn eval_jet(&self, t: [f64; 2], order: usize, design: &[P], _scratch: &mut Basis<2>) -> Jet<P, 2> {
        let bu = self.u.basis(t[0], order);
        let bv = self.v.basis(t[1], order);
        let nv = self.v.design_count();
        // The support's rows are consecutive design rows, its columns consecutive columns.
        let net = &design[bu.first * nv + bv.first..];
        let n = (self.u.degree() + 1, self.v.degree() + 1);
        let [[p, pv, pvv], [pu, puv, _], [puu, _, _]] = tensor_jet(
            net,
            nv,
            n,
            [&bu.value, &bu.d1, &bu.d2],
            [&bv.value, &bv.d1, &bv.d2],
            order.min(2),
        );
        Jet {
            point: p,
            d1: [pu, pv],
            d2: [[puu, puv], [puv, pvv]],
        }
    }

    fn basis(&self, t: [f64; 2], order: usize, out: &mut Basis<2>) {
        let bu = self.u.basis(t[0], order);
        let bv = self.v.basis(t[1], order);
        let (a, b) = (bu.segment, bv.segment);
        let (vu, du, ddu) = (&bu.value, &bu.d1, &bu.d2);
        let (vv, dv, ddv) = (&bv.value, &bv.d1, &bv.d2);
        let (nu, nv) = (self.u.support(a).len(), self.v.support(b).len());
        out.cell = a * self.v.segments() + b;
        out.resize(nu * nv, order);
        for i in 0..nu {
            for j in 0..nv {
                let s = i * nv + j;
                out.value[s] = vu[i] * vv[j];
                if order >= 1 {
                    out.d1[s] = [du[i] * vv[j], vu[i] * dv[j]];
                }
                if order >= 2 {
                    let cross = du[i] * dv[j];
                    out.d2[s] = [[ddu[i] * vv[j], cross], [cross, vu[i] * ddv[j]]];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{Continuity, CurveChain, PatchGrid};
    use glam::{DVec2, DVec3};

    fn chain(c: Continuity) -> CurveChain<DVec2> {
        let layout = ChainLayout::with_breaks(4, vec![0.0, 0.15, 0.5, 0.8, 1.0], c).unwrap();
        let design = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.3, (1.7 * i as f64).sin()))
            .collect();
        CurveChain::new(layout, design).unwrap()
    }

    #[test]
    fn curve_basis_reproduces_the_chain_and_its_derivatives() {
        for c in [Continuity::C0, Continuity::C1, Continuity::C2] {
            let chain = chain(c);
            let shape = CurveShape::<DVec2>::new(chain.layout().clone());
            let mut b = Basis::new();
            for cell in 0..shape.cell_count() {
                assert_eq!(
                    shape.support(cell).len(),
                    5,
                    "a B-spline segment has d + 1 supports"
                );
            }
            let h = 1e-6;
            for i in 1..200 {
                let t = i as f64 / 200.0 + 1e-3;
                shape.basis([t], 2, &mut b);
                let jet = shape.jet(&b, chain.design(), 2);
                assert!((jet.point - chain.eval(t)).length() < 1e-13, "{c} t={t}");
                assert!((jet.d1[0] - chain.deriv(t)).length() < 1e-11);
                let sum: f64 = b.value.iter().sum();
                assert!((sum - 1.0).abs() < 1e-13, "partition of unity");
                // Second derivative against central differences of the first, inside a segment.
                let (k, u) = chain.layout().locate(t);
                if u > 1e-4 && u < 1.0 - 1e-4 {
                    let fd = (chain.deriv(t + h) - chain.deriv(t - h)) * (0.5 / h);
                    assert!(
                        (jet.d2[0][0] - fd).length() < 1e-5 * (1.0 + fd.length()),
                        "{c} seg {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn grid_basis_reproduces_the_grid_and_its_partials() {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.4, 1.0], Continuity::C1).unwrap();
        let v = ChainLayout::uniform(2, 3, Continuity::C1).unwrap();
        let layout = GridLayout::new(u, v);
        let (nu, nv) = layout.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|i| {
                let (a, b) = ((i / nv) as f64, (i % nv) as f64);
                DVec3::new(a, b, (a * 0.7 + b * 1.3).sin())
            })
            .collect();
        let grid = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        let shape = GridShape::<DVec3>::new(layout);
        let mut b = Basis::new();
        let h = 1e-6;
        for i in 0..17 {
            for j in 0..13 {
                let t = [0.01 + i as f64 / 17.3, 0.02 + j as f64 / 13.1];
                shape.basis(t, 2, &mut b);
                let jet = shape.jet(&b, &design, 2);
                let (p, pu, pv) = grid.partials(t[0], t[1]);
                assert!((jet.point - p).length() < 1e-13);
                assert!((jet.d1[0] - pu).length() < 1e-11 && (jet.d1[1] - pv).length() < 1e-11);
                let (_, pu_v, pv_v) = grid.partials(t[0], t[1] + h);
                let (_, pu_m, pv_m) = grid.partials(t[0], t[1] - h);
                let fd_uv = (pu_v - pu_m) * (0.5 / h);
                let fd_vv = (pv_v - pv_m) * (0.5 / h);
                assert!((jet.d2[0][1] - fd_uv).length() < 1e-5 * (1.0 + fd_uv.length()));
                assert!((jet.d2[1][0] - fd_uv).length() < 1e-5 * (1.0 + fd_uv.length()));
                if (t[1] * 3.0 - (t[1] * 3.0).round()).abs() > 1e-3 {
                    assert!((jet.d2[1][1] - fd_vv).length() < 1e-5 * (1.0 + fd_vv.length()));
                }
            }
        }
    }

    fn wavy_grid() -> (PatchGrid<DVec3>, GridShape<DVec3>) {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.15, 0.6, 1.0], Continuity::C1).unwrap();
        let v = ChainLayout::with_breaks(3, vec![0.0, 0.7, 0.95, 1.0], Continuity::C2).unwrap();
        let layout = GridLayout::new(u, v);
        let (nu, nv) = layout.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|i| {
                let (a, b) = ((i / nv) as f64, (i % nv) as f64);
                DVec3::new(a * 0.3, (1.9 * a).sin() * 0.4, b * 0.5 + 0.2 * (a * b).cos())
            })
            .collect();
        (
            PatchGrid::new(layout.clone(), design).unwrap(),
            GridShape::new(layout),
        )
    }

    #[test]
    fn grid_eval_jet_matches_the_basis_and_locates_like_the_layout() {
        let (grid, shape) = wavy_grid();
        let mut b = Basis::new();
        for i in 0..=60 {
            for j in 0..=45 {
                // Parameters on and next to the (non-uniform) breaks included.
                let t = [i as f64 / 60.0, j as f64 / 45.0];
                for t in [t, [0.15, 0.95], [0.6 - 1e-17, 0.7], [1.0, 0.0]] {
                    let direct = shape.eval_jet(t, 2, grid.design(), &mut b);
                    shape.basis(t, 2, &mut b);
                    let via = shape.jet(&b, grid.design(), 2);
                    assert!((direct.point - via.point).length() < 1e-13);
                    for k in 0..2 {
                        assert!((direct.d1[k] - via.d1[k]).length() < 1e-11);
                        for l in 0..2 {
                            assert!((direct.d2[k][l] - via.d2[k][l]).length() < 1e-9);
                        }
                    }
                    let (a, _) = grid.layout().u.locate(t[0]);
                    let (c, _) = grid.layout().v.locate(t[1]);
                    assert_eq!(b.cell, a * 3 + c, "{t:?}");
                }
            }
        }
    }

    #[test]
    fn a_grid_factors_its_basis_and_restricts_to_its_rows() {
        let (grid, shape) = wavy_grid();
        let (mut b, mut b1) = (Basis::new(), Basis::<1>::new());
        let (mut first, mut rest) = (Vec::new(), Vec::new());
        for i in 0..=40 {
            for j in 0..=30 {
                let t = [i as f64 / 40.0, j as f64 / 30.0];
                for t in [t, [0.15, 0.95], [0.6 - 1e-17, 0.7], [1.0, 0.0]] {
                    // The basis is the product of the u and v factors, in the support's order.
                    let cell = shape.product_basis(t, &mut first, &mut rest, None).unwrap();
                    shape.basis(t, 0, &mut b);
                    assert_eq!(cell, b.cell, "{t:?}");
                    assert_eq!(first.len() * rest.len(), b.value.len());
                    for (a, &v) in b.value.iter().enumerate() {
                        assert!((first[a / rest.len()] * rest[a % rest.len()] - v).abs() < 1e-15);
                    }
                    // Along the same v, the other factor is kept and only the first computed.
                    let next = [(t[0] + 0.37) % 1.0, t[1]];
                    let kept = shape.product_basis(next, &mut first, &mut rest, Some(cell));
                    let (mut f2, mut r2) = (Vec::new(), Vec::new());
                    assert_eq!(
                        kept,
                        shape.product_basis(next, &mut f2, &mut r2, None),
                        "{next:?}"
                    );
                    assert_eq!((&first, &rest), (&f2, &r2));
                    // The row through v is the grid along u at that v, with its u derivatives.
                    let (curve, row) = shape.first_curve(grid.design(), t).unwrap();
                    let ctrl = curve.prepare(&row);
                    let along = curve.jet_at(&ctrl, [t[0]], 2, &mut b1);
                    let jet = shape.eval_jet(t, 2, grid.design(), &mut b);
                    assert!((along.point - jet.point).length() < 1e-13, "{t:?}");
                    assert!((along.d1[0] - jet.d1[0]).length() < 1e-11, "{t:?}");
                    assert!((along.d2[0][0] - jet.d2[0][0]).length() < 1e-9, "{t:?}");
                }
            }
        }
    }

    #[test]
    fn sample_deviation_bounds_the_distance_to_the_bilinear_interpolant() {
        let (grid, shape) = wavy_grid();
        let samples = 4;
        let mut b = Basis::new();
        for cell in 0..shape.cell_count() {
            let dev = shape.sample_deviation(cell, grid.design(), samples).unwrap();
            let (lo, hi) = shape.cell_box(cell);
            let mut at = |x: f64, y: f64| {
                let t = [lo[0] + x * (hi[0] - lo[0]), lo[1] + y * (hi[1] - lo[1])];
                let j = shape.eval_jet(t, 0, grid.design(), &mut b);
                j.point
            };
            let h = 1.0 / samples as f64;
            let mut worst: f64 = 0.0;
            for i in 0..samples {
                for j in 0..samples {
                    let (x0, y0) = (i as f64 * h, j as f64 * h);
                    let c = [at(x0, y0), at(x0 + h, y0), at(x0, y0 + h), at(x0 + h, y0 + h)];
                    for a in 0..=8 {
                        for e in 0..=8 {
                            let (s, t) = (a as f64 / 8.0, e as f64 / 8.0);
                            let bilinear = c[0] * ((1.0 - s) * (1.0 - t))
                                + c[1] * (s * (1.0 - t))
                                + c[2] * ((1.0 - s) * t)
                                + c[3] * (s * t);
                            worst = worst.max((at(x0 + s * h, y0 + t * h) - bilinear).length());
                        }
                    }
                }
            }
            assert!(
                worst <= dev,
                "cell {cell}: deviation {worst} above the bound {dev}"
            );
            // and the bound is not wildly loose
            assert!(
                dev < 20.0 * worst.max(1e-12),
                "cell {cell}: bound {dev} for deviation {worst}"
            );
        }
    }
}
