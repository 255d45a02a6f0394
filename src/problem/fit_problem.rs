//! `FitProblem`: the one fitting problem every solver takes. It owns the data points, the
//! shape (a chain or grid layout), the offset metric, the per-point parameters, the anchors
//! (points tied to fixed parameters), per-point weights, parameter directions held fixed,
//! linear constraints on the design (the aerofoil rule, the span rule), the start design and
//! the box bounds; it gives the objective (sum of squared offsets), its gradient, the
//! per-point residual blocks and linear least squares.
//!
//! The solvers: [`lsq`](crate::optim::lsq::lsq) (the residual structure), Nelder-Mead and BFGS (the
//! [`Objective`] of [`FitProblem::objective_fn`]), the GA and CMA-ES (the population
//! objective of [`crate::fit::population`]).

use super::band::{BandMatrix, BandPlan};
use super::frame::Frame;
use super::objective::Objective;
use super::offset::{check_points, chord_length_params, corresponding_offsets, Metric, OffsetStats};
use crate::bezier::Vector;
use crate::chain::shape::{Basis, CurveShape, GridShape, Shape};
use crate::chain::{ChainLayout, CurveChain, GridLayout, PatchGrid};
use crate::closest::{closest_all, refine_held, Foot, FootOptions, SampleGrid, CHUNK, PARALLEL_MIN};
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::sync::OnceLock;

/// A fitting problem: data points `q_j`, a shape (chain or grid layout) and a metric.
///
/// The objective is `Σ_j |C(t_j) - q_j|²` over the design points, with `t_j` the foot point
/// (closest point) of `q_j` for [`Metric::Closest`], or the fixed parameter `params()[j]` for
/// [`Metric::Corresponding`]. The fixed parameters also start the closest-point fit.
///
/// *Anchored* points keep their fixed parameter under both metrics. Curve problems anchor the
/// first and last data points at `t = 0` and `t = 1` by default: the chain then spans the
/// data. Without anchors the closest-point objective lets the chain's ends run past the data
/// (the points there only see the part of the chain near them), and on aerofoils the fit
/// drifts towards end segments that loop far outside the contour while the offsets shrink
/// by a few per cent; the optimum is then not a usable shape.
///
/// Optional parts, all kept by every solver that can: per-point *weights* `w_j` (the
/// objective becomes `Σ_j w_j |C(t_j) - q_j|²`; the minimax polish reweights), parameter
/// directions *held* at the given parameters for every point (a sectioned cloud's span
/// parameter), a linear [`Constraint`] on the design points, a start design and box bounds
/// (the evolutionary methods').
#[derive(Clone, Debug)]
pub struct FitProblem<'a, S: Shape<K>, const K: usize> {
    shape: S,
    points: &'a [S::Point],
    metric: Metric,
    params: Vec<[f64; K]>,
    anchored: Vec<bool>,
    weights: Option<Vec<f64>>,
    held: [bool; K],
    constraint: Option<Constraint>,
    start: Option<Vec<S::Point>>,
    start_flat: Vec<f64>,
    bounds: Vec<[f64; 2]>,
    box_extent: f64,
    foot: FootOptions,
    /// The foot-point search's samples, built at the first global search.
    grid: OnceLock<SampleGrid<K>>,
    /// The evolutionary methods' centred frame, made at first use.
    frame: OnceLock<Frame>,
    /// The normal matrix's sparsity, made at the first linear fit.
    gram: OnceLock<GramPattern>,
    /// The band plans of the linear fit's systems ([`FitProblem::band_plans`]), made at the
    /// first linear fit.
    plans: OnceLock<Vec<Option<BandPlan>>>,
    extent: f64,
}

/// Which entries of a linear fit's normal matrix `AᵀWA` can be non-zero: design points `i`
/// and `l` couple only where some cell supports both. Rows in CSR form (`col[start[i]..
/// start[i + 1]]`, ascending), and for every cell the slot of each pair of its support.
#[derive(Clone, Debug)]
struct GramPattern {
    start: Vec<usize>,
    col: Vec<u32>,
    /// `(lower, upper)` slots of every pair `l < i`: the sum fills the upper triangle and
    /// copies it down.
    mirror: Vec<(u32, u32)>,
    /// `slots[cell][a * s + b]`: the slot of `(support[a], support[b])`, `s` the support size.
    slots: Vec<Vec<u32>>,
}

/// The normal equations' sums over a run of points in one cell of a tensor-product shape
/// that share the basis of the other parameters ([`Shape::product_basis`]): the first
/// factor's products `Σ w f_a f_c` and `Σ w f_a q`, expanded into the full sums once.
#[derive(Default)]
struct ProductRun {
    cell: Option<usize>,
    rest: Vec<f64>,
    /// `Σ w f_a f_c`, row-major over the first factor.
    gram: Vec<f64>,
    /// `Σ w f_a q_k` at `a * dim + k`.
    rhs: Vec<f64>,
    width: usize,
    dim: usize,
}

impl ProductRun {
    fn start(&mut self, cell: usize, rest: &[f64], width: usize, dim: usize) {
        self.cell = Some(cell);
        self.rest.clear();
        self.rest.extend_from_slice(rest);
        self.gram.clear();
        self.gram.resize(width * width, 0.0);
        self.rhs.clear();
        self.rhs.resize(width * dim, 0.0);
        self.width = width;
        self.dim = dim;
    }

    fn add<P: Vector>(&mut self, first: &[f64], w: f64, q: P) {
        let n = self.width;
        for (a, &fa) in first.iter().enumerate() {
            let wa = w * fa;
            for (g, &fc) in self.gram[a * n..(a + 1) * n].iter_mut().zip(first) {
                *g += wa * fc;
            }
            for k in 0..self.dim {
                self.rhs[a * self.dim + k] += wa * q.coord(k);
            }
        }
    }

    /// Add the run's sums to the upper triangle `ata` ([`GramPattern`] slots of the cell,
    /// `slots`) and to `atq`, for the cell's `support`; the run is then empty.
    fn flush(&mut self, slots: &[u32], support: &[u32], ata: &mut [f64], atq: &mut [f64]) {
        let (n, r, s) = (self.width, self.rest.len(), support.len());
        for a in 0..s {
            let (au, av) = (a / r, a % r);
            let ra = self.rest[av];
            for c in a..s {
                let (cu, cv) = (c / r, c % r);
                ata[slots[a * s + c] as usize] += self.gram[au * n + cu] * ra * self.rest[cv];
            }
            for k in 0..self.dim {
                atq[support[a] as usize * self.dim + k] += self.rhs[au * self.dim + k] * ra;
            }
        }
        self.cell = None;
    }
}

impl GramPattern {
    fn new<S: Shape<K>, const K: usize>(shape: &S) -> Self {
        let m = shape.design_count();
        let cells = shape.cell_count();
        // The cells whose support holds each design point, with its place in the support.
        let mut cells_of: Vec<Vec<(u32, u32)>> = vec![Vec::new(); m];
        for c in 0..cells {
            for (k, &a) in shape.support(c).iter().enumerate() {
                cells_of[a as usize].push((c as u32, k as u32));
            }
        }
        // Each point's neighbours once (marked as met), then in order. Built before by
        // appending every support whole and sorting, 7 % of the IEA 3.4 MW search.
        let mut mark = vec![usize::MAX; m];
        let nbr: Vec<Vec<u32>> = (0..m)
            .map(|a| {
                let mut row = Vec::new();
                for &(c, _) in &cells_of[a] {
                    for &b in shape.support(c as usize) {
                        if mark[b as usize] != a {
                            mark[b as usize] = a;
                            row.push(b);
                        }
                    }
                }
                row.sort_unstable();
                row
            })
            .collect();
        let mut start = Vec::with_capacity(m + 1);
        start.push(0);
        for n in &nbr {
            start.push(start.last().copied().unwrap_or(0) + n.len());
        }
        // The slot of every pair of a support, row by row: each neighbour's place in the row.
        let mut slots: Vec<Vec<u32>> = (0..cells)
            .map(|c| vec![0; shape.support(c).len().pow(2)])
            .collect();
        let mut place = vec![0; m];
        for a in 0..m {
            for (k, &b) in nbr[a].iter().enumerate() {
                place[b as usize] = start[a] + k;
            }
            for &(c, k) in &cells_of[a] {
                let sup = shape.support(c as usize);
                let s = sup.len();
                for (l, &b) in sup.iter().enumerate() {
                    slots[c as usize][k as usize * s + l] = place[b as usize] as u32;
                }
            }
        }
        let mirror = (0..m)
            .flat_map(|i| {
                let (nbr, start) = (&nbr, &start);
                nbr[i]
                    .iter()
                    .enumerate()
                    .filter(move |(_, &l)| (l as usize) < i)
                    .map(move |(k, &l)| {
                        let up = start[l as usize] + nbr[l as usize].binary_search(&(i as u32)).unwrap_or(0);
                        ((start[i] + k) as u32, up as u32)
                    })
            })
            .collect();
        GramPattern {
            start,
            col: nbr.concat(),
            mirror,
            slots,
        }
    }

    /// Row `i`'s columns: the design points that share a cell with `i` (itself included).
    fn neighbours(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        self.col[self.start[i]..self.start[i + 1]]
            .iter()
            .map(|&l| l as usize)
    }

    /// Row `i`'s entries `(l, value)` of the values `val`.
    fn row<'v>(&'v self, val: &'v [f64], i: usize) -> impl Iterator<Item = (usize, f64)> + 'v {
        self.neighbours(i)
            .zip(val[self.start[i]..self.start[i + 1]].iter().copied())
    }
}

/// A linear rule for one coordinate of every design point: coordinate `c` of design point
/// `i` is `Σ w z_k` over the entries `(k, w)` of row `i`, plus `offset[i]`, with `z` this
/// coordinate's unknowns.
#[derive(Clone, Debug, PartialEq)]
pub struct CoordRule {
    rows: Vec<Vec<(usize, f64)>>,
    offset: Vec<f64>,
    unknowns: usize,
}

impl CoordRule {
    /// The coordinate of each of `m` design points is its own unknown.
    #[must_use]
    pub fn free(m: usize) -> Self {
        CoordRule {
            rows: (0..m).map(|i| vec![(i, 1.0)]).collect(),
            offset: vec![0.0; m],
            unknowns: m,
        }
    }

    /// The coordinate is fixed at `values` (one per design point): no unknowns.
    #[must_use]
    pub fn fixed(values: Vec<f64>) -> Self {
        CoordRule {
            rows: vec![Vec::new(); values.len()],
            offset: values,
            unknowns: 0,
        }
    }

    /// The coordinate is a linear combination of `unknowns` numbers, row `i` for design point
    /// `i` (entries `(unknown, weight)`).
    #[must_use]
    pub fn linear(rows: Vec<Vec<(usize, f64)>>, unknowns: usize) -> Self {
        let m = rows.len();
        CoordRule {
            rows,
            offset: vec![0.0; m],
            unknowns,
        }
    }

    /// Number of unknowns.
    #[must_use]
    pub fn unknowns(&self) -> usize {
        self.unknowns
    }

    /// Row `i`: the entries `(unknown, weight)` of design point `i`.
    #[must_use]
    pub fn row(&self, i: usize) -> &[(usize, f64)] {
        &self.rows[i]
    }

    /// The coordinate of design point `i` for unknowns `z`.
    #[must_use]
    pub fn value(&self, i: usize, z: &[f64]) -> f64 {
        self.rows[i].iter().map(|&(k, w)| w * z[k]).sum::<f64>() + self.offset[i]
    }

    /// The unknowns that reproduce the coordinates `x` best (exactly when `x` follows the
    /// rule): the least-squares solution of `A z = x - offset`.
    fn unknowns_of(&self, x: &[f64]) -> Option<Vec<f64>> {
        let n = self.unknowns;
        let mut a = DMatrix::<f64>::zeros(n, n);
        let mut b = DVector::<f64>::zeros(n);
        for (i, row) in self.rows.iter().enumerate() {
            for &(k, w) in row {
                b[k] += w * (x[i] - self.offset[i]);
                for &(l, v) in row {
                    a[(k, l)] += w * v;
                }
            }
        }
        let z = a.cholesky()?.solve(&b);
        z.iter().all(|v| v.is_finite()).then(|| z.as_slice().to_vec())
    }
}

/// Linear constraints on the design points, one [`CoordRule`] per coordinate: the design is
/// `A z + c` for the unknowns `z` (coordinate 0's unknowns first, then coordinate 1's, ...).
/// The aerofoil rule makes every x a combination of 2 or 3 numbers; the span rule fixes the
/// span coordinate of every design column. A [`Constraint::coupled`] constraint shares
/// unknowns between coordinates (a blade section's thickness-direction coordinate moves a
/// design point along a direction that is not an axis).
#[derive(Clone, Debug, PartialEq)]
pub struct Constraint {
    coords: Vec<CoordRule>,
    /// Index of each coordinate's first unknown in `z`.
    first: Vec<usize>,
    /// The entries `(unknown, weight)` of every flat design variable `i * DIM + c`.
    flat: Vec<Vec<(usize, f64)>>,
    /// For a coupled constraint: the offset of every flat design variable and the number of
    /// unknowns (`coords` is then empty).
    coupled: Option<(Vec<f64>, usize)>,
    /// A fairness penalty on the unknowns of a coupled constraint: rows `(unknown, weight)`
    /// of `D` and the factor `ε`; the linear fit adds `ε d̄ Σ (D z)²`, `d̄` the mean diagonal
    /// of the data's normal matrix.
    fair: Option<(Vec<SparseRow>, f64)>,
}

/// A curve through held parameter values ([`FitProblem::held_curve`]).
struct HeldCurve<'s, P, const K: usize> {
    /// The parameters it was made for (`t[1..]` held; `t[0]` runs along it).
    t: [f64; K],
    /// The curve's shape.
    shape: &'s CurveShape<P>,
    /// Its design, prepared for evaluation ([`Shape::prepare`]).
    ctrl: Vec<P>,
}

/// A sparse row: `(unknown, weight)` entries.
type SparseRow = Vec<(usize, f64)>;

impl Constraint {
    /// The constraint of one rule per coordinate.
    #[must_use]
    pub fn new(coords: Vec<CoordRule>) -> Self {
        let mut first = Vec::with_capacity(coords.len());
        let mut at = 0;
        for c in &coords {
            first.push(at);
            at += c.unknowns;
        }
        let m = coords.first().map_or(0, |c| c.rows.len());
        let flat = (0..m)
            .flat_map(|i| (0..coords.len()).map(move |c| (i, c)))
            .map(|(i, c)| {
                let rows = coords[c].rows.get(i).map_or(&[][..], Vec::as_slice);
                rows.iter().map(|&(k, w)| (first[c] + k, w)).collect()
            })
            .collect();
        Constraint {
            coords,
            first,
            flat,
            coupled: None,
            fair: None,
        }
    }

    /// A constraint whose unknowns may move several coordinates: flat design variable
    /// `i * DIM + c` is `Σ w z_k` over the entries `(k, w)` of `rows[i * DIM + c]`, plus
    /// `offset[i * DIM + c]`, for `unknowns` unknowns `z`.
    #[must_use]
    pub fn coupled(rows: Vec<Vec<(usize, f64)>>, offset: Vec<f64>, unknowns: usize) -> Self {
        Constraint {
            coords: Vec::new(),
            first: Vec::new(),
            flat: rows,
            coupled: Some((offset, unknowns)),
            fair: None,
        }
    }

    /// The coupled constraint with a fairness penalty `ε d̄ Σ (D z)²` in the linear fit
    /// (`d̄` the mean diagonal of the data's normal matrix in the unknowns): `rows` are the
    /// rows of `D`. Design points the data leave barely determined (a cell with no point of
    /// some section) then follow their neighbours instead of swinging freely.
    #[must_use]
    pub fn with_fairness(mut self, rows: Vec<SparseRow>, eps: f64) -> Self {
        self.fair = Some((rows, eps));
        self
    }

    /// Add the fairness penalty ([`Constraint::with_fairness`]) to the normal matrix `a` of
    /// the coupled constraint's unknowns.
    fn add_fairness(&self, a: &mut Normal<'_>) {
        let Some((d, eps)) = &self.fair else {
            return;
        };
        let nz = a.size();
        let lambda = eps * (0..nz).map(|i| a.diagonal(i)).sum::<f64>() / nz.max(1) as f64;
        for row in d {
            for &(p, wp) in row {
                for &(q, wq) in row {
                    a.add(p, q, lambda * wp * wq);
                }
            }
        }
    }

    /// The coordinates that share one rule (the same rows and unknowns: a span-rule grid's
    /// two free coordinates), each group with its first coordinate, in coordinate order.
    fn groups(&self) -> Vec<(usize, Vec<usize>)> {
        let mut done = vec![false; self.coords.len()];
        let mut out = Vec::new();
        for k0 in 0..self.coords.len() {
            if done[k0] {
                continue;
            }
            let rule = &self.coords[k0];
            let group: Vec<usize> = (k0..self.coords.len())
                .filter(|&k| {
                    !done[k] && self.coords[k].rows == rule.rows && self.coords[k].unknowns == rule.unknowns
                })
                .collect();
            for &k in &group {
                done[k] = true;
            }
            out.push((k0, group));
        }
        out
    }

    /// The rule of coordinate `c`; `None` for a coupled constraint.
    #[must_use]
    pub fn coord(&self, c: usize) -> Option<&CoordRule> {
        self.coords.get(c)
    }

    /// Number of unknowns, all coordinates together.
    #[must_use]
    pub fn unknowns(&self) -> usize {
        match &self.coupled {
            Some((_, n)) => *n,
            None => self.coords.iter().map(|c| c.unknowns).sum(),
        }
    }

    /// The entries `(unknown, weight)` of every flat design variable `i * DIM + c`.
    pub(crate) fn flat_rows(&self) -> &[Vec<(usize, f64)>] {
        &self.flat
    }

    /// The design points for unknowns `z`.
    #[must_use]
    pub fn design<P: Vector>(&self, z: &[f64]) -> Vec<P> {
        if let Some((offset, _)) = &self.coupled {
            return (0..self.flat.len() / P::DIM)
                .map(|i| {
                    let c: Vec<f64> = (0..P::DIM)
                        .map(|c| {
                            let r = i * P::DIM + c;
                            self.flat[r].iter().map(|&(k, w)| w * z[k]).sum::<f64>() + offset[r]
                        })
                        .collect();
                    P::from_coords(&c)
                })
                .collect();
        }
        let m = self.coords.first().map_or(0, |c| c.rows.len());
        (0..m)
            .map(|i| {
                let c: Vec<f64> = (0..P::DIM)
                    .map(|c| self.coords[c].value(i, &z[self.first[c]..]))
                    .collect();
                P::from_coords(&c)
            })
            .collect()
    }

    /// The unknowns of design points that follow the constraint (least squares per
    /// coordinate); `None` when a rule's unknowns are not determined.
    #[must_use]
    pub fn unknowns_of<P: Vector>(&self, design: &[P]) -> Option<Vec<f64>> {
        if let Some((offset, n)) = &self.coupled {
            let mut a = DMatrix::<f64>::zeros(*n, *n);
            let mut b = DVector::<f64>::zeros(*n);
            for (r, row) in self.flat.iter().enumerate() {
                let x = design.get(r / P::DIM)?.coord(r % P::DIM) - offset[r];
                for &(k, w) in row {
                    b[k] += w * x;
                    for &(l, v) in row {
                        a[(k, l)] += w * v;
                    }
                }
            }
            let z = a.cholesky()?.solve(&b);
            return z.iter().all(|v| v.is_finite()).then(|| z.as_slice().to_vec());
        }
        let mut z = Vec::with_capacity(self.unknowns());
        for (c, rule) in self.coords.iter().enumerate() {
            let x: Vec<f64> = design.iter().map(|p| p.coord(c)).collect();
            z.extend(rule.unknowns_of(&x)?);
        }
        Some(z)
    }

    fn check(&self, dim: usize, m: usize) -> Result<()> {
        if let Some((offset, n)) = &self.coupled {
            if self.flat.len() != m * dim || offset.len() != m * dim {
                return Err(Error::invalid(format!(
                    "the coupled constraint has {} rows for {m} design points of {dim} coordinates",
                    self.flat.len()
                )));
            }
            if self
                .flat
                .iter()
                .flatten()
                .any(|&(k, w)| k >= *n || !w.is_finite())
                || offset.iter().any(|o| !o.is_finite())
            {
                return Err(Error::invalid(
                    "a constraint row names an unknown it does not have",
                ));
            }
            return Ok(());
        }
        if self.coords.len() != dim || self.coords.iter().any(|c| c.rows.len() != m) {
            return Err(Error::invalid(format!(
                "the constraint has {} coordinate rules for {m} design points; the problem has {dim}                  coordinates",
                self.coords.len()
            )));
        }
        if self.coords.iter().any(|c| {
            c.rows
                .iter()
                .flatten()
                .any(|&(k, w)| k >= c.unknowns || !w.is_finite())
        }) {
            return Err(Error::invalid(
                "a constraint row names an unknown it does not have",
            ));
        }
        Ok(())
    }
}

/// A fitting problem for a chain of curves.
pub type CurveProblem<'a, P> = FitProblem<'a, CurveShape<P>, 1>;
/// A fitting problem for a grid of patches.
pub type GridProblem<'a, P> = FitProblem<'a, GridShape<P>, 2>;

/// The residual of one data point at parameter `t` and its derivatives.
///
/// With `basis` the shape's basis at `t`, the Jacobian block of `r` is `∂r/∂x_i = φ_i I` for
/// each design point `x_i` of the support, and `∂r/∂t_k = tangents[k]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual<P, const K: usize> {
    /// `C(t) - q`.
    pub r: P,
    /// `∂C/∂t_k` at `t`.
    pub tangents: [P; K],
}

/// Groups the per-point sums of large point sets are split into: each group is summed on its
/// own and the groups are merged in order, so the result does not depend on how rayon
/// schedules the work (the same bits on any number of threads).
const SUM_GROUPS: usize = 16;

/// Sum `body` over chunks of `0..n`, on rayon's pool when `n` is large (in [`SUM_GROUPS`]
/// fixed groups merged in order, so the result is reproducible).
pub(crate) fn chunked_sum<T: Send>(
    n: usize,
    init: impl Fn() -> T + Sync + Send,
    body: impl Fn(&mut T, std::ops::Range<usize>) + Sync + Send,
    merge: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    if n < PARALLEL_MIN {
        let mut acc = init();
        body(&mut acc, 0..n);
        return acc;
    }
    let groups = n.div_ceil(CHUNK).min(SUM_GROUPS);
    let parts: Vec<T> = (0..groups)
        .into_par_iter()
        .map(|g| {
            let mut acc = init();
            body(&mut acc, g * n / groups..(g + 1) * n / groups);
            acc
        })
        .collect();
    let mut parts = parts.into_iter();
    let first = parts.next().unwrap_or_else(&init);
    parts.fold(first, merge)
}

/// A linear fit's symmetric normal matrix as it is summed: in band form where the problem's
/// plan of its sparsity ([`BandPlan`]) makes that cheaper, else dense. Every entry is added
/// with its mirror ([`Normal::add`] both ways round), as a dense sum would.
enum Normal<'p> {
    Dense(DMatrix<f64>),
    Band(&'p BandPlan, BandMatrix),
}

impl<'p> Normal<'p> {
    fn new(n: usize, plan: Option<&'p BandPlan>) -> Self {
        match plan {
            Some(p) if p.size() == n => Normal::Band(p, p.zeros()),
            _ => Normal::Dense(DMatrix::zeros(n, n)),
        }
    }

    #[inline]
    fn add(&mut self, i: usize, j: usize, v: f64) {
        match self {
            Normal::Dense(a) => a[(i, j)] += v,
            Normal::Band(p, m) => p.add(m, i, j, v),
        }
    }

    fn size(&self) -> usize {
        match self {
            Normal::Dense(a) => a.nrows(),
            Normal::Band(p, _) => p.size(),
        }
    }

    fn diagonal(&self, i: usize) -> f64 {
        match self {
            Normal::Dense(a) => a[(i, i)],
            Normal::Band(p, m) => p.diagonal(m, i),
        }
    }

    /// Solve `a x = rhs` by Cholesky (a dense system in band form where its own sparsity
    /// allows, [`BandPlan::of`]); when `a` is singular, with a ridge of `1e-10` of its
    /// largest diagonal pulling column `k` of the solution towards `toward(k)`.
    fn solve_ridged(self, mut rhs: DMatrix<f64>, toward: impl Fn(usize) -> f64) -> Result<DMatrix<f64>> {
        let n = self.size();
        let mu = 1e-10
            * (0..n)
                .map(|i| self.diagonal(i))
                .fold(0.0, f64::max)
                .max(f64::MIN_POSITIVE);
        let ridge = |rhs: &mut DMatrix<f64>| {
            for i in 0..n {
                for k in 0..rhs.ncols() {
                    rhs[(i, k)] += mu * toward(k);
                }
            }
        };
        let singular = || Error::Numerical("the least-squares system is singular".into());
        match self {
            Normal::Band(plan, m) => {
                if let Some(x) = plan.solve_summed(m.clone(), &rhs) {
                    return Ok(x);
                }
                let mut m = m;
                for i in 0..n {
                    plan.add(&mut m, i, i, mu);
                }
                ridge(&mut rhs);
                plan.solve_summed(m, &rhs).ok_or_else(singular)
            }
            Normal::Dense(mut a) => {
                let plan = BandPlan::of(&a);
                let solve = |a: &DMatrix<f64>, rhs: &DMatrix<f64>| match &plan {
                    Some(p) => p.solve(a, rhs),
                    None => a.clone().cholesky().map(|ch| ch.solve(rhs)),
                };
                if let Some(x) = solve(&a, &rhs) {
                    return Ok(x);
                }
                for i in 0..n {
                    a[(i, i)] += mu;
                }
                ridge(&mut rhs);
                solve(&a, &rhs).ok_or_else(singular)
            }
        }
    }
}

impl<'a, S: Shape<K>, const K: usize> FitProblem<'a, S, K> {
    /// A problem from a shape, data points, one parameter per point in `[0, 1]^K` (the
    /// corresponding parameters, also the start of a closest-point fit), a metric and the
    /// foot-point search options.
    pub fn new(
        shape: S,
        points: &'a [S::Point],
        params: Vec<[f64; K]>,
        metric: Metric,
        foot: FootOptions,
    ) -> Result<Self> {
        check_points(points)?;
        let m = shape.design_count();
        if points.len() < m {
            return Err(Error::invalid(format!(
                "{} data points cannot determine {m} design points: at least {m} are needed",
                points.len()
            )));
        }
        if params.len() != points.len() {
            return Err(Error::invalid(format!(
                "{} parameters given for {} data points",
                params.len(),
                points.len()
            )));
        }
        if params.iter().flatten().any(|t| !(0.0..=1.0).contains(t)) {
            return Err(Error::invalid("data point parameters must lie in [0, 1]"));
        }
        if foot.samples == 0 {
            return Err(Error::invalid(
                "foot-point search needs at least one sample per cell",
            ));
        }
        let mut extent: f64 = 0.0;
        for c in 0..S::Point::DIM {
            let (lo, hi) = points.iter().fold((f64::MAX, f64::MIN), |(lo, hi), p| {
                (lo.min(p.coord(c)), hi.max(p.coord(c)))
            });
            extent = extent.max(hi - lo);
        }
        let grid = OnceLock::new();
        let anchored = vec![false; points.len()];
        let extent = if extent > 0.0 { extent } else { 1.0 };
        Ok(FitProblem {
            shape,
            points,
            metric,
            params,
            anchored,
            weights: None,
            held: [false; K],
            constraint: None,
            start: None,
            start_flat: Vec::new(),
            bounds: Vec::new(),
            box_extent: extent,
            foot,
            grid,
            frame: OnceLock::new(),
            gram: OnceLock::new(),
            plans: OnceLock::new(),
            extent,
        })
    }

    /// The problem with weight `weights[j]` on data point `j` (finite, at least 0), or none
    /// (all 1).
    pub fn with_weights(mut self, weights: Option<Vec<f64>>) -> Result<Self> {
        self.set_weights(weights)?;
        Ok(self)
    }

    /// Replace the weights (see [`FitProblem::with_weights`]).
    pub fn set_weights(&mut self, weights: Option<Vec<f64>>) -> Result<()> {
        if let Some(w) = &weights {
            if w.len() != self.points.len() {
                return Err(Error::invalid(format!(
                    "{} weights given for {} data points",
                    w.len(),
                    self.points.len()
                )));
            }
            if w.iter().any(|&x| !(x >= 0.0) || !x.is_finite()) {
                return Err(Error::invalid("weights must be finite and at least 0"));
            }
        }
        self.weights = weights;
        Ok(())
    }

    /// The weight of data point `j` (1 without weights).
    #[inline]
    #[must_use]
    pub fn weight(&self, j: usize) -> f64 {
        self.weights.as_ref().map_or(1.0, |w| w[j])
    }

    /// The problem with the parameter directions marked in `held` kept at every point's given
    /// parameter (e.g. a sectioned cloud's span parameter `v`): only the others move.
    #[must_use]
    pub fn with_held(mut self, held: [bool; K]) -> Self {
        self.held = held;
        self
    }

    /// The parameter directions held at the given parameters.
    #[must_use]
    pub fn held(&self) -> [bool; K] {
        self.held
    }

    /// The problem with the design points constrained to `constraint`.
    pub fn with_constraint(mut self, constraint: Constraint) -> Result<Self> {
        constraint.check(S::Point::DIM, self.design_count())?;
        self.constraint = Some(constraint);
        self.plans = OnceLock::new();
        Ok(self)
    }

    /// The linear constraint on the design, if any.
    #[must_use]
    pub fn constraint(&self) -> Option<&Constraint> {
        self.constraint.as_ref()
    }

    /// The problem with `start` as its start design (the paper's start for curves; the
    /// evolutionary methods start from it).
    pub fn with_start(mut self, start: Vec<S::Point>) -> Result<Self> {
        if start.len() != self.design_count() {
            return Err(Error::invalid(format!(
                "the start has {} design points, the layout {}",
                start.len(),
                self.design_count()
            )));
        }
        if start.iter().any(|p| !p.is_finite_point()) {
            return Err(Error::invalid("the start design must be finite"));
        }
        self.start_flat = Self::to_flat(&start);
        self.start = Some(start);
        self.frame = OnceLock::new();
        Ok(self)
    }

    /// The start design, if one was given.
    #[must_use]
    pub fn start_design(&self) -> Option<&[S::Point]> {
        self.start.as_deref()
    }

    /// The start design flat (`x0, y0, (z0,) x1, …`; empty without one).
    #[must_use]
    pub fn start_flat(&self) -> &[f64] {
        &self.start_flat
    }

    /// The problem with box bounds on every design variable: the bounding box of the data and
    /// the start design, each side grown by `margin` times its largest side (the evolutionary
    /// methods' search box).
    pub fn with_bounds(mut self, margin: f64) -> Result<Self> {
        if !(margin >= 0.0) || !margin.is_finite() {
            return Err(Error::invalid(format!(
                "the bounds margin must be a finite number ≥ 0 (a fraction of the data extent), not {margin}"
            )));
        }
        let dim = S::Point::DIM;
        let mut sides = vec![[f64::INFINITY, f64::NEG_INFINITY]; dim];
        for p in self.points.iter().chain(self.start.iter().flatten()) {
            for (c, s) in sides.iter_mut().enumerate() {
                s[0] = s[0].min(p.coord(c));
                s[1] = s[1].max(p.coord(c));
            }
        }
        let extent = sides.iter().map(|s| s[1] - s[0]).fold(0.0, f64::max);
        let extent = if extent > 0.0 { extent } else { 1.0 };
        for s in &mut sides {
            s[0] -= margin * extent;
            s[1] += margin * extent;
        }
        self.bounds = (0..self.design_count())
            .flat_map(|_| sides.iter().copied())
            .collect();
        self.box_extent = extent;
        self.frame = OnceLock::new();
        Ok(self)
    }

    /// The frame the evolutionary methods see the problem in: the start and bounds less the
    /// centre of the bounds' box (see [`Frame`]).
    pub(crate) fn frame(&self) -> &Frame {
        self.frame
            .get_or_init(|| Frame::new(&self.start_flat, &self.bounds, S::Point::DIM))
    }

    /// `[lower, upper]` of every flat design variable (empty until [`FitProblem::with_bounds`]).
    #[must_use]
    pub fn bounds(&self) -> &[[f64; 2]] {
        &self.bounds
    }

    /// The largest side of the box the bounds were grown from (data and start), model units.
    #[must_use]
    pub fn box_extent(&self) -> f64 {
        self.box_extent
    }

    /// The problem with the given data points anchored at their fixed parameters (replacing
    /// any earlier anchors).
    pub fn with_anchors(mut self, anchors: &[usize]) -> Result<Self> {
        self.anchored.fill(false);
        for &j in anchors {
            match self.anchored.get_mut(j) {
                Some(a) => *a = true,
                None => {
                    return Err(Error::invalid(format!(
                        "anchor {j} is not a data point index (there are {})",
                        self.points.len()
                    )))
                }
            }
        }
        Ok(self)
    }

    /// True when data point `j` keeps its fixed parameter.
    #[must_use]
    pub fn is_anchored(&self, j: usize) -> bool {
        self.anchored[j]
    }

    /// The anchored data points, with the design points (and weights) of the shape point each
    /// is tied to (its basis at its fixed parameter, zero weights left out).
    #[must_use]
    pub fn anchors(&self) -> Vec<(usize, Vec<(usize, f64)>)> {
        let mut b = Basis::new();
        (0..self.points.len())
            .filter(|&j| self.anchored[j])
            .map(|j| {
                self.shape.basis(self.params[j], 0, &mut b);
                let weights = self
                    .shape
                    .support(b.cell)
                    .iter()
                    .zip(&b.value)
                    .filter(|(_, &w)| w != 0.0)
                    .map(|(&i, &w)| (i as usize, w))
                    .collect();
                (j, weights)
            })
            .collect()
    }

    /// The shape.
    #[must_use]
    pub fn shape(&self) -> &S {
        &self.shape
    }

    /// The data points.
    #[must_use]
    pub fn points(&self) -> &'a [S::Point] {
        self.points
    }

    /// The offset metric.
    #[must_use]
    pub fn metric(&self) -> Metric {
        self.metric
    }

    /// The fixed parameter of every data point.
    #[must_use]
    pub fn params(&self) -> &[[f64; K]] {
        &self.params
    }

    /// The foot-point search options.
    #[must_use]
    pub fn foot_options(&self) -> &FootOptions {
        &self.foot
    }

    /// Replace the foot-point search options (e.g. fewer Newton steps for a polish); the
    /// global search's samples are rebuilt when their count changes.
    pub fn set_foot_options(&mut self, foot: FootOptions) -> Result<()> {
        if foot.samples == 0 {
            return Err(Error::invalid(
                "foot-point search needs at least one sample per cell",
            ));
        }
        if foot.samples != self.foot.samples {
            self.grid = OnceLock::new();
        }
        self.foot = foot;
        Ok(())
    }

    /// The largest side of the data's bounding box, in model units (1 for a single point).
    #[must_use]
    pub fn extent(&self) -> f64 {
        self.extent
    }

    /// Number of design points.
    #[must_use]
    pub fn design_count(&self) -> usize {
        self.shape.design_count()
    }

    /// Number of scalar design variables: design points times coordinates.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.design_count() * S::Point::DIM
    }

    /// Design points as a flat vector `x0, y0, (z0,) x1, …`.
    #[must_use]
    pub fn to_flat(design: &[S::Point]) -> Vec<f64> {
        design
            .iter()
            .flat_map(|p| (0..S::Point::DIM).map(move |c| p.coord(c)))
            .collect()
    }

    /// Design points from a flat vector `x0, y0, (z0,) x1, …`.
    #[must_use]
    pub fn from_flat(x: &[f64]) -> Vec<S::Point> {
        x.chunks_exact(S::Point::DIM).map(S::Point::from_coords).collect()
    }

    /// The residual of data point `j` at parameter `t`, leaving the basis at `t` (with first
    /// derivatives) in `basis`.
    pub fn residual(
        &self,
        design: &[S::Point],
        j: usize,
        t: [f64; K],
        basis: &mut Basis<K>,
    ) -> Residual<S::Point, K> {
        let prepared = self.shape.prepare(design);
        self.residual_at(&prepared, design, j, t, basis)
    }

    /// [`FitProblem::residual`] with the design also prepared ([`Shape::prepare`]).
    pub fn residual_at(
        &self,
        prepared: &S::Prepared<'_>,
        design: &[S::Point],
        j: usize,
        t: [f64; K],
        basis: &mut Basis<K>,
    ) -> Residual<S::Point, K> {
        let jet = self.shape.basis_and_jet(prepared, design, t, basis);
        Residual {
            r: jet.point - self.points[j],
            tangents: jet.d1,
        }
    }

    /// The objective's foot point of every data point: the closest point (global search;
    /// `warm` holds optional starts), or the fixed parameter for anchored points.
    #[must_use]
    pub fn feet(&self, design: &[S::Point], warm: Option<&[[f64; K]]>) -> Vec<Foot<K>> {
        let mut feet = self.true_feet(design, warm);
        let mut b = Basis::new();
        for (j, f) in feet.iter_mut().enumerate() {
            if self.anchored[j] {
                let t = self.params[j];
                self.shape.basis(t, 0, &mut b);
                let dist_sq = (self.shape.jet(&b, design, 0).point - self.points[j]).length_squared();
                *f = Foot { t, dist_sq };
            }
        }
        feet
    }

    /// The true closest point of every data point, anchors ignored.
    fn true_feet(&self, design: &[S::Point], warm: Option<&[[f64; K]]>) -> Vec<Foot<K>> {
        let mut feet = vec![
            Foot {
                t: [0.0; K],
                dist_sq: 0.0
            };
            self.points.len()
        ];
        closest_all(
            &self.shape,
            self.grid
                .get_or_init(|| SampleGrid::new(&self.shape, self.foot.samples)),
            design,
            self.points,
            warm,
            &self.foot,
            &mut feet,
        );
        feet
    }

    /// Move every parameter but the anchored ones (and the held directions) to the local
    /// closest point by Newton's method started from it, returning `Σ w_j |C(t_j) - q_j|²` at
    /// the new parameters.
    pub fn project(&self, design: &[S::Point], params: &mut [[f64; K]]) -> f64 {
        self.project_max(design, params).0
    }

    /// [`FitProblem::project`], with the largest distance `|C(t_j) - q_j|` of any point.
    pub fn project_max(&self, design: &[S::Point], params: &mut [[f64; K]]) -> (f64, f64) {
        debug_assert_eq!(
            params.len(),
            self.points.len(),
            "project: one parameter per point"
        );
        let prepared = self.shape.prepare(design);
        let run = |offset: usize, ts: &mut [[f64; K]]| {
            let mut b = Basis::new();
            let mut b1 = Basis::<1>::new();
            // With every parameter but the first held (a sectioned cloud's points move along
            // their section), each point's search runs on the curve through its held values.
            let mut cache = None;
            let (mut sum, mut max) = (0.0, 0.0_f64);
            for (j, t) in ts.iter_mut().enumerate() {
                let q = self.points[offset + j];
                let curve = self.held_curve(design, *t, &mut cache);
                let d2 = if self.anchored[offset + j] {
                    self.shape.basis(*t, 0, &mut b);
                    (self.shape.jet(&b, design, 0).point - q).length_squared()
                } else if let Some(h) = curve {
                    let f = refine_held(h.shape, &h.ctrl, q, [t[0]], [false], &self.foot, &mut b1);
                    t[0] = f.t[0];
                    f.dist_sq
                } else {
                    let f = refine_held(&self.shape, &prepared, q, *t, self.held, &self.foot, &mut b);
                    *t = f.t;
                    f.dist_sq
                };
                sum += self.weight(offset + j) * d2;
                max = max.max(d2);
            }
            (sum, max)
        };
        let (sum, max) = if params.len() < PARALLEL_MIN {
            run(0, params)
        } else {
            // Per-chunk sums added in order: the same bits on any number of threads.
            let parts: Vec<(f64, f64)> = params
                .par_chunks_mut(CHUNK)
                .enumerate()
                .map(|(c, ts)| run(c * CHUNK, ts))
                .collect();
            parts
                .iter()
                .fold((0.0, 0.0_f64), |(s, m), &(a, b)| (s + a, m.max(b)))
        };
        (sum, max.sqrt())
    }

    /// The distance `|C(t_j) - q_j|` of every data point at its parameter.
    #[must_use]
    pub fn distances(&self, design: &[S::Point], params: &[[f64; K]]) -> Vec<f64> {
        let mut b = Basis::new();
        let mut b1 = Basis::<1>::new();
        let prepared = self.shape.prepare(design);
        // As in `project_max`: on the curves through the held values, where there are such.
        let mut cache = None;
        params
            .iter()
            .zip(self.points)
            .map(|(&t, &q)| {
                let p = match self.held_curve(design, t, &mut cache) {
                    Some(h) => h.shape.jet_at(&h.ctrl, [t[0]], 0, &mut b1).point,
                    None => self.shape.jet_at(&prepared, t, 0, &mut b).point,
                };
                (p - q).length()
            })
            .collect()
    }

    /// Every parameter but the first held: a sectioned cloud's points, whose searches and
    /// evaluations run on the shape's curves through their held values
    /// ([`Shape::first_curve`]).
    fn along_first(&self) -> bool {
        K > 1 && !self.held[0] && self.held[1..].iter().all(|&h| h)
    }

    /// The curve through `t`'s held values ([`Shape::first_curve`]) with its prepared design,
    /// kept in `cache` and made again only when they change (a run of points of one
    /// section shares it); `None` unless [`FitProblem::along_first`] and the shape has one.
    fn held_curve<'c>(
        &'a self,
        design: &[S::Point],
        t: [f64; K],
        cache: &'c mut Option<HeldCurve<'a, S::Point, K>>,
    ) -> Option<&'c HeldCurve<'a, S::Point, K>> {
        if !self.along_first() {
            return None;
        }
        if cache.as_ref().is_none_or(|c| c.t[1..] != t[1..]) {
            *cache = self.shape.first_curve(design, t).map(|(shape, row)| HeldCurve {
                t,
                shape,
                ctrl: shape.prepare(&row),
            });
        }
        cache.as_ref()
    }

    /// `Σ w_j |C(t_j) - q_j|²` at the given parameters.
    #[must_use]
    pub fn sum_sq_at(&self, design: &[S::Point], params: &[[f64; K]]) -> f64 {
        chunked_sum(
            self.points.len(),
            || (0.0, Basis::new()),
            |(acc, b), range| {
                for j in range {
                    self.shape.basis(params[j], 0, b);
                    *acc += self.weight(j)
                        * (self.shape.jet(b, design, 0).point - self.points[j]).length_squared();
                }
            },
            |a, b| (a.0 + b.0, a.1),
        )
        .0
    }

    /// The objective: the sum of squared offsets under the problem's metric.
    ///
    /// For the closest-point metric, `cache` holds the foot points of the previous call (empty
    /// at first) as warm starts and is updated; the result is still the global closest point.
    pub fn objective(&self, design: &[S::Point], cache: &mut Vec<[f64; K]>) -> f64 {
        match self.metric {
            Metric::Corresponding => self.sum_sq_at(design, &self.params),
            Metric::Closest => {
                let warm = (cache.len() == self.points.len()).then_some(cache.as_slice());
                let feet = self.feet(design, warm);
                cache.clear();
                cache.extend(feet.iter().map(|f| f.t));
                feet.iter()
                    .enumerate()
                    .map(|(j, f)| self.weight(j) * f.dist_sq)
                    .sum()
            }
        }
    }

    /// The objective and its gradient with respect to the design points, written to `grad`.
    ///
    /// At the foot points the envelope theorem gives
    /// `∂/∂x_i Σ_j |C(t_j) - q_j|² = Σ_j 2 φ_i(t_j) (C(t_j) - q_j)` with `t_j` held fixed.
    pub fn objective_grad(
        &self,
        design: &[S::Point],
        cache: &mut Vec<[f64; K]>,
        grad: &mut [S::Point],
    ) -> f64 {
        debug_assert_eq!(
            grad.len(),
            design.len(),
            "gradient has one entry per design point"
        );
        let value = self.objective(design, cache);
        let params: &[[f64; K]] = match self.metric {
            Metric::Corresponding => &self.params,
            Metric::Closest => cache,
        };
        let m = design.len();
        let g = chunked_sum(
            self.points.len(),
            || (vec![S::Point::ZERO; m], Basis::new()),
            |(g, b), range| {
                for j in range {
                    self.shape.basis(params[j], 0, b);
                    let r = (self.shape.jet(b, design, 0).point - self.points[j]) * self.weight(j);
                    for (&i, &w) in self.shape.support(b.cell).iter().zip(&b.value) {
                        g[i as usize] += r * (2.0 * w);
                    }
                }
            },
            |mut a, b| {
                for (x, y) in a.0.iter_mut().zip(b.0) {
                    *x += y;
                }
                a
            },
        )
        .0;
        grad.copy_from_slice(&g);
        value
    }

    /// The band plans of `linear_fit`'s systems, from their sparsity (not their values: a
    /// basis function can vanish at a point and leave an entry zero in one fit and not the
    /// next): the unconstrained or coupled system's at 0, each group of a per-coordinate
    /// constraint's at its first coordinate ([`Constraint::groups`]); `None` where the system
    /// is solved dense.
    fn band_plans(&self, pat: &GramPattern) -> Vec<Option<BandPlan>> {
        let m = self.design_count();
        let dim = S::Point::DIM;
        let neighbours = |i: usize| pat.neighbours(i);
        // The shape's orders of its design points fit the systems whose unknowns are the
        // design points themselves.
        let orders = self.shape.narrow_orders();
        let one_per_point = |rule: &CoordRule| (0..m).all(|i| rule.row(i) == [(i, 1.0)]);
        match &self.constraint {
            None => vec![BandPlan::of_pairs(
                m,
                &orders,
                |add: &mut dyn FnMut(usize, usize)| {
                    for i in 0..m {
                        neighbours(i).for_each(|l| add(i, l));
                    }
                },
            )],
            Some(con) if con.coupled.is_some() => {
                // In the constraint's own order (the chord rule's: column by column with each
                // column's frame, band 123 of 1,023 on the IEA 15 MW where reverse
                // Cuthill-McKee gave 312). Its pairs through the frame numbers every design
                // point of a column shares are too many to list (listing them took 13 % of
                // a chord-rule search): the band is the widest reach between the unknowns
                // of two coupled design points, over all their coordinates together.
                let rows = con.flat_rows();
                let span: Vec<Option<(usize, usize)>> = (0..m)
                    .map(|i| {
                        let all = (0..dim).flat_map(|k| rows[i * dim + k].iter().map(|e| e.0));
                        all.clone().min().zip(all.max())
                    })
                    .collect();
                let mut band = 0;
                for i in 0..m {
                    let Some((lo, hi)) = span[i] else { continue };
                    for (l_lo, l_hi) in neighbours(i).filter_map(|l| span[l]) {
                        band = band.max(l_hi.saturating_sub(lo)).max(hi.saturating_sub(l_lo));
                    }
                }
                for row in con.fair.iter().flat_map(|(d, _)| d) {
                    let at = row.iter().map(|e| e.0);
                    if let Some((lo, hi)) = at.clone().min().zip(at.max()) {
                        band = band.max(hi - lo);
                    }
                }
                vec![BandPlan::in_order(con.unknowns(), band)]
            }
            Some(con) => {
                let mut plans = vec![None; dim];
                for (k0, _) in con.groups() {
                    let Some(rule) = con.coord(k0) else { continue };
                    let ours: &[Vec<u32>] = if one_per_point(rule) { &orders } else { &[] };
                    plans[k0] =
                        BandPlan::of_pairs(rule.unknowns(), ours, |add: &mut dyn FnMut(usize, usize)| {
                            for i in 0..m {
                                for &(p, _) in rule.row(i) {
                                    for l in neighbours(i) {
                                        for &(r, _) in rule.row(l) {
                                            add(p, r);
                                        }
                                    }
                                }
                            }
                        });
                }
                plans
            }
        }
    }

    /// The best design for fixed parameters: the linear least-squares problem
    /// `min Σ_j w_j |Σ_i φ_i(t_j) x_i - q_j|²` (within the constraint, when there is one),
    /// solved by Cholesky on the normal equations. At fixed parameters the coordinates are
    /// independent, so a constraint is solved coordinate by coordinate on its own unknowns.
    ///
    /// Where the parameters leave design points undetermined (a cell without data), a tiny
    /// Tikhonov term (`1e-10` of the largest diagonal) pulls them towards the data centroid.
    pub fn linear_fit(&self, params: &[[f64; K]]) -> Result<Vec<S::Point>> {
        if params.len() != self.points.len() {
            return Err(Error::invalid(
                "linear_fit: one parameter per data point is needed",
            ));
        }
        let m = self.design_count();
        let dim = S::Point::DIM;
        let pat = self.gram.get_or_init(|| GramPattern::new(&self.shape));
        let (ata, atq, _) = chunked_sum(
            self.points.len(),
            || (vec![0.0; pat.col.len()], vec![0.0; m * dim], Basis::new()),
            |(ata, atq, b), range| {
                let mut run = ProductRun::default();
                let (mut first, mut rest) = (Vec::new(), Vec::new());
                // The previous point's parameters and cell, for its other factor.
                let mut prev: Option<([f64; K], usize)> = None;
                for j in range {
                    let q = self.points[j];
                    let w = self.weight(j);
                    let t = params[j];
                    let same = prev.filter(|(p, _)| p[1..] == t[1..]).map(|(_, c)| c);
                    let product = self.shape.product_basis(t, &mut first, &mut rest, same);
                    prev = product.map(|c| (t, c));
                    if let Some(cell) = product {
                        if run.cell != Some(cell) || run.rest != rest {
                            if let Some(c) = run.cell {
                                run.flush(&pat.slots[c], self.shape.support(c), ata, atq);
                            }
                            run.start(cell, &rest, first.len(), dim);
                        }
                        run.add(&first, w, q);
                        continue;
                    }
                    self.shape.basis(params[j], 0, b);
                    let support = self.shape.support(b.cell);
                    let slots = &pat.slots[b.cell];
                    let s = support.len();
                    for (a, &ia) in support.iter().enumerate() {
                        let wa = w * b.value[a];
                        // The upper triangle (the support ascends), copied down below.
                        for c in a..s {
                            ata[slots[a * s + c] as usize] += wa * b.value[c];
                        }
                        for k in 0..dim {
                            atq[ia as usize * dim + k] += wa * q.coord(k);
                        }
                    }
                }
                if let Some(c) = run.cell {
                    run.flush(&pat.slots[c], self.shape.support(c), ata, atq);
                }
            },
            |mut a, b| {
                a.0.iter_mut().zip(b.0).for_each(|(x, y)| *x += y);
                a.1.iter_mut().zip(b.1).for_each(|(x, y)| *x += y);
                a
            },
        );
        let mut ata = ata;
        for &(lo, up) in &pat.mirror {
            ata[lo as usize] = ata[up as usize];
        }
        let row = |i: usize| pat.row(&ata, i);
        let centroid: Vec<f64> = (0..dim)
            .map(|k| self.points.iter().map(|p| p.coord(k)).sum::<f64>() / self.points.len() as f64)
            .collect();
        let plans = self.plans.get_or_init(|| self.band_plans(pat));
        let design: Vec<S::Point> = match &self.constraint {
            None => {
                let mut a = Normal::new(m, plans[0].as_ref());
                for i in 0..m {
                    for (l, v) in row(i) {
                        a.add(i, l, v);
                    }
                }
                let rhs = DMatrix::from_row_slice(m, dim, &atq);
                let sol = a.solve_ridged(rhs, |k| centroid[k])?;
                (0..m)
                    .map(|i| {
                        let c: Vec<f64> = (0..dim).map(|k| sol[(i, k)]).collect();
                        S::Point::from_coords(&c)
                    })
                    .collect()
            }
            Some(con) if con.coupled.is_some() => {
                // (Aᵀ (N ⊗ I) A) z = Aᵀ (q̂ - (N ⊗ I) b), with N the normal matrix, q̂ = Nᵀ q
                // per coordinate and b the flat offsets.
                let (offset, nz) = con
                    .coupled
                    .as_ref()
                    .map_or((&[][..], 0), |(o, n)| (o.as_slice(), *n));
                let rows = con.flat_rows();
                let mut a = Normal::new(nz, plans[0].as_ref());
                let mut rhs = DMatrix::<f64>::zeros(nz, 1);
                for i in 0..m {
                    for k in 0..dim {
                        let r = i * dim + k;
                        let nb: f64 = row(i).map(|(l, v)| v * offset[l * dim + k]).sum();
                        for &(p, wp) in &rows[r] {
                            rhs[(p, 0)] += wp * (atq[r] - nb);
                        }
                    }
                    for (l, v) in row(i) {
                        if v == 0.0 {
                            continue;
                        }
                        for k in 0..dim {
                            for &(p, wp) in &rows[i * dim + k] {
                                for &(q, wq) in &rows[l * dim + k] {
                                    a.add(p, q, wp * v * wq);
                                }
                            }
                        }
                    }
                }
                con.add_fairness(&mut a);
                let z = a.solve_ridged(rhs, |_| 0.0)?;
                con.design::<S::Point>(z.as_slice())
            }
            Some(con) => {
                // Per coordinate: (Aᵀ N A) z = Aᵀ (N⁻ q - N b), with N the normal matrix.
                // Coordinates with the same A (the two free coordinates of a span-rule grid)
                // share the matrix: factored once, one right-hand side each.
                let rules: Vec<&CoordRule> = (0..dim)
                    .map(|k| {
                        con.coord(k)
                            .ok_or_else(|| Error::invalid("linear_fit: a constraint rule is missing"))
                    })
                    .collect::<Result<_>>()?;
                let mut coords = vec![vec![0.0; m]; dim];
                for (k0, group) in con.groups() {
                    let rule = rules[k0];
                    let n = rule.unknowns();
                    let mut a = Normal::new(n, plans[k0].as_ref());
                    let mut rhs = DMatrix::<f64>::zeros(n, group.len());
                    // (N b)_i of each coordinate of the group, once a design point.
                    let mut nb = vec![0.0; group.len()];
                    for i in 0..m {
                        if rule.row(i).is_empty() {
                            continue;
                        }
                        for (c, &k) in group.iter().enumerate() {
                            nb[c] = row(i).map(|(l, v)| v * rules[k].offset[l]).sum();
                        }
                        for &(p, wp) in rule.row(i) {
                            for (c, &k) in group.iter().enumerate() {
                                rhs[(p, c)] += wp * (atq[i * dim + k] - nb[c]);
                            }
                            for (l, v) in row(i) {
                                if v != 0.0 {
                                    for &(r, wr) in rule.row(l) {
                                        a.add(p, r, wp * v * wr);
                                    }
                                }
                            }
                        }
                    }
                    let z = if n > 0 {
                        a.solve_ridged(rhs, |c| centroid[group[c]])?
                    } else {
                        DMatrix::zeros(0, group.len())
                    };
                    for (c, &k) in group.iter().enumerate() {
                        let zk: Vec<f64> = z.column(c).iter().copied().collect();
                        for (i, xi) in coords[k].iter_mut().enumerate() {
                            *xi = rules[k].value(i, &zk);
                        }
                    }
                }
                (0..m)
                    .map(|i| {
                        let c: Vec<f64> = (0..dim).map(|k| coords[k][i]).collect();
                        S::Point::from_coords(&c)
                    })
                    .collect()
            }
        };
        if design.iter().any(|p| !p.is_finite_point()) {
            return Err(Error::Numerical(
                "the least-squares solution is not finite".into(),
            ));
        }
        Ok(design)
    }

    /// Offsets of the data from `design` under the problem's metric (closest points by the
    /// global search), with the parameters they were measured at.
    #[must_use]
    pub fn stats(&self, design: &[S::Point]) -> (OffsetStats<S::Point>, Vec<[f64; K]>) {
        match self.metric {
            Metric::Closest => self.closest_stats(design, None),
            Metric::Corresponding => {
                // Lengths were checked when the problem was built.
                let stats = corresponding_offsets(&self.shape, design, self.points, &self.params);
                match stats {
                    Ok(s) => (s, self.params.clone()),
                    Err(_) => self.closest_stats(design, None),
                }
            }
        }
    }

    /// True closest-point offsets of the data from `design` (global search, optional warm
    /// starts; anchors play no part).
    #[must_use]
    pub fn closest_stats(
        &self,
        design: &[S::Point],
        warm: Option<&[[f64; K]]>,
    ) -> (OffsetStats<S::Point>, Vec<[f64; K]>) {
        let feet = self.true_feet(design, warm);
        let d2: Vec<f64> = feet.iter().map(|f| f.dist_sq).collect();
        (
            OffsetStats::from_dist_sq(Metric::Closest, &d2, self.points),
            feet.iter().map(|f| f.t).collect(),
        )
    }

    /// This problem as an [`Objective`] over flat design vectors, for the general minimisers.
    #[must_use]
    pub fn objective_fn(&self) -> ProblemObjective<'_, 'a, S, K> {
        ProblemObjective {
            problem: self,
            cache: Vec::new(),
            grad: Vec::new(),
        }
    }
}

/// A [`FitProblem`] seen as an [`Objective`] of the flat design vector; keeps the foot points
/// of the last evaluation as warm starts.
#[derive(Debug)]
pub struct ProblemObjective<'p, 'a, S: Shape<K>, const K: usize> {
    problem: &'p FitProblem<'a, S, K>,
    cache: Vec<[f64; K]>,
    grad: Vec<S::Point>,
}

impl<S: Shape<K>, const K: usize> Objective for ProblemObjective<'_, '_, S, K> {
    fn dim(&self) -> usize {
        self.problem.dim()
    }

    fn value(&mut self, x: &[f64]) -> f64 {
        let design = FitProblem::<S, K>::from_flat(x);
        self.problem.objective(&design, &mut self.cache)
    }

    fn value_grad(&mut self, x: &[f64], grad: &mut [f64]) -> f64 {
        let design = FitProblem::<S, K>::from_flat(x);
        self.grad.resize(design.len(), S::Point::ZERO);
        let v = self
            .problem
            .objective_grad(&design, &mut self.cache, &mut self.grad);
        for (i, p) in self.grad.iter().enumerate() {
            for c in 0..S::Point::DIM {
                grad[i * S::Point::DIM + c] = p.coord(c);
            }
        }
        v
    }
}

impl<'a, P: Vector> FitProblem<'a, CurveShape<P>, 1> {
    /// A chain-fitting problem; every point gets its normalised chord-length parameter (see
    /// [`chord_length_params`]), the first and last points are anchored at `t = 0` and
    /// `t = 1`, the start is the paper's ([`increment_start`]), and the foot-point search
    /// has its default options.
    pub fn curve(layout: ChainLayout, points: &'a [P], metric: Metric) -> Result<Self> {
        Self::curve_with(layout, points, metric, FootOptions::default(), true)
    }

    /// [`FitProblem::curve`] with explicit foot-point options, and the ends anchored or not.
    pub fn curve_with(
        layout: ChainLayout,
        points: &'a [P],
        metric: Metric,
        foot: FootOptions,
        anchor_ends: bool,
    ) -> Result<Self> {
        check_points(points)?;
        let m = layout.design_count();
        if points.len() < m {
            return Err(Error::invalid(format!(
                "{} data points cannot determine {m} design points: at least {m} are needed",
                points.len()
            )));
        }
        let params = chord_length_params(points)?.into_iter().map(|t| [t]).collect();
        let start = increment_start(points, m)?;
        let problem = Self::new(CurveShape::new(layout), points, params, metric, foot)?.with_start(start)?;
        if anchor_ends {
            problem.with_anchors(&[0, points.len() - 1])
        } else {
            Ok(problem)
        }
    }

    /// The chain with the given design points.
    pub fn chain(&self, design: &[P]) -> Result<CurveChain<P>> {
        CurveChain::new(self.shape.layout().clone(), design.to_vec())
    }

    /// The paper's start: design points picked from the data at an even increment.
    pub fn increment_start(&self) -> Result<Vec<P>> {
        increment_start(self.points, self.design_count())
    }
}

impl<'a, P: Vector> FitProblem<'a, GridShape<P>, 2> {
    /// A grid-fitting problem with one `(u, v)` parameter per point and the default foot-point
    /// options (8 samples per patch side).
    pub fn grid(layout: GridLayout, points: &'a [P], params: Vec<[f64; 2]>, metric: Metric) -> Result<Self> {
        let foot = FootOptions {
            samples: 8,
            ..FootOptions::default()
        };
        Self::new(GridShape::new(layout), points, params, metric, foot)
    }

    /// The patch grid with the given design net.
    pub fn patch_grid(&self, design: &[P]) -> Result<PatchGrid<P>> {
        PatchGrid::new(self.shape.layout(), design.to_vec())
    }
}

/// The paper's start for a chain of `count` design points: data points picked at an even
/// increment along the data, `points[round(i (n - 1) / (count - 1))]` for `i = 0 … count - 1`,
/// so the first and last data points are always taken.
pub fn increment_start<P: Vector>(points: &[P], count: usize) -> Result<Vec<P>> {
    check_points(points)?;
    let n = points.len();
    if count < 2 {
        return Err(Error::invalid("a chain has at least two design points"));
    }
    if n < count {
        return Err(Error::invalid(format!(
            "{n} data points cannot provide {count} distinct start points"
        )));
    }
    Ok((0..count)
        .map(|i| points[((i * (n - 1)) as f64 / (count - 1) as f64).round() as usize])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::super::objective::testing::assert_gradient_matches;
    use super::*;
    use crate::chain::Continuity;
    use glam::{DVec2, DVec3};

    fn sample_chain() -> (CurveChain<DVec2>, Vec<DVec2>) {
        let layout = ChainLayout::with_breaks(3, vec![0.0, 0.3, 0.55, 1.0], Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.3, 0.5 * (1.3 * i as f64).sin()))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let pts = (0..50)
            .map(|i| {
                let t = i as f64 / 49.0;
                chain.eval(t) + DVec2::new(0.02 * (9.0 * t).sin(), 0.03 * (11.0 * t).cos())
            })
            .collect();
        (chain, pts)
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let (chain, pts) = sample_chain();
        for metric in [Metric::Closest, Metric::Corresponding] {
            let p = FitProblem::curve(chain.layout().clone(), &pts, metric).unwrap();
            let x = CurveProblem::<DVec2>::to_flat(chain.design());
            assert_gradient_matches(&mut p.objective_fn(), &x, &metric.to_string());
        }
    }

    #[test]
    fn residual_jacobian_matches_finite_differences() {
        let (chain, pts) = sample_chain();
        let p = FitProblem::curve(chain.layout().clone(), &pts, Metric::Closest).unwrap();
        let design = chain.design().to_vec();
        let mut b = Basis::new();
        let h = 1e-6;
        for j in [0, 7, 23, 49] {
            let t = [p.params()[j][0].clamp(0.01, 0.99)];
            let res = p.residual(&design, j, t, &mut b);
            let support = p.shape().support(b.cell).to_vec();
            let phi = b.value.clone();
            // d r / d t
            let mut bb = Basis::new();
            let rp = p.residual(&design, j, [t[0] + h], &mut bb).r;
            let rm = p.residual(&design, j, [t[0] - h], &mut bb).r;
            assert!((res.tangents[0] - (rp - rm) * (0.5 / h)).length() < 1e-7);
            // d r / d x_i for every design point: phi_i on the support, zero elsewhere.
            for i in 0..design.len() {
                let mut dp = design.clone();
                dp[i].y += h;
                let d = (p.residual(&dp, j, t, &mut bb).r - res.r) * (1.0 / h);
                let expect = support
                    .iter()
                    .position(|&s| s as usize == i)
                    .map_or(0.0, |a| phi[a]);
                assert!(
                    (d.y - expect).abs() < 1e-8 && d.x.abs() < 1e-8,
                    "point {j} design {i}"
                );
            }
        }
    }

    #[test]
    fn linear_fit_reproduces_a_chain_sampled_at_its_parameters() {
        let (chain, _) = sample_chain();
        let params: Vec<[f64; 1]> = (0..40).map(|i| [(i as f64 / 39.0).powf(1.3)]).collect();
        let pts: Vec<DVec2> = params.iter().map(|t| chain.eval(t[0])).collect();
        let p = FitProblem::new(
            CurveShape::new(chain.layout().clone()),
            &pts,
            params.clone(),
            Metric::Corresponding,
            FootOptions::default(),
        )
        .unwrap();
        let design = p.linear_fit(&params).unwrap();
        for (a, b) in design.iter().zip(chain.design()) {
            assert!((*a - *b).length() < 1e-11);
        }
        assert!(p.objective(&design, &mut Vec::new()) < 1e-24);
    }

    #[test]
    fn too_few_points_and_bad_input_are_refused() {
        let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
        let pts: Vec<DVec2> = (0..11).map(|i| DVec2::new(i as f64, 0.0)).collect();
        let err = FitProblem::curve(layout.clone(), &pts, Metric::Closest).unwrap_err();
        assert!(matches!(err, Error::Invalid(_)));
        assert!(err.to_string().contains("12 design points"), "{err}");
        let same = vec![DVec2::new(0.5, 0.5); 30];
        assert!(matches!(
            FitProblem::curve(layout.clone(), &same, Metric::Closest),
            Err(Error::Invalid(_))
        ));
        let mut bad: Vec<DVec2> = (0..30).map(|i| DVec2::new(i as f64, 0.0)).collect();
        bad[4].y = f64::INFINITY;
        assert!(FitProblem::curve(layout, &bad, Metric::Closest).is_err());
    }

    #[test]
    fn increment_start_takes_both_ends() {
        let pts: Vec<DVec2> = (0..82).map(|i| DVec2::new(i as f64, 0.0)).collect();
        let s = increment_start(&pts, 12).unwrap();
        assert_eq!(s.len(), 12);
        assert_eq!((s[0].x, s[11].x), (0.0, 81.0));
        assert!(s.windows(2).all(|w| w[1].x > w[0].x));
        assert!(increment_start(&pts[..5], 12).is_err());
    }

    #[test]
    fn grid_gradient_matches_finite_differences() {
        let layout = GridLayout::uniform((2, 2), (2, 2), Continuity::C1).unwrap();
        let (nu, nv) = layout.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|i| {
                let (a, b) = ((i / nv) as f64 / 3.0, (i % nv) as f64 / 3.0);
                DVec3::new(a, b, 0.3 * (2.0 * a + b).sin())
            })
            .collect();
        // Interior points off the surface, and a few beyond its borders (feet clamped there).
        // Points exactly on a border with zero offset are avoided: there the squared distance
        // is only C1 (like max(0, s)²) and central differences are off by O(h).
        let mut params: Vec<[f64; 2]> = (0..64)
            .map(|i| {
                [
                    0.03 + 0.94 * (i / 8) as f64 / 7.0,
                    0.04 + 0.93 * (i % 8) as f64 / 7.0,
                ]
            })
            .collect();
        let grid = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        let mut pts: Vec<DVec3> = params
            .iter()
            .map(|t| grid.eval(t[0], t[1]) + DVec3::new(0.0, 0.0, 0.01 + 0.01 * (t[0] * 13.0).sin()))
            .collect();
        for (t, q) in [
            ([0.0, 0.5], DVec3::new(-0.2, 0.4, 0.1)),
            ([1.0, 0.2], DVec3::new(1.3, 0.3, -0.1)),
        ] {
            params.push(t);
            pts.push(q);
        }
        let p = FitProblem::grid(layout, &pts, params, Metric::Closest).unwrap();
        let x = GridProblem::<DVec3>::to_flat(&design);
        assert_gradient_matches(&mut p.objective_fn(), &x, "grid");
    }

    /// A sectioned cloud off the wavy grid of `grid_gradient_matches_finite_differences`'s
    /// layout: 9 sections at fixed v, 23 points each.
    fn sectioned() -> (GridLayout, Vec<DVec3>, Vec<[f64; 2]>) {
        let u = ChainLayout::with_breaks(3, vec![0.0, 0.3, 0.45, 1.0], Continuity::C2).unwrap();
        let v = ChainLayout::with_breaks(2, vec![0.0, 0.6, 1.0], Continuity::C1).unwrap();
        let layout = GridLayout::new(u, v);
        let mut pts = Vec::new();
        let mut params = Vec::new();
        for k in 0..9 {
            let v = k as f64 / 8.0;
            for i in 0..23 {
                let u = (i as f64 / 22.0).powf(1.3);
                pts.push(DVec3::new(
                    u,
                    (3.0 * u).sin() * (1.0 + v),
                    v + 0.1 * (5.0 * u * v).cos(),
                ));
                params.push([(u + 0.01 * (7.0 * u).sin()).clamp(0.0, 1.0), v]);
            }
        }
        (layout, pts, params)
    }

    #[test]
    fn a_grid_fit_by_section_sums_solves_the_normal_equations() {
        let (layout, pts, params) = sectioned();
        let mut p = FitProblem::grid(layout.clone(), &pts, params.clone(), Metric::Closest).unwrap();
        let w: Vec<f64> = (0..pts.len())
            .map(|j| 1.0 + 0.5 * (j as f64 * 0.37).sin())
            .collect();
        p.set_weights(Some(w.clone())).unwrap();
        let design = p.linear_fit(&params).unwrap();
        // The same least-squares problem, point by point and dense.
        let shape = GridShape::<DVec3>::new(layout);
        let m = shape.design_count();
        let mut a = DMatrix::<f64>::zeros(m, m);
        let mut rhs = DMatrix::<f64>::zeros(m, 3);
        let mut b = Basis::new();
        for (j, (t, q)) in params.iter().zip(&pts).enumerate() {
            shape.basis(*t, 0, &mut b);
            let sup = shape.support(b.cell);
            for (x, &i) in sup.iter().enumerate() {
                for (y, &l) in sup.iter().enumerate() {
                    a[(i as usize, l as usize)] += w[j] * b.value[x] * b.value[y];
                }
                for k in 0..3 {
                    rhs[(i as usize, k)] += w[j] * b.value[x] * q.coord(k);
                }
            }
        }
        let x = a.cholesky().unwrap().solve(&rhs);
        for (i, d) in design.iter().enumerate() {
            let e = DVec3::new(x[(i, 0)], x[(i, 1)], x[(i, 2)]);
            assert!((*d - e).length() < 1e-10, "design point {i}: {d} against {e}");
        }
    }

    #[test]
    fn a_banded_constrained_grid_fit_solves_the_normal_equations_fit_after_fit() {
        // 23 x 13 design points (above BAND_MIN), x and y free, z fixed by a span rule.
        let u = ChainLayout::uniform(3, 20, Continuity::C2).unwrap();
        let v = ChainLayout::uniform(3, 10, Continuity::C2).unwrap();
        let layout = GridLayout::new(u, v);
        let (nu, nv) = layout.design_shape();
        let m = nu * nv;
        assert!(m >= crate::problem::band::BAND_MIN);
        let (mut pts, mut at_breaks, mut inside) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..31 {
            let v = k as f64 / 30.0;
            for i in 0..=60 {
                let u = i as f64 / 60.0;
                pts.push(DVec3::new(
                    (4.0 * u).cos() * (1.0 + v),
                    (4.0 * u).sin() * (1.0 - 0.3 * v),
                    v,
                ));
                // Every third point exactly on a u break: its basis has zeros there.
                at_breaks.push([u, v]);
                inside.push([(u + 0.004 * (9.0 * u).sin()).clamp(0.0, 1.0), v]);
            }
        }
        let span: Vec<f64> = (0..m).map(|i| (i % nv) as f64 / (nv - 1) as f64).collect();
        let con = Constraint::new(vec![
            CoordRule::free(m),
            CoordRule::free(m),
            CoordRule::fixed(span.clone()),
        ]);
        let p = FitProblem::grid(layout.clone(), &pts, at_breaks.clone(), Metric::Closest)
            .unwrap()
            .with_constraint(con)
            .unwrap();
        let shape = GridShape::<DVec3>::new(layout);
        let mut b = Basis::new();
        for params in [&at_breaks, &inside] {
            let design = p.linear_fit(params).unwrap();
            let mut a = DMatrix::<f64>::zeros(m, m);
            let mut rhs = DMatrix::<f64>::zeros(m, 2);
            for (t, q) in params.iter().zip(&pts) {
                shape.basis(*t, 0, &mut b);
                let sup = shape.support(b.cell);
                for (x, &i) in sup.iter().enumerate() {
                    for (y, &l) in sup.iter().enumerate() {
                        a[(i as usize, l as usize)] += b.value[x] * b.value[y];
                    }
                    rhs[(i as usize, 0)] += b.value[x] * q.x;
                    rhs[(i as usize, 1)] += b.value[x] * q.y;
                }
            }
            let x = a.cholesky().unwrap().solve(&rhs);
            for (i, d) in design.iter().enumerate() {
                let e = DVec3::new(x[(i, 0)], x[(i, 1)], span[i]);
                assert!((*d - e).length() < 1e-9, "design point {i}: {d} against {e}");
            }
        }
    }

    #[test]
    fn a_search_along_u_at_held_v_finds_the_grid_search_feet() {
        let (layout, pts, params) = sectioned();
        let p = FitProblem::grid(layout.clone(), &pts, params.clone(), Metric::Closest)
            .unwrap()
            .with_held([false, true]);
        let design = p.linear_fit(&params).unwrap();
        let mut moved = params.clone();
        let (_, max) = p.project_max(&design, &mut moved);
        // The same searches on the grid itself.
        let shape = GridShape::<DVec3>::new(layout);
        let mut b = Basis::new();
        let mut worst = 0.0_f64;
        for ((t, q), got) in params.iter().zip(&pts).zip(&moved) {
            let f = refine_held(
                &shape,
                &design.as_slice(),
                *q,
                *t,
                [false, true],
                p.foot_options(),
                &mut b,
            );
            assert_eq!(got[1], t[1], "v is held");
            assert!((got[0] - f.t[0]).abs() < 1e-9, "{got:?} against {:?}", f.t);
            worst = worst.max(f.dist_sq.sqrt());
        }
        assert!((max - worst).abs() < 1e-12, "{max} against {worst}");
        // The distances at held v, on the rows, are the grid's.
        let grid = PatchGrid::new(shape.layout(), design.clone()).unwrap();
        for ((d, t), q) in p.distances(&design, &moved).iter().zip(&moved).zip(&pts) {
            assert!((d - (grid.eval(t[0], t[1]) - *q).length()).abs() < 1e-12);
        }
    }

    #[test]
    fn large_sums_do_not_depend_on_the_thread_count() {
        let n = 50_000;
        let x: Vec<f64> = (0..n)
            .map(|i| ((i as f64) * 0.73).sin() * 1e-3 + 1.0 / (1.0 + i as f64))
            .collect();
        let sum = || {
            chunked_sum(
                n,
                || 0.0,
                |acc, range| {
                    for j in range {
                        *acc += x[j];
                    }
                },
                |a, b| a + b,
            )
        };
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(sum);
        let three = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap()
            .install(sum);
        assert_eq!(one.to_bits(), three.to_bits());
    }
}
