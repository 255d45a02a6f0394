//! One aerofoil analysed: its contour paneled, the panel method solved, coefficients and
//! pressures at any angle of attack.

use super::contour::{panel_params, Contour, Paneling, SplineContour};
use super::panel::{Coefficients, PanelSolution, MAX_NODES, MIN_NODES};
use crate::chain::CurveChain;
use crate::error::{Error, Result};
use glam::DVec2;

/// A contour's panel nodes (their parameters on it) and the solved panel method.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    /// The node parameters on the contour (see [`panel_params`]).
    pub params: Vec<f64>,
    /// The panel method on the nodes.
    pub solution: PanelSolution,
    /// How far the trailing edge's ends moved to close it where they overlapped
    /// ([`close_crossed_trailing_edge`](super::panel::close_crossed_trailing_edge)); `None`
    /// when they did not.
    pub te_closed: Option<f64>,
}

impl Analysis {
    /// Panel `contour` and solve. Trailing-edge ends that overlap are closed at their
    /// crossing ([`Analysis::te_closed`]); a contour whose panels cross anywhere else is
    /// refused ([`check_simple`](super::panel::check_simple)).
    pub fn of(contour: &dyn Contour, paneling: &Paneling) -> Result<Analysis> {
        let mut params = panel_params(contour, paneling)?;
        let mut nodes: Vec<DVec2> = params.iter().map(|&t| contour.point(t)).collect();
        let te_closed =
            super::panel::close_crossed_trailing_edge(&mut nodes, &mut params, &|t| contour.point(t));
        super::panel::check_simple(&nodes)?;
        Ok(Analysis {
            solution: PanelSolution::solve(&nodes)?,
            params,
            te_closed,
        })
    }

    /// Raw aerofoil coordinates (e.g. a `.dat` file's), through a [`SplineContour`].
    pub fn of_points(points: &[DVec2], paneling: &Paneling) -> Result<Analysis> {
        Self::of(&SplineContour::new(points)?, paneling)
    }

    /// A fitted or regenerated chain.
    pub fn of_chain(chain: &CurveChain<DVec2>, paneling: &Paneling) -> Result<Analysis> {
        Self::of(chain, paneling)
    }

    /// CL and CM at each angle (degrees).
    #[must_use]
    pub fn polar(&self, alphas: &[f64]) -> Vec<Coefficients> {
        alphas.iter().map(|&a| self.solution.coefficients(a)).collect()
    }
}

/// `Ok` when `bezchain aero` takes `alphas` (degrees) and `paneling`: at least one angle, each
/// finite and within ±90°, and [`MIN_NODES`]`..=`[`MAX_NODES`] nodes; otherwise the error it
/// prints, naming its options.
pub fn check_polar(alphas: &[f64], paneling: &Paneling) -> Result<()> {
    if alphas.is_empty() || alphas.iter().any(|a| !a.is_finite() || a.abs() > 90.0) {
        return Err(Error::invalid(
            "--alpha takes angles in degrees between -90 and 90",
        ));
    }
    if !(MIN_NODES..=MAX_NODES).contains(&paneling.nodes) {
        return Err(Error::invalid(format!(
            "--panels must be between {MIN_NODES} and {MAX_NODES}"
        )));
    }
    Ok(())
}

/// The chord as reported: leading edge, trailing-edge midpoint, length (model units).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ChordReport {
    /// The leading edge.
    pub le: [f64; 2],
    /// The trailing-edge midpoint.
    pub te: [f64; 2],
    /// Their distance.
    pub length: f64,
}

/// The pressure coefficient at every node at one angle.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pressure {
    /// Angle of attack, degrees.
    pub alpha: f64,
    /// `1 − γ²` at every node, in node order.
    pub cp: Vec<f64>,
}

/// What was analysed.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AeroInput {
    /// The input file as given.
    pub path: String,
    /// `coordinates` (a spline through the file's points) or `curve report` (its chain).
    pub kind: String,
    /// Points in the file (coordinates) or control points (report).
    pub points: usize,
}

/// The JSON report of `bezchain aero`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct AeroReport {
    /// The input.
    pub input: AeroInput,
    /// Panel nodes.
    pub nodes: usize,
    /// The paneling's trailing-edge density ratio.
    pub te_ratio: f64,
    /// `sharp` (gap below 1e-4 chord: bisector condition) or `blunt` (trailing-edge panel).
    pub trailing_edge: String,
    /// The trailing-edge gap, model units.
    pub te_gap: f64,
    /// The chord the coefficients are based on.
    pub chord: ChordReport,
    /// CL and CM (about the quarter chord) at every angle.
    pub polar: Vec<Coefficients>,
    /// The node positions, counterclockwise from the upper trailing edge.
    pub node_points: Vec<[f64; 2]>,
    /// Cp at every node, per angle.
    pub pressure: Vec<Pressure>,
}

impl AeroReport {
    /// The report of `analysis` at `alphas` (degrees).
    #[must_use]
    pub fn new(analysis: &Analysis, paneling: &Paneling, alphas: &[f64], input: AeroInput) -> Self {
        let s = &analysis.solution;
        let c = s.chord();
        let nodes = s.nodes();
        AeroReport {
            input,
            nodes: nodes.len(),
            te_ratio: paneling.te_ratio,
            trailing_edge: if s.sharp() { "sharp" } else { "blunt" }.into(),
            te_gap: (nodes[0] - nodes[nodes.len() - 1]).length(),
            chord: ChordReport {
                le: c.le.to_array(),
                te: c.te.to_array(),
                length: c.length,
            },
            polar: analysis.polar(alphas),
            node_points: nodes.iter().map(|p| p.to_array()).collect(),
            pressure: alphas
                .iter()
                .map(|&alpha| Pressure {
                    alpha,
                    cp: s.cp(alpha),
                })
                .collect(),
        }
    }
}
