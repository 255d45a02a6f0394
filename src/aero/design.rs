//! The design space of an aerodynamic optimisation: the stored numbers of an adapted
//! encoding ([`Encoding`], what `bezchain adapt` finds), as offsets from a start, bounded by a
//! box, with the linear map from those offsets to panel nodes.
//!
//! The variables are every stored y, every stored x (free layouts) and the numbers of the
//! aerofoil rule; stored breaks are held at the start's values (a break moves the basis
//! itself, so the nodes would no longer be linear in it). The control points are linear in
//! the variables, and the panel nodes sit at fixed parameters on the chain (placed once, on
//! the start shape, by [`panel_params`]), so the nodes are an affine function of the offsets:
//! [`NodeMap`], computed here from the encoding column by column and checked to be linear.

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

/// The design variables of an encoding, their box, and the node map.
#[derive(Clone, Debug, PartialEq)]
pub struct DesignSpace {
    start: Encoding,
    vars: Vec<Var>,
    bounds: Vec<[f64; 2]>,
    zero: Vec<f64>,
    params: Vec<f64>,
    map: NodeMap,
    chord: f64,
}

impl DesignSpace {
    /// The space around `start`: offsets bounded by `± margin × chord` (the start's chord),
    /// nodes placed on the start by `paneling`.
    pub fn new(start: &Encoding, paneling: &Paneling, margin: f64) -> Result<Self> {
        if !(margin > 0.0) || !margin.is_finite() {
            return Err(Error::invalid(format!(
                "the box margin must be a finite fraction > 0 of the chord, not {margin}"
            )));
        }
        let chain = chain_of(start)?;
        let params = panel_params(&chain, paneling)?;
        let base: Vec<DVec2> = params.iter().map(|&t| chain.eval(t)).collect();
        let chord = super::panel::Chord::of(&base).length;
        let mut vars: Vec<Var> = (0..start.y.len()).map(Var::Y).collect();
        match &start.x {
            XStore::Free(x) => vars.extend((0..x.len()).map(Var::X)),
            XStore::AerofoilRule(theta) => vars.extend((0..theta.len()).map(Var::Rule)),
        }
        let mut space = DesignSpace {
            start: start.clone(),
            bounds: vec![[-margin * chord, margin * chord]; vars.len()],
            zero: vec![0.0; vars.len()],
            vars,
            params,
            map: NodeMap {
                base: base.clone(),
                columns: Vec::new(),
            },
            chord,
        };
        let scale = base.iter().fold(chord, |m, p| m.max(p.abs().max_element()));
        for i in 0..space.vars.len() {
            let mut unit = vec![0.0; space.vars.len()];
            unit[i] = 1.0;
            let one = space.nodes_direct(&unit)?;
            unit[i] = 2.0;
            let two = space.nodes_direct(&unit)?;
            let col: Vec<DVec2> = one.iter().zip(&base).map(|(a, b)| *a - *b).collect();
            // Linear: twice the offset moves every node twice as far.
            let off = two
                .iter()
                .zip(&base)
                .zip(&col)
                .map(|((t, b), c)| (*t - *b - 2.0 * *c).length())
                .fold(0.0, f64::max);
            if off > 1e-9 * scale {
                return Err(Error::Numerical(format!(
                    "the nodes are not linear in design variable {i} (off by {off:.3e})"
                )));
            }
            space.map.columns.push(col);
        }
        Ok(space)
    }

    /// The encoding at offsets `delta`.
    #[must_use]
    pub fn encoding(&self, delta: &[f64]) -> Encoding {
        let mut e = self.start.clone();
        for (v, &d) in self.vars.iter().zip(delta) {
            match *v {
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
        e
    }

    /// The chain at offsets `delta`, regenerated from its encoding.
    pub fn chain(&self, delta: &[f64]) -> Result<CurveChain<DVec2>> {
        chain_of(&self.encoding(delta))
    }

    /// The nodes at offsets `delta` by evaluating the chain (the node map's definition).
    fn nodes_direct(&self, delta: &[f64]) -> Result<Vec<DVec2>> {
        let chain = self.chain(delta)?;
        Ok(self.params.iter().map(|&t| chain.eval(t)).collect())
    }

    /// Design variables.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.vars.len()
    }

    /// The variables' names: `y3` (design point 3's y), `x5`, `rule0` (the aerofoil rule's
    /// leading-edge x), `rule1`, `rule2` (its trailing-edge x).
    #[must_use]
    pub fn names(&self) -> Vec<String> {
        self.vars
            .iter()
            .map(|v| match v {
                Var::Y(k) => format!("y{k}"),
                Var::X(k) => format!("x{k}"),
                Var::Rule(k) => format!("rule{k}"),
            })
            .collect()
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

impl crate::fit::evo::SearchSpace for DesignSpace {
    fn dim(&self) -> usize {
        self.vars.len()
    }
    fn bounds(&self) -> &[[f64; 2]] {
        &self.bounds
    }
    fn start(&self) -> &[f64] {
        &self.zero
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::adaptive::{adapt_curve, AdaptOptions};
    use crate::geometry::{Naca, NacaOptions};

    #[test]
    fn the_node_map_reproduces_the_chain_at_any_offsets() {
        let pts = Naca::parse("0012")
            .unwrap()
            .contour(&NacaOptions {
                points: 161,
                ..NacaOptions::default()
            })
            .unwrap();
        let a = adapt_curve(
            &pts,
            &AdaptOptions {
                tol: 1e-4,
                ..AdaptOptions::default()
            },
        )
        .unwrap();
        let space = DesignSpace::new(&a.encoding, &Paneling::default(), 0.1).unwrap();
        assert_eq!(space.dim(), a.encoding.count().total - a.encoding.count().breaks);
        let delta: Vec<f64> = (0..space.dim())
            .map(|i| 0.01 * ((i as f64) * 1.7).sin())
            .collect();
        let by_map = space.map().nodes(&delta);
        let by_chain = space.nodes_direct(&delta).unwrap();
        for (a, b) in by_map.iter().zip(&by_chain) {
            assert!((*a - *b).length() < 1e-12, "{a} {b}");
        }
        assert!(space.names().iter().any(|n| n == "y0"));
    }
}
