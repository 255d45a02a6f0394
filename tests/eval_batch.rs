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

#[test]
fn case_1_far_from_the_origin_gives_the_sums_it_gives_at_the_origin() {
    // Case 1's data, design and population moved by +1000 in x and y. With absolute
    // f32 coordinates `bezchain eval` gave 1.15e-7 instead of 1.468e-8 on both backends; the
    // door now reads rows in f64 and measures every individual against the first in f64.
    use bezchain::chain::ChainLayout;
    use bezchain::fit::{fit_curve, FitOptions};
    let pts = bezchain::geometry::read_curve(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/naca4413.dat"
    )))
    .unwrap()
    .points;
    let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
    let fit = fit_curve(&pts, layout.clone(), &FitOptions::default()).unwrap();
    let design: Vec<f64> = fit.chain.design().iter().flat_map(|p| [p.x, p.y]).collect();
    // The fit, then individuals around it at the spreads of a converging population.
    let mut population = design.clone();
    for (k, spread) in [1e-6, 1e-5, 1e-4, 1e-3].iter().enumerate() {
        for j in 0..5 {
            population.extend(
                design
                    .iter()
                    .enumerate()
                    .map(|(i, x)| x + spread * ((i * 7 + j * 13 + k) as f64 * 0.7).sin()),
            );
        }
    }
    let shift = DVec2::new(1000.0, 1000.0);
    let far_pts: Vec<DVec2> = pts.iter().map(|p| *p + shift).collect();
    let far_pop: Vec<f64> = population.iter().map(|x| x + 1000.0).collect();
    let mut backends = vec![Backend::Cpu];
    if gpu().is_some() {
        backends.push(Backend::Gpu);
    }
    for backend in backends {
        let o = BatchOptions {
            backend,
            ..BatchOptions::default()
        };
        let here = eval_curve_population(&layout, &pts, &population, &o).unwrap();
        let there = eval_curve_population(&layout, &far_pts, &far_pop, &o).unwrap();
        let d = here
            .fitness
            .iter()
            .zip(&there.fitness)
            .map(|(a, b)| rel(a.sum_sq.into(), b.sum_sq.into()))
            .fold(0.0, f64::max);
        eprintln!(
            "case 1 on {backend}: sum_sq {:e} at the origin, {:e} at +1000 (individuals within {d:.1e})",
            here.fitness[0].sum_sq, there.fitness[0].sum_sq
        );
        assert!(d <= 1e-4, "{backend}: shifted sums differ by {d:e}");
        // The first individual is the lsq fit: its f32 sum is the f64 report's to the door's
        // accuracy (offsets to 2⁻²⁴ of the extent: here residuals of 1.3e-5 to 3e-8).
        let s = f64::from(there.fitness[0].sum_sq);
        assert!(
            rel(s, fit.closest.sum_sq) < 1e-2,
            "{s:e} vs {:e}",
            fit.closest.sum_sq
        );
    }
}

/// `Backend::Auto` takes a hardware GPU only: on a software adapter (lavapipe, on the same cores
/// and slower than the CPU kernels) it takes the CPU and says why; the panel method's kernel
/// takes the CPU under Auto wherever it runs.
#[test]
fn auto_takes_a_hardware_gpu_only() {
    let Some(ctx) = gpu() else {
        return;
    };
    let case = curve_case(103, 3, 4, Continuity::C1, 60, 8, 4e-3, 4e-3);
    let EvalLayout::Curve(layout) = &case.layout else {
        unreachable!()
    };
    let points: Vec<DVec2> = case.targets.points().iter().map(|p| p.truncate()).collect();
    let auto = eval_curve_population(layout, &points, &case.population, &BatchOptions::default()).unwrap();
    eprintln!("Auto on {}: {}", ctx.adapter(), auto.info);
    if ctx.is_software() {
        assert_eq!(auto.info.backend, Backend::Cpu);
        let why = auto.info.fallback.as_deref().unwrap_or_default();
        assert!(why.contains("software adapter"), "{why}");
    } else {
        assert_eq!(auto.info.backend, Backend::Gpu);
    }

    use bezchain::aero::{
        build_aero_evaluator, AeroBatch, Analysis, Constraints, NodeMap, Objective, Paneling,
    };
    let pts = bezchain::geometry::read_curve(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/naca4413.dat"
    )))
    .unwrap()
    .points;
    let a = Analysis::of_points(&pts, &Paneling::default()).unwrap();
    let map = NodeMap {
        base: a.solution.nodes().to_vec(),
        columns: vec![],
    };
    let b = AeroBatch::new(map, 4.0, Objective::MaxCl, Constraints::default()).unwrap();
    let ev = build_aero_evaluator(&b.kernel(), Backend::Auto, &Default::default()).unwrap();
    assert_eq!(ev.info().backend, Backend::Cpu, "{}", ev.info());
}
