//! The closest-point least-squares fit: Levenberg-Marquardt over the design points and every
//! data point's foot-point parameters together, the parameters eliminated blockwise.
//!
//! The unknowns are the design points `x` (`m` points, `D` coordinates) and one parameter
//! `t_j ∈ [0, 1]^K` per data point; the residuals are `r_j = C(t_j) - q_j`. Each `t_j` touches
//! only its own residual, so the damped normal equations
//!
//! ```text
//! [ Jxᵀ Jx + λ Dx    Jxᵀ Jt       ] [dx]     [Jxᵀ r]
//! [ Jtᵀ Jx           Jtᵀ Jt + λ Dt] [dt] = - [Jtᵀ r]
//! ```
//!
//! have a block-diagonal lower-right part (a `K x K` block `M_j = T_jᵀ T_j` per point, `T_j`
//! the tangents; `Dx`, `Dt` are the diagonals of `Jxᵀ Jx` and `Jtᵀ Jt`, Marquardt's scaling).
//! Eliminating it leaves an `mD x mD` system
//!
//! ```text
//! S = Σ_j (a_j a_jᵀ) ⊗ P_j + λ Dx,   b = Σ_j a_j ⊗ (P_j r_j),   P_j = I - T_j (M_j + λ Dt_j)⁻¹ T_jᵀ,
//! ```
//!
//! with `a_j` the basis of point `j` over the design points; then `dx = -S⁻¹ b` and
//! `dt_j = -(M_j + λ Dt_j)⁻¹ T_jᵀ (r_j + Σ_i a_ji dx_i)`. Building `S` costs `O(n)` (each
//! point adds a small block over its cell's support, `rayon` splits large point sets);
//! solving it costs `O((mD)³)`, independent of `n`. With `λ → 0`, `P_j` projects onto the
//! normal space: the step is the tangent-distance step of Wang, Pottmann and Liu (2006), which
//! converges where the alternation of a linear solve and a foot-point projection (Hoschek's
//! parameter correction, [`alternate`]) crawls.
//!
//! The step's `dt` only starts Newton's method for the exact local foot points on the trial
//! design: the trial is judged by the true sum of squared distances. At convergence a global
//! foot-point search checks that no data point has a closer foot point elsewhere on the
//! shape; if one has, the iteration goes on from there.
//!
//! On aerofoils the closest-point objective has long, flat, curved valleys (design points
//! can slide along the shape while the offsets barely change; the reduced system's condition
//! number reaches 1e8) and many local minima. The iteration walks such valleys in tens to
//! hundreds of steps, and stops when ten iterations together gain less than `ftol`.
//!
//! Tried and left out: the residuals' second-order terms (a Newton model of the
//! closest-point objective) and geodesic acceleration (Transtrum and Sethna 2012). On the
//! paper's cases both took about as many iterations and more often stopped in a worse local
//! minimum.

use super::report::{SolveReport, StopReason};
use crate::bezier::Vector;
use crate::chain::shape::{Basis, Shape};
use crate::closest::{clamp01, free_params, solve_spd, PARALLEL_MIN};
use crate::error::{Error, Result};
use crate::problem::band::{rcm_order, BandMatrix, BAND_MIN};
use crate::problem::fit_problem::{chunked_sum, FitProblem};
use crate::problem::offset::Metric;
use crate::problem::Constraint;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::time::Instant;

/// Options of the Levenberg-Marquardt fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsqOptions {
    /// Most iterations (steps tried, accepted or not). Default 300.
    pub max_iterations: usize,
    /// Converged when the last 10 iterations together lowered the sum of squares by less
    /// than this fraction of it. Default 1e-7.
    pub ftol: f64,
    /// Converged when an accepted step moves no design coordinate by more than this fraction
    /// of the data extent. Default 1e-13.
    pub xtol: f64,
    /// Initial damping `λ`, relative to the diagonal of the normal equations (Marquardt's
    /// scaling). A large value makes the first steps short, gradient-like ones, which on the
    /// aerofoil files led to better local minima than bold first steps. Default 10.
    pub initial_damping: f64,
    /// How often a global foot-point search may restart the iteration after convergence, when
    /// it finds closer foot points elsewhere on the shape. Default 3.
    pub global_checks: usize,
    /// Iterations over which the `ftol` test measures the decrease. Default 10: on aerofoils
    /// the iteration crosses flat stretches of a valley where single steps gain little.
    pub window: usize,
    /// Smallest ratio of the actual to the predicted decrease of the sum of squares for a step
    /// to be accepted. Default 1e-4.
    pub accept_ratio: f64,
    /// `[down, up]`: the damping is divided by `down` (not below 1e-12) after an accepted step
    /// and multiplied by `up` after a rejected one; `None`, the default, is Nielsen's update
    /// (down by up to 3 as the model predicted well, up by 2, 4, 8, ... in a row).
    pub damping_factors: Option<[f64; 2]>,
    /// What the damping `λ` scales. Default [`DampingScale::Jacobian`].
    pub damping_scale: DampingScale,
    /// The method. Default [`LsqMethod::Joint`].
    pub method: LsqMethod,
}

/// Marquardt's scaling of the damping term `λ D` of the design step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DampingScale {
    /// `D` is the diagonal of `Jxᵀ W Jx`, the design points' own weight in the data (the same
    /// for every coordinate of a point). The default.
    #[default]
    Jacobian,
    /// `D` is the diagonal of the reduced normal matrix (after the parameters are eliminated),
    /// one per unknown: a direction that the data pin only along the shape is damped less.
    /// The adaptive search's short, warm-started fits converge on it as its own engine did.
    Reduced,
}

impl Default for LsqOptions {
    fn default() -> Self {
        LsqOptions {
            max_iterations: 300,
            ftol: 1e-7,
            xtol: 1e-13,
            initial_damping: 10.0,
            global_checks: 3,
            window: 10,
            accept_ratio: 1e-4,
            damping_factors: None,
            damping_scale: DampingScale::Jacobian,
            method: LsqMethod::Joint,
        }
    }
}

/// How [`lsq`] iterates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LsqMethod {
    /// Levenberg-Marquardt over the design and the parameters together (see the module docs).
    #[default]
    Joint,
    /// Hoschek's parameter correction, the baseline the joint method replaces: each iteration
    /// is a linear least-squares solve at fixed parameters, then a projection of every
    /// parameter to its local foot point. `max_iterations` rounds at most; only the observer
    /// stops it earlier.
    Alternate,
}

/// The result of a least-squares fit.
#[derive(Clone, Debug, PartialEq)]
pub struct LsqFit<P, const K: usize> {
    /// The fitted design points.
    pub design: Vec<P>,
    /// The parameter of every data point at the end (foot points for the closest-point
    /// metric, fixed parameters for anchored points and the corresponding-points metric).
    pub params: Vec<[f64; K]>,
    /// The objective `Σ_j |C(t_j) - q_j|²` at those parameters, in squared model units.
    pub sum_sq: f64,
    /// Iterations, evaluations, time, stop reason.
    pub report: SolveReport,
}

/// Per-point quantities of the damped, parameter-eliminated system.
struct PointModel<P, const K: usize> {
    r: P,
    tangents: [P; K],
    /// `T_kᵀ r`.
    g: [f64; K],
    /// Diagonal of `M = Tᵀ T`, the scale of the parameters' damping.
    m_diag: [f64; K],
    /// `(M + λ diag M)⁻¹` on the free parameters, zero elsewhere.
    m_inv: [[f64; K]; K],
}

impl<P: Vector, const K: usize> PointModel<P, K> {
    /// The model of a point with residual `r` and tangents `T` at parameter `t`. Parameters
    /// held at a bound by an outward gradient, with a degenerate tangent, or anchored, are
    /// fixed (their rows of `M⁻¹` are zero).
    fn new(r: P, tangents: [P; K], t: &[f64; K], lambda: f64, anchored: bool, held: [bool; K]) -> Self {
        let mut g = [0.0; K];
        let mut m = [[0.0; K]; K];
        for k in 0..K {
            g[k] = tangents[k].dot(r);
            for l in 0..K {
                m[k][l] = tangents[k].dot(tangents[l]);
            }
        }
        let mut free = if anchored { [false; K] } else { free_params(t, &g) };
        for (f, &h) in free.iter_mut().zip(&held) {
            *f = *f && !h;
        }
        let mut m_diag = [0.0; K];
        for k in 0..K {
            m_diag[k] = m[k][k];
            if !(m[k][k] > 0.0) || !m[k][k].is_finite() {
                free[k] = false;
            }
            m[k][k] *= 1.0 + lambda;
        }
        let mut m_inv = [[0.0; K]; K];
        // Two free parameters (patch grids): the closed-form inverse, with solve_spd's test
        // for positive definiteness; a tenth of the cost of two Cholesky solves.
        if K == 2 && free.iter().all(|&f| f) {
            let (a, b, d) = (m[0][K - 1], m[K - 1][0], m[K - 1][K - 1]);
            let a00 = m[0][0];
            let scale = a00.abs().max(d.abs());
            let det = a00 * d - a * b;
            if a00 > 1e-13 * scale && det > 1e-13 * scale * a00 && scale.is_finite() {
                m_inv[0][0] = d / det;
                m_inv[0][K - 1] = -a / det;
                m_inv[K - 1][0] = -b / det;
                m_inv[K - 1][K - 1] = a00 / det;
            }
            return PointModel {
                r,
                tangents,
                g,
                m_diag,
                m_inv,
            };
        }
        for l in 0..K {
            if !free[l] {
                continue;
            }
            let mut e = [0.0; K];
            e[l] = -1.0;
            match solve_spd(&m, &e, &free) {
                Some(col) => {
                    for k in 0..K {
                        m_inv[k][l] = col[k];
                    }
                }
                None => {
                    m_inv = [[0.0; K]; K];
                    break;
                }
            }
        }
        PointModel {
            r,
            tangents,
            g,
            m_diag,
            m_inv,
        }
    }

    /// `P = I - T M⁻¹ Tᵀ` as a `D x D` matrix (D ≤ 3).
    fn projector(&self) -> [[f64; 3]; 3] {
        let dim = P::DIM;
        let mut p = [[0.0; 3]; 3];
        for (c, row) in p.iter_mut().enumerate().take(dim) {
            row[c] = 1.0;
        }
        for k in 0..K {
            for l in 0..K {
                let w = self.m_inv[k][l];
                if w == 0.0 {
                    continue;
                }
                for (c1, row) in p.iter_mut().enumerate().take(dim) {
                    let tk = self.tangents[k].coord(c1) * w;
                    for (c2, x) in row.iter_mut().enumerate().take(dim) {
                        *x -= tk * self.tangents[l].coord(c2);
                    }
                }
            }
        }
        p
    }

    /// `dt = -M⁻¹ Tᵀ (r + jx)` for the design step's displacement `jx` of this point.
    fn param_step(&self, jx: P) -> [f64; K] {
        let mut rhs = [0.0; K];
        for k in 0..K {
            rhs[k] = self.g[k] + self.tangents[k].dot(jx);
        }
        let mut dt = [0.0; K];
        for k in 0..K {
            for l in 0..K {
                dt[k] -= self.m_inv[k][l] * rhs[l];
            }
        }
        dt
    }
}

/// The model of data point `j` at parameter `t`, leaving the basis (with first derivatives)
/// in `b`.
fn model_at<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    (prepared, design): (&S::Prepared<'_>, &[S::Point]),
    j: usize,
    t: &[f64; K],
    lambda: f64,
    b: &mut Basis<K>,
) -> PointModel<S::Point, K> {
    let res = problem.residual_at(prepared, design, j, *t, b);
    PointModel::new(
        res.r,
        res.tangents,
        t,
        lambda,
        problem.is_anchored(j),
        problem.held(),
    )
}

/// The reduced normal equations, accumulated per cell over the cell's support.
///
/// The cell's block of `S` is `Σ_j (a_j a_jᵀ) ⊗ P_j`; it is kept as one `s x s` matrix
/// `G_c1c2 = Σ_j P_j[c1][c2] a_j a_jᵀ` per coordinate pair `c1 ≤ c2` (`s` the support size),
/// so each point adds `D (D + 1) / 2` rank-one updates, of their lower triangles only (every
/// `G` is symmetric, and the lower triangle of `S` is all its factorisation reads).
struct Normal {
    /// Per cell, the `D (D + 1) / 2` matrices `G_c1c2`, each row-major `s x s`, pairs in the
    /// order of [`pair`]: cell `c` at `blocks[at[c].0..]`.
    blocks: Vec<f64>,
    /// Per cell, `s D`, at `rhs[at[c].1..]`.
    rhs: Vec<f64>,
    /// Per cell, `Σ a_i²` per support point (the undamped diagonal of `Jxᵀ Jx`), at
    /// `diag[at[c].2..]`.
    diag: Vec<f64>,
    /// Per cell, its support size and the starts of its parts in the three buffers.
    at: Vec<(usize, usize, usize, usize)>,
}

impl Normal {
    fn new<S: Shape<K>, const K: usize>(shape: &S) -> Self {
        let dim = S::Point::DIM;
        let pairs = dim * (dim + 1) / 2;
        let mut at = Vec::with_capacity(shape.cell_count());
        let (mut b, mut r, mut d) = (0, 0, 0);
        for c in 0..shape.cell_count() {
            let s = shape.support(c).len();
            at.push((s, b, r, d));
            b += pairs * s * s;
            r += s * dim;
            d += s;
        }
        Normal {
            blocks: vec![0.0; b],
            rhs: vec![0.0; r],
            diag: vec![0.0; d],
            at,
        }
    }

    /// Cell `c`'s blocks, right-hand side and diagonal.
    fn cell(&self, c: usize, dim: usize) -> (&[f64], &[f64], &[f64]) {
        let (s, b, r, d) = self.at[c];
        let pairs = dim * (dim + 1) / 2;
        (
            &self.blocks[b..b + pairs * s * s],
            &self.rhs[r..r + s * dim],
            &self.diag[d..d + s],
        )
    }

    /// [`Normal::cell`], to fill.
    fn cell_mut(&mut self, c: usize, dim: usize) -> (&mut [f64], &mut [f64], &mut [f64]) {
        let (s, b, r, d) = self.at[c];
        let pairs = dim * (dim + 1) / 2;
        (
            &mut self.blocks[b..b + pairs * s * s],
            &mut self.rhs[r..r + s * dim],
            &mut self.diag[d..d + s],
        )
    }

    /// Add point model `pm` with weight `w`, its basis `values` over cell `cell`'s support.
    fn add<P: Vector, const K: usize>(&mut self, pm: &PointModel<P, K>, cell: usize, values: &[f64], w: f64) {
        // The supports of chains (2 to 8 design points) as constants: the short loops over
        // them unroll (the same operations in the same order).
        match values.len() {
            2 => self.add_sized::<P, K, 2>(pm, cell, values, w),
            3 => self.add_sized::<P, K, 3>(pm, cell, values, w),
            4 => self.add_sized::<P, K, 4>(pm, cell, values, w),
            5 => self.add_sized::<P, K, 5>(pm, cell, values, w),
            6 => self.add_sized::<P, K, 6>(pm, cell, values, w),
            7 => self.add_sized::<P, K, 7>(pm, cell, values, w),
            8 => self.add_sized::<P, K, 8>(pm, cell, values, w),
            _ => self.add_sized::<P, K, 0>(pm, cell, values, w),
        }
    }

    /// [`Normal::add`] for a support of `N` design points (`N = 0`: any).
    #[inline(always)]
    fn add_sized<P: Vector, const K: usize, const N: usize>(
        &mut self,
        pm: &PointModel<P, K>,
        cell: usize,
        values: &[f64],
        w: f64,
    ) {
        let dim = P::DIM;
        let s = if N > 0 { N } else { values.len() };
        let values = &values[..s];
        let mut proj = pm.projector();
        if w != 1.0 {
            proj.iter_mut().flatten().for_each(|x| *x *= w);
        }
        let mut pr = [0.0; 3];
        for (c1, x) in pr.iter_mut().enumerate().take(dim) {
            *x = (0..dim).map(|c2| proj[c1][c2] * pm.r.coord(c2)).sum();
        }
        let (block, rhs, diag) = self.cell_mut(cell, dim);
        let (rhs, diag) = (&mut rhs[..s * dim], &mut diag[..s]);
        for (a, &wa) in values.iter().enumerate() {
            diag[a] += w * wa * wa;
            for c1 in 0..dim {
                rhs[a * dim + c1] += wa * pr[c1];
            }
        }
        for c1 in 0..dim {
            for c2 in c1..dim {
                let w = proj[c1][c2];
                if w == 0.0 {
                    continue;
                }
                let g = &mut block[pair(c1, c2, dim) * s * s..(pair(c1, c2, dim) + 1) * s * s];
                // G is symmetric in the support indices: its lower triangle is kept.
                for a in 0..s {
                    let wa = w * values[a];
                    for (x, &wb) in g[a * s..=a * s + a].iter_mut().zip(values) {
                        *x += wa * wb;
                    }
                }
            }
        }
    }

    fn merge(mut self, other: Normal) -> Normal {
        let add = |a: &mut Vec<f64>, b: Vec<f64>| a.iter_mut().zip(b).for_each(|(p, q)| *p += q);
        add(&mut self.blocks, other.blocks);
        add(&mut self.rhs, other.rhs);
        add(&mut self.diag, other.diag);
        self
    }
}

/// Calls `add(row, col, value)` for every entry of the cells' blocks (flat design indices).
#[inline]
fn each_entry<S: Shape<K>, const K: usize, F: FnMut(usize, usize, f64) + ?Sized>(
    shape: &S,
    normal: &Normal,
    add: &mut F,
) {
    let dim = S::Point::DIM;
    for cell in 0..shape.cell_count() {
        let support = shape.support(cell);
        let n = support.len();
        let block = normal.cell(cell, dim).0;
        for (a, &ia) in support.iter().enumerate() {
            for c1 in 0..dim {
                let row = ia as usize * dim + c1;
                for (bb, &ib) in support.iter().enumerate() {
                    for c2 in 0..dim {
                        // G_c1c2 is symmetric in the support indices (its lower triangle is
                        // kept), and P in the coordinates.
                        let g = pair(c1.min(c2), c1.max(c2), dim);
                        let (hi, lo) = (a.max(bb), a.min(bb));
                        add(row, ib as usize * dim + c2, block[g * n * n + hi * n + lo]);
                    }
                }
            }
        }
    }
}

/// Adds the diagonal of `S` to `diag` (flat design indices): of the entries [`each_entry`]
/// visits, those of a support point's coordinate with itself, in the same order.
fn add_diagonal<S: Shape<K>, const K: usize>(shape: &S, normal: &Normal, diag: &mut [f64]) {
    let dim = S::Point::DIM;
    for cell in 0..shape.cell_count() {
        let support = shape.support(cell);
        let n = support.len();
        let block = normal.cell(cell, dim).0;
        for (a, &ia) in support.iter().enumerate() {
            for c in 0..dim {
                diag[ia as usize * dim + c] += block[pair(c, c, dim) * n * n + a * n + a];
            }
        }
    }
}

/// Index of the coordinate pair `(c1, c2)`, `c1 <= c2 < dim`, in row-major upper-triangle
/// order.
#[inline]
fn pair(c1: usize, c2: usize, dim: usize) -> usize {
    debug_assert!(c1 <= c2 && c2 < dim, "pair: ({c1}, {c2}) not ordered in {dim}");
    c1 * dim - c1 * (c1 + 1) / 2 + c2
}

/// Accumulate the reduced system at `(design, params)` with damping `lambda`.
///
/// Small point sets keep their point models (for the trial step, and for the next assembly):
/// `kept` are those of the last assembly at the same design and parameters, after a rejected
/// step, of which only the damping changes, so no point is evaluated again.
fn assemble<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: &[S::Point],
    params: &[[f64; K]],
    lambda: f64,
    kept: Option<Models<S::Point, K>>,
) -> (Normal, Option<Models<S::Point, K>>) {
    let shape = problem.shape();
    if params.len() < PARALLEL_MIN {
        let models = match kept {
            Some(mut m) => {
                m.damp(problem, params, lambda);
                m
            }
            None => Models::new(problem, design, params, lambda),
        };
        let mut normal = Normal::new(shape);
        for (j, pm) in models.models.iter().enumerate() {
            normal.add(pm, models.cells[j] as usize, models.values(j), problem.weight(j));
        }
        return (normal, Some(models));
    }
    let prepared = shape.prepare(design);
    let (normal, _) = chunked_sum(
        params.len(),
        || (Normal::new(shape), Basis::new()),
        |(acc, b), range| {
            for j in range {
                let pm = model_at(problem, (&prepared, design), j, &params[j], lambda, b);
                acc.add(&pm, b.cell, &b.value, problem.weight(j));
            }
        },
        |a, b| (a.0.merge(b.0), a.1),
    );
    (normal, None)
}

/// The per-point models of one assembly, kept for the trial step of small point sets (the
/// same numbers [`trial_starts`] would compute again) and for the assembly after a rejected
/// step.
struct Models<P, const K: usize> {
    models: Vec<PointModel<P, K>>,
    cells: Vec<u32>,
    /// Basis values of point `j`: `values[offsets[j - 1]..offsets[j]]` (from 0 for `j = 0`).
    values: Vec<f64>,
    offsets: Vec<u32>,
}

impl<P: Vector, const K: usize> Models<P, K> {
    /// The model of every point at `(design, params)` with damping `lambda`.
    fn new<S: Shape<K, Point = P>>(
        problem: &FitProblem<'_, S, K>,
        design: &[P],
        params: &[[f64; K]],
        lambda: f64,
    ) -> Self {
        let shape = problem.shape();
        let prepared = shape.prepare(design);
        let (n, s) = (params.len(), shape.support(0).len());
        let mut m = Models {
            models: Vec::with_capacity(n),
            cells: Vec::with_capacity(n),
            values: Vec::with_capacity(n * s),
            offsets: Vec::with_capacity(n),
        };
        let mut b = Basis::new();
        for (j, t) in params.iter().enumerate() {
            m.models
                .push(model_at(problem, (&prepared, design), j, t, lambda, &mut b));
            m.cells.push(b.cell as u32);
            m.values.extend_from_slice(&b.value);
            m.offsets.push(m.values.len() as u32);
        }
        m
    }

    /// The same models at damping `lambda` (only `M⁻¹` depends on it).
    fn damp<S: Shape<K, Point = P>>(
        &mut self,
        problem: &FitProblem<'_, S, K>,
        params: &[[f64; K]],
        lambda: f64,
    ) {
        for (j, pm) in self.models.iter_mut().enumerate() {
            *pm = PointModel::new(
                pm.r,
                pm.tangents,
                &params[j],
                lambda,
                problem.is_anchored(j),
                problem.held(),
            );
        }
    }

    /// The basis values of point `j` over its cell's support.
    fn values(&self, j: usize) -> &[f64] {
        let from = if j == 0 { 0 } else { self.offsets[j - 1] as usize };
        &self.values[from..self.offsets[j] as usize]
    }
}

/// Assemble the reduced matrix, damp it and solve for the design step: dense for small
/// systems, in band form for large ones (patch grids with many patches, whose matrix couples
/// each design point only with its neighbours). Returns the step and the floored diagonal
/// `Dx`, or `None` when the system is not positive definite.
fn solve_step<S: Shape<K>, const K: usize>(
    shape: &S,
    normal: &Normal,
    lambda: f64,
    constraint: Option<&Constraint>,
    scale: DampingScale,
) -> Option<(Vec<S::Point>, f64)> {
    let dim = S::Point::DIM;
    let m = shape.design_count();
    let nn = m * dim;
    let mut dx = vec![0.0; m];
    let mut b = vec![0.0; nn];
    // Largest index distance between design points that share a cell, in points.
    let mut reach = 0;
    for cell in 0..shape.cell_count() {
        let support = shape.support(cell);
        if let (Some(&lo), Some(&hi)) = (support.iter().min(), support.iter().max()) {
            reach = reach.max((hi - lo) as usize);
        }
        for (a, &ia) in support.iter().enumerate() {
            dx[ia as usize] += normal.cell(cell, dim).2[a];
            for c1 in 0..dim {
                b[ia as usize * dim + c1] += normal.cell(cell, dim).1[a * dim + c1];
            }
        }
    }
    // Design points no data point depends on get a tiny diagonal so the system stays regular;
    // their step is then zero.
    let floor = 1e-12 * dx.iter().fold(0.0_f64, |a, &b| a.max(b)).max(f64::MIN_POSITIVE);
    for v in &mut dx {
        *v = v.max(floor);
    }
    // With the reduced scaling: the matrix's own diagonal (zeros get the mean), per unknown.
    let scaled = |diag: &mut dyn FnMut(usize) -> f64, n: usize| -> Vec<f64> {
        let d: Vec<f64> = (0..n).map(&mut *diag).collect();
        let mean = d.iter().sum::<f64>() / n.max(1) as f64;
        d.into_iter().map(|x| if x > 0.0 { x } else { mean }).collect()
    };
    let mut sdiag = vec![0.0; nn];
    if scale == DampingScale::Reduced && constraint.is_none() {
        add_diagonal(shape, normal, &mut sdiag);
        sdiag = scaled(&mut |k| sdiag[k], nn);
    }
    // The damping of flat design variable k.
    let damp = |k: usize| match scale {
        DampingScale::Jacobian => dx[k / dim],
        DampingScale::Reduced => sdiag[k],
    };
    let band = (reach + 1) * dim - 1;
    let mut damping_term = None;
    let x: Vec<f64> = if let Some(con) = constraint {
        // Within the constraint the step is `A dz`: (Aᵀ S A + λ Dz) dz = -Aᵀ b, with `Dz` the
        // design damping carried over to the unknowns.
        let nz = con.unknowns();
        let rows = con.flat_rows();
        let mut sz = DMatrix::<f64>::zeros(nz, nz);
        let mut bz = DVector::<f64>::zeros(nz);
        let mut dz_scale = vec![0.0; nz];
        for r in 0..nn {
            for &(a, wa) in &rows[r] {
                bz[a] -= wa * b[r];
                dz_scale[a] += wa * wa * dx[r / dim];
            }
        }
        // Only the lower triangle (with the diagonal) is summed: all the factorisation and
        // the damping read.
        let flat = sz.as_mut_slice();
        each_entry(shape, normal, &mut |r, c, v| {
            if v != 0.0 {
                for &(a, wa) in &rows[r] {
                    let wv = wa * v;
                    for &(z, wz) in &rows[c] {
                        if z <= a {
                            // Column-major: entry (a, z).
                            flat[a + z * nz] += wv * wz;
                        }
                    }
                }
            }
        });
        if scale == DampingScale::Reduced {
            dz_scale = scaled(&mut |a| sz[(a, a)], nz);
        }
        for (a, &d) in dz_scale.iter().enumerate() {
            sz[(a, a)] += lambda * d;
        }
        let dz = sz.cholesky()?.solve(&bz);
        damping_term = Some(lambda * dz.iter().zip(&dz_scale).map(|(x, d)| d * x * x).sum::<f64>());
        (0..nn)
            .map(|r| rows[r].iter().map(|&(a, w)| w * dz[a]).sum())
            .collect()
    } else if nn >= BAND_MIN && band < nn / 2 {
        // Reorder the design points (reverse Cuthill-McKee) when that narrows the band: the
        // factorisation costs O(n b²).
        let order = rcm_order(m, (0..shape.cell_count()).map(|c| shape.support(c)));
        let mut pos: Vec<usize> = vec![0; m];
        for (k, &i) in order.iter().enumerate() {
            pos[i as usize] = k;
        }
        let reach_rcm = (0..shape.cell_count())
            .map(|c| {
                let (lo, hi) = shape.support(c).iter().fold((usize::MAX, 0), |(lo, hi), &i| {
                    (lo.min(pos[i as usize]), hi.max(pos[i as usize]))
                });
                hi.saturating_sub(lo)
            })
            .max()
            .unwrap_or(0);
        if reach_rcm >= reach {
            pos = (0..m).collect();
        }
        let band = (reach.min(reach_rcm) + 1) * dim - 1;
        let at = |row: usize| pos[row / dim] * dim + row % dim;
        let mut s = BandMatrix::zeros(nn, band);
        each_entry(shape, normal, &mut |r, c, v| {
            let (r, c) = (at(r), at(c));
            if c <= r {
                s.add_lower(r, c, v);
            }
        });
        for i in 0..m {
            for c in 0..dim {
                let k = pos[i] * dim + c;
                s.add_lower(k, k, lambda * damp(i * dim + c));
            }
        }
        let mut y = vec![0.0; nn];
        for (row, v) in b.iter().enumerate() {
            y[at(row)] = -v;
        }
        s.cholesky()?.solve_in_place(&mut y);
        (0..nn).map(|row| y[at(row)]).collect()
    } else {
        let mut s = DMatrix::<f64>::zeros(nn, nn);
        // The lower triangle, all the factorisation reads (column-major: (r, c) at r + c nn).
        let flat = s.as_mut_slice();
        each_entry(shape, normal, &mut |r, c, v| {
            if c <= r {
                flat[r + c * nn] += v;
            }
        });
        for i in 0..m {
            for c in 0..dim {
                s[(i * dim + c, i * dim + c)] += lambda * damp(i * dim + c);
            }
        }
        let x = s.cholesky()?.solve(&(-DVector::from_vec(b)));
        x.as_slice().to_vec()
    };
    if x.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let step: Vec<S::Point> = x.chunks_exact(dim).map(S::Point::from_coords).collect();
    // The damping term `λ δᵀ D δ` of the predicted decrease.
    let damping_term = damping_term.unwrap_or_else(|| match scale {
        DampingScale::Jacobian => step
            .iter()
            .zip(&dx)
            .map(|(d, w)| lambda * w * d.length_squared())
            .sum(),
        DampingScale::Reduced => lambda * x.iter().zip(&sdiag).map(|(v, d)| d * v * v).sum::<f64>(),
    });
    Some((step, damping_term))
}

/// The trial of a design step: every parameter's start `t + dt` and the predicted decrease of
/// the linear model, `-gᵀδ + λ δᵀ D δ` over design points and parameters.
#[allow(clippy::too_many_arguments)]
fn trial_starts<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: &[S::Point],
    params: &[[f64; K]],
    step: &[S::Point],
    damping_term: f64,
    lambda: f64,
    models: Option<&Models<S::Point, K>>,
) -> (Vec<[f64; K]>, f64) {
    let shape = problem.shape();
    // The kept models, or (without them) the prepared design every point is evaluated on.
    let source = models.ok_or_else(|| shape.prepare(design));
    let per_point = |b: &mut Basis<K>, j: usize| -> ([f64; K], f64) {
        let computed;
        let (pm, cell, values) = match &source {
            Ok(m) => (&m.models[j], m.cells[j] as usize, m.values(j)),
            Err(prepared) => {
                computed = model_at(problem, (prepared, design), j, &params[j], lambda, b);
                (&computed, b.cell, &b.value[..])
            }
        };
        let mut jx = S::Point::ZERO;
        for (&i, &w) in shape.support(cell).iter().zip(values) {
            jx += step[i as usize] * w;
        }
        let dt = pm.param_step(jx);
        let mut pred = -pm.r.dot(jx);
        let mut t = params[j];
        for k in 0..K {
            pred += -pm.g[k] * dt[k] + lambda * pm.m_diag[k] * dt[k] * dt[k];
            t[k] += dt[k];
        }
        (clamp01(t), problem.weight(j) * pred)
    };
    let n = params.len();
    let out: Vec<([f64; K], f64)> = if n < PARALLEL_MIN {
        let mut b = Basis::new();
        (0..n).map(|j| per_point(&mut b, j)).collect()
    } else {
        (0..n).into_par_iter().map_init(Basis::new, per_point).collect()
    };
    let mut pred = damping_term;
    let starts = out
        .into_iter()
        .map(|(t, p)| {
            pred += p;
            t
        })
        .collect();
    (starts, pred)
}

/// A test of a design and its parameters that the fit keeps true once it holds (see
/// [`LsqHooks::guard`]).
pub type Guard<'g, P, const K: usize> = &'g (dyn Fn(&[P], &[[f64; K]]) -> bool + Sync);

/// An observer of every iteration (the iterate, the current design and parameters), and of
/// the start (iteration 0); returning false stops the fit (reason
/// [`StopReason::MaxIterations`]).
pub type Observer<'o, P, const K: usize> = &'o mut dyn FnMut(&LsqIterate, &[P], &[[f64; K]]) -> bool;

/// What a caller may hook into [`lsq`].
pub struct LsqHooks<'h, P, const K: usize> {
    /// Once the guard holds, every step after which it would no longer hold is rejected (a
    /// barrier: the fit stays in the region the guard admits, e.g. chains that do not fold
    /// back on themselves). From a start where it fails, steps are taken freely until it
    /// holds. Joint method only.
    pub guard: Option<Guard<'h, P, K>>,
    /// Called after every iteration. With an observer, several starts run one after another.
    pub observe: Option<Observer<'h, P, K>>,
}

impl<P, const K: usize> Default for LsqHooks<'_, P, K> {
    fn default() -> Self {
        LsqHooks {
            guard: None,
            observe: None,
        }
    }
}

/// The state after one iteration, for progress reports and observers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsqIterate {
    /// Iterations so far (steps tried).
    pub iteration: usize,
    /// The (weighted) sum of squares at the current design, in squared model units.
    pub sum_sq: f64,
    /// The largest distance of any data point at the current design and parameters, model
    /// units.
    pub max: f64,
    /// The damping `λ` for the next step (0 for the alternating method).
    pub lambda: f64,
    /// True when this iteration's step was accepted.
    pub accepted: bool,
}

/// Where a least-squares fit starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Start<P, const K: usize> {
    /// One parameter per data point; the design is the linear least-squares fit at them.
    Params(Vec<[f64; K]>),
    /// A design, with one parameter per data point from which the local foot points are
    /// found.
    Design(Vec<P>, Vec<[f64; K]>),
    /// A design with its local foot points already found (the result of an earlier fit):
    /// taken as they are.
    Feet(Vec<P>, Vec<[f64; K]>),
}

/// The least-squares fit of `problem` from each of `starts`, one fit per start, in order
/// (several starts run in parallel unless an observer is hooked).
///
/// For the closest-point metric each start is followed by the method of `opts`:
/// Levenberg-Marquardt over the design and the parameters together ([`LsqMethod::Joint`],
/// see the module docs) or Hoschek's alternation ([`LsqMethod::Alternate`]). Anchored points
/// keep the problem's parameters whatever the start says. For the corresponding-points metric
/// the parameters are fixed and one linear solve at the problem's parameters is exact: one
/// fit, whatever the starts. [`LsqFit::best`] picks the lowest sum of squares.
pub fn lsq<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    starts: &[Start<S::Point, K>],
    opts: &LsqOptions,
    hooks: LsqHooks<'_, S::Point, K>,
) -> Result<Vec<LsqFit<S::Point, K>>> {
    let clock = Instant::now();
    if problem.metric() == Metric::Corresponding {
        let params = problem.params().to_vec();
        let design = problem.linear_fit(&params)?;
        let sum_sq = problem.sum_sq_at(&design, &params);
        return Ok(vec![LsqFit {
            design,
            params,
            sum_sq,
            report: SolveReport {
                iterations: 1,
                evaluations: 1,
                seconds: clock.elapsed().as_secs_f64(),
                stop: StopReason::Exact,
            },
        }]);
    }
    if starts.is_empty() {
        return Err(Error::invalid("lsq: at least one start is needed"));
    }
    let n = problem.points().len();
    // Anchored points keep the problem's parameters whatever the start says.
    let own = |t: &[[f64; K]]| -> Result<Vec<[f64; K]>> {
        if t.len() != n {
            return Err(Error::invalid(format!(
                "lsq: a start has {} parameters for {n} data points",
                t.len()
            )));
        }
        Ok(t.iter()
            .enumerate()
            .map(|(j, &t)| {
                if problem.is_anchored(j) {
                    problem.params()[j]
                } else {
                    clamp01(t)
                }
            })
            .collect())
    };
    let guard = hooks.guard;
    let run =
        |start: &Start<S::Point, K>, observe: Observer<'_, S::Point, K>| -> Result<LsqFit<S::Point, K>> {
            let (design, params, projected) = match start {
                Start::Params(t) => (None, own(t)?, false),
                Start::Design(x, t) => (Some(x.clone()), own(t)?, false),
                Start::Feet(x, t) => (Some(x.clone()), own(t)?, true),
            };
            match opts.method {
                LsqMethod::Joint => {
                    let design = match design {
                        Some(x) => x,
                        None => problem.linear_fit(&params)?,
                    };
                    levenberg_marquardt(problem, design, params, projected, opts, guard, observe)
                }
                LsqMethod::Alternate => alternate(problem, design, params, opts, observe),
            }
        };
    match hooks.observe {
        Some(observe) => starts.iter().map(|s| run(s, &mut *observe)).collect(),
        None if starts.len() == 1 => Ok(vec![run(&starts[0], &mut |_, _, _| true)?]),
        None => starts.par_iter().map(|s| run(s, &mut |_, _, _| true)).collect(),
    }
}

impl<P, const K: usize> LsqFit<P, K> {
    /// The fit with the least sum of squares (the first on ties), its report carrying the
    /// summed iterations and evaluations of all; `None` for no fits.
    #[must_use]
    pub fn best(fits: Vec<Self>) -> Option<Self> {
        pick(fits, |a, b| a.sum_sq < b.sum_sq)
    }
}

/// Levenberg-Marquardt on the design points and the data points' parameters together, from
/// `design` and `params` (see the module docs), under `guard`, calling `observe` after every
/// iteration.
#[allow(clippy::too_many_arguments)]
fn levenberg_marquardt<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: Vec<S::Point>,
    params: Vec<[f64; K]>,
    projected: bool,
    opts: &LsqOptions,
    guard: Option<Guard<'_, S::Point, K>>,
    observe: Observer<'_, S::Point, K>,
) -> Result<LsqFit<S::Point, K>> {
    let clock = Instant::now();
    if design.len() != problem.design_count() || params.len() != problem.points().len() {
        return Err(Error::invalid(format!(
            "levenberg_marquardt: {} design points and {} parameters given, the problem needs {} and {}",
            design.len(),
            params.len(),
            problem.design_count(),
            problem.points().len()
        )));
    }
    let (mut design, mut params) = (design, params);
    // Below this sum of squares the data lie on the shape to rounding.
    let tiny = (f64::EPSILON * problem.extent()).powi(2) * problem.points().len() as f64;
    let mut evaluations = 1;
    let mut iterations = 0;
    let (mut phi, mut max) = if projected {
        let d = problem.distances(&design, &params);
        let phi = d.iter().enumerate().map(|(j, e)| problem.weight(j) * e * e).sum();
        (phi, d.iter().fold(0.0_f64, |m, &e| m.max(e)))
    } else {
        problem.project_max(&design, &mut params)
    };
    let admits = |d: &[S::Point], t: &[[f64; K]]| guard.is_none_or(|g| g(d, t));
    let mut feasible = admits(&design, &params);
    let mut lambda = opts.initial_damping;
    let mut nu = 2.0;
    // The sum of squares after every iteration, for the windowed convergence test.
    let window = opts.window.max(1);
    let mut history = vec![phi];
    let mut checks = 0;
    // The point models at the current design and parameters, while no step has moved them.
    let mut kept = None;
    let start = LsqIterate {
        iteration: 0,
        sum_sq: phi,
        max,
        lambda,
        accepted: false,
    };
    let stop = loop {
        if iterations == 0 && !observe(&start, &design, &params) {
            break StopReason::MaxIterations;
        }
        let mut done = None;
        if phi <= tiny {
            done = Some(StopReason::Converged);
        } else if iterations >= opts.max_iterations {
            break StopReason::MaxIterations;
        } else {
            iterations += 1;
            let (normal, models) = assemble(problem, &design, &params, lambda, kept.take());
            let mut accepted = false;
            let solved = solve_step(
                problem.shape(),
                &normal,
                lambda,
                problem.constraint(),
                opts.damping_scale,
            );
            if let Some((step, damping_term)) = solved {
                let (starts, pred) = trial_starts(
                    problem,
                    &design,
                    &params,
                    &step,
                    damping_term,
                    lambda,
                    models.as_ref(),
                );
                let trial: Vec<S::Point> = design.iter().zip(&step).map(|(&x, &d)| x + d).collect();
                let mut trial_params = starts;
                let (phi_trial, max_trial) = problem.project_max(&trial, &mut trial_params);
                evaluations += 1;
                let rho = (phi - phi_trial) / pred;
                let trial_feasible = || admits(&trial, &trial_params);
                if pred > 0.0
                    && phi_trial.is_finite()
                    && rho > opts.accept_ratio
                    && (!feasible || trial_feasible())
                {
                    feasible = feasible || trial_feasible();
                    accepted = true;
                    let moved = step.iter().fold(0.0_f64, |m, d| m.max(d.max_abs()));
                    design = trial;
                    params = trial_params;
                    // Nielsen's update: shrink the damping by up to 3 when the model was good.
                    match opts.damping_factors {
                        Some([down, _]) => lambda = (lambda / down).max(1e-12),
                        None => lambda *= (1.0 - (2.0 * rho.min(1.0) - 1.0).powi(3)).max(1.0 / 3.0),
                    }
                    nu = 2.0;
                    phi = phi_trial;
                    max = max_trial;
                    if moved <= opts.xtol * problem.extent() {
                        done = Some(StopReason::Converged);
                    }
                }
            }
            if !accepted {
                kept = models;
                match opts.damping_factors {
                    Some([_, up]) => lambda *= up,
                    None => {
                        lambda *= nu;
                        nu *= 2.0;
                    }
                }
                if lambda > 1e16 {
                    done = Some(StopReason::NoProgress);
                }
            }
            history.push(phi);
            if history.len() > window && history[history.len() - 1 - window] - phi <= opts.ftol * phi {
                done = done.or(Some(StopReason::Converged));
            }
            let state = LsqIterate {
                iteration: iterations,
                sum_sq: phi,
                max,
                lambda,
                accepted,
            };
            if !observe(&state, &design, &params) && done.is_none() {
                break StopReason::MaxIterations;
            }
        }
        if let Some(reason) = done {
            if problem.metric() == Metric::Closest && checks < opts.global_checks && phi > tiny {
                let feet = problem.feet(&design, Some(&params));
                evaluations += 1;
                let phi_global: f64 = feet
                    .iter()
                    .enumerate()
                    .map(|(j, f)| problem.weight(j) * f.dist_sq)
                    .sum();
                if phi_global < phi * (1.0 - 1e-9) {
                    checks += 1;
                    params = feet.iter().map(|f| f.t).collect();
                    phi = phi_global;
                    max = feet.iter().fold(0.0_f64, |m, f| m.max(f.dist_sq)).sqrt();
                    history.clear();
                    history.push(phi);
                    lambda = opts.initial_damping;
                    nu = 2.0;
                    kept = None;
                    continue;
                }
            }
            break reason;
        }
    };
    Ok(LsqFit {
        design,
        params,
        sum_sq: phi,
        report: SolveReport {
            iterations,
            evaluations,
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    })
}

/// The fit that `better` prefers (the first on ties), its report carrying the summed
/// iterations and evaluations of all.
pub(crate) fn pick<F, T>(fits: Vec<T>, better: F) -> Option<T>
where
    F: Fn(&T, &T) -> bool,
    T: HasReport,
{
    let (mut iterations, mut evaluations) = (0, 0);
    let mut best: Option<T> = None;
    for fit in fits {
        iterations += fit.report().iterations;
        evaluations += fit.report().evaluations;
        if best.as_ref().is_none_or(|b| better(&fit, b)) {
            best = Some(fit);
        }
    }
    best.map(|mut b| {
        b.report_mut().iterations = iterations;
        b.report_mut().evaluations = evaluations;
        b
    })
}

/// Access to a result's solver report.
pub(crate) trait HasReport {
    /// The report.
    fn report(&self) -> &SolveReport;
    /// The report, to amend.
    fn report_mut(&mut self) -> &mut SolveReport;
}

impl<P, const K: usize> HasReport for LsqFit<P, K> {
    fn report(&self) -> &SolveReport {
        &self.report
    }
    fn report_mut(&mut self) -> &mut SolveReport {
        &mut self.report
    }
}

/// Hoschek's parameter correction (the baseline the joint method replaces): rounds of a
/// linear least-squares solve at fixed parameters and a projection of every parameter to its
/// local foot point, from `design` (projected first) or the linear fit at `params`, at most
/// `opts.max_iterations` rounds. Returns the last design with its foot points and sum of
/// squares.
fn alternate<S: Shape<K>, const K: usize>(
    problem: &FitProblem<'_, S, K>,
    design: Option<Vec<S::Point>>,
    mut params: Vec<[f64; K]>,
    opts: &LsqOptions,
    observe: Observer<'_, S::Point, K>,
) -> Result<LsqFit<S::Point, K>> {
    let clock = Instant::now();
    let rounds = opts.max_iterations.max(1);
    let (mut design, mut iterations, mut evaluations) = match design {
        Some(x) => (x, 0, 1),
        None => (problem.linear_fit(&params)?, 1, 0),
    };
    let (mut sum_sq, mut max) = problem.project_max(&design, &mut params);
    let mut stop = StopReason::MaxIterations;
    loop {
        let state = LsqIterate {
            iteration: iterations,
            sum_sq,
            max,
            lambda: 0.0,
            accepted: true,
        };
        if !observe(&state, &design, &params) {
            break;
        }
        if iterations >= rounds {
            break;
        }
        design = problem.linear_fit(&params)?;
        (sum_sq, max) = problem.project_max(&design, &mut params);
        iterations += 1;
        evaluations += 1;
        if !sum_sq.is_finite() {
            stop = StopReason::NoProgress;
            break;
        }
    }
    Ok(LsqFit {
        design,
        params,
        sum_sq,
        report: SolveReport {
            iterations,
            evaluations: evaluations.max(1),
            seconds: clock.elapsed().as_secs_f64(),
            stop,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
    use crate::problem::CurveProblem;
    use glam::{DVec2, DVec3};

    /// The fit from the problem's own parameters.
    fn own<S: Shape<K>, const K: usize>(p: &FitProblem<'_, S, K>, opts: &LsqOptions) -> LsqFit<S::Point, K> {
        lsq(
            p,
            &[Start::Params(p.params().to_vec())],
            opts,
            LsqHooks::default(),
        )
        .unwrap()
        .remove(0)
    }

    #[test]
    fn recovers_a_chain_from_points_sampled_off_its_chord_length_parameters() {
        let layout = ChainLayout::uniform(3, 4, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.2, 0.3 * (1.1 * i as f64).sin()))
            .collect();
        let chain = CurveChain::new(layout.clone(), design).unwrap();
        // Uneven sampling, so the chord-length start is off and the parameters must move.
        let pts: Vec<DVec2> = (0..120)
            .map(|i| chain.eval((i as f64 / 119.0).powf(1.4)))
            .collect();
        let p = CurveProblem::curve(layout, &pts, Metric::Closest).unwrap();
        let fit = own(&p, &LsqOptions::default());
        assert!(fit.sum_sq < 1e-24, "sum_sq {}", fit.sum_sq);
        let (stats, _) = p.stats(&fit.design);
        assert!(stats.max < 1e-12, "max {}", stats.max);
        assert!(fit.report.converged());
        for (a, b) in fit.design.iter().zip(chain.design()) {
            assert!((*a - *b).length() < 1e-9, "{a} vs {b}");
        }
    }

    #[test]
    fn the_joint_step_beats_alternation_on_noisy_data() {
        let layout = ChainLayout::uniform(3, 3, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.25, 0.4 * (0.9 * i as f64).cos()))
            .collect();
        let chain = CurveChain::new(layout.clone(), design).unwrap();
        let pts: Vec<DVec2> = (0..90)
            .map(|i| {
                let t = (i as f64 / 89.0).powf(0.7);
                chain.eval(t) + DVec2::new(1e-3 * (37.0 * t).sin(), 1e-3 * (23.0 * t).cos())
            })
            .collect();
        let p = CurveProblem::curve(layout, &pts, Metric::Closest).unwrap();
        let joint = own(&p, &LsqOptions::default());
        let slow = own(
            &p,
            &LsqOptions {
                method: LsqMethod::Alternate,
                max_iterations: 50,
                ..LsqOptions::default()
            },
        );
        assert_eq!(slow.report.iterations, 50);
        assert!(joint.report.converged());
        assert!(joint.sum_sq < slow.sum_sq, "{} vs {}", joint.sum_sq, slow.sum_sq);
        // The optimum is stationary: the gradient of the objective (a sum of `2 φ_i r_j`
        // terms) is tiny next to the size of its terms, `2 Σ |r_j|`.
        let mut g = vec![DVec2::ZERO; joint.design.len()];
        let mut cache = Vec::new();
        p.objective_grad(&joint.design, &mut cache, &mut g);
        let gmax = g.iter().map(|v| v.max_abs()).fold(0.0, f64::max);
        let scale = 2.0 * p.stats(&joint.design).0.sum;
        assert!(gmax < 1e-6 * scale, "gradient {gmax} against {scale}");
    }

    #[test]
    fn recovers_a_patch_grid_from_a_cloud_with_perturbed_parameters() {
        let layout = GridLayout::uniform((3, 3), (2, 2), Continuity::C1).unwrap();
        let design: Vec<DVec3> =
            layout.design_from(|a, b| DVec3::new(a, b, 0.2 * (2.5 * a).sin() * (1.5 * b + 0.3).cos()));
        let grid = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        // A 25 x 25 cloud sampled on the grid; the fit starts from parameters off by up to 0.02
        // and must recover the surface and the sampling parameters.
        let mut pts = Vec::new();
        let mut params = Vec::new();
        for i in 0..25 {
            for j in 0..25 {
                let (u, v) = (i as f64 / 24.0, j as f64 / 24.0);
                pts.push(grid.eval(u, v));
                let wobble = 0.02 * ((7 * i + 3 * j) as f64).sin();
                params.push([(u + wobble).clamp(0.0, 1.0), (v - wobble).clamp(0.0, 1.0)]);
            }
        }
        let corners = [0, 24, 600, 624];
        for &c in &corners {
            params[c] = [(c / 25) as f64 / 24.0, (c % 25) as f64 / 24.0];
        }
        let p = FitProblem::grid(layout, &pts, params, Metric::Closest)
            .unwrap()
            .with_anchors(&corners)
            .unwrap();
        let fit = own(&p, &LsqOptions::default());
        assert!(fit.sum_sq < 1e-20, "sum_sq {}", fit.sum_sq);
        let fitted = p.patch_grid(&fit.design).unwrap();
        assert!(fitted.continuity_error() < 1e-9);
        let (stats, _) = p.stats(&fit.design);
        assert!(stats.max < 1e-10, "max {}", stats.max);
    }
}
