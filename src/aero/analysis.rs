//! One aerofoil analysed: its contour paneled, the panel method solved, coefficients and
//! pressures at any angle of attack.

use super::contour::{panel_params, Contour, Paneling, SplineContour};
use super::panel::{Coefficients, PanelSolution};
use crate::chain::CurveChain;
use crate::error::Result;
use glam::DVec2;

/// A contour's panel nodes (their parameters on it) and the solved panel method.
#[derive(Clone, Debug, PartialEq)]
pub struct Analysis {
    /// The node parameters on the contour (see [`panel_params`]).
    pub params: Vec<f64>,
    /// The panel method on the nodes.
    pub solution: PanelSolution,
}

impl Analysis {
    /// Panel `contour` and solve.
    pub fn of(contour: &dyn Contour, paneling: &Paneling) -> Result<Analysis> {
        let params = panel_params(contour, paneling)?;
        let nodes: Vec<DVec2> = params.iter().map(|&t| contour.point(t)).collect();
        Ok(Analysis {
            solution: PanelSolution::solve(&nodes)?,
            params,
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
