//! `ExtractionMap`: the sparse linear map from design points to expanded Bezier control points.
//!
//! A chain of degree `d` with `Ck` joins is a B-spline whose interior knots (the breaks) have
//! multiplicity `d - k`; its control points are the design points. Inserting every interior
//! knot up to multiplicity `d` (Boehm) yields the Bezier control points of each segment. The
//! map depends only on `(d, breaks, k)`, so it is built once, by running the insertion on the
//! unit basis vectors, and stored in compressed-row form.

use crate::bezier::Vector;

/// Sparse `rows x cols` matrix `E` with `expanded = E · design`, one row per expanded point.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtractionMap {
    cols: usize,
    /// Row `r` holds entries `start[r] .. start[r + 1]`.
    start: Vec<usize>,
    index: Vec<u32>,
    weight: Vec<f64>,
}

/// Weights below this are rounding noise of the knot insertion and are dropped.
const WEIGHT_EPS: f64 = 1e-14;

impl ExtractionMap {
    /// The map of a chain of `degree` over `breaks` whose interior knots (the breaks) start at
    /// the multiplicities `knots` gives them: every interior knot is raised to multiplicity
    /// `degree` by Boehm's insertion, run on the unit basis vectors.
    pub(crate) fn for_knots(degree: usize, breaks: &[f64], knots: &[f64]) -> Self {
        let p = degree;
        let mut knots = knots.to_vec();
        let cols = knots.len() - p - 1;
        let rows = (breaks.len() - 1) * p + 1;
        // Each control point as its dense weights over the design points, row-major in one
        // buffer with room for every row the insertions add.
        let mut pts = vec![0.0; rows * cols];
        for i in 0..cols {
            pts[i * cols + i] = 1.0;
        }
        let mut count = cols;
        let mut row = vec![0.0; cols];
        for &b in &breaks[1..breaks.len() - 1] {
            let mult = knots.iter().filter(|&&x| x == b).count();
            for _ in mult..p {
                // Boehm's insertion (as `insert_knot`), rows shifted in place from the back.
                let k = knots.partition_point(|&x| x <= b) - 1;
                let m = knots.iter().filter(|&&x| x == b).count();
                for i in (0..=count).rev() {
                    if i + p <= k {
                        break;
                    }
                    if i + m > k {
                        pts.copy_within((i - 1) * cols..i * cols, i * cols);
                    } else {
                        let a = (b - knots[i]) / (knots[i + p] - knots[i]);
                        for (j, x) in row.iter_mut().enumerate() {
                            *x = (1.0 - a) * pts[(i - 1) * cols + j] + a * pts[i * cols + j];
                        }
                        pts[i * cols..(i + 1) * cols].copy_from_slice(&row);
                    }
                }
                knots.insert(k + 1, b);
                count += 1;
            }
        }
        debug_assert_eq!(count, rows, "Bezier extraction produced the wrong count");
        let mut map = ExtractionMap {
            cols,
            start: vec![0],
            index: Vec::new(),
            weight: Vec::new(),
        };
        for row in pts.chunks_exact(cols) {
            for (j, &w) in row.iter().enumerate() {
                if w.abs() > WEIGHT_EPS {
                    map.index.push(j as u32);
                    map.weight.push(w);
                }
            }
            map.start.push(map.index.len());
        }
        map
    }

    /// A map from explicit rows of `(design index, weight)` entries.
    #[must_use]
    pub fn from_rows(cols: usize, rows: &[Vec<(usize, f64)>]) -> Self {
        let mut map = ExtractionMap {
            cols,
            start: vec![0],
            index: Vec::new(),
            weight: Vec::new(),
        };
        for row in rows {
            for &(j, w) in row {
                debug_assert!(j < cols, "extraction entry column {j} out of range {cols}");
                map.index.push(j as u32);
                map.weight.push(w);
            }
            map.start.push(map.index.len());
        }
        map
    }

    /// Number of expanded points (rows).
    #[must_use]
    pub fn rows(&self) -> usize {
        self.start.len() - 1
    }

    /// Number of design points (columns).
    #[must_use]
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of stored entries.
    #[must_use]
    pub fn nnz(&self) -> usize {
        self.index.len()
    }

    /// Row `r` as parallel slices of design indices and weights.
    #[must_use]
    pub fn row(&self, r: usize) -> (&[u32], &[f64]) {
        let range = self.start[r]..self.start[r + 1];
        (&self.index[range.clone()], &self.weight[range])
    }

    /// The compressed-row arrays `(start, index, weight)`, for upload to the GPU.
    #[must_use]
    pub fn csr(&self) -> (&[usize], &[u32], &[f64]) {
        (&self.start, &self.index, &self.weight)
    }

    /// True when row `r` is a copy of a single design point (weight 1).
    #[must_use]
    pub fn is_copy(&self, r: usize) -> bool {
        let (i, w) = self.row(r);
        i.len() == 1 && (w[0] - 1.0).abs() < WEIGHT_EPS
    }

    /// `expanded = E · design`.
    #[must_use]
    pub fn apply<P: Vector>(&self, design: &[P]) -> Vec<P> {
        let mut out = vec![P::ZERO; self.rows()];
        self.apply_into(design, &mut out);
        out
    }

    /// `out = E · design` into a preallocated slice of `rows()` points.
    pub fn apply_into<P: Vector>(&self, design: &[P], out: &mut [P]) {
        debug_assert_eq!(design.len(), self.cols, "design length does not match the map");
        for (r, o) in out.iter_mut().enumerate() {
            let (idx, w) = self.row(r);
            let mut acc = P::ZERO;
            for (&j, &wj) in idx.iter().zip(w) {
                acc += design[j as usize] * wj;
            }
            *o = acc;
        }
    }

    /// `E · x` for scalars.
    #[must_use]
    pub fn apply_scalar(&self, x: &[f64]) -> Vec<f64> {
        (0..self.rows())
            .map(|r| {
                let (idx, w) = self.row(r);
                idx.iter().zip(w).map(|(&j, &wj)| x[j as usize] * wj).sum()
            })
            .collect()
    }

    /// `Eᵀ · g`: pulls a gradient over expanded points back to the design points.
    #[must_use]
    pub fn transpose_apply<P: Vector>(&self, g: &[P]) -> Vec<P> {
        debug_assert_eq!(g.len(), self.rows(), "gradient length does not match the map");
        let mut out = vec![P::ZERO; self.cols];
        for (r, &gr) in g.iter().enumerate() {
            let (idx, w) = self.row(r);
            for (&j, &wj) in idx.iter().zip(w) {
                out[j as usize] += gr * wj;
            }
        }
        out
    }

    /// The dense matrix, row-major `rows() x cols()`.
    #[must_use]
    pub fn to_dense(&self) -> Vec<f64> {
        let mut m = vec![0.0; self.rows() * self.cols];
        for r in 0..self.rows() {
            let (idx, w) = self.row(r);
            for (&j, &wj) in idx.iter().zip(w) {
                m[r * self.cols + j as usize] = wj;
            }
        }
        m
    }
}

/// Insert knot `t` once (Boehm's algorithm) into a clamped B-spline of degree `p` with
/// coefficients `c`; `lerp(a, b, s)` is `a (1 - s) + b s` for the coefficient type.
pub(crate) fn insert_knot<T: Clone>(
    knots: &mut Vec<f64>,
    c: &mut Vec<T>,
    p: usize,
    t: f64,
    lerp: impl Fn(&T, &T, f64) -> T,
) {
    // k: the last index with knots[k] <= t; `mult` the multiplicity of t already present.
    let k = knots.partition_point(|&x| x <= t) - 1;
    let mult = knots.iter().filter(|&&x| x == t).count();
    let mut out = Vec::with_capacity(c.len() + 1);
    for i in 0..=c.len() {
        if i + p <= k {
            out.push(c[i].clone());
        } else if i + mult > k {
            out.push(c[i - 1].clone());
        } else {
            let a = (t - knots[i]) / (knots[i + p] - knots[i]);
            out.push(lerp(&c[i - 1], &c[i], a));
        }
    }
    knots.insert(k + 1, t);
    *c = out;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity};

    fn map(d: usize, breaks: &[f64], c: Continuity) -> ExtractionMap {
        ChainLayout::with_breaks(d, breaks.to_vec(), c)
            .unwrap()
            .map()
            .clone()
    }

    #[test]
    fn c1_joins_follow_the_weighted_midpoint_rule() {
        let breaks = [0.0, 0.2, 0.3, 0.75, 1.0];
        let d = 3;
        let m = map(d, &breaks, Continuity::C1);
        let (rows, cols) = (m.rows(), m.cols());
        assert_eq!((rows, cols), (13, 10));
        // Design points are the expanded points with the joins left out, in order.
        let mut design_row = Vec::new();
        for r in 0..rows {
            if r % d == 0 && r != 0 && r != rows - 1 {
                let k = r / d;
                let (hl, hr) = (breaks[k] - breaks[k - 1], breaks[k + 1] - breaks[k]);
                let (idx, w) = m.row(r);
                assert_eq!(idx.len(), 2);
                let (a, b) = (idx[0] as usize, idx[1] as usize);
                assert_eq!(b, a + 1);
                assert!((w[0] - hr / (hl + hr)).abs() < 1e-14 && (w[1] - hl / (hl + hr)).abs() < 1e-14);
            } else {
                assert!(m.is_copy(r));
                design_row.push(m.row(r).0[0]);
            }
        }
        assert_eq!(design_row, (0..cols as u32).collect::<Vec<_>>());
    }

    #[test]
    fn uniform_c1_is_the_papers_midpoint() {
        let m = map(3, &[0.0, 0.2, 0.4, 0.6, 0.8, 1.0], Continuity::C1);
        assert_eq!((m.rows(), m.cols()), (16, 12));
        let (idx, w) = m.row(3);
        assert_eq!(idx, &[2, 3]);
        assert_eq!(w, &[0.5, 0.5]);
    }

    #[test]
    fn c0_is_the_identity() {
        let m = map(4, &[0.0, 0.5, 1.0], Continuity::C0);
        assert_eq!((m.rows(), m.cols()), (9, 9));
        assert!((0..9).all(|r| m.is_copy(r) && m.row(r).0[0] as usize == r));
    }

    #[test]
    fn rows_are_affine_combinations() {
        for c in [Continuity::C0, Continuity::C1, Continuity::C2] {
            let m = map(5, &[0.0, 0.1, 0.5, 0.55, 1.0], c);
            for r in 0..m.rows() {
                let s: f64 = m.row(r).1.iter().sum();
                assert!((s - 1.0).abs() < 1e-13, "{c} row {r} sums to {s}");
            }
        }
    }

    #[test]
    fn transpose_is_the_adjoint() {
        use glam::DVec2;
        let m = map(3, &[0.0, 0.3, 0.6, 1.0], Continuity::C2);
        let x: Vec<DVec2> = (0..m.cols())
            .map(|i| DVec2::new(i as f64 * 0.7 - 1.0, (i as f64).sin()))
            .collect();
        let g: Vec<DVec2> = (0..m.rows())
            .map(|i| DVec2::new((i as f64).cos(), 0.3 * i as f64))
            .collect();
        let ex = m.apply(&x);
        let etg = m.transpose_apply(&g);
        let lhs: f64 = ex.iter().zip(&g).map(|(a, b)| a.dot(*b)).sum();
        let rhs: f64 = x.iter().zip(&etg).map(|(a, b)| a.dot(*b)).sum();
        assert!((lhs - rhs).abs() < 1e-12);
    }
}
