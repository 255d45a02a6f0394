//! `ChainLayout`, the one spline kernel: degree, breaks and the continuity of every join of a
//! chain, with its clamped knot vector, the extraction map, knot insertion and the basis.
//!
//! A chain of degree `d` whose join at break `t_i` has continuity `C(k_i)` is a B-spline whose
//! interior knot `t_i` has multiplicity `d - k_i`; its B-spline coefficients are the design points
//! (`docs/ARCHITECTURE.md` §2.2). The paper's chains have `k_i = 1` at every join
//! ([`Continuity::C1`]); a join with a larger `k_i` generates more of its neighbouring control
//! points and so stores fewer. Raising every interior knot to multiplicity `d` (Boehm's insertion)
//! gives the expanded Bezier control points: the sparse map `expanded = E · design`
//! ([`ExtractionMap`]), built once per layout.
//!
//! The basis at a parameter is the segment's Bernstein polynomials (from the one evaluator in
//! [`crate::bezier`]) times the segment's block of `E` (precomputed with its first and second
//! differences), so a basis function and its derivatives cost one Bernstein recurrence and a
//! few short dot products.
//!
//! Curves ([`CurveChain`](super::CurveChain)) and patch grids
//! ([`GridLayout`](super::GridLayout), one layout per direction) are built from it; the
//! fitters, the closest-point search, the adaptive search, the evaluator's kernels and the
//! exports all take what they need from it.

use super::map::{insert_knot, ExtractionMap};
use crate::bezier::{bernstein_levels, combine, curve_jet, Vector};
use crate::error::{Error, Result};
use crate::keyword::keywords;
use serde::{Deserialize, Serialize};

/// The highest degree of a chain, in each direction of a grid.
///
/// Why 7: the population evaluator's kernels (GPU and CPU mirror alike) hold one patch's
/// `(d + 1)²` control points per thread in registers and fixed-size arrays, which degree 7
/// (64 points, 192 floats) still fits; every layout must be usable by every solver, the GA
/// and CMA-ES included. The paper's chains are of degree 3 to 5, and the adaptive search
/// tries 2 to 7 by default. Checked once, when a layout is built ([`ChainLayout::with_orders`]);
/// the evaluator checks it again at its own boundary.
pub const MAX_DEGREE: usize = 7;

/// Basis functions non-zero on a segment, at most: `MAX_DEGREE + 1`.
pub const MAX_SUPPORT: usize = MAX_DEGREE + 1;

/// The most segments a chain may have (a bound checked before its breaks are made).
pub const MAX_SEGMENTS: usize = 1 << 20;

/// The most control-point × design-point weights a layout is built from (256 MiB of f64; a
/// cubic C1 chain of about 2,300 segments).
const MAX_MAP_WEIGHTS: usize = 1 << 25;

/// Continuity across the joins of a chain, for the layouts with the same continuity at every
/// join (the `C0`/`C1`/`C2` constructors).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Continuity {
    /// Position only: joins are shared points.
    C0,
    /// Tangent (first derivative with respect to the global parameter).
    C1,
    /// Curvature (second derivative); needs degree 3 or more.
    C2,
}

impl Continuity {
    /// The order `k` of `Ck`.
    #[must_use]
    pub fn order(self) -> usize {
        match self {
            Continuity::C0 => 0,
            Continuity::C1 => 1,
            Continuity::C2 => 2,
        }
    }

    /// `Ck` for `k` up to 2; higher orders are `C2` (they are at least that smooth).
    #[must_use]
    pub fn at_least(order: usize) -> Self {
        match order {
            0 => Continuity::C0,
            1 => Continuity::C1,
            _ => Continuity::C2,
        }
    }
}

keywords!(Continuity, "continuity", { C0 => "C0", C1 => "C1", C2 => "C2" });

/// The shape of a chain: degree `d`, `s` segments over breaks `0 = t0 < ... < ts = 1`, the
/// continuity order of every join, the clamped knot vector, the extraction map and the
/// per-segment basis blocks, all built once.
#[derive(Clone, Debug, PartialEq)]
pub struct ChainLayout {
    degree: usize,
    breaks: Vec<f64>,
    orders: Vec<usize>,
    continuity: Continuity,
    knots: Vec<f64>,
    map: ExtractionMap,
    /// `0 .. design_count()`, so that a segment's support is a slice of it.
    indices: Vec<u32>,
    /// First design index of every segment's support (`d + 1` consecutive indices).
    first: Vec<usize>,
    /// Per segment, `(d + 1) x (d + 1)`: the extraction map restricted to the segment's
    /// control points and its supporting design points, one row per design point (row `a`
    /// holds design point `first + a`'s weights in the segment's control points).
    local: Vec<f64>,
    /// Per segment, `(d + 1) x d`: the hodograph's weights `d (L[r+1] - L[r])`.
    local_d1: Vec<f64>,
    /// Per segment, `(d + 1) x (d - 1)`: `d (d - 1) (L[r+2] - 2 L[r+1] + L[r])`.
    local_d2: Vec<f64>,
    /// `1 / h[k]` per segment.
    inv_len: Vec<f64>,
    /// True when the breaks are uniform, so a parameter's segment is one multiplication away.
    uniform: bool,
    /// For non-uniform breaks: the segment holding the start of each of [`LOOKUP`] equal bins
    /// of `[0, 1]`, so that locating a parameter scans at most a few breaks.
    lookup: Vec<u32>,
}

/// Bins of the segment lookup table of non-uniform chains.
const LOOKUP: usize = 256;

/// Non-uniform chains with at most this many segments locate a parameter by counting the
/// breaks below it instead of the lookup table.
const SCAN_MAX: usize = 16;

/// The basis functions of a chain that are non-zero at one parameter: design points
/// `first ..= first + degree`, with the values and the first and second derivatives with
/// respect to the global parameter.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpanBasis {
    /// The segment holding the parameter.
    pub segment: usize,
    /// Design index of `value[0]`.
    pub first: usize,
    /// Values (the first `degree + 1` entries).
    pub value: [f64; MAX_SUPPORT],
    /// First derivatives (filled when asked for).
    pub d1: [f64; MAX_SUPPORT],
    /// Second derivatives (filled when asked for).
    pub d2: [f64; MAX_SUPPORT],
}

impl ChainLayout {
    /// A layout with `segments` equal segments and `continuity` at every join.
    pub fn uniform(degree: usize, segments: usize, continuity: Continuity) -> Result<Self> {
        if segments == 0 {
            return Err(Error::invalid("segments must be at least 1"));
        }
        if segments > MAX_SEGMENTS {
            return Err(Error::invalid(format!(
                "{segments} segments is more than a chain may have ({MAX_SEGMENTS})"
            )));
        }
        let breaks = (0..=segments).map(|k| k as f64 / segments as f64).collect();
        Self::with_breaks(degree, breaks, continuity)
    }

    /// A layout with the given breaks (strictly increasing, from 0 to 1, at least two) and
    /// `continuity` at every join.
    pub fn with_breaks(degree: usize, breaks: Vec<f64>, continuity: Continuity) -> Result<Self> {
        if continuity.order() >= degree && degree > 0 {
            return Err(Error::invalid(format!(
                "{continuity} continuity needs degree {} or more (got {degree})",
                continuity.order() + 1
            )));
        }
        let joins = breaks.len().saturating_sub(2);
        let mut layout = Self::with_orders(degree, breaks, vec![continuity.order(); joins])?;
        layout.continuity = continuity;
        Ok(layout)
    }

    /// A layout whose joins all have continuity order `order`, capped at `degree - 1`.
    pub fn with_order(degree: usize, breaks: Vec<f64>, order: usize) -> Result<Self> {
        let k = order.min(degree.saturating_sub(1));
        let joins = breaks.len().saturating_sub(2);
        Self::with_orders(degree, breaks, vec![k; joins])
    }

    /// A layout of `degree` (1 ..= [`MAX_DEGREE`]) over `breaks` (strictly increasing from 0
    /// to 1) with continuity order `orders[i]` (0 ..= degree - 1) at interior break `i + 1`.
    pub fn with_orders(degree: usize, breaks: Vec<f64>, orders: Vec<usize>) -> Result<Self> {
        if degree == 0 {
            return Err(Error::invalid("degree must be at least 1"));
        }
        if degree > MAX_DEGREE {
            return Err(Error::invalid(format!(
                "degree {degree} is above the supported maximum of {MAX_DEGREE} (the population \
                 evaluator holds a patch of degree {MAX_DEGREE} in registers)"
            )));
        }
        if breaks.len() < 2 {
            return Err(Error::invalid("a chain needs at least two breaks (one segment)"));
        }
        if breaks.iter().any(|b| !b.is_finite()) {
            return Err(Error::invalid("breaks must be finite numbers"));
        }
        if breaks[0] != 0.0 || breaks[breaks.len() - 1] != 1.0 {
            return Err(Error::invalid("breaks must start at 0 and end at 1"));
        }
        if breaks.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::invalid("breaks must be strictly increasing"));
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
        // Clamped knot vector: d+1 zeros, interior break i with multiplicity d - k_i, d+1 ones.
        let mut knots = vec![0.0; degree + 1];
        let mut spans = vec![degree];
        for (&b, &k) in breaks[1..breaks.len() - 1].iter().zip(&orders) {
            knots.extend(std::iter::repeat_n(b, degree - k));
            spans.push(knots.len() - 1);
        }
        knots.extend(std::iter::repeat_n(1.0, degree + 1));
        // The map is built from dense rows of weights: bounded before it is made.
        let (rows, cols) = ((breaks.len() - 1) * degree + 1, knots.len() - degree - 1);
        if rows.saturating_mul(cols) > MAX_MAP_WEIGHTS {
            return Err(Error::invalid(format!(
                "{} segments of degree {degree} are more than a chain may have: its {rows} control \
                 points over {cols} design points are more than the {MAX_MAP_WEIGHTS} weights the \
                 layout is built from",
                breaks.len() - 1
            )));
        }
        let map = ExtractionMap::for_knots(degree, &breaks, &knots);
        // The continuity every join has at least; a chain without joins is as smooth as its
        // degree allows the constructors to say.
        let lowest = orders.iter().copied().min().unwrap_or(degree - 1);
        let segments = breaks.len() - 1;
        let mut layout = ChainLayout {
            degree,
            continuity: Continuity::at_least(lowest.min(degree - 1)),
            indices: (0..map.cols() as u32).collect(),
            first: spans.iter().map(|&s| s - degree).collect(),
            local: Vec::new(),
            local_d1: Vec::new(),
            local_d2: Vec::new(),
            inv_len: breaks.windows(2).map(|w| 1.0 / (w[1] - w[0])).collect(),
            uniform: breaks
                .iter()
                .enumerate()
                .all(|(k, &b)| (b - k as f64 / segments as f64).abs() <= 4.0 * f64::EPSILON),
            lookup: Vec::new(),
            breaks,
            orders,
            knots,
            map,
        };
        layout.build_blocks();
        if !layout.uniform {
            layout.lookup = (0..LOOKUP)
                .map(|i| layout.locate_scan(i as f64 / LOOKUP as f64).0 as u32)
                .collect();
        }
        Ok(layout)
    }

    /// The per-segment blocks of the extraction map and their differences.
    fn build_blocks(&mut self) {
        let d = self.degree;
        let n = d + 1;
        let df = d as f64;
        for k in 0..self.segments() {
            let first = self.first[k];
            // block[r][a]: weight of design point first + a in control point k d + r.
            let mut block = vec![0.0; n * n];
            for (r, row) in block.chunks_mut(n).enumerate() {
                let (idx, w) = self.map.row(k * d + r);
                for (&j, &wj) in idx.iter().zip(w) {
                    let j = j as usize;
                    debug_assert!(
                        (first..first + n).contains(&j),
                        "segment {k}: control point weight outside its B-spline support"
                    );
                    if (first..first + n).contains(&j) {
                        row[j - first] += wj;
                    }
                }
            }
            let d1: Vec<f64> = (0..d * n).map(|i| df * (block[i + n] - block[i])).collect();
            let d2: Vec<f64> = (0..d.saturating_sub(1) * n)
                .map(|i| df * (df - 1.0) * (block[i + 2 * n] - 2.0 * block[i + n] + block[i]))
                .collect();
            // Stored transposed, one row per support point, so each basis function is one
            // contiguous dot product with the Bernstein values.
            let transpose = |m: &[f64], rows: usize, out: &mut Vec<f64>| {
                let start = out.len();
                out.resize(start + m.len(), 0.0);
                for r in 0..rows {
                    for a in 0..n {
                        out[start + a * rows + r] = m[r * n + a];
                    }
                }
            };
            transpose(&block, n, &mut self.local);
            transpose(&d1, d, &mut self.local_d1);
            transpose(&d2, d.saturating_sub(1), &mut self.local_d2);
        }
    }

    /// Polynomial degree of every segment.
    #[must_use]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Number of segments `s`.
    #[must_use]
    pub fn segments(&self) -> usize {
        self.breaks.len() - 1
    }

    /// The breaks `t0 = 0 < ... < ts = 1`.
    #[must_use]
    pub fn breaks(&self) -> &[f64] {
        &self.breaks
    }

    /// Continuity order `k_i` of every interior join, in order.
    #[must_use]
    pub fn orders(&self) -> &[usize] {
        &self.orders
    }

    /// The continuity of the joins: the constructor's for the `C0`/`C1`/`C2` constructors,
    /// otherwise the continuity every join has at least (orders above 2 count as `C2`).
    #[must_use]
    pub fn continuity(&self) -> Continuity {
        self.continuity
    }

    /// The clamped knot vector.
    #[must_use]
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// The extraction map `expanded = E · design`.
    #[must_use]
    pub fn map(&self) -> &ExtractionMap {
        &self.map
    }

    /// Number of design points (B-spline coefficients; the optimisation variables, per
    /// coordinate): `d + 1 + Σ (d - k_i)`.
    #[must_use]
    pub fn design_count(&self) -> usize {
        self.map.cols()
    }

    /// Number of expanded Bezier control points, `s * d + 1`.
    #[must_use]
    pub fn expanded_count(&self) -> usize {
        self.segments() * self.degree + 1
    }

    /// Length `h[k] = t[k+1] - t[k]` of segment `k`.
    #[must_use]
    pub fn segment_length(&self, k: usize) -> f64 {
        self.breaks[k + 1] - self.breaks[k]
    }

    /// The segment holding global parameter `t` (clamped to `[0, 1]`; a break belongs to the
    /// segment that starts there, 1 to the last) and the local parameter in it.
    #[inline(always)]
    #[must_use]
    pub fn locate(&self, t: f64) -> (usize, f64) {
        let s = self.segments();
        let t = t.clamp(0.0, 1.0);
        let breaks = &self.breaks;
        if !self.uniform && s <= SCAN_MAX {
            // Few breaks: count those at or below t (branch-free).
            let k = breaks[1..s].iter().map(|&b| usize::from(b <= t)).sum::<usize>();
            return (k, ((t - breaks[k]) / self.segment_length(k)).clamp(0.0, 1.0));
        }
        if !self.uniform {
            // The bin's first segment, then forward past every break at or below t.
            let mut k = self
                .lookup
                .get(((t * LOOKUP as f64) as usize).min(LOOKUP - 1))
                .map_or(0, |&k| k as usize);
            while k + 1 < s && breaks[k + 1] <= t {
                k += 1;
            }
            return (k, ((t - breaks[k]) / self.segment_length(k)).clamp(0.0, 1.0));
        }
        let k = ((t * s as f64) as usize).min(s - 1);
        // Rounding of t * s can put a parameter next to a break in the wrong segment.
        let k = if t < breaks[k] {
            k - 1
        } else if k + 1 < s && t >= breaks[k + 1] {
            k + 1
        } else {
            k
        };
        (k, ((t - breaks[k]) * self.inv_len[k]).clamp(0.0, 1.0))
    }

    /// [`ChainLayout::locate`] by a binary search of the breaks (builds the lookup table).
    fn locate_scan(&self, t: f64) -> (usize, f64) {
        let t = t.clamp(0.0, 1.0);
        let s = self.segments();
        // partition_point gives the first break > t; the segment is the one before it.
        let k = self.breaks[1..s].partition_point(|&b| b <= t);
        let u = (t - self.breaks[k]) / self.segment_length(k);
        (k, u.clamp(0.0, 1.0))
    }

    /// The global parameter of local parameter `u` in segment `k`.
    #[must_use]
    pub fn global(&self, k: usize, u: f64) -> f64 {
        self.breaks[k] + u * self.segment_length(k)
    }

    /// The design indices supporting segment `k`: `d + 1` consecutive ones, ascending.
    #[must_use]
    pub fn support(&self, k: usize) -> &[u32] {
        let f = self.first[k];
        &self.indices[f..=f + self.degree]
    }

    /// The extraction map restricted to segment `k`: row `a` holds support point `a`'s weights
    /// in the segment's `degree + 1` Bezier control points.
    #[must_use]
    pub fn local(&self, k: usize) -> &[f64] {
        let n = self.degree + 1;
        &self.local[k * n * n..(k + 1) * n * n]
    }

    /// The basis at global parameter `t` (clamped to `[0, 1]`), with derivatives with respect
    /// to `t` up to `order` (0, 1 or 2; the arrays of orders not asked for are zero).
    #[inline]
    #[must_use]
    pub fn basis(&self, t: f64, order: usize) -> SpanBasis {
        let (k, u) = self.locate(t);
        self.basis_in(k, u, order)
    }

    /// [`ChainLayout::basis`] at local parameter `u` of segment `k`. Always inlined: called
    /// out of line it built its 208-byte result on its own stack and copied it out, a
    /// `memmove` that took 6.6 % of the 1M-point surface fit.
    #[inline(always)]
    #[must_use]
    pub fn basis_in(&self, k: usize, u: f64, order: usize) -> SpanBasis {
        let mut out = SpanBasis {
            segment: k,
            first: self.first[k],
            value: [0.0; MAX_SUPPORT],
            d1: [0.0; MAX_SUPPORT],
            d2: [0.0; MAX_SUPPORT],
        };
        self.basis_into(k, u, order, &mut out);
        out
    }

    /// [`ChainLayout::basis_in`] written into `out`, whose entries past the degree's and of
    /// the orders not asked for are left as they are. Where the caller reads the values off a
    /// basis it keeps, this spares the copy of the returned one (a `memcpy` a point in the
    /// least-squares sums of a grid fit, which `basis_in` inlined still made).
    #[inline(always)]
    pub fn basis_into(&self, k: usize, u: f64, order: usize, out: &mut SpanBasis) {
        out.segment = k;
        out.first = self.first[k];
        // One monomorphic path per degree: every loop length is a constant, unrolled.
        match self.degree {
            1 => self.eval_fixed::<2>(k, u, order, out),
            2 => self.eval_fixed::<3>(k, u, order, out),
            3 => self.eval_fixed::<4>(k, u, order, out),
            4 => self.eval_fixed::<5>(k, u, order, out),
            5 => self.eval_fixed::<6>(k, u, order, out),
            6 => self.eval_fixed::<7>(k, u, order, out),
            _ => self.eval_fixed::<MAX_SUPPORT>(k, u, order, out),
        }
    }

    /// The basis in segment `k` at local `u`, for degree `N - 1`.
    fn eval_fixed<const N: usize>(&self, k: usize, u: f64, order: usize, out: &mut SpanBasis) {
        debug_assert_eq!(
            self.degree + 1,
            N,
            "eval_fixed: wrong path for degree {}",
            self.degree
        );
        let d = N - 1;
        // Bernstein polynomials of degree d, d - 1 and d - 2 from one recurrence: the values,
        // and the weights of the hodographs' blocks for the derivatives.
        let levels = bernstein_levels::<N, 3>(d, u);
        // Row `a` of a block of `len` columns against the first `len` Bernstein values.
        fn dot<const N: usize>(m: &[f64], w: &[f64; N], len: usize, out: &mut [f64], scale: f64) {
            for (x, row) in out[..N].iter_mut().zip(m.chunks_exact(len.max(1))) {
                *x = scale * row.iter().zip(&w[..len]).map(|(a, b)| a * b).sum::<f64>();
            }
        }
        let n = N;
        dot(
            &self.local[k * n * n..(k + 1) * n * n],
            &levels[0],
            n,
            &mut out.value,
            1.0,
        );
        if order >= 1 && d >= 1 {
            dot(
                &self.local_d1[k * n * d..(k + 1) * n * d],
                &levels[1],
                d,
                &mut out.d1,
                self.inv_len[k],
            );
        }
        if order >= 2 && d >= 2 {
            let m = n * (d - 1);
            dot(
                &self.local_d2[k * m..(k + 1) * m],
                &levels[2],
                d - 1,
                &mut out.d2,
                self.inv_len[k] * self.inv_len[k],
            );
        }
    }

    /// The chain with expanded Bezier control points `ctrl` at `t`: the point and its
    /// derivatives with respect to `t` up to `order` (higher ones zero), by Horner's scheme on
    /// the segment's control points and their differences (the hodographs'; [`curve_jet`]).
    #[inline]
    #[must_use]
    pub fn segment_jet<P: Vector>(&self, ctrl: &[P], t: f64, order: usize) -> [P; 3] {
        let (k, u) = self.locate(t);
        self.segment_jet_in(ctrl, k, u, order)
    }

    /// [`ChainLayout::segment_jet`] at local parameter `u` of segment `k` (a caller that also
    /// needs the basis there locates the parameter once).
    #[inline]
    #[must_use]
    pub fn segment_jet_in<P: Vector>(&self, ctrl: &[P], k: usize, u: f64, order: usize) -> [P; 3] {
        // One monomorphic path per degree, as for the basis: every loop length is a constant.
        // The segment's points, sliced with the constant degree of each path.
        let (c, h) = (|d: usize| &ctrl[k * d..=(k + 1) * d], self.inv_len[k]);
        match self.degree {
            1 => curve_jet::<P, 1>(c(1), u, order, h),
            2 => curve_jet::<P, 2>(c(2), u, order, h),
            3 => curve_jet::<P, 3>(c(3), u, order, h),
            4 => curve_jet::<P, 4>(c(4), u, order, h),
            5 => curve_jet::<P, 5>(c(5), u, order, h),
            6 => curve_jet::<P, 6>(c(6), u, order, h),
            _ => curve_jet::<P, MAX_DEGREE>(c(MAX_DEGREE), u, order, h),
        }
    }

    /// The chain with coefficients `coeffs` at `t`: the point and its first and second
    /// derivatives with respect to `t`.
    #[must_use]
    pub fn jet<P: Vector>(&self, coeffs: &[P], t: f64) -> [P; 3] {
        let b = self.basis(t, 2);
        let x = &coeffs[b.first..=b.first + self.degree];
        [combine(x, &b.value), combine(x, &b.d1), combine(x, &b.d2)]
    }

    /// The chain with coefficients `coeffs` at `t`.
    #[must_use]
    pub fn eval<P: Vector>(&self, coeffs: &[P], t: f64) -> P {
        let b = self.basis(t, 0);
        combine(&coeffs[b.first..=b.first + self.degree], &b.value)
    }

    /// The expanded Bezier control points (`s d + 1`) of the chain with coefficients `coeffs`.
    #[must_use]
    pub fn bezier<P: Vector>(&self, coeffs: &[P]) -> Vec<P> {
        self.map.apply(coeffs)
    }

    /// The layout with break `t` inserted with continuity order `order` (capped at
    /// `degree - 1`), and `coeffs` re-expressed on it: the same curve, exactly (Boehm's knot
    /// insertion). `t` must lie strictly inside a segment.
    pub fn split<P: Vector>(&self, t: f64, order: usize, coeffs: &[P]) -> Result<(ChainLayout, Vec<P>)> {
        if !(t > 0.0 && t < 1.0) || self.breaks.contains(&t) {
            return Err(Error::invalid(format!(
                "split at {t}: not strictly inside a segment"
            )));
        }
        let order = order.min(self.degree - 1);
        let k = self.locate_scan(t).0;
        let mut breaks = self.breaks.clone();
        breaks.insert(k + 1, t);
        let mut orders = self.orders.clone();
        orders.insert(k, order);
        let layout = ChainLayout::with_orders(self.degree, breaks, orders)?;
        let mut knots = self.knots.clone();
        let mut c = coeffs.to_vec();
        for _ in 0..self.degree - order {
            insert_knot(&mut knots, &mut c, self.degree, t, |x: &P, y: &P, a| {
                *x * (1.0 - a) + *y * a
            });
        }
        debug_assert_eq!(knots, layout.knots, "split: knot vectors differ");
        Ok((layout, c))
    }

    /// The Greville abscissae: the coefficients of the function `t` itself (design point `i`
    /// sits at parameter `g_i`).
    #[must_use]
    pub fn greville(&self) -> Vec<f64> {
        let d = self.degree;
        (0..self.design_count())
            .map(|j| self.knots[j + 1..=j + d].iter().sum::<f64>() / d as f64)
            .collect()
    }

    /// The C1 layout of the same degree and breaks: every chain of this layout is also a
    /// chain of it (its joins are at least C1), with the same expanded control points.
    /// `None` when a join is only C0.
    #[must_use]
    pub fn as_c1(&self) -> Option<ChainLayout> {
        if self.orders.iter().any(|&k| k < 1) || self.degree < 2 {
            return None;
        }
        ChainLayout::with_breaks(self.degree, self.breaks.clone(), Continuity::C1).ok()
    }
}

/// The sample parameters of one direction: `per` steps in every segment between `breaks`
/// (the breaks themselves exact).
pub fn samples(breaks: &[f64], per: usize) -> Vec<f64> {
    let mut t = Vec::with_capacity((breaks.len() - 1) * per + 1);
    for w in breaks.windows(2) {
        for k in 0..per {
            t.push(w[0] + (w[1] - w[0]) * k as f64 / per as f64);
        }
    }
    t.push(breaks[breaks.len() - 1]);
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::CurveChain;
    use glam::DVec2;

    fn coeffs(n: usize) -> Vec<DVec2> {
        (0..n)
            .map(|i| DVec2::new(i as f64 * 0.3, (1.7 * i as f64).sin()))
            .collect()
    }

    #[test]
    fn the_papers_counts() {
        for &(d, s, design, expanded) in &[(3, 5, 12, 16), (4, 3, 11, 13), (5, 3, 14, 16)] {
            let l = ChainLayout::uniform(d, s, Continuity::C1).unwrap();
            assert_eq!(
                (l.design_count(), l.expanded_count()),
                (design, expanded),
                "d={d} s={s}"
            );
        }
    }

    #[test]
    fn counts_for_every_continuity() {
        for d in 1..=MAX_DEGREE {
            for s in 1..6 {
                let c0 = ChainLayout::uniform(d, s, Continuity::C0).unwrap();
                assert_eq!(c0.design_count(), s * d + 1);
                if d >= 2 {
                    assert_eq!(
                        ChainLayout::uniform(d, s, Continuity::C1).unwrap().design_count(),
                        s * (d - 1) + 2
                    );
                }
                if d >= 3 {
                    assert_eq!(
                        ChainLayout::uniform(d, s, Continuity::C2).unwrap().design_count(),
                        s * (d - 2) + 3
                    );
                }
            }
        }
        let l = ChainLayout::with_orders(5, vec![0.0, 0.3, 0.5, 1.0], vec![1, 4]).unwrap();
        assert_eq!(l.design_count(), 6 + 4 + 1);
        assert_eq!(l.continuity(), Continuity::C1);
    }

    #[test]
    fn bad_layouts_are_refused() {
        assert!(ChainLayout::uniform(0, 3, Continuity::C0).is_err());
        assert!(ChainLayout::uniform(3, 0, Continuity::C1).is_err());
        assert!(ChainLayout::uniform(1, 3, Continuity::C1).is_err());
        assert!(ChainLayout::uniform(2, 3, Continuity::C2).is_err());
        assert!(ChainLayout::with_breaks(3, vec![0.0, 0.5, 0.5, 1.0], Continuity::C1).is_err());
        assert!(ChainLayout::with_breaks(3, vec![0.0, 0.5, 0.9], Continuity::C1).is_err());
        assert!(ChainLayout::with_breaks(3, vec![0.0, f64::NAN, 1.0], Continuity::C1).is_err());
        assert!(ChainLayout::with_orders(3, vec![0.0, 0.5, 1.0], vec![3]).is_err());
        assert!(ChainLayout::with_orders(3, vec![0.0, 0.5, 1.0], vec![]).is_err());
        let e = ChainLayout::uniform(MAX_DEGREE + 1, 2, Continuity::C1).unwrap_err();
        assert!(e.to_string().contains("maximum of 7"), "{e}");
    }

    #[test]
    fn locate_and_global_are_inverse() {
        for breaks in [vec![0.0, 0.1, 0.45, 1.0], vec![0.0, 0.25, 0.5, 0.75, 1.0]] {
            let l = ChainLayout::with_breaks(3, breaks, Continuity::C1).unwrap();
            for i in 0..=1000 {
                let t = i as f64 / 1000.0;
                let (k, u) = l.locate(t);
                assert_eq!((k, u), l.locate_scan(t), "t = {t}");
                assert!((l.global(k, u) - t).abs() < 1e-15);
            }
        }
        let l = ChainLayout::with_breaks(3, vec![0.0, 0.1, 0.45, 1.0], Continuity::C1).unwrap();
        assert_eq!(l.locate(0.1), (1, 0.0));
        assert_eq!(l.locate(1.0), (2, 1.0));
        assert_eq!(l.locate(-3.0), (0, 0.0));
    }

    #[test]
    fn c1_layouts_extract_the_weighted_midpoint_joins() {
        let breaks = vec![0.0, 0.15, 0.5, 0.8, 1.0];
        let l = ChainLayout::with_breaks(4, breaks.clone(), Continuity::C1).unwrap();
        let c = coeffs(l.design_count());
        let ctrl = l.bezier(&c);
        for k in 1..l.segments() {
            let (hl, hr) = (breaks[k] - breaks[k - 1], breaks[k + 1] - breaks[k]);
            let join = c[3 * k] * (hr / (hl + hr)) + c[3 * k + 1] * (hl / (hl + hr));
            assert!((ctrl[4 * k] - join).length() < 1e-13);
        }
    }

    #[test]
    fn basis_reproduces_the_bezier_chain_and_its_derivatives() {
        for orders in [vec![1, 3, 2], vec![3, 3, 3], vec![0, 1, 2]] {
            let l = ChainLayout::with_orders(4, vec![0.0, 0.1, 0.45, 0.7, 1.0], orders.clone()).unwrap();
            let c = coeffs(l.design_count());
            let ctrl = l.bezier(&c);
            let h = 1e-6;
            for i in 0..=400 {
                let t = i as f64 / 400.0;
                let b = l.basis(t, 2);
                let sum: f64 = b.value[..5].iter().sum();
                assert!((sum - 1.0).abs() < 1e-13);
                let p = l.eval(&c, t);
                let k = b.segment;
                let (t0, t1) = (l.breaks()[k], l.breaks()[k + 1]);
                let seg = crate::bezier::BezierCurve::new(ctrl[4 * k..=4 * k + 4].to_vec());
                let u = (t - t0) / (t1 - t0);
                assert!((seg.eval(u) - p).length() < 1e-13, "{orders:?} t={t}");
                let [q, e1, e2] = l.segment_jet(&ctrl, t, 2);
                let [_, b1, b2] = l.jet(&c, t);
                assert!((q - p).length() < 1e-13);
                assert!((e1 - b1).length() < 1e-11 * (1.0 + b1.length()));
                assert!((e2 - b2).length() < 1e-9 * (1.0 + b2.length()));
                if t - t0 > 2.0 * h && t1 - t > 2.0 * h {
                    let [_, d1, d2] = l.jet(&c, t);
                    let fd1 = (l.eval(&c, t + h) - l.eval(&c, t - h)) / (2.0 * h);
                    let fd2 = (l.eval(&c, t + h) - 2.0 * p + l.eval(&c, t - h)) / (h * h);
                    assert!((d1 - fd1).length() < 1e-6 * (1.0 + fd1.length()));
                    assert!((d2 - fd2).length() < 1e-3 * (1.0 + fd2.length()));
                }
            }
        }
    }

    #[test]
    fn split_keeps_the_curve_exactly() {
        let l = ChainLayout::with_orders(5, vec![0.0, 0.3, 1.0], vec![4]).unwrap();
        let c = coeffs(l.design_count());
        for order in [1, 2, 4] {
            let (l2, c2) = l.split(0.62, order, &c).unwrap();
            assert_eq!(l2.design_count(), l.design_count() + 5 - order);
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
    fn smoother_joins_regenerate_as_a_c1_chain() {
        let l = ChainLayout::with_orders(3, vec![0.0, 0.2, 0.55, 1.0], vec![2, 1]).unwrap();
        let c = coeffs(l.design_count());
        let smooth = CurveChain::new(l.clone(), c).unwrap();
        let c1 = smooth.to_c1().unwrap();
        assert_eq!(c1.layout().continuity(), Continuity::C1);
        assert!(crate::bezier::same_points(c1.ctrl(), smooth.ctrl()));
        assert!(c1.continuity_error(1) < 1e-12);
        let g = l.greville();
        assert_eq!((g[0], g[g.len() - 1]), (0.0, 1.0));
        assert!(g.windows(2).all(|w| w[1] > w[0]));
    }
}
