//! The `bezchain eval` door: closest-point fitness of a population file's individuals, the
//! same on the CPU and the GPU and within 1e-4 of the f64 closest points.

mod eval_support;

use bezchain::chain::Continuity;
use bezchain::eval::{Backend, EvalLayout};
use bezchain::fit::population::{eval_curve_population, eval_grid_population, BatchOptions, BatchResult};
use bezchain::Error;
use eval_support::*;
use glam::DVec2;

/// f32 door against the f64 closest points, relative, on `sum_sq` and `max`.
const TOL: f64 = 1e-4;

/// The door on every backend this machine has, checked against `truth`.
fn every_backend(name: &str, truth: &[(f64, f64)], run: impl Fn(&BatchOptions) -> BatchResult) {
    let mut backends = vec![Backend::Cpu];
    if gpu().is_some() {
        backends.push(Backend::Gpu);
    }
    let mut first: Option<BatchResult> = None;
    for backend in backends {
        let result = run(&BatchOptions {
            backend,
            ..BatchOptions::default()
        });
        assert_eq!(result.info.backend, backend);
        let (s, m) = worst_against(&result.fitness, truth);
        eprintln!(
            "{name} via {}: sum_sq within {s:.1e}, max within {m:.1e} of f64",
            result.info
        );
        assert!(s <= TOL && m <= TOL, "{name} on {backend}: {s:e} {m:e}");
        if let Some(f) = &first {
            let d = f
                .fitness
                .iter()
                .zip(&result.fitness)
                .map(|(a, b)| rel(a.sum_sq.into(), b.sum_sq.into()))
                .fold(0.0, f64::max);
            assert!(d <= TOL, "{name}: backends differ by {d:e}");
        } else {
            first = Some(result);
        }
    }
}

#[test]
fn curve_populations_get_closest_point_offsets() {
    // Data scattered about the shape with parameters the door never sees.
    let case = curve_case(101, 3, 5, Continuity::C1, 160, 40, 4e-3, 4e-3);
    let EvalLayout::Curve(layout) = &case.layout else {
        unreachable!()
    };
    let points: Vec<DVec2> = case.targets.points().iter().map(|p| p.truncate()).collect();
    let truth = truth_closest(&case);
    every_backend("curve", &truth, |o| {
        eval_curve_population(layout, &points, &case.population, o).unwrap()
    });
}

#[test]
fn grid_populations_get_closest_point_offsets() {
    let case = grid_case(102, (3, 3), (2, 2), Continuity::C1, 250, 20, 4e-3, 4e-3);
    let EvalLayout::Grid(layout) = &case.layout else {
        unreachable!()
    };
    let truth = truth_closest(&case);
    every_backend("grid", &truth, |o| {
        eval_grid_population(layout, case.targets.points(), &case.population, o).unwrap()
    });
}

#[test]
fn bad_population_files_are_input_errors() {
    let case = curve_case(103, 3, 2, Continuity::C1, 10, 3, 1e-2, 1e-2);
    let EvalLayout::Curve(layout) = &case.layout else {
        unreachable!()
    };
    let points: Vec<DVec2> = case.targets.points().iter().map(|p| p.truncate()).collect();
    let o = BatchOptions {
        backend: Backend::Cpu,
        ..BatchOptions::default()
    };
    let bad = |pop: &[f32]| match eval_curve_population(layout, &points, pop, &o) {
        Err(e @ Error::Invalid(_)) => assert!(e.is_user_error()),
        other => panic!("expected an input error, got {other:?}"),
    };
    bad(&[]);
    bad(&case.population[..case.population.len() - 1]);
    let mut nan = case.population.clone();
    nan[1] = f32::NAN;
    bad(&nan);
}
