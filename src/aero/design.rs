//! The design space of an aerodynamic optimisation: the stored numbers of an adapted
//! encoding ([`Encoding`], what `bezchain adapt` finds), as offsets from a start, bounded by a
//! box, with the linear map from those offsets to panel nodes.
//!
//! The stored numbers are every stored y, every stored x (free layouts) and the numbers of the
//! aerofoil rule; stored breaks are held at the start's values (a break moves the basis
//! itself, so the nodes would no longer be linear in it).
//!
//! **What is held** ([`Hold`]). Pressures, CL and CM do not change when a shape is moved or
//! scaled, and turning it is a change of the angle of attack: an optimiser left free to do so
//! drifts (an inverse design matches the target's pressures with a shape shifted and scaled)
//! or cheats (max-CL turns the nose up). And an inviscid solver rewards a thick blunt base
//! with lift that real flow would not give (max-CL opens the trailing edge to a tenth of the
//! chord). So both trailing-edge points and the x of the leading edge (the point at the
//! start's leading-edge parameter) stay where the start has them, and with
//! [`Hold::ChordLine`] the leading edge's y too: linear conditions on the stored numbers, each
//! independent one solved for one of them (the one it weighs most).
//! The design variables are the other stored numbers; [`DesignSpace::names`] lists them and
//! [`DesignSpace::dependents`] the ones that follow.
//!
//! The control points are linear in the stored numbers, and the panel nodes sit at fixed
//! parameters on the chain (placed once, on the start shape, by [`panel_params`]), so the
//! nodes are an affine function of the offsets: [`NodeMap`], computed here from the encoding
//! column by column and checked to be linear.

use super::batch::NodeMap;
use super::contour::{panel_params, Paneling};
use crate::adaptive::{chain_of, Encoding, XStore};
use crate::chain::CurveChain;
use crate::error::{Error, Result};
use glam::DVec2;

/// Which stored number a variable is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Var {
    /// The y of design point `k`.
    Y(usize),
    /// The x of design point `k` (free layouts).
    X(usize),
    /// Number `k` of the aerofoil rule (`x_le`, `x_te` …).
    Rule(usize),
}

/// What the design space holds where the start has it (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// The trailing-edge points and the leading edge's x: no translation, no scaling, the
    /// same trailing edge; the shape may turn (which changes its pressures). For inverse
    /// design.
    Similarity,
    /// The trailing-edge points and the leading edge: the chord line too. For objectives that
    /// turning would improve (max CL).
    ChordLine,
}

/// The design variables of an encoding, their box, and the node map.
#[derive(Clone, Debug, PartialEq)]
pub struct DesignSpace {
    start: Encoding,
    /// Every stored number that may move.
    stored: Vec<Var>,
    /// The stored numbers that are design variables (indices into `stored`).
    free: Vec<usize>,
    /// Per design variable, the offsets of every stored number it moves (itself and the
    /// dependents that keep the chord line).
    basis: Vec<Vec<f64>>,
    /// The dependents: (index into `stored`).
    dependents: Vec<usize>,
    bounds: Vec<[f64; 2]>,
    zero: Vec<f64>,
    params: Vec<f64>,
    map: NodeMap,
    chord: f64,
}

impl DesignSpace {
    /// The space around `start`: offsets bounded by `± margin × chord` (the start's chord),
    /// nodes placed on the start by `paneling`, `hold` kept where the start has it.
    pub fn new(start: &Encoding, paneling: &Paneling, margin: f64, hold: Hold) -> Result<Self> {
        if !(margin > 0.0) || !margin.is_finite() {
            return Err(Error::invalid(format!(
                "the box margin must be a finite fraction > 0 of the chord, not {margin}"
            )));
        }
        let chain = chain_of(start)?;
        let mut params = panel_params(&chain, paneling)?;
        let mut base: Vec<DVec2> = params.iter().map(|&t| chain.eval(t)).collect();
        // A start whose trailing-edge ends overlap within its fit's tolerance is closed where
        // they cross, as the analysis closes it: the end nodes then sit at those parameters.
        super::panel::close_crossed_trailing_edge(&mut base, &mut params, &|t| chain.eval(t));
        let chord = super::panel::Chord::of(&base).length;
        let t_le = super::contour::leading_edge_param(&chain);
        let mut stored: Vec<Var> = (0..start.y.len()).map(Var::Y).collect();
        match &start.x {
            XStore::Free(x) => stored.extend((0..x.len()).map(Var::X)),
            XStore::AerofoilRule(theta) => stored.extend((0..theta.len()).map(Var::Rule)),
        }
        let m = stored.len();
        let scale = base.iter().fold(chord, |acc, p| acc.max(p.abs().max_element()));
        // Each stored number's effect on the nodes and on the chord line (leading edge, trailing
        // edge midpoint), checked to be linear.
        // Rows: leading edge x and y, the two trailing-edge points' x and y.
        let line = |c: &CurveChain<DVec2>| {
            let (le, a, b) = (c.eval(t_le), c.eval(0.0), c.eval(1.0));
            [le.x, le.y, a.x, a.y, b.x, b.y]
        };
        let probe = |i: usize, d: f64| -> Result<(Vec<DVec2>, [f64; 6])> {
            let mut e = start.clone();
            apply(&mut e, stored[i], d);
            let c = chain_of(&e)?;
            let nodes = params.iter().map(|&t| c.eval(t)).collect();
            Ok((nodes, line(&c)))
        };
        let line0 = line(&chain);
        let mut cols = Vec::with_capacity(m);
        let mut conditions = vec![vec![0.0; m]; 6];
        let held = [true, hold == Hold::ChordLine, true, true, true, true];
        for i in 0..m {
            let (one, l1) = probe(i, 1.0)?;
            let (two, _) = probe(i, 2.0)?;
            let col: Vec<DVec2> = one.iter().zip(&base).map(|(a, b)| *a - *b).collect();
            let off = two
                .iter()
                .zip(&base)
                .zip(&col)
                .map(|((t, b), c)| (*t - *b - 2.0 * *c).length())
                .fold(0.0, f64::max);
            if off > 1e-9 * scale {
                return Err(Error::Numerical(format!(
                    "the nodes are not linear in stored number {i} (off by {off:.3e})"
                )));
            }
            for r in 0..6 {
                conditions[r][i] = l1[r] - line0[r];
            }
            cols.push(col);
        }
        // Reduce the conditions (column pivoting); each independent one fixes a dependent.
        let mut pivots: Vec<usize> = Vec::new();
        let mut rows: Vec<Vec<f64>> = Vec::new();
        for (mut row, _) in conditions.into_iter().zip(held).filter(|(_, h)| *h) {
            for (r, &p) in rows.iter().zip(&pivots) {
                let f = row[p];
                for c in 0..m {
                    row[c] -= f * r[c];
                }
            }
            let (p, big) = (0..m)
                .filter(|c| !pivots.contains(c))
                .map(|c| (c, row[c].abs()))
                .fold((usize::MAX, 0.0), |a, b| if b.1 > a.1 { b } else { a });
            if p == usize::MAX || big < 1e-9 {
                continue;
            }
            let inv = 1.0 / row[p];
            row.iter_mut().for_each(|v| *v *= inv);
            for (r, &q) in rows.iter_mut().zip(&pivots) {
                let f = r[p];
                for c in 0..m {
                    r[c] -= f * row[c];
                }
                debug_assert!(r[q] == 1.0 || (r[q] - 1.0).abs() < 1e-12, "pivot kept");
            }
            rows.push(row);
            pivots.push(p);
        }
        let free: Vec<usize> = (0..m).filter(|c| !pivots.contains(c)).collect();
        let basis: Vec<Vec<f64>> = free
            .iter()
            .map(|&c| {
                let mut v = vec![0.0; m];
                v[c] = 1.0;
                for (r, &p) in rows.iter().zip(&pivots) {
                    v[p] = -r[c];
                }
                v
            })
            .collect();
        let columns = basis
            .iter()
            .map(|v| {
                (0..base.len())
                    .map(|k| v.iter().zip(&cols).map(|(w, col)| *w * col[k]).sum())
                    .collect()
            })
            .collect();
        let n = free.len();
        Ok(DesignSpace {
            start: start.clone(),
            stored,
            free,
            basis,
            dependents: pivots,
            bounds: vec![[-margin * chord, margin * chord]; n],
            zero: vec![0.0; n],
            params,
            map: NodeMap { base, columns },
            chord,
        })
    }

    /// The encoding at offsets `delta` (the dependents following).
    #[must_use]
    pub fn encoding(&self, delta: &[f64]) -> Encoding {
        let mut e = self.start.clone();
        for (i, &var) in self.stored.iter().enumerate() {
            let d: f64 = self.basis.iter().zip(delta).map(|(v, &w)| v[i] * w).sum();
            apply(&mut e, var, d);
        }
        e
    }

    /// The chain at offsets `delta`, regenerated from its encoding.
    pub fn chain(&self, delta: &[f64]) -> Result<CurveChain<DVec2>> {
        chain_of(&self.encoding(delta))
    }

    /// The nodes at offsets `delta` by evaluating the chain (the node map's definition).
    #[cfg(test)]
    fn nodes_direct(&self, delta: &[f64]) -> Result<Vec<DVec2>> {
        let chain = self.chain(delta)?;
        Ok(self.params.iter().map(|&t| chain.eval(t)).collect())
    }

    /// Design variables.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.free.len()
    }

    /// The variables' names: `y3` (design point 3's y), `x5`, `rule0` (the aerofoil rule's
    /// leading-edge x), `rule1`, `rule2` (its trailing-edge x).
    #[must_use]
    pub fn names(&self) -> Vec<String> {
        self.free.iter().map(|&i| self.stored[i].name()).collect()
    }

    /// The stored numbers that follow the design variables so that the chord line stays.
    #[must_use]
    pub fn dependents(&self) -> Vec<String> {
        self.dependents.iter().map(|&i| self.stored[i].name()).collect()
    }

    /// The box of the offsets.
    #[must_use]
    pub fn bounds(&self) -> &[[f64; 2]] {
        &self.bounds
    }

    /// The start: zero offsets.
    #[must_use]
    pub fn start(&self) -> &[f64] {
        &self.zero
    }

    /// The start's encoding.
    #[must_use]
    pub fn start_encoding(&self) -> &Encoding {
        &self.start
    }

    /// The node parameters on the chain.
    #[must_use]
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// The node map.
    #[must_use]
    pub fn map(&self) -> &NodeMap {
        &self.map
    }

    /// The start's chord (model units).
    #[must_use]
    pub fn chord(&self) -> f64 {
        self.chord
    }
}

/// Add `d` to stored number `var` of `e`.
fn apply(e: &mut Encoding, var: Var, d: f64) {
    match var {
        Var::Y(k) => e.y[k] += d,
        Var::X(k) => {
            if let XStore::Free(x) = &mut e.x {
                x[k] += d;
            }
        }
        Var::Rule(k) => {
            if let XStore::AerofoilRule(t) = &mut e.x {
                t[k] += d;
            }
        }
    }
}

impl Var {
    fn name(self) -> String {
        match self {
            Var::Y(k) => format!("y{k}"),
            Var::X(k) => format!("x{k}"),
            Var::Rule(k) => format!("rule{k}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adaptive::{adapt_curve, AdaptOptions};
    use crate::geometry::test_contour;

    #[test]
    fn the_node_map_reproduces_the_chain_at_any_offsets() {
        let pts = test_contour("0012", 161);
        let a = adapt_curve(
            &pts,
            &AdaptOptions {
                tol: 1e-4,
                ..AdaptOptions::default()
            },
        )
        .unwrap();
        let stored = a.encoding.count().total - a.encoding.count().breaks;
        let similar = DesignSpace::new(&a.encoding, &Paneling::default(), 0.1, Hold::Similarity).unwrap();
        // The rule's two numbers and the two end y values.
        assert_eq!(similar.dependents().len(), 4, "{:?}", similar.dependents());
        let space = DesignSpace::new(&a.encoding, &Paneling::default(), 0.1, Hold::ChordLine).unwrap();
        // And the y nearest the leading edge.
        assert_eq!(space.dim() + space.dependents().len(), stored);
        assert_eq!(space.dependents().len(), 5, "{:?}", space.dependents());
        let delta: Vec<f64> = (0..space.dim())
            .map(|i| 0.01 * ((i as f64) * 1.7).sin())
            .collect();
        let by_map = space.map().nodes(&delta);
        let by_chain = space.nodes_direct(&delta).unwrap();
        for (a, b) in by_map.iter().zip(&by_chain) {
            assert!((*a - *b).length() < 1e-12, "{a} {b}");
        }
        // The leading edge and the trailing-edge midpoint do not move.
        let (c0, c1) = (space.chain(space.start()).unwrap(), space.chain(&delta).unwrap());
        let t_le = crate::aero::leading_edge_param(&c0);
        assert!((c0.eval(t_le) - c1.eval(t_le)).length() < 1e-12);
        for t in [0.0, 1.0] {
            assert!((c0.eval(t) - c1.eval(t)).length() < 1e-12);
        }
    }
}
