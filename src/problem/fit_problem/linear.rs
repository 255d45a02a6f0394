//! Linear least squares at fixed parameters: the normal equations of the data (and of a
//! constraint's fairness term), summed in band form where the problem's sparsity makes that
//! cheaper, and solved for the design.

use super::{chunked_sum, FitProblem};
use crate::bezier::Vector;
use crate::chain::shape::{Basis, Shape};
use crate::error::{Error, Result};
use crate::problem::band::{BandMatrix, BandPlan};
use crate::problem::constraint::{Constraint, CoordRule};
use nalgebra::DMatrix;

/// Which entries of a linear fit's normal matrix `AᵀWA` can be non-zero: design points `i`
/// and `l` couple only where some cell supports both. Rows in CSR form (`col[start[i]..
/// start[i + 1]]`, ascending), and for every cell the slot of each pair of its support.
#[derive(Clone, Debug)]
pub(super) struct GramPattern {
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
        debug_assert_eq!(self.dim, P::DIM, "a run sums the points' own coordinates");
        for (a, &fa) in first.iter().enumerate() {
            let wa = w * fa;
            for (g, &fc) in self.gram[a * n..(a + 1) * n].iter_mut().zip(first) {
                *g += wa * fc;
            }
            // Over the point's own dimension, a constant: unrolled, each coordinate read
            // directly (over `self.dim` it was a loop of indexed reads).
            for (k, r) in self.rhs[a * P::DIM..(a + 1) * P::DIM].iter_mut().enumerate() {
                *r += wa * q.coord(k);
            }
        }
    }

    /// Add the run's sums to the upper triangle `ata` ([`GramPattern`] slots of the cell,
    /// `slots`) and to `atq`, for the cell's `support`; the run is then empty.
    fn flush(&mut self, slots: &[u32], support: &[u32], ata: &mut [f64], atq: &mut [f64]) {
        let (n, r, s) = (self.width, self.rest.len(), support.len());
        debug_assert_eq!(s, n * r, "a cell's support is the product of its factors'");
        for a in 0..s {
            let (au, av) = (a / r, a % r);
            let ra = self.rest[av];
            // Support entries `c = cu r + cv >= a`, walked factor by factor rather than
            // divided out of `c` (an integer division per entry).
            let row = &slots[a * s..(a + 1) * s];
            for cu in au..n {
                let g = self.gram[au * n + cu] * ra;
                let from = if cu == au { av } else { 0 };
                for (&slot, &rc) in row[cu * r + from..(cu + 1) * r].iter().zip(&self.rest[from..]) {
                    ata[slot as usize] += g * rc;
                }
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
                // Row r = (i, k) of (N ⊗ I) A, gathered once over the unknowns it touches
                // (the design points of a column share their frame's), then spread by row r
                // of A: far fewer scattered additions than pair by pair.
                let (mut y, mut seen, mut touched) = (vec![0.0; nz], vec![false; nz], Vec::new());
                for i in 0..m {
                    for k in 0..dim {
                        let r = i * dim + k;
                        let nb: f64 = row(i).map(|(l, v)| v * offset[l * dim + k]).sum();
                        for &(p, wp) in &rows[r] {
                            rhs[(p, 0)] += wp * (atq[r] - nb);
                        }
                        if rows[r].is_empty() {
                            continue;
                        }
                        for (l, v) in row(i) {
                            if v == 0.0 {
                                continue;
                            }
                            for &(q, wq) in &rows[l * dim + k] {
                                if !seen[q] {
                                    seen[q] = true;
                                    touched.push(q);
                                }
                                y[q] += v * wq;
                            }
                        }
                        for &(p, wp) in &rows[r] {
                            for &q in &touched {
                                a.add(p, q, wp * y[q]);
                            }
                        }
                        for q in touched.drain(..) {
                            y[q] = 0.0;
                            seen[q] = false;
                        }
                    }
                }
                add_fairness(con, &mut a);
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
                        add_fairness(con, &mut a);
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
}

/// Add `con`'s fairness penalty ([`Constraint::with_fairness`]) to the normal matrix `a` of
/// its unknowns: the coupled constraint's, or one coordinate group's with unknowns (its rows
/// then index that group's unknowns, as the span rule's two free coordinates share theirs).
fn add_fairness(con: &Constraint, a: &mut Normal<'_>) {
    let Some((d, eps)) = &con.fair else {
        return;
    };
    let nz = a.size();
    debug_assert!(
        d.iter().flatten().all(|&(p, _)| p < nz),
        "fairness rows index {nz} unknowns at most"
    );
    let lambda = eps * (0..nz).map(|i| a.diagonal(i)).sum::<f64>() / nz.max(1) as f64;
    for row in d {
        for &(p, wp) in row {
            for &(q, wq) in row {
                a.add(p, q, lambda * wp * wq);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{sample_chain, sectioned};
    use super::*;
    use crate::chain::{ChainLayout, Continuity, CurveShape, GridLayout, GridShape};
    use crate::closest::FootOptions;
    use crate::problem::{Constraint, CoordRule, Metric};
    use glam::{DVec2, DVec3};

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
    fn a_coupled_grid_fit_solves_the_normal_equations_of_its_unknowns() {
        // The chord rule's shape of constraint: the design points of a column share two frame
        // unknowns, each has one of its own, and z is its own unknown, with offsets.
        let (layout, pts, params) = sectioned();
        let (nu, nv) = layout.design_shape();
        let m = nu * nv;
        let nz = 2 * nv + 2 * m;
        let mut rows = Vec::with_capacity(3 * m);
        for i in 0..m {
            let (col, own) = (i % nv, 2 * nv + 2 * i);
            let s = 0.3 + 0.1 * (i as f64).sin();
            rows.push(vec![(2 * col, 1.0), (own, s)]);
            let c = 0.2 + 0.1 * (1.3 * i as f64).cos();
            rows.push(vec![(2 * col + 1, 1.0), (own, -0.7 * s), (2 * col, c)]);
            rows.push(vec![(own + 1, 1.0)]);
        }
        let offset: Vec<f64> = (0..3 * m).map(|r| 0.01 * (r as f64 * 0.7).cos()).collect();
        let con = Constraint::coupled(rows.clone(), offset.clone(), nz);
        let mut p = FitProblem::grid(layout.clone(), &pts, params.clone(), Metric::Closest)
            .unwrap()
            .with_constraint(con)
            .unwrap();
        let w: Vec<f64> = (0..pts.len())
            .map(|j| 1.0 + 0.5 * (j as f64 * 0.37).sin())
            .collect();
        p.set_weights(Some(w.clone())).unwrap();
        let design = p.linear_fit(&params).unwrap();
        // The same problem dense: min Σ w_j |B_j (A z + b) - q_j|², A the rows, b the offsets.
        let mut a = DMatrix::<f64>::zeros(3 * m, nz);
        for (r, row) in rows.iter().enumerate() {
            for &(k, v) in row {
                a[(r, k)] += v;
            }
        }
        let mut design_basis = DMatrix::<f64>::zeros(3 * pts.len(), 3 * m);
        let mut target = DMatrix::<f64>::zeros(3 * pts.len(), 1);
        let shape = GridShape::<DVec3>::new(layout);
        let mut b = Basis::new();
        for (j, (t, q)) in params.iter().zip(&pts).enumerate() {
            shape.basis(*t, 0, &mut b);
            let root = w[j].sqrt();
            for (x, &i) in shape.support(b.cell).iter().enumerate() {
                for k in 0..3 {
                    design_basis[(3 * j + k, 3 * i as usize + k)] = root * b.value[x];
                }
            }
            for k in 0..3 {
                target[(3 * j + k, 0)] = root * q.coord(k);
            }
        }
        let ba = &design_basis * &a;
        let rhs = ba.transpose() * (target - &design_basis * DMatrix::from_column_slice(3 * m, 1, &offset));
        let z = (ba.transpose() * &ba).cholesky().unwrap().solve(&rhs);
        let flat = &a * z + DMatrix::from_column_slice(3 * m, 1, &offset);
        for (i, d) in design.iter().enumerate() {
            let e = DVec3::new(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
            assert!((*d - e).length() < 1e-9, "design point {i}: {d} against {e}");
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
}
