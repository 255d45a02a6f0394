//! Closest points (foot points) on chains and patch grids, in f64: the one search that
//! fitting, the offset reports, the evolutionary methods' re-projection, `eval` and the
//! adaptive search all use.
//!
//! **Global seeding.** Every cell (segment or patch) is sampled on a regular grid of
//! [`FootOptions::samples`] intervals per direction ([`SampleGrid`], built once per layout;
//! sampling a design costs one pass). Cells are visited in order of a lower bound of their
//! distance to the data point, and only while that bound is below the best distance found.
//! For patch grids the bound is rigorous: a patch lies within [`Shape::sample_deviation`]
//! of the bilinear interpolant of its samples, so every box between neighbouring samples that
//! could hold a closer point gets a Newton start from its nearest sample (best boxes first, at
//! most 16). For chains the bound is the distance to the samples' bounding box less 1.5
//! sample spacings, and Newton starts from every sample that is a local minimum of its cell
//! and could still be closer (at most 16).
//!
//! **Clamped Newton across cell borders.** [`refine`] runs Newton's method on the squared
//! distance in the *global* parameters `t ∈ [0, 1]^K`, so a step may cross from one segment
//! or patch into the next (the shape is evaluated wherever the step lands); Gauss-Newton
//! where the Hessian is not positive definite, backtracking so that the distance never grows
//! by more than rounding, and each parameter held at 0 or 1 where the distance decreases
//! outwards.
//!
//! **Accuracy contract.**
//! - The result is a point of the shape: [`Foot::dist_sq`] is the squared distance from the
//!   data point to `C(t)` at the returned `t`, evaluated in f64, so it is never below the true
//!   closest distance by more than rounding (about `1e-16` of the coordinates' magnitude).
//! - `t` is a stationary point of the distance (or a bound-held one): Newton stops when a
//!   step moves `t` by less than `1e-15`, or after a full Newton step shorter than `1e-9`
//!   (quadratic convergence puts the next below `1e-15`). At a foot point where the curve
//!   speed is `|C'|`, a parameter error `δ` changes the distance by about `|C'|² δ² / (2 e)`,
//!   far below `1e-12` model units for the shapes fitted here.
//! - It is the global minimum whenever the seeding reaches its basin: always for patch grids
//!   unless more than 16 boxes remain candidates (the rigorous bound), and for chains when
//!   each segment turns by well under a sample spacing's worth of curvature (32 or 48 samples
//!   a segment, the defaults of fitting and reporting). The tests compare with dense scans.
//!
//! [`feet`] is the whole search for many points (on rayon's pool for large sets);
//! [`chain_feet`] and [`grid_feet`] apply it to a [`CurveChain`] or a [`PatchGrid`].

#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

use crate::bezier::Vector;
use crate::chain::shape::{Basis, CurveShape, GridShape, Jet, Shape};
use crate::chain::{CurveChain, PatchGrid};
use rayon::prelude::*;

/// Point counts from which the per-point loops run on rayon's thread pool.
pub(crate) const PARALLEL_MIN: usize = 4096;
/// Points per rayon task.
pub(crate) const CHUNK: usize = 1024;

/// Options of the closest-point search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FootOptions {
    /// Samples per cell and direction in the global search: `samples + 1` parameters per
    /// segment, `(samples + 1)²` per patch. Default 32.
    pub samples: usize,
    /// Newton iterations at most from one start. Default 40.
    pub max_newton: usize,
    /// Newton's method stops before a step that would move the foot point by less than this
    /// along the shape, model units: the foot is found to within it, and the distance to
    /// within its square over the curvature radius. 0 (the default): to rounding.
    pub tolerance: f64,
    /// Backtrack (halve a Newton step until the distance does not grow). Default true. With
    /// false, every refinement ([`refine_held`]) takes only full (clamped) Newton steps that
    /// lower the distance and stops at the first that does not, or once a step moves the
    /// parameter by less than `1e-12`: a conservative parameter correction that keeps each
    /// parameter near its start (still a point of the shape, so never below the true
    /// distance). The adaptive surface search's alternation uses it (see
    /// [`crate::adaptive::adapt_surface`]).
    pub backtrack: bool,
}

impl Default for FootOptions {
    fn default() -> Self {
        FootOptions {
            samples: 32,
            max_newton: 40,
            tolerance: 0.0,
            backtrack: true,
        }
    }
}

/// A foot point: its global parameter and the squared distance to the data point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foot<const K: usize> {
    /// Global parameter of the closest point, in `[0, 1]^K`.
    pub t: [f64; K],
    /// Squared distance from the data point to the shape at `t`.
    pub dist_sq: f64,
}

/// Newton's method stops once a step moves the parameter by less than this.
const PARAM_TOL: f64 = 1e-15;
/// Newton's method also stops after an accepted step shorter than this: convergence is
/// quadratic there, so the next step would be below `1e-15`.
const QUADRATIC_TOL: f64 = 1e-9;

/// Solve `A s = -g` over the coordinates marked `free` (the others get 0) by Cholesky.
/// `None` when `A` restricted to them is not positive definite.
pub(crate) fn solve_spd<const K: usize>(
    a: &[[f64; K]; K],
    g: &[f64; K],
    free: &[bool; K],
) -> Option<[f64; K]> {
    let mut idx = [0usize; K];
    let mut n = 0;
    for (k, &f) in free.iter().enumerate() {
        if f {
            idx[n] = k;
            n += 1;
        }
    }
    let idx = &idx[..n];
    let mut l = [[0.0; K]; K];
    let scale = idx.iter().map(|&k| a[k][k].abs()).fold(0.0, f64::max);
    if !(scale > 0.0) || !scale.is_finite() {
        return None;
    }
    for i in 0..n {
        for j in 0..=i {
            let mut s = a[idx[i]][idx[j]];
            for p in 0..j {
                s -= l[i][p] * l[j][p];
            }
            if i == j {
                if s <= 1e-13 * scale {
                    return None;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    let mut y = [0.0; K];
    for i in 0..n {
        let mut s = -g[idx[i]];
        for p in 0..i {
            s -= l[i][p] * y[p];
        }
        y[i] = s / l[i][i];
    }
    let mut x = [0.0; K];
    for i in (0..n).rev() {
        let mut s = y[i];
        for p in i + 1..n {
            s -= l[p][i] * x[p];
        }
        x[i] = s / l[i][i];
    }
    let mut out = [0.0; K];
    for i in 0..n {
        out[idx[i]] = x[i];
    }
    Some(out)
}

/// [`solve_spd`], with the closed form for two free parameters (patch grids), which is a few
/// times cheaper and accepts the same matrices.
#[inline]
fn solve_newton<const K: usize>(a: &[[f64; K]; K], g: &[f64; K], free: &[bool; K]) -> Option<[f64; K]> {
    if K == 1 && free[0] {
        // solve_spd's arithmetic for one unknown, without its index bookkeeping.
        let a = a[0][0];
        if !(a > 1e-13 * a.abs()) || !a.is_finite() {
            return None;
        }
        let l = a.sqrt();
        let mut x = [0.0; K];
        x[0] = -g[0] / l / l;
        return Some(x);
    }
    if K != 2 || !free.iter().all(|&f| f) {
        return solve_spd(a, g, free);
    }
    let (a00, a01, a10, a11) = (a[0][0], a[0][K - 1], a[K - 1][0], a[K - 1][K - 1]);
    let scale = a00.abs().max(a11.abs());
    if !(scale > 0.0) || !scale.is_finite() {
        return None;
    }
    // Cholesky's pivots: a00 and the Schur complement det / a00.
    let det = a00 * a11 - a01 * a10;
    if a00 <= 1e-13 * scale || det <= 1e-13 * scale * a00 {
        return None;
    }
    let mut x = [0.0; K];
    x[0] = -(a11 * g[0] - a01 * g[K - 1]) / det;
    x[K - 1] = -(a00 * g[K - 1] - a10 * g[0]) / det;
    Some(x)
}

/// Clamp every coordinate to `[0, 1]`.
#[inline]
pub(crate) fn clamp01<const K: usize>(mut t: [f64; K]) -> [f64; K] {
    for x in &mut t {
        *x = x.clamp(0.0, 1.0);
    }
    t
}

/// Which parameters are not held at a bound of `[0, 1]` by a gradient `g` pointing outwards.
#[inline]
pub(crate) fn free_params<const K: usize>(t: &[f64; K], g: &[f64; K]) -> [bool; K] {
    let mut free = [true; K];
    for k in 0..K {
        if (t[k] <= 0.0 && g[k] > 0.0) || (t[k] >= 1.0 && g[k] < 0.0) {
            free[k] = false;
        }
    }
    free
}

/// The local closest point to `q` from the start `t0`: Newton's method on the squared distance
/// (Gauss-Newton where the Hessian is not positive definite), with backtracking so that the
/// distance never grows by more than rounding, and each parameter held at 0 or 1 where the distance
/// decreases outwards. Stops when a step moves the parameter by less than `1e-15`, or after a full
/// Newton step shorter than `1e-9` (the next one would be below `1e-15`).
///
/// `scratch` is working space for [`Shape::eval_jet`].
pub fn refine<S: Shape<K>, const K: usize>(
    shape: &S,
    design: &S::Prepared<'_>,
    q: S::Point,
    t0: [f64; K],
    opts: &FootOptions,
    scratch: &mut Basis<K>,
) -> Foot<K> {
    refine_held(shape, design, q, t0, [false; K], opts, scratch)
}

/// [`refine`] with the parameter directions marked in `held` kept at `t0` (a sectioned
/// cloud's points move along their section only).
pub fn refine_held<S: Shape<K>, const K: usize>(
    shape: &S,
    design: &S::Prepared<'_>,
    q: S::Point,
    t0: [f64; K],
    held: [bool; K],
    opts: &FootOptions,
    scratch: &mut Basis<K>,
) -> Foot<K> {
    let mut t = clamp01(t0);
    let mut jet = shape.jet_at(design, t, 2, scratch);
    let mut r = jet.point - q;
    let mut f = r.length_squared();
    let tol_sq = opts.tolerance * opts.tolerance;
    for _ in 0..opts.max_newton {
        let (g, h, gn) = local_model(&jet, r);
        let mut free = free_params(&t, &g);
        for (f, &h) in free.iter_mut().zip(&held) {
            *f = *f && !h;
        }
        if !free.iter().any(|&x| x) {
            break;
        }
        let (step, gauss_newton) = match solve_newton(&h, &g, &free) {
            Some(s) => (s, false),
            None => match solve_newton(&gn, &g, &free) {
                Some(s) => (s, true),
                None => break,
            },
        };
        let size = step.iter().fold(0.0_f64, |m, s| m.max(s.abs()));
        if !(size > PARAM_TOL) {
            break;
        }
        if tol_sq > 0.0 {
            // |J s|², the squared distance the step would move the foot along the shape.
            let mut moved_sq = 0.0;
            for k in 0..K {
                for l in 0..K {
                    moved_sq += step[k] * gn[k][l] * step[l];
                }
            }
            if moved_sq <= tol_sq {
                break;
            }
        }
        let mut alpha = 1.0;
        let mut moved = 0.0;
        if !opts.backtrack {
            let mut tn = t;
            for k in 0..K {
                tn[k] = (t[k] + step[k]).clamp(0.0, 1.0);
            }
            let jn = shape.jet_at(design, tn, 2, scratch);
            let rn = jn.point - q;
            let fn_ = rn.length_squared();
            if !(fn_ < f) {
                break;
            }
            moved = (0..K).fold(0.0_f64, |m, k| m.max((tn[k] - t[k]).abs()));
            t = tn;
            jet = jn;
            r = rn;
            f = fn_;
            if moved < 1e-12 {
                break;
            }
            continue;
        }
        while alpha * size > PARAM_TOL {
            let mut tn = t;
            for k in 0..K {
                tn[k] = (t[k] + alpha * step[k]).clamp(0.0, 1.0);
            }
            let jn = shape.jet_at(design, tn, 2, scratch);
            let rn = jn.point - q;
            let fn_ = rn.length_squared();
            // Rounding tolerance: near the foot point the squared distance changes by less
            // than its last bits, and a correct Newton step must not be refused for that.
            if fn_ <= f + 4.0 * f64::EPSILON * f {
                moved = (0..K).fold(0.0_f64, |m, k| m.max((tn[k] - t[k]).abs()));
                t = tn;
                jet = jn;
                r = rn;
                f = fn_;
                break;
            }
            alpha *= 0.5;
        }
        // A full Newton step (no backtracking) this short is in the quadratic regime.
        if !(moved > PARAM_TOL) || (alpha == 1.0 && moved < QUADRATIC_TOL && !gauss_newton) {
            break;
        }
    }
    Foot { t, dist_sq: f }
}

/// Gradient `J^T r`, Hessian `J^T J + r · C''` and Gauss-Newton matrix `J^T J` of
/// `|C(t) - q|² / 2`.
#[inline]
fn local_model<P: Vector, const K: usize>(jet: &Jet<P, K>, r: P) -> ([f64; K], [[f64; K]; K], [[f64; K]; K]) {
    let mut g = [0.0; K];
    let mut h = [[0.0; K]; K];
    let mut gn = [[0.0; K]; K];
    for k in 0..K {
        g[k] = jet.d1[k].dot(r);
        for l in 0..K {
            gn[k][l] = jet.d1[k].dot(jet.d1[l]);
            h[k][l] = gn[k][l] + r.dot(jet.d2[k][l]);
        }
    }
    (g, h, gn)
}

/// The sample parameters of a shape (a regular grid in every cell) and their basis values,
/// built once per shape so that sampling a design costs one pass over the samples.
#[derive(Clone, Debug)]
pub struct SampleGrid<const K: usize> {
    /// Samples per direction and cell, plus one.
    side: usize,
    /// Samples per cell, `side^K`.
    per_cell: usize,
    /// Parameter of every sample, cell-major.
    params: Vec<[f64; K]>,
    /// The basis cell of every sample (a sample on a border may belong to the neighbour).
    cells: Vec<u32>,
    /// Start of every sample's basis values in `values`.
    offsets: Vec<usize>,
    values: Vec<f64>,
}

/// The shape sampled at one design: sample positions and, per cell, the longest distance
/// between neighbouring samples (which bounds how much closer than the nearest sample the
/// cell can come to any point) and the bounding box of its samples.
#[derive(Clone, Debug)]
pub struct Sampled<P> {
    positions: Vec<P>,
    spacing: Vec<f64>,
    /// Per cell, the lower and upper corners of the samples' bounding box (`DIM` coordinates).
    bbox: Vec<([f64; 3], [f64; 3])>,
    /// Per cell, the shape's bound on its distance from the samples' multilinear interpolant
    /// ([`Shape::sample_deviation`]); empty when the shape has none.
    dev: Vec<f64>,
    /// With `dev`: per cell, the bounding boxes of the boxes between neighbouring samples
    /// (`(side - 1)^K` per cell, lowest corner's digits in order), and each box's lowest
    /// corner sample.
    boxes: Vec<([f64; 3], [f64; 3], u32)>,
}

/// Squared distance from `q` to the box `[lo, hi]` (first `DIM` coordinates).
#[inline]
fn box_distance_sq<P: Vector>(lo: &[f64; 3], hi: &[f64; 3], q: P) -> f64 {
    let mut d2 = 0.0;
    for c in 0..P::DIM {
        let x = q.coord(c);
        let e = (lo[c] - x).max(x - hi[c]).max(0.0);
        d2 += e * e;
    }
    d2
}

/// Distance from `q` to the box `[lo, hi]` (first `DIM` coordinates).
#[inline]
fn box_distance<P: Vector>(lo: &[f64; 3], hi: &[f64; 3], q: P) -> f64 {
    box_distance_sq(lo, hi, q).sqrt()
}

impl<P: Vector> Sampled<P> {
    /// A lower bound on the distance from `q` to cell `cell`: the distance to the samples'
    /// bounding box less 1.5 sample spacings.
    fn lower_bound(&self, cell: usize, q: P) -> f64 {
        let (lo, hi) = &self.bbox[cell];
        let margin = if self.dev.is_empty() {
            1.5 * self.spacing[cell]
        } else {
            self.dev[cell]
        };
        box_distance(lo, hi, q) - margin
    }
}

impl<const K: usize> SampleGrid<K> {
    /// The sample grid of `shape` with `samples` intervals per cell and direction.
    #[must_use]
    pub fn new<S: Shape<K>>(shape: &S, samples: usize) -> Self {
        let side = samples.max(1) + 1;
        let per_cell = side.pow(K as u32);
        let cells_n = shape.cell_count();
        let mut grid = SampleGrid {
            side,
            per_cell,
            params: Vec::with_capacity(cells_n * per_cell),
            cells: Vec::with_capacity(cells_n * per_cell),
            offsets: Vec::with_capacity(cells_n * per_cell),
            values: Vec::new(),
        };
        let mut b = Basis::new();
        for c in 0..cells_n {
            let (lo, hi) = shape.cell_box(c);
            for s in 0..per_cell {
                let digits = grid.digits(s);
                let mut t = [0.0; K];
                for k in 0..K {
                    let w = digits[k] as f64 / (side - 1) as f64;
                    t[k] = if digits[k] + 1 == side {
                        hi[k]
                    } else {
                        lo[k] + w * (hi[k] - lo[k])
                    };
                }
                shape.basis(t, 0, &mut b);
                grid.params.push(t);
                grid.cells.push(b.cell as u32);
                grid.offsets.push(grid.values.len());
                grid.values.extend_from_slice(&b.value);
            }
        }
        grid
    }

    /// Number of samples.
    #[must_use]
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// True when there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    fn digits(&self, s: usize) -> [usize; K] {
        let mut d = [0; K];
        let mut rest = s;
        for x in &mut d {
            *x = rest % self.side;
            rest /= self.side;
        }
        d
    }

    /// Sample the shape at `design`.
    #[must_use]
    pub fn sample<S: Shape<K>>(&self, shape: &S, design: &[S::Point]) -> Sampled<S::Point> {
        let positions: Vec<S::Point> = (0..self.len())
            .map(|s| {
                let support = shape.support(self.cells[s] as usize);
                let vals = &self.values[self.offsets[s]..self.offsets[s] + support.len()];
                let mut p = S::Point::ZERO;
                for (&i, &w) in support.iter().zip(vals) {
                    p += design[i as usize] * w;
                }
                p
            })
            .collect();
        let mut stride = [1usize; K];
        for k in 1..K {
            stride[k] = stride[k - 1] * self.side;
        }
        let spacing = (0..self.params.len() / self.per_cell)
            .map(|c| {
                let base = c * self.per_cell;
                let mut h: f64 = 0.0;
                for s in 0..self.per_cell {
                    let d = self.digits(s);
                    for k in 0..K {
                        if d[k] + 1 < self.side {
                            let (a, b) = (positions[base + s], positions[base + s + stride[k]]);
                            h = h.max((a - b).length());
                        }
                    }
                }
                h
            })
            .collect();
        let bbox = positions
            .chunks_exact(self.per_cell)
            .map(|cell| {
                let mut lo = [f64::INFINITY; 3];
                let mut hi = [f64::NEG_INFINITY; 3];
                for p in cell {
                    for c in 0..S::Point::DIM {
                        lo[c] = lo[c].min(p.coord(c));
                        hi[c] = hi[c].max(p.coord(c));
                    }
                }
                (lo, hi)
            })
            .collect();
        let cells = self.params.len() / self.per_cell;
        let dev: Vec<f64> = (0..cells)
            .map(|c| shape.sample_deviation(c, design, self.side - 1))
            .collect::<Option<Vec<f64>>>()
            .unwrap_or_default();
        let mut boxes = Vec::new();
        if !dev.is_empty() {
            let per_box = (self.side - 1).pow(K as u32);
            boxes.reserve(cells * per_box);
            for c in 0..cells {
                for bi in 0..per_box {
                    let corner = c * self.per_cell + self.box_corner(bi, &stride);
                    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                    for m in 0..1usize << K {
                        let p = positions[self.corner_sample(corner, m, &stride)];
                        for k in 0..S::Point::DIM {
                            lo[k] = lo[k].min(p.coord(k));
                            hi[k] = hi[k].max(p.coord(k));
                        }
                    }
                    boxes.push((lo, hi, corner as u32));
                }
            }
        }
        Sampled {
            positions,
            spacing,
            bbox,
            dev,
            boxes,
        }
    }

    /// Offset, within its cell, of the lowest corner sample of box `bi` (boxes numbered by the
    /// digits of their lowest corner, each below `side - 1`).
    #[inline]
    fn box_corner(&self, bi: usize, stride: &[usize; K]) -> usize {
        let mut rest = bi;
        let mut off = 0;
        for k in 0..K {
            off += (rest % (self.side - 1)) * stride[k];
            rest /= self.side - 1;
        }
        off
    }

    /// Corner `m` (bit `k` set: one step along direction `k`) of the box whose lowest corner
    /// is sample `corner`.
    #[inline]
    fn corner_sample(&self, corner: usize, m: usize, stride: &[usize; K]) -> usize {
        let mut s = corner;
        for k in 0..K {
            if m >> k & 1 == 1 {
                s += stride[k];
            }
        }
        s
    }

    /// True when no in-cell neighbour of sample `s` is closer than it.
    fn is_local_min(&self, s: usize, d2: &[f64]) -> bool {
        let base = s - s % self.per_cell;
        let d = self.digits(s % self.per_cell);
        let mut stride = 1;
        for k in 0..K {
            if d[k] > 0 && d2[s - stride] < d2[s] {
                return false;
            }
            if d[k] + 1 < self.side && d2[s + stride] < d2[s] {
                return false;
            }
            stride *= self.side;
        }
        debug_assert!(s >= base, "sample index below its cell");
        true
    }

    /// The closest point of the shape to `q`, over the whole domain.
    ///
    /// Newton's method starts from the warm start (when given); then the cells are visited in
    /// order of a lower bound on their distance (distance to the bounding box of their samples
    /// less 1.5 sample spacings), and a cell is measured only while that bound is below the
    /// best distance found. Newton's method then starts from every measured sample that is a
    /// local minimum within its cell and that could still hold a closer point (its distance
    /// less 1.5 sample spacings is below the best). Samples next to the warm start are skipped.
    #[allow(clippy::too_many_arguments)]
    pub fn closest<S: Shape<K>>(
        &self,
        shape: &S,
        sampled: &Sampled<S::Point>,
        design: &S::Prepared<'_>,
        q: S::Point,
        warm: Option<[f64; K]>,
        opts: &FootOptions,
        scratch: &mut FootScratch<K>,
    ) -> Foot<K> {
        let query = Query {
            shape,
            sampled,
            design,
            q,
            warm,
            opts,
        };
        let best = if sampled.dev.is_empty() {
            self.closest_spaced(&query, scratch)
        } else {
            self.closest_bounded(&query, scratch)
        };
        if best.dist_sq.is_finite() {
            best
        } else {
            // A non-finite design: the first sample, never a parameter outside [0, 1].
            Foot {
                t: self.params.first().copied().unwrap_or([0.0; K]),
                ..best
            }
        }
    }

    /// [`SampleGrid::closest`] by sample spacing.
    fn closest_spaced<S: Shape<K>>(&self, query: &Query<S, K>, scratch: &mut FootScratch<K>) -> Foot<K> {
        let (shape, sampled, q, warm) = (query.shape, query.sampled, query.q, query.warm);
        let mut best = query.start(scratch);
        let cells = self.len() / self.per_cell;
        scratch.order.clear();
        scratch
            .order
            .extend((0..cells).map(|c| (sampled.lower_bound(c, q), c)));
        scratch.order.sort_by(|a, b| a.0.total_cmp(&b.0));
        scratch.d2.resize(self.len(), f64::INFINITY);
        scratch.cands.clear();
        // The best sampled distance is an upper bound on the shape's distance as well.
        let mut bound = best.dist_sq.sqrt();
        for oi in 0..scratch.order.len() {
            let (lb, cell) = scratch.order[oi];
            if lb > bound {
                break;
            }
            let range = cell * self.per_cell..(cell + 1) * self.per_cell;
            let mut cell_best = f64::INFINITY;
            for s in range.clone() {
                let d = (sampled.positions[s] - q).length_squared();
                scratch.d2[s] = d;
                if d < cell_best {
                    cell_best = d;
                }
            }
            bound = bound.min(cell_best.sqrt());
            // sqrt(d2) - 1.5 h > bound  <=>  d2 > (bound + 1.5 h)²
            let limit = (bound + 1.5 * sampled.spacing[cell]).powi(2);
            for s in range {
                let ds = scratch.d2[s];
                if ds > limit || !self.is_local_min(s, &scratch.d2) {
                    continue;
                }
                if self.next_to_warm(shape, cell, s, warm) {
                    continue;
                }
                scratch.cands.push((ds, s));
            }
        }
        scratch.cands.sort_by(|a, b| a.0.total_cmp(&b.0));
        for ci in 0..scratch.cands.len().min(16) {
            let (ds, s) = scratch.cands[ci];
            let cell = s / self.per_cell;
            if best.dist_sq.is_finite() && ds.sqrt() - 1.5 * sampled.spacing[cell] > best.dist_sq.sqrt() {
                continue;
            }
            let f = query.refine(self.params[s], scratch);
            if f.dist_sq < best.dist_sq {
                best = f;
            }
        }
        best
    }

    /// [`SampleGrid::closest`] for shapes that bound their distance from the samples'
    /// multilinear interpolant (`dev` per cell, see [`Shape::sample_deviation`]): a cell, and
    /// each box between neighbouring samples in it, is searched only while the distance to
    /// its samples' bounding box, less `dev`, is below the best distance found. Newton's
    /// method starts from the closest sample of every box that passes (best boxes first, at
    /// most 16, boxes next to the warm start skipped). On patch grids whose patches are long
    /// in one direction this bound is far tighter than 1.5 sample spacings.
    fn closest_bounded<S: Shape<K>>(&self, query: &Query<S, K>, scratch: &mut FootScratch<K>) -> Foot<K> {
        let (shape, sampled, q, warm) = (query.shape, query.sampled, query.q, query.warm);
        let mut best = query.start(scratch);
        let cells = self.len() / self.per_cell;
        scratch.order.clear();
        // Only cells that may beat the warm start are visited (usually one to four).
        let mut bound = best.dist_sq.sqrt();
        for c in 0..cells {
            // lb = |q - box| - dev < bound  <=>  |q - box|² < (bound + dev)², no root needed.
            let (lo, hi) = &sampled.bbox[c];
            let reach = bound + sampled.dev[c];
            let d2 = box_distance_sq(lo, hi, q);
            if d2 < reach * reach {
                scratch.order.push((d2.sqrt() - sampled.dev[c], c));
            }
        }
        scratch.order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        scratch.cands.clear();
        let mut stride = [1usize; K];
        for k in 1..K {
            stride[k] = stride[k - 1] * self.side;
        }
        let per_box = (self.side - 1).pow(K as u32);
        for oi in 0..scratch.order.len() {
            let (lb, cell) = scratch.order[oi];
            if lb >= bound {
                break;
            }
            let dev = sampled.dev[cell];
            for &(lo, hi, corner) in &sampled.boxes[cell * per_box..(cell + 1) * per_box] {
                // sqrt(d2) - dev < bound  <=>  d2 < (bound + dev)²
                let reach = bound + dev;
                let d2 = box_distance_sq(&lo, &hi, q);
                if d2 >= reach * reach {
                    continue;
                }
                let (mut near_s, mut near_d) = (corner as usize, f64::INFINITY);
                for m in 0..1usize << K {
                    let s = self.corner_sample(corner as usize, m, &stride);
                    let d = (sampled.positions[s] - q).length_squared();
                    if d < near_d {
                        near_d = d;
                        near_s = s;
                    }
                }
                bound = bound.min(near_d.sqrt());
                if self.next_to_warm(shape, cell, near_s, warm) {
                    continue;
                }
                scratch.cands.push((d2.sqrt() - dev, near_s));
            }
        }
        scratch.cands.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut tried = 0;
        for ci in 0..scratch.cands.len() {
            let (lb, s) = scratch.cands[ci];
            if tried == 16 || (best.dist_sq.is_finite() && lb >= best.dist_sq.sqrt()) {
                break;
            }
            if scratch.cands[..ci].iter().any(|c| c.1 == s) {
                continue;
            }
            tried += 1;
            let f = query.refine(self.params[s], scratch);
            if f.dist_sq < best.dist_sq {
                best = f;
            }
        }
        best
    }

    /// Whether sample `s` of `cell` lies within one sample step of the warm start (Newton's
    /// method from there has already been run).
    fn next_to_warm<S: Shape<K>>(&self, shape: &S, cell: usize, s: usize, warm: Option<[f64; K]>) -> bool {
        let Some(w) = warm else { return false };
        let steps = 1.0 / (self.side - 1) as f64;
        let (lo, hi) = shape.cell_box(cell);
        (0..K).all(|k| (self.params[s][k] - w[k]).abs() <= steps * (hi[k] - lo[k]) * 1.000001)
    }
}

/// One closest-point question: the shape, its samples and prepared design, the point, the
/// warm start and the options.
struct Query<'a, 'd, S: Shape<K> + 'd, const K: usize> {
    shape: &'a S,
    sampled: &'a Sampled<S::Point>,
    design: &'a S::Prepared<'d>,
    q: S::Point,
    warm: Option<[f64; K]>,
    opts: &'a FootOptions,
}

impl<'d, S: Shape<K> + 'd, const K: usize> Query<'_, 'd, S, K> {
    /// Newton's method from the warm start, or no foot (an infinite distance) without one.
    fn start(&self, scratch: &mut FootScratch<K>) -> Foot<K> {
        match self.warm {
            Some(w) => self.refine(w, scratch),
            None => Foot {
                t: [0.0; K],
                dist_sq: f64::INFINITY,
            },
        }
    }

    /// Newton's method from `t0`.
    fn refine(&self, t0: [f64; K], scratch: &mut FootScratch<K>) -> Foot<K> {
        refine(self.shape, self.design, self.q, t0, self.opts, &mut scratch.basis)
    }
}

/// Reusable buffers of the closest-point search.
#[derive(Clone, Debug, Default)]
pub struct FootScratch<const K: usize> {
    /// Basis buffer for Newton's method.
    pub basis: Basis<K>,
    d2: Vec<f64>,
    cands: Vec<(f64, usize)>,
    order: Vec<(f64, usize)>,
}

impl<const K: usize> FootScratch<K> {
    /// Empty buffers.
    #[must_use]
    pub fn new() -> Self {
        FootScratch {
            basis: Basis::new(),
            d2: Vec::new(),
            cands: Vec::new(),
            order: Vec::new(),
        }
    }
}

/// The closest point of every data point on `shape` with design points `design`; `warm`
/// (when given) holds a start parameter per point. Runs on rayon's pool for large point sets.
#[must_use]
pub fn feet<S: Shape<K>, const K: usize>(
    shape: &S,
    design: &[S::Point],
    points: &[S::Point],
    warm: Option<&[[f64; K]]>,
    opts: &FootOptions,
) -> Vec<Foot<K>> {
    let grid = SampleGrid::new(shape, opts.samples);
    let mut out = vec![
        Foot {
            t: [0.0; K],
            dist_sq: 0.0
        };
        points.len()
    ];
    closest_all(shape, &grid, design, points, warm, opts, &mut out);
    out
}

/// The closest point of every data point on `chain` (global parameters).
#[must_use]
pub fn chain_feet<P: Vector>(chain: &CurveChain<P>, points: &[P], opts: &FootOptions) -> Vec<Foot<1>> {
    feet(
        &CurveShape::<P>::new(chain.layout().clone()),
        chain.design(),
        points,
        None,
        opts,
    )
}

/// The closest point of every data point on `grid` (global parameters `(u, v)`).
#[must_use]
pub fn grid_feet<P: Vector>(grid: &PatchGrid<P>, points: &[P], opts: &FootOptions) -> Vec<Foot<2>> {
    feet(
        &GridShape::<P>::new(grid.layout().clone()),
        grid.design(),
        points,
        None,
        opts,
    )
}

/// The closest points of every data point, written to `feet`, with the sample grid built by
/// the caller (kept across designs of one layout); `warm` (when given) holds a start
/// parameter per point. Runs on rayon's pool for large point sets.
#[allow(clippy::too_many_arguments)]
pub fn closest_all<S: Shape<K>, const K: usize>(
    shape: &S,
    grid: &SampleGrid<K>,
    design: &[S::Point],
    points: &[S::Point],
    warm: Option<&[[f64; K]]>,
    opts: &FootOptions,
    feet: &mut [Foot<K>],
) {
    debug_assert_eq!(points.len(), feet.len(), "closest_all: one foot per point");
    let sampled = grid.sample(shape, design);
    let prepared = shape.prepare(design);
    let run = |offset: usize, pts: &[S::Point], out: &mut [Foot<K>]| {
        let mut scratch = FootScratch::new();
        for (j, (q, f)) in pts.iter().zip(out.iter_mut()).enumerate() {
            let w = warm.map(|w| w[offset + j]);
            *f = grid.closest(shape, &sampled, &prepared, *q, w, opts, &mut scratch);
        }
    };
    if points.len() < PARALLEL_MIN {
        run(0, points, feet);
    } else {
        points
            .par_chunks(CHUNK)
            .zip(feet.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (pts, out))| run(c * CHUNK, pts, out));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
    use glam::{DVec2, DVec3};

    fn wavy_chain() -> CurveChain<DVec2> {
        let layout = ChainLayout::uniform(3, 4, Continuity::C1).unwrap();
        let design = (0..layout.design_count())
            .map(|i| DVec2::new(i as f64 * 0.25, 0.4 * (2.1 * i as f64).sin()))
            .collect();
        CurveChain::new(layout, design).unwrap()
    }

    #[test]
    fn closest_matches_a_dense_scan() {
        let chain = wavy_chain();
        let shape = CurveShape::<DVec2>::new(chain.layout().clone());
        let grid = SampleGrid::new(&shape, 16);
        let sampled = grid.sample(&shape, chain.design());
        let mut scratch = FootScratch::new();
        let dense: Vec<DVec2> = (0..=20000).map(|i| chain.eval(i as f64 / 20000.0)).collect();
        for i in 0..60 {
            let q = DVec2::new(-0.3 + i as f64 * 0.05, 0.7 * (i as f64 * 0.9).cos());
            let f = grid.closest(
                &shape,
                &sampled,
                &shape.prepare(chain.design()),
                q,
                None,
                &FootOptions::default(),
                &mut scratch,
            );
            let scan = dense
                .iter()
                .map(|p| (*p - q).length_squared())
                .fold(f64::MAX, f64::min);
            assert!(f.dist_sq <= scan + 1e-15, "q={q}: {} vs scan {scan}", f.dist_sq);
            assert!(f.dist_sq >= scan - 1e-6, "scan is dense enough to be close");
            assert!(((chain.eval(f.t[0]) - q).length_squared() - f.dist_sq).abs() < 1e-15);
            // A warm start from anywhere gives the same answer.
            let w = grid.closest(
                &shape,
                &sampled,
                &shape.prepare(chain.design()),
                q,
                Some([0.93]),
                &FootOptions::default(),
                &mut scratch,
            );
            assert!((w.dist_sq - f.dist_sq).abs() <= 1e-14 * (1.0 + f.dist_sq));
        }
    }

    #[test]
    fn interior_feet_are_orthogonal_and_outside_points_clamp() {
        let chain = wavy_chain();
        let shape = CurveShape::<DVec2>::new(chain.layout().clone());
        let mut b = Basis::new();
        let q = DVec2::new(1.3, 0.9);
        let f = refine(
            &shape,
            &shape.prepare(chain.design()),
            q,
            [0.6],
            &FootOptions::default(),
            &mut b,
        );
        if f.t[0] > 0.0 && f.t[0] < 1.0 {
            let r = chain.eval(f.t[0]) - q;
            let d = chain.deriv(f.t[0]);
            assert!(
                r.dot(d).abs() < 1e-12 * r.length() * d.length(),
                "t={} r={r} d={d} dot={}",
                f.t[0],
                r.dot(d)
            );
        }
        // Far beyond the first point along the reversed tangent: the foot is t = 0.
        let p0 = chain.eval(0.0);
        let q = p0 - chain.deriv(0.0) * 3.0;
        let grid = SampleGrid::new(&shape, 16);
        let sampled = grid.sample(&shape, chain.design());
        let mut scratch = FootScratch::new();
        let opts = FootOptions::default();
        let f = grid.closest(
            &shape,
            &sampled,
            &shape.prepare(chain.design()),
            q,
            Some([0.2]),
            &opts,
            &mut scratch,
        );
        assert_eq!(f.t[0], 0.0);
        assert!((f.dist_sq - (p0 - q).length_squared()).abs() < 1e-12);
    }

    #[test]
    fn surface_feet_recover_the_sampling_parameters() {
        let layout = GridLayout::uniform((3, 2), (2, 2), Continuity::C1).unwrap();
        let design: Vec<DVec3> =
            layout.design_from(|a, b| DVec3::new(a, b, 0.2 * (3.0 * a).sin() * (2.0 * b).cos()));
        let grid_surface = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        let shape = GridShape::<DVec3>::new(layout);
        let grid = SampleGrid::new(&shape, 6);
        let sampled = grid.sample(&shape, &design);
        let mut scratch = FootScratch::new();
        for i in 0..10 {
            for j in 0..10 {
                let t = [0.05 + 0.1 * i as f64, 0.03 + 0.1 * j as f64];
                let q = grid_surface.eval(t[0], t[1]);
                let f = grid.closest(
                    &shape,
                    &sampled,
                    &shape.prepare(&design),
                    q,
                    None,
                    &FootOptions::default(),
                    &mut scratch,
                );
                assert!(f.dist_sq < 1e-26, "{t:?}: {}", f.dist_sq);
                assert!((f.t[0] - t[0]).abs() < 1e-9 && (f.t[1] - t[1]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn spd_solve_respects_fixed_coordinates() {
        let a = [[4.0, 1.0], [1.0, 3.0]];
        let g = [1.0, 2.0];
        let s = solve_spd(&a, &g, &[true, true]).unwrap();
        assert!((4.0 * s[0] + s[1] + 1.0).abs() < 1e-15 && (s[0] + 3.0 * s[1] + 2.0).abs() < 1e-15);
        let s = solve_spd(&a, &g, &[false, true]).unwrap();
        assert_eq!(s[0], 0.0);
        assert!((s[1] + 2.0 / 3.0).abs() < 1e-15);
        assert!(solve_spd(&[[1.0, 2.0], [2.0, 1.0]], &g, &[true, true]).is_none());
    }

    #[test]
    fn bounded_grid_search_matches_a_dense_scan() {
        // A thin, curved, folded-over strip (like a blade's trailing edge): points near both
        // sheets, with and without warm starts from the wrong sheet.
        let layout = GridLayout::new(
            ChainLayout::with_breaks(3, vec![0.0, 0.2, 0.5, 0.8, 1.0], Continuity::C1).unwrap(),
            ChainLayout::uniform(3, 3, Continuity::C1).unwrap(),
        );
        let design: Vec<DVec3> = layout.design_from(|a, b| {
            let ang = std::f64::consts::PI * 1.9 * a;
            DVec3::new(0.5 * ang.cos() + 0.1 * b, 0.05 * ang.sin(), 3.0 * b)
        });
        let surface = PatchGrid::new(layout.clone(), design.clone()).unwrap();
        let shape = GridShape::<DVec3>::new(layout);
        let grid = SampleGrid::new(&shape, 8);
        let sampled = grid.sample(&shape, &design);
        assert!(!sampled.dev.is_empty(), "grids bound their deviation");
        let dense: Vec<([f64; 2], DVec3)> = (0..=400)
            .flat_map(|i| (0..=60).map(move |j| [i as f64 / 400.0, j as f64 / 60.0]))
            .map(|t| (t, surface.eval(t[0], t[1])))
            .collect();
        let mut scratch = FootScratch::new();
        let opts = FootOptions::default();
        for k in 0..80 {
            let t = [(k as f64 * 0.6180339).fract(), (k as f64 * 0.41421).fract()];
            let (p, pu, pv) = surface.partials(t[0], t[1]);
            let n = pu.cross(pv).normalize();
            let q = p + n * (0.004 * ((k % 7) as f64 - 3.0));
            for warm in [None, Some(t), Some([1.0 - t[0], t[1]])] {
                let f = grid.closest(
                    &shape,
                    &sampled,
                    &shape.prepare(&design),
                    q,
                    warm,
                    &opts,
                    &mut scratch,
                );
                let scan = dense
                    .iter()
                    .map(|(_, x)| (*x - q).length_squared())
                    .fold(f64::MAX, f64::min);
                assert!(
                    f.dist_sq <= scan + 1e-14,
                    "q {q} warm {warm:?}: {} vs scan {scan}",
                    f.dist_sq
                );
            }
        }
    }
}
