//! The GA and CMA-ES on patch grids: a small grid with a known optimum, the least-squares
//! polish, and checkpoint/resume identity with two parameters per point.

use bezchain::chain::{ChainLayout, Continuity, GridLayout, PatchGrid};
use bezchain::eval::Backend;
use bezchain::fit::fit_grid_evo;
use bezchain::optim::evo::{
    evolve, Algorithm, Checkpoint, EvoHooks, EvoOptions, Evolution, PopulationObjective,
};
use bezchain::optim::LsqOptions;
use bezchain::problem::{GridProblem, Metric};
use glam::DVec3;

/// A grid problem: points, their uniform start parameters, the layout and the start net.
struct Case {
    points: Vec<DVec3>,
    params: Vec<[f64; 2]>,
    layout: GridLayout,
    start: Vec<DVec3>,
}

/// A biquadratic 2 x 2 grid (4 x 4 design points, 48 variables), 144 points on it at
/// non-uniform parameters, and the start: the least-squares net at uniform parameters.
fn case() -> Case {
    let chain = ChainLayout::uniform(2, 2, Continuity::C1).unwrap();
    let layout = GridLayout::new(chain.clone(), chain);
    let (nu, nv) = layout.design_shape();
    let design: Vec<DVec3> = (0..nu * nv)
        .map(|k| {
            let (x, y) = (
                (k / nv) as f64 / (nu - 1) as f64,
                (k % nv) as f64 / (nv - 1) as f64,
            );
            DVec3::new(x, y, 0.2 * (2.5 * x).sin() * (1.0 + y * y))
        })
        .collect();
    let truth = PatchGrid::new(layout.clone(), design).unwrap();
    let mut points = Vec::new();
    let mut params = Vec::new();
    for i in 0..12 {
        for j in 0..12 {
            let (a, b) = (i as f64 / 11.0, j as f64 / 11.0);
            points.push(truth.eval(a.powf(1.4), b.powf(0.8)));
            params.push([a, b]);
        }
    }
    let problem = GridProblem::grid(layout.clone(), &points, params.clone(), Metric::Closest).unwrap();
    let start = problem.linear_fit(&params).unwrap();
    Case {
        points,
        params,
        layout,
        start,
    }
}

fn options(population: usize, generations: usize) -> EvoOptions {
    EvoOptions {
        population: Some(population),
        generations: Some(generations),
        backend: Backend::Cpu,
        samples: 8,
        ..EvoOptions::default()
    }
}

#[test]
fn cmaes_and_the_ga_fit_a_grid_and_the_polish_reaches_the_optimum() {
    let Case {
        points,
        params,
        layout,
        start,
    } = case();
    let evo = GridProblem::grid(layout.clone(), &points, params.clone(), Metric::Closest)
        .and_then(|p| p.with_start(start.clone()))
        .and_then(|p| p.with_bounds(0.1))
        .unwrap();
    assert_eq!(PopulationObjective::dim(&evo), 48);
    let first = evo.measure(evo.start_flat(), &options(4, 1)).unwrap();
    let es = evolve(
        &evo,
        Algorithm::Cmaes,
        &options(48, 150),
        &mut EvoHooks::default(),
    )
    .unwrap();
    let ga = evolve(&evo, Algorithm::Ga, &options(128, 60), &mut EvoHooks::default()).unwrap();
    eprintln!("start {first:.3e}  cmaes {:.3e}  ga {:.3e}", es.sum_sq, ga.sum_sq);
    // 48 variables with flat tangential directions: short runs gain over an order of magnitude
    // (measured: CMA-ES 1.5e-4 and the GA 2.2e-4 from 8.1e-3; CMA-ES reaches 1.1e-5 in 500
    // generations), and the polish takes it from there to the optimum.
    assert!(es.sum_sq < 0.05 * first, "cmaes {:e} from {first:e}", es.sum_sq);
    assert!(ga.sum_sq < 0.1 * first, "ga {:e} from {first:e}", ga.sum_sq);
    let fit = fit_grid_evo(
        &points,
        params,
        layout,
        &start,
        Algorithm::Ga,
        true,
        &options(64, 20),
        &LsqOptions::default(),
        &mut EvoHooks::default(),
    )
    .unwrap();
    let stages: Vec<&str> = fit.summary.stages.iter().map(|s| s.method.as_str()).collect();
    assert_eq!(stages, ["ga", "lsq"]);
    assert!(
        fit.closest.sum_sq < 1e-18,
        "polished grid: {:e}",
        fit.closest.sum_sq
    );
    assert!(fit.grid.continuity_error() < 1e-9);
}

#[test]
fn a_resumed_grid_run_ends_identical() {
    let Case {
        points,
        params,
        layout,
        start,
    } = case();
    let evo = GridProblem::grid(layout, &points, params, Metric::Closest)
        .and_then(|p| p.with_start(start))
        .and_then(|p| p.with_bounds(0.1))
        .unwrap();
    let opts = EvoOptions {
        reproject_every: 2,
        ..options(24, 12)
    };
    for algorithm in [Algorithm::Ga, Algorithm::Cmaes] {
        let mut straight = Evolution::new(&evo, algorithm, &opts).unwrap();
        let mut saved = None;
        straight
            .run(|e| {
                if e.generation() == 5 {
                    saved = Some(e.checkpoint().to_bytes());
                }
                Ok(())
            })
            .unwrap();
        let ck = Checkpoint::from_bytes(&saved.unwrap()).unwrap();
        assert!(ck.params.iter().any(|p| p[1] > 0.0), "grid parameters are (u, v)");
        let mut resumed = Evolution::resume(&evo, algorithm, &opts, &ck).unwrap();
        resumed.run(|_| Ok(())).unwrap();
        let (a, b) = (straight.checkpoint(), resumed.checkpoint());
        assert_eq!(a.best, b.best, "{algorithm}");
        assert_eq!(a.population, b.population);
        assert_eq!(a.cmaes, b.cmaes);
    }
}
