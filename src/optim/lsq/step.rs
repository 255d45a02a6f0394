//! One Levenberg-Marquardt step: every data point's residual model at its foot point, the
//! design-point system with the foot parameters eliminated blockwise (dense or banded), and
//! its solution for the damped step.

use super::DampingScale;
use crate::bezier::Vector;
use crate::chain::shape::{Basis, Shape};
use crate::closest::{clamp01, free_params, solve_spd, PARALLEL_MIN};
use crate::problem::band::{rcm_order, BandMatrix, BAND_MIN};
use crate::problem::fit_problem::{chunked_sum, FitProblem};
use crate::problem::Constraint;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Per-point quantities of the damped, parameter-eliminated system.
pub(super) struct PointModel<P, const K: usize> {
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
pub(super) fn model_at<S: Shape<K>, const K: usize>(
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
pub(super) struct Normal {
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
pub(super) fn each_entry<S: Shape<K>, const K: usize, F: FnMut(usize, usize, f64) + ?Sized>(
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
pub(super) fn add_diagonal<S: Shape<K>, const K: usize>(shape: &S, normal: &Normal, diag: &mut [f64]) {
    each_entry(shape, normal, &mut |row, col, value| {
        if row == col {
            diag[row] += value;
        }
    });
}

/// Index of the coordinate pair `(c1, c2)`, `c1 <= c2 < dim`, in row-major upper-triangle
/// order.
#[inline]
pub(super) fn pair(c1: usize, c2: usize, dim: usize) -> usize {
    debug_assert!(c1 <= c2 && c2 < dim, "pair: ({c1}, {c2}) not ordered in {dim}");
    c1 * dim - c1 * (c1 + 1) / 2 + c2
}

/// Accumulate the reduced system at `(design, params)` with damping `lambda`.
///
/// Small point sets keep their point models (for the trial step, and for the next assembly):
/// `kept` are those of the last assembly at the same design and parameters, after a rejected
/// step, of which only the damping changes, so no point is evaluated again.
pub(super) fn assemble<S: Shape<K>, const K: usize>(
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
pub(super) struct Models<P, const K: usize> {
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
pub(super) fn solve_step<S: Shape<K>, const K: usize>(
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
pub(super) fn trial_starts<S: Shape<K>, const K: usize>(
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
