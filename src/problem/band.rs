//! `BandMatrix`: a symmetric positive definite matrix stored as its lower band, with an
//! in-place Cholesky factorisation and solve in `O(n b²)` and `O(n b)` for bandwidth `b`.
//!
//! The reduced normal equations of a patch grid couple a design point only with the design
//! points within one patch's support of it, so in row-major design order their bandwidth is
//! about `(du + 1) nv` points: for the 26 x 24 design nets of the blade fits that is a few
//! hundred unknowns out of a couple of thousand, and the banded factorisation is 10 to 50 times
//! cheaper than the dense one.

/// A reverse Cuthill-McKee ordering of the graph with `n` nodes whose edges join every two
/// nodes of each clique in `cliques`: `order[k]` is the node placed at position `k`. It keeps
/// linked nodes close together, so a matrix with this sparsity has a small bandwidth in that
/// order. On a patch grid's design net it starts at a corner and its levels run diagonally:
/// band 146 on a 26 x 23 net of degrees 4 x 3, where the net column by column has 82
/// ([`BandPlan::of_edges_with`] takes the narrowest). Deterministic.
#[must_use]
pub fn rcm_order<'a>(n: usize, cliques: impl Iterator<Item = &'a [u32]>) -> Vec<u32> {
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for c in cliques {
        for &a in c {
            for &b in c {
                if a != b && (a as usize) < n && (b as usize) < n {
                    adj[a as usize].push(b);
                }
            }
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    let mut placed = vec![false; n];
    let mut order: Vec<u32> = Vec::with_capacity(n);
    while order.len() < n {
        // Start each component at an unplaced node of least degree (a peripheral one).
        let Some(start) = (0..n).filter(|&i| !placed[i]).min_by_key(|&i| (adj[i].len(), i)) else {
            break;
        };
        placed[start] = true;
        let mut head = order.len();
        order.push(start as u32);
        while head < order.len() {
            let node = order[head] as usize;
            head += 1;
            let mut next: Vec<u32> = adj[node]
                .iter()
                .copied()
                .filter(|&b| !placed[b as usize])
                .collect();
            next.sort_unstable_by_key(|&b| (adj[b as usize].len(), b));
            for b in next {
                placed[b as usize] = true;
                order.push(b);
            }
        }
    }
    order.reverse();
    order
}

/// Systems with at least this many unknowns are solved in band form where their sparsity
/// allows; below it (every curve) the dense Cholesky factorisation is as fast.
pub(crate) const BAND_MIN: usize = 256;

/// How to solve a symmetric positive definite system held densely but mostly zero (the
/// normal equations of a constrained patch-grid fit): a reverse Cuthill-McKee order of its
/// sparsity and the bandwidth in that order. Built once per sparsity pattern, used for every
/// system with that pattern (a ridge on the diagonal keeps it).
#[derive(Clone, Debug, PartialEq)]
pub struct BandPlan {
    /// `pos[i]`: the position of unknown `i` in the band order.
    pos: Vec<usize>,
    band: usize,
}

impl BandPlan {
    /// The plan for `a`'s sparsity (its lower triangle's non-zero entries), or `None` when
    /// the dense factorisation is as fast: fewer than `BAND_MIN` unknowns, or a band wider
    /// than a third of them (`O(n b²)` against `O(n³ / 3)`).
    #[must_use]
    pub fn of(a: &nalgebra::DMatrix<f64>) -> Option<Self> {
        let n = a.nrows();
        if n < BAND_MIN || a.ncols() != n {
            return None;
        }
        let mut edges: Vec<[u32; 2]> = Vec::new();
        for j in 0..n {
            let col = &a.as_slice()[j * n..(j + 1) * n];
            for (i, &v) in col.iter().enumerate().skip(j + 1) {
                if v != 0.0 {
                    edges.push([i as u32, j as u32]);
                }
            }
        }
        Self::of_edges(n, &edges)
    }

    /// The plan for `n` unknowns whose system has non-zero entries off the diagonal only at
    /// `edges` (`[i, j]`, either way round; repeats allowed), or `None` as [`BandPlan::of`].
    #[must_use]
    pub fn of_edges(n: usize, edges: &[[u32; 2]]) -> Option<Self> {
        Self::of_edges_with(n, edges, &[])
    }

    /// [`BandPlan::of_edges`] with more candidate orders (`orders[c][k]`: the unknown at
    /// position `k`; those not a permutation of the `n` unknowns are passed over): the
    /// narrowest of them, the given order and reverse Cuthill-McKee's wins.
    #[must_use]
    pub fn of_edges_with(n: usize, edges: &[[u32; 2]], orders: &[Vec<u32>]) -> Option<Self> {
        if n < BAND_MIN {
            return None;
        }
        let positions = |order: &[u32]| {
            let mut pos = vec![usize::MAX; n];
            for (k, &i) in order.iter().enumerate() {
                *pos.get_mut(i as usize)? = k;
            }
            (order.len() == n && pos.iter().all(|&p| p != usize::MAX)).then_some(pos)
        };
        let pos = positions(&rcm_order(n, edges.iter().map(|e| e.as_slice())))?;
        let reach = |pos: &[usize]| {
            edges
                .iter()
                .map(|e| pos[e[0] as usize].abs_diff(pos[e[1] as usize]))
                .max()
                .unwrap_or(0)
        };
        // The given order when it is narrower: a chord-rule grid's unknowns come column by
        // column with each column's frame, a band of about three columns (123 of 1,023 on
        // the IEA 15 MW), where the ordering's breadth-first levels spread to 312.
        let natural: Vec<usize> = (0..n).collect();
        let (pos, band) = [pos, natural]
            .into_iter()
            .chain(orders.iter().filter_map(|o| positions(o)))
            .map(|p| {
                let b = reach(&p);
                (p, b)
            })
            .min_by_key(|(_, b)| *b)?;
        (3 * band < n).then_some(BandPlan { pos, band })
    }

    /// The plan for `n` unknowns whose system has non-zero entries off the diagonal only at
    /// the pairs `pairs` gives its argument (either way round; repeats allowed), with the
    /// candidate `orders` of [`BandPlan::of_edges_with`], or `None` as [`BandPlan::of`].
    pub fn of_pairs(
        n: usize,
        orders: &[Vec<u32>],
        pairs: impl FnOnce(&mut dyn FnMut(usize, usize)),
    ) -> Option<Self> {
        if n < BAND_MIN {
            return None;
        }
        // Every pair once, from each unknown's list of lower neighbours.
        let mut lower: Vec<Vec<u32>> = vec![Vec::new(); n];
        pairs(&mut |p, q| {
            if p > q {
                lower[p].push(q as u32);
            } else if q > p {
                lower[q].push(p as u32);
            }
        });
        let mut edges = Vec::new();
        for (p, l) in lower.iter_mut().enumerate() {
            l.sort_unstable();
            l.dedup();
            edges.extend(l.iter().map(|&q| [p as u32, q]));
        }
        Self::of_edges_with(n, &edges, orders)
    }

    /// The plan that keeps the unknowns in their own order, for a system whose non-zero
    /// entries all lie within `band` of the diagonal in that order; `None` as
    /// [`BandPlan::of`].
    #[must_use]
    pub fn in_order(n: usize, band: usize) -> Option<Self> {
        (n >= BAND_MIN && 3 * band < n).then(|| BandPlan {
            pos: (0..n).collect(),
            band,
        })
    }

    /// The number of unknowns.
    #[must_use]
    pub fn size(&self) -> usize {
        self.pos.len()
    }

    /// A zero system with the plan's sparsity, summed by [`BandPlan::add`].
    #[must_use]
    pub fn zeros(&self) -> BandMatrix {
        BandMatrix::zeros(self.pos.len(), self.band)
    }

    /// Add `v` to entry `(i, j)` (the unknowns' own numbers) of a symmetric system `m` from
    /// [`BandPlan::zeros`]: a sum that adds every entry and its mirror keeps the entries on
    /// and below the diagonal in the plan's order and skips the others. A non-zero entry
    /// outside the band is a plan made for another sparsity (a debug build stops there).
    #[inline]
    pub fn add(&self, m: &mut BandMatrix, i: usize, j: usize, v: f64) {
        let (pi, pj) = (self.pos[i], self.pos[j]);
        debug_assert!(
            pi.abs_diff(pj) <= self.band || v == 0.0,
            "entry ({i}, {j}) outside the plan's band {}",
            self.band
        );
        if pi >= pj && pi - pj <= self.band {
            m.add_lower(pi, pj, v);
        }
    }

    /// Entry `(i, i)` of a system summed by [`BandPlan::add`].
    #[must_use]
    pub fn diagonal(&self, m: &BandMatrix, i: usize) -> f64 {
        m.get(self.pos[i], self.pos[i])
    }

    /// Solve `m x = rhs` (every column of `rhs`) for a system summed by [`BandPlan::add`];
    /// `None` when it is not positive definite.
    #[must_use]
    pub fn solve_summed(
        &self,
        m: BandMatrix,
        rhs: &nalgebra::DMatrix<f64>,
    ) -> Option<nalgebra::DMatrix<f64>> {
        let n = self.pos.len();
        let ch = m.cholesky()?;
        let mut x = nalgebra::DMatrix::<f64>::zeros(n, rhs.ncols());
        let mut y = vec![0.0; n];
        for k in 0..rhs.ncols() {
            for i in 0..n {
                y[self.pos[i]] = rhs[(i, k)];
            }
            ch.solve_in_place(&mut y);
            for i in 0..n {
                x[(i, k)] = y[self.pos[i]];
            }
        }
        Some(x)
    }

    /// The bandwidth in the plan's order.
    #[must_use]
    pub fn bandwidth(&self) -> usize {
        self.band
    }

    /// Solve `a x = rhs` (every column of `rhs`) for an `a` with the plan's sparsity (entries
    /// outside it are ignored); `None` when `a` is not positive definite.
    #[must_use]
    pub fn solve(
        &self,
        a: &nalgebra::DMatrix<f64>,
        rhs: &nalgebra::DMatrix<f64>,
    ) -> Option<nalgebra::DMatrix<f64>> {
        let n = self.pos.len();
        let mut m = self.zeros();
        for j in 0..n {
            for i in j..n {
                let v = a[(i, j)];
                if v != 0.0 {
                    // Both ways round: the one on or below the diagonal in the plan's order.
                    self.add(&mut m, i, j, v);
                    if i != j {
                        self.add(&mut m, j, i, v);
                    }
                }
            }
        }
        self.solve_summed(m, rhs)
    }
}

/// A symmetric `n x n` matrix with `a[i][j] = 0` for `|i - j| > b`, lower band stored row by
/// row: row `i` holds columns `i - b ..= i` (entries left of column 0 are unused zeros).
#[derive(Clone, Debug, PartialEq)]
pub struct BandMatrix {
    n: usize,
    b: usize,
    data: Vec<f64>,
}

impl BandMatrix {
    /// The zero matrix of size `n` and bandwidth `b` (clamped to `n - 1`).
    #[must_use]
    pub fn zeros(n: usize, b: usize) -> Self {
        let b = b.min(n.saturating_sub(1));
        BandMatrix {
            n,
            b,
            data: vec![0.0; n * (b + 1)],
        }
    }

    /// Size `n`.
    #[must_use]
    pub fn size(&self) -> usize {
        self.n
    }

    /// Bandwidth `b`.
    #[must_use]
    pub fn bandwidth(&self) -> usize {
        self.b
    }

    /// Storage index of entry `(i, j)`, `j <= i <= j + b`.
    #[inline]
    fn at(&self, i: usize, j: usize) -> usize {
        debug_assert!(
            j <= i && i - j <= self.b,
            "band entry ({i}, {j}) outside bandwidth {}",
            self.b
        );
        i * (self.b + 1) + self.b + j - i
    }

    /// Add `v` to entry `(i, j)` of the lower triangle (`j <= i`, within the band).
    #[inline]
    pub fn add_lower(&mut self, i: usize, j: usize, v: f64) {
        let k = self.at(i, j);
        self.data[k] += v;
    }

    /// Entry `(i, j)` of the symmetric matrix (zero outside the band).
    #[must_use]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if j > i { (j, i) } else { (i, j) };
        if i - j > self.b {
            0.0
        } else {
            self.data[self.at(i, j)]
        }
    }

    /// Factor in place into `L Lᵀ` (the band then holds `L`). `None` when a pivot is not
    /// positive and finite: the matrix is not positive definite.
    #[must_use]
    pub fn cholesky(mut self) -> Option<BandCholesky> {
        let (n, b, w) = (self.n, self.b, self.b + 1);
        for i in 0..n {
            let lo_i = i.saturating_sub(b);
            for j in lo_i..=i {
                // L[i][j] = (A[i][j] - Σ_{k < j} L[i][k] L[j][k]) / L[j][j], k within both bands.
                let lo = lo_i.max(j.saturating_sub(b));
                let (ri, rj) = (i * w + b - i, j * w + b - j);
                let mut s = self.data[ri + j];
                s -= dot(&self.data[ri + lo..ri + j], &self.data[rj + lo..rj + j]);
                if i == j {
                    if !(s > 0.0) || !s.is_finite() {
                        return None;
                    }
                    self.data[ri + i] = s.sqrt();
                } else {
                    self.data[ri + j] = s / self.data[rj + j];
                }
            }
        }
        Some(BandCholesky { l: self })
    }
}

/// `Σ a_k b_k` in four interleaved partial sums, which the compiler keeps in vector
/// registers (a single running sum must add in order and is not vectorised): the band
/// factorisation's inner loop, 21 % of a plain `adapt-surface` search's time before.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    debug_assert_eq!(a.len(), b.len());
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0; 4];
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// The Cholesky factor `L` of a [`BandMatrix`].
#[derive(Clone, Debug, PartialEq)]
pub struct BandCholesky {
    l: BandMatrix,
}

impl BandCholesky {
    /// Solve `L Lᵀ x = rhs` in place.
    pub fn solve_in_place(&self, x: &mut [f64]) {
        let (n, b, w) = (self.l.n, self.l.b, self.l.b + 1);
        debug_assert_eq!(x.len(), n, "band solve: right-hand side of the wrong length");
        let d = &self.l.data;
        for i in 0..n {
            let lo = i.saturating_sub(b);
            let ri = i * w + b - i;
            let s = dot(&d[ri + lo..ri + i], &x[lo..i]);
            x[i] = (x[i] - s) / d[ri + i];
        }
        for i in (0..n).rev() {
            x[i] /= d[i * w + b];
            let xi = x[i];
            let lo = i.saturating_sub(b);
            let ri = i * w + b - i;
            for (xk, &l) in x[lo..i].iter_mut().zip(&d[ri + lo..ri + i]) {
                *xk -= l * xi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn matches_the_dense_solve() {
        let (n, b) = (40, 5);
        let mut band = BandMatrix::zeros(n, b);
        let mut dense = DMatrix::<f64>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(b)..=i {
                let v = if i == j {
                    10.0 + i as f64 * 0.1
                } else {
                    ((i * 7 + j * 3) as f64).sin()
                };
                band.add_lower(i, j, v);
                dense[(i, j)] = v;
                dense[(j, i)] = v;
            }
        }
        assert_eq!(band.get(3, 20), 0.0);
        assert_eq!(band.get(2, 5), dense[(2, 5)]);
        let rhs: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).cos()).collect();
        let want = dense.cholesky().unwrap().solve(&DVector::from_vec(rhs.clone()));
        let mut x = rhs;
        band.cholesky().unwrap().solve_in_place(&mut x);
        for i in 0..n {
            assert!((x[i] - want[i]).abs() < 1e-12, "{i}: {} vs {}", x[i], want[i]);
        }
    }

    /// Every `block[0] x block[1]` block of a `rows x cols` grid of nodes (row-major), its
    /// nodes row-major.
    fn block_cliques(rows: usize, cols: usize, block: [usize; 2]) -> Vec<Vec<u32>> {
        let id = |a: usize, b: usize| (a * cols + b) as u32;
        let mut cliques = Vec::new();
        for i in 0..=rows - block[0] {
            for j in 0..=cols - block[1] {
                cliques.push(
                    (i..i + block[0])
                        .flat_map(|a| (j..j + block[1]).map(move |b| id(a, b)))
                        .collect(),
                );
            }
        }
        cliques
    }

    #[test]
    fn a_plan_takes_the_narrowest_of_its_candidate_orders() {
        // A 26 x 23 net (row-major) of degrees 4 x 3: every two points of a 5 x 4 block linked.
        let (nu, nv) = (26u32, 23u32);
        let mut edges = Vec::new();
        for block in block_cliques(nu as usize, nv as usize, [5, 4]) {
            for &a in &block {
                for &b in &block {
                    if a > b {
                        edges.push([a, b]);
                    }
                }
            }
        }
        let n = (nu * nv) as usize;
        assert_eq!(BandPlan::of_edges(n, &edges).unwrap().bandwidth(), 4 * 23 + 3);
        let by_column: Vec<u32> = (0..nv).flat_map(|j| (0..nu).map(move |i| i * nv + j)).collect();
        let not_a_permutation = vec![0; n];
        let plan = BandPlan::of_edges_with(n, &edges, &[not_a_permutation, by_column]).unwrap();
        assert_eq!(plan.bandwidth(), 3 * 26 + 4);
    }

    #[test]
    fn rcm_puts_the_short_side_of_a_grid_across_the_band() {
        // A 5 x 30 grid of nodes (row-major, 30 per row) linked in 2 x 2 cliques: bandwidth 31
        // in the natural order, about 5 to 6 after reordering.
        let (rows, cols) = (5usize, 30usize);
        let cliques = block_cliques(rows, cols, [2, 2]);
        let order = rcm_order(rows * cols, cliques.iter().map(|c| c.as_slice()));
        let mut pos = vec![0usize; rows * cols];
        for (k, &node) in order.iter().enumerate() {
            pos[node as usize] = k;
        }
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(
            sorted,
            (0..(rows * cols) as u32).collect::<Vec<_>>(),
            "a permutation"
        );
        let band = cliques
            .iter()
            .flat_map(|c| c.iter().flat_map(|&a| c.iter().map(move |&b| (a, b))))
            .map(|(a, b)| pos[a as usize].abs_diff(pos[b as usize]))
            .max()
            .unwrap();
        assert!(band <= 2 * rows, "bandwidth {band}");
    }

    #[test]
    fn a_band_plan_solves_what_the_dense_factorisation_solves() {
        // A banded SPD matrix of 300 unknowns (bandwidth 6) in a scrambled order: the plan
        // finds a narrow band again and solves it as the dense Cholesky does.
        let (n, b) = (300usize, 6usize);
        let scramble = |i: usize| (i * 7) % n;
        let mut a = DMatrix::<f64>::zeros(n, n);
        for i in 0..n {
            for j in i.saturating_sub(b)..=i {
                let v = if i == j { 20.0 } else { ((i * 3 + j) as f64).cos() };
                a[(scramble(i), scramble(j))] = v;
                a[(scramble(j), scramble(i))] = v;
            }
        }
        let rhs = DMatrix::<f64>::from_fn(n, 2, |i, k| ((i + 5 * k) as f64 * 0.3).sin());
        assert!(BandPlan::of(&DMatrix::<f64>::identity(BAND_MIN - 1, BAND_MIN - 1)).is_none());
        let plan = BandPlan::of(&a).expect("narrow after reordering");
        assert!(plan.bandwidth() <= 2 * b, "bandwidth {}", plan.bandwidth());
        let x = plan.solve(&a, &rhs).unwrap();
        let want = a.clone().cholesky().unwrap().solve(&rhs);
        assert!((x - want).abs().max() < 1e-12);
        let mut neg = a.clone();
        neg[(0, 0)] = -1.0;
        assert!(plan.solve(&neg, &rhs).is_none());
    }

    #[test]
    fn indefinite_matrices_are_refused() {
        let mut m = BandMatrix::zeros(3, 1);
        m.add_lower(0, 0, 1.0);
        m.add_lower(1, 0, 2.0);
        m.add_lower(1, 1, 1.0);
        m.add_lower(2, 2, 1.0);
        assert!(m.cholesky().is_none());
        assert!(BandMatrix::zeros(4, 2).cholesky().is_none());
    }
}
