//! A patch grid fitted by an evolutionary method, with the least-squares polish.

use crate::chain::GridLayout;
use crate::chain::PatchGrid;
use crate::error::Result;
use crate::optim::evo::{EvoHooks, EvoOptions};
use crate::optim::hybrid::{evolve_then_polish, EvoSummary};
use crate::optim::lsq::LsqOptions;
use crate::optim::method::Method;
use crate::optim::report::SolveReport;
use crate::problem::offset::{grid_offset_stats, Metric, OffsetStats};
use crate::problem::GridProblem;
use glam::DVec3;

/// A patch grid fitted by an evolutionary method.
#[derive(Clone, Debug, PartialEq)]
pub struct GridEvoFit {
    /// The fitted grid.
    pub grid: PatchGrid<DVec3>,
    /// Its closest-point offsets, re-measured in f64.
    pub closest: OffsetStats<DVec3>,
    /// Generations and evaluations of every stage, total seconds.
    pub report: SolveReport,
    /// The evolutionary run and the stages.
    pub summary: EvoSummary,
}

/// Fit a patch grid of `layout` to `points` by `algorithm` from the design net `start`, then
/// (with `polish_after`) polish by least squares. `params` (one `(u, v)` per point) start the
/// least-squares problem's foot points and serve no other purpose.
#[allow(clippy::too_many_arguments)]
pub fn fit_grid_evo(
    points: &[DVec3],
    params: Vec<[f64; 2]>,
    layout: GridLayout,
    start: &[DVec3],
    algorithm: Method,
    polish_after: bool,
    options: &EvoOptions,
    lsq: &LsqOptions,
    hooks: &mut EvoHooks<'_>,
) -> Result<GridEvoFit> {
    let problem = GridProblem::grid(layout, points, params, Metric::Closest)?
        .with_start(start.to_vec())?
        .with_bounds(options.margin)?;
    let (design, report, summary) = evolve_then_polish(
        &problem,
        &problem,
        algorithm,
        polish_after,
        options,
        lsq,
        None,
        hooks,
    )?;
    let grid = problem.patch_grid(&design)?;
    let closest = grid_offset_stats(&grid, points)?;
    Ok(GridEvoFit {
        grid,
        closest,
        report,
        summary,
    })
}
