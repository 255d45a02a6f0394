//! Linear constraints on the design: one rule per coordinate (a design coordinate as a
//! combination of fewer unknowns plus an offset), the aerofoil rule and the span rule built
//! from them, and the fairness penalty a coupled constraint may carry.

use crate::bezier::Vector;
use crate::error::{Error, Result};
use nalgebra::{DMatrix, DVector};

/// A linear rule for one coordinate of every design point: coordinate `c` of design point
/// `i` is `Σ w z_k` over the entries `(k, w)` of row `i`, plus `offset[i]`, with `z` this
/// coordinate's unknowns.
#[derive(Clone, Debug, PartialEq)]
pub struct CoordRule {
    pub(crate) rows: Vec<Vec<(usize, f64)>>,
    pub(crate) offset: Vec<f64>,
    pub(crate) unknowns: usize,
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
    pub(crate) fn unknowns_of(&self, x: &[f64]) -> Option<Vec<f64>> {
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
    pub(crate) coords: Vec<CoordRule>,
    /// Index of each coordinate's first unknown in `z`.
    pub(crate) first: Vec<usize>,
    /// The entries `(unknown, weight)` of every flat design variable `i * DIM + c`.
    pub(crate) flat: Vec<Vec<(usize, f64)>>,
    /// For a coupled constraint: the offset of every flat design variable and the number of
    /// unknowns (`coords` is then empty).
    pub(crate) coupled: Option<(Vec<f64>, usize)>,
    /// A fairness penalty on the unknowns of a coupled constraint: rows `(unknown, weight)`
    /// of `D` and the factor `ε`; the linear fit adds `ε d̄ Σ (D z)²`, `d̄` the mean diagonal
    /// of the data's normal matrix.
    pub(crate) fair: Option<(Vec<SparseRow>, f64)>,
}

/// A sparse row: `(unknown, weight)` entries.
pub(crate) type SparseRow = Vec<(usize, f64)>;

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

    /// The coordinates that share one rule (the same rows and unknowns: a span-rule grid's
    /// two free coordinates), each group with its first coordinate, in coordinate order.
    pub(crate) fn groups(&self) -> Vec<(usize, Vec<usize>)> {
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

    pub(crate) fn check(&self, dim: usize, m: usize) -> Result<()> {
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
