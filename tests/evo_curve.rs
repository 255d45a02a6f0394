//! The GA and CMA-ES on curve chains: convergence on a problem with a known optimum,
//! bit-identical reruns (whatever the thread count), checkpoint/resume identity, refused
//! checkpoints and options, and CPU/GPU parity.

mod common;
mod eval_support;

use bezchain::chain::{ChainLayout, Continuity, CurveChain};
use bezchain::eval::Backend;
use bezchain::fit::{fit_curve, FitOptions, Method};
use bezchain::optim::evo::{
    evolve, Algorithm, Checkpoint, EvoHooks, EvoOptions, EvoResult, EvoStop, Evolution, PopulationObjective,
};
use bezchain::problem::{offset_stats, CurveProblem, Metric};
use bezchain::Error;
use glam::DVec2;

/// 61 points on a chain of degree 3 with 3 segments (8 design points, 16 variables): the
/// closest-point optimum is 0, at the chain itself.
fn exact_case() -> (Vec<DVec2>, ChainLayout, CurveChain<DVec2>) {
    let layout = ChainLayout::uniform(3, 3, Continuity::C1).unwrap();
    let design: Vec<DVec2> = (0..layout.design_count())
        .map(|k| {
            let a = std::f64::consts::PI * k as f64 / (layout.design_count() - 1) as f64;
            DVec2::new(0.5 - 0.5 * a.cos(), 0.25 * a.sin() + 0.05 * (3.0 * a).sin())
        })
        .collect();
    let chain = CurveChain::new(layout.clone(), design).unwrap();
    let points = (0..61).map(|i| chain.eval(i as f64 / 60.0)).collect();
    (points, layout, chain)
}

fn options(population: usize, generations: usize) -> EvoOptions {
    EvoOptions {
        population: Some(population),
        generations: Some(generations),
        backend: Backend::Cpu,
        ..EvoOptions::default()
    }
}

/// The fitting problem of a chain through `points`, ends anchored, in a box grown by 0.1 of
/// the data's extent (what `fit --method ga` optimises).
fn evo_problem(points: &[DVec2], layout: ChainLayout) -> CurveProblem<'_, DVec2> {
    CurveProblem::curve(layout, points, Metric::Closest)
        .and_then(|p| p.with_bounds(0.1))
        .unwrap()
}

/// The f64 objective of `design` (48 samples a segment).
fn measure(problem: &CurveProblem<'_, DVec2>, design: &[f64]) -> f64 {
    PopulationObjective::measure(problem, design, &EvoOptions::default()).unwrap()
}

fn run(problem: &CurveProblem<'_, DVec2>, algorithm: Algorithm, opts: &EvoOptions) -> EvoResult {
    evolve(problem, algorithm, opts, &mut EvoHooks::default()).unwrap()
}

fn bits(x: &[f64]) -> Vec<u64> {
    x.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn both_methods_approach_the_known_optimum() {
    let (points, layout, truth) = exact_case();
    let problem = evo_problem(&points, layout);
    let start = measure(&problem, problem.start_flat());
    let ga = run(&problem, Algorithm::Ga, &options(256, 300));
    let es = run(&problem, Algorithm::Cmaes, &options(64, 400));
    eprintln!(
        "start {start:.3e}  ga {:.3e}  cmaes {:.3e} ({})",
        ga.sum_sq, es.sum_sq, es.stop
    );
    // The GA gains almost four orders of magnitude (2.7e-6 from 1.8e-2: fine convergence is
    // its weak side), CMA-ES ten or more.
    assert!(ga.sum_sq < 2e-4 * start, "ga {:e} from {start:e}", ga.sum_sq);
    assert!(es.sum_sq < 1e-10 * start, "cmaes {:e} from {start:e}", es.sum_sq);
    // The f64 re-measure agrees with the library's closest-point offsets (anchored ends sit
    // on the data ends here, so both measure the same thing at the optimum).
    let design: Vec<DVec2> = es.design.chunks(2).map(|c| DVec2::new(c[0], c[1])).collect();
    let chain = CurveChain::new(truth.layout().clone(), design.clone()).unwrap();
    let stats = offset_stats(&chain, &points).unwrap();
    assert!(
        stats.sum_sq <= es.sum_sq * 1.001 + 1e-15,
        "{:e} vs {:e}",
        stats.sum_sq,
        es.sum_sq
    );
    // And it is the truth: every design point within 1e-3 of the chain's extent.
    for (a, b) in design.iter().zip(truth.design()) {
        assert!((*a - *b).length() < 1e-3, "{a} vs {b}");
    }
    // Reports count what ran.
    assert_eq!(ga.report.iterations, 300);
    assert_eq!(ga.report.evaluations, 256 * 301);
    assert_eq!(ga.history.len(), 301);
    assert!(
        ga.history.windows(2).all(|w| w[1].best <= w[0].best),
        "elitism keeps the best"
    );
    assert!(ga.evals_per_second > 0.0 && ga.point_evals == 256 * 301 * 59);
}

#[test]
fn the_same_seed_gives_bit_identical_runs_on_any_thread_count() {
    let (points, layout, _) = exact_case();
    let problem = evo_problem(&points, layout);
    for (algorithm, size) in [(Algorithm::Ga, 96), (Algorithm::Cmaes, 40)] {
        let opts = options(size, 25);
        let pool = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
        };
        let a = pool(1).install(|| run(&problem, algorithm, &opts));
        let b = pool(3).install(|| run(&problem, algorithm, &opts));
        let c = run(&problem, algorithm, &opts);
        assert_eq!(bits(&a.design), bits(&b.design), "{algorithm}: 1 vs 3 threads");
        assert_eq!(bits(&a.design), bits(&c.design), "{algorithm}: rerun");
        let best = |r: &EvoResult| r.history.iter().map(|h| h.best.to_bits()).collect::<Vec<_>>();
        assert_eq!(best(&a), best(&b));
        // Another seed takes another path.
        let other = run(
            &problem,
            algorithm,
            &EvoOptions {
                seed: 2,
                ..opts.clone()
            },
        );
        assert_ne!(bits(&a.design), bits(&other.design), "{algorithm}: seed 2");
    }
}

#[test]
fn a_resumed_run_ends_identical_to_an_uninterrupted_one() {
    let (points, layout, _) = exact_case();
    let problem = evo_problem(&points, layout);
    for (algorithm, size) in [(Algorithm::Ga, 64), (Algorithm::Cmaes, 32)] {
        // Checkpoints taken every 5 generations, as the CLI does; projection every 3, so the
        // resumed run must restore the evaluator's parameters too.
        let opts = EvoOptions {
            reproject_every: 3,
            ..options(size, 40)
        };
        let mut straight = Evolution::new(&problem, algorithm, &opts).unwrap();
        let mut saved = None;
        straight
            .run(|e| {
                if e.generation() == 20 {
                    saved = Some(e.checkpoint().to_bytes());
                }
                Ok(())
            })
            .unwrap();
        let end = straight.checkpoint();
        let ck = Checkpoint::from_bytes(&saved.unwrap()).unwrap();
        assert_eq!(ck.generation, 20);
        let mut resumed = Evolution::resume(&problem, algorithm, &opts, &ck).unwrap();
        resumed.run(|_| Ok(())).unwrap();
        let back = resumed.checkpoint();
        assert_eq!(back.generation, 40);
        assert_eq!(back.best, end.best, "{algorithm}: best individual");
        assert_eq!(back.population, end.population, "{algorithm}: population");
        assert_eq!(back.scores, end.scores);
        assert_eq!(back.cmaes, end.cmaes, "{algorithm}: strategy");
        assert_eq!(back.params, end.params);
        let h = |c: &Checkpoint| {
            c.history
                .iter()
                .map(|p| (p.best.to_bits(), p.evaluations))
                .collect::<Vec<_>>()
        };
        assert_eq!(h(&back), h(&end));
    }
}

/// CMA-ES with restarts: each converged run (here a coarse step-size tolerance makes them
/// short) starts again from the origin; the count reaches the result, a restart's stall
/// window starts afresh, and a run resumed from a checkpoint taken after a restart ends
/// bit-identical to the uninterrupted one (the restart count and the kept mean are in it).
#[test]
fn cmaes_restarts_converged_runs_and_resumes_across_them() {
    let (points, layout, _) = exact_case();
    let problem = evo_problem(&points, layout);
    let mut opts = options(16, 150);
    opts.cmaes.tol_x = 2e-3;
    opts.cmaes.restarts = 3;
    let mut straight = Evolution::new(&problem, Algorithm::Cmaes, &opts).unwrap();
    let mut saved = Vec::new();
    let mut first_restart = None;
    let why = straight
        .run(|e| {
            if e.restarts() == 1 && first_restart.is_none() {
                first_restart = Some(e.generation());
            }
            saved.push(e.checkpoint().to_bytes());
            Ok(())
        })
        .unwrap();
    let first = first_restart.expect("a run converged and restarted");
    let end = straight.checkpoint();
    let restarts = end.cmaes.as_ref().unwrap().restarts;
    // Either all three restarts converged (the last one's reason ends the run) or the
    // generation limit cut the last one.
    assert!(
        restarts == 3 || why == EvoStop::Generations,
        "{restarts} restarts, {why}"
    );
    assert!(restarts >= 2, "{restarts} restarts in 150 generations");
    let kept = &end.cmaes.as_ref().unwrap().kept_mean;
    assert_eq!(kept.len(), problem.dim(), "a converged mean is kept");
    let ck = Checkpoint::from_bytes(&saved[first as usize + 2]).unwrap();
    assert_eq!(ck.cmaes.as_ref().unwrap().restarts, 1);
    let mut resumed = Evolution::resume(&problem, Algorithm::Cmaes, &opts, &ck).unwrap();
    assert_eq!(resumed.run(|_| Ok(())).unwrap(), why);
    let back = resumed.checkpoint();
    assert_eq!(back.cmaes, end.cmaes, "strategy, restarts and kept mean");
    assert_eq!(back.best, end.best);
    let result = straight.finish(why).unwrap();
    assert_eq!(result.restarts, restarts);
    // The result is at least as good as the kept mean, re-measured.
    let kept_abs = problem.absolute(kept);
    assert!(
        result.sum_sq <= measure(&problem, &kept_abs),
        "{:e}",
        result.sum_sq
    );
    // Without restarts the same options stop at the first convergence.
    opts.cmaes.restarts = 0;
    let once = run(&problem, Algorithm::Cmaes, &opts);
    assert_eq!((once.restarts, once.report.iterations as u64), (0, first - 1));
}

#[test]
fn checkpoints_of_other_runs_and_bad_options_are_refused() {
    let (points, layout, _) = exact_case();
    let problem = evo_problem(&points, layout.clone());
    let opts = options(16, 3);
    let mut e = Evolution::new(&problem, Algorithm::Ga, &opts).unwrap();
    e.step().unwrap();
    let ck = e.checkpoint();
    let refused =
        |p: &CurveProblem<'_, DVec2>, a: Algorithm, o: &EvoOptions| match Evolution::resume(p, a, o, &ck) {
            Err(Error::Invalid(m)) => m,
            Err(other) => panic!("expected Invalid, got {other}"),
            Ok(_) => panic!("a foreign checkpoint was accepted"),
        };
    let mut moved = points.clone();
    moved[7].y += 1e-9;
    let other_data = evo_problem(&moved, layout.clone());
    assert!(refused(&other_data, Algorithm::Ga, &opts).contains("another problem"));
    let other_layout = evo_problem(&points, ChainLayout::uniform(2, 4, Continuity::C1).unwrap());
    assert!(refused(&other_layout, Algorithm::Ga, &opts).contains("another problem"));
    assert!(refused(
        &problem,
        Algorithm::Ga,
        &EvoOptions {
            seed: 9,
            ..opts.clone()
        }
    )
    .contains("another problem"));
    assert!(refused(&problem, Algorithm::Cmaes, &opts).contains("ga run"));
    // The generation limit may change on resume.
    assert!(Evolution::resume(
        &problem,
        Algorithm::Ga,
        &EvoOptions {
            generations: Some(9),
            ..opts.clone()
        },
        &ck
    )
    .is_ok());
    // Options out of range.
    let bad = [
        EvoOptions {
            population: Some(3),
            ..opts.clone()
        },
        EvoOptions {
            generations: Some(0),
            ..opts.clone()
        },
        EvoOptions {
            spread: -0.1,
            ..opts.clone()
        },
        EvoOptions {
            target: f64::NAN,
            ..opts.clone()
        },
        EvoOptions {
            reproject_every: 0,
            ..opts.clone()
        },
    ];
    for o in bad {
        assert!(
            matches!(
                Evolution::new(&problem, Algorithm::Ga, &o),
                Err(Error::Invalid(_))
            ),
            "{o:?}"
        );
    }
    let mut o = opts.clone();
    o.ga.mutation_rate = Some(-0.5);
    assert!(matches!(
        Evolution::new(&problem, Algorithm::Ga, &o),
        Err(Error::Invalid(_))
    ));
}

#[test]
fn stops_on_target_and_stall() {
    let (points, layout, _) = exact_case();
    let problem = evo_problem(&points, layout);
    let target = EvoOptions {
        target: 1e-4,
        ..options(64, 500)
    };
    let r = run(&problem, Algorithm::Cmaes, &target);
    assert_eq!(r.stop.to_string(), "target reached");
    assert!(r.score.sum_sq <= 1e-4 && r.report.iterations < 500);
    let stall = EvoOptions {
        stall_generations: 5,
        stall_tolerance: 0.99,
        ..options(32, 500)
    };
    let r = run(&problem, Algorithm::Ga, &stall);
    assert_eq!(r.stop.to_string(), "stalled");
    assert!(r.report.iterations < 100);
}

#[test]
fn fit_curve_runs_the_hybrids_to_the_least_squares_optimum() {
    let (points, layout, _) = exact_case();
    let mut opts = FitOptions {
        method: Method::GaLsq,
        evo: options(64, 30),
        ..FitOptions::default()
    };
    let hybrid = fit_curve(&points, layout.clone(), &opts).unwrap();
    let evo = hybrid.evolution.as_ref().unwrap();
    assert_eq!(
        evo.stages.iter().map(|s| s.method.as_str()).collect::<Vec<_>>(),
        ["ga", "lsq"]
    );
    assert!(evo.run.sum_sq > 1e-12, "the short GA alone is not at the optimum");
    assert!(
        hybrid.closest.sum_sq < 1e-20,
        "polished: {:e}",
        hybrid.closest.sum_sq
    );
    assert_eq!(
        hybrid.report.iterations,
        evo.stages[0].report.iterations + evo.stages[1].report.iterations
    );
    opts.method = Method::Cmaes;
    opts.metric = bezchain::problem::Metric::Corresponding;
    assert!(matches!(
        fit_curve(&points, layout, &opts),
        Err(Error::Invalid(_))
    ));
}

/// CPU and GPU reach the same best offset within the parity tolerance (1e-4 relative).
#[test]
fn cpu_and_gpu_reach_the_same_best_offset() {
    if eval_support::gpu().is_none() {
        return;
    }
    let (points, layout, _) = exact_case();
    let problem = evo_problem(&points, layout);
    for (algorithm, size, generations) in [(Algorithm::Ga, 128, 40), (Algorithm::Cmaes, 48, 60)] {
        let cpu = run(&problem, algorithm, &options(size, generations));
        let gpu = run(
            &problem,
            algorithm,
            &EvoOptions {
                backend: Backend::Gpu,
                ..options(size, generations)
            },
        );
        assert_eq!(gpu.backend.backend, Backend::Gpu);
        let rel = (cpu.sum_sq - gpu.sum_sq).abs() / cpu.sum_sq;
        eprintln!(
            "{algorithm}: cpu {:.6e} gpu {:.6e} rel {rel:.1e}",
            cpu.sum_sq, gpu.sum_sq
        );
        assert!(
            rel <= 1e-4,
            "{algorithm}: cpu {:e} gpu {:e}",
            cpu.sum_sq,
            gpu.sum_sq
        );
    }
}

/// Case 1 (degree 3, 5 segments) moved 1000 chords from the origin (+1000 in
/// x and y) evolves as it does at the origin. The problem is centred on its box and the
/// evaluator anchored at the best design, so the two runs see the same f32 numbers up to the
/// rounding of the data's move: CMA-ES (λ = 128, to its flatness stop, in a minimum of
/// 2.76e-8) ends within 1 % on every backend. (With the default λ = 13 both reach 2.062e-8
/// on both backends, a 45 s test; before the centring the far run stopped at 8e-6.)
#[test]
fn case_1_far_from_the_origin_evolves_as_at_the_origin() {
    let points = common::naca4413();
    let far: Vec<DVec2> = points.iter().map(|p| *p + DVec2::splat(1000.0)).collect();
    let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
    for backend in backends() {
        let opts = FitOptions {
            method: Method::Cmaes,
            evo: EvoOptions {
                population: Some(128),
                backend,
                ..EvoOptions::default()
            },
            ..FitOptions::default()
        };
        let near = fit_curve(&points, layout.clone(), &opts).unwrap();
        let moved = fit_curve(&far, layout.clone(), &opts).unwrap();
        let (a, b) = (near.closest.sum_sq, moved.closest.sum_sq);
        eprintln!(
            "case 1 cmaes on {backend:?}: {a:.6e} at the origin, {b:.6e} at +1000 ({} generations)",
            near.report.iterations
        );
        assert!((a - b).abs() <= 0.01 * a, "{backend:?}: {a:e} against {b:e}");
    }
}

/// The paper's case `(degree, segments)` on NACA 4413 by `method`, P 1024, at most 500
/// generations, seed 1 (what `bezchain compare` runs), on `backend`: the f64 closest-point sum.
fn paper_case(degree: usize, segments: usize, method: Method, backend: Backend) -> f64 {
    let points = common::naca4413();
    let layout = ChainLayout::uniform(degree, segments, Continuity::C1).unwrap();
    let opts = FitOptions {
        method,
        evo: EvoOptions {
            population: Some(1024),
            generations: Some(500),
            backend,
            ..EvoOptions::default()
        },
        ..FitOptions::default()
    };
    fit_curve(&points, layout, &opts).unwrap().closest.sum_sq
}

/// The CPU, and the GPU where an adapter is found (`BEZCHAIN_REQUIRE_GPU=1`: required).
fn backends() -> Vec<Backend> {
    let mut b = vec![Backend::Cpu];
    if eval_support::gpu().is_some() {
        b.push(Backend::Gpu);
    }
    b
}

/// Case 3 (degree 5, 3 segments) by CMA-ES with P 1024 reaches the minimum the
/// build before the redesign reached (4.05e-8 on lavapipe), now that the evaluator is anchored
/// at the mean: 2.27e-8 (anchored at a stale best it stopped at 6.6e-6). Release: a few
/// seconds on the CPU, about 15 on lavapipe (`cargo test --release -- --ignored`).
#[test]
#[ignore = "release: case 3 by CMA-ES, P 1024"]
fn case_3_cmaes_reaches_the_minimum() {
    for backend in backends() {
        let s = paper_case(5, 3, Method::Cmaes, backend);
        eprintln!("case 3 cmaes on {backend:?}: {s:.4e}");
        assert!(s <= 4.1e-8, "{backend:?}: {s:e}");
    }
}

/// Case 2 (degree 4, 3 segments) has two minima, 1.310e-7 and 2.511e-7 (where
/// BFGS ends). CMA-ES with P 1024, seed 1, reaches the second on the CPU (seeds 1-8: 7 of 8
/// reach the first; the build before the redesign 6 of 8, seed 1 among them); restarting while
/// the 500 generations last (what `bezchain compare` does) reaches the first. Release, about
/// 5 s a backend on the CPU.
#[test]
#[ignore = "release: case 2 by CMA-ES, P 1024, with and without restarts"]
fn case_2_cmaes_restarts_reach_the_better_minimum() {
    let points = common::naca4413();
    let layout = ChainLayout::uniform(4, 3, Continuity::C1).unwrap();
    let fit = |restarts, backend| {
        let mut evo = options(1024, 500);
        evo.backend = backend;
        evo.cmaes.restarts = restarts;
        let opts = FitOptions {
            method: Method::Cmaes,
            evo,
            ..FitOptions::default()
        };
        fit_curve(&points, layout.clone(), &opts).unwrap().closest.sum_sq
    };
    let once = fit(0, Backend::Cpu);
    eprintln!("case 2 cmaes, no restarts, cpu: {once:.4e}");
    assert!(once > 2.4e-7, "seed 1 without restarts: {once:e}");
    for backend in backends() {
        let s = fit(usize::MAX, backend);
        eprintln!("case 2 cmaes with restarts on {backend:?}: {s:.4e}");
        assert!(s <= 1.32e-7, "{backend:?}: {s:e}");
    }
}

/// Case 1 (degree 3, 5 segments) by the GA, P 1024, 500 generations, on the CPU.
/// The bar is 1e-6 on seed 1, which the covariance mutation meets (seed 1: 3.0e-7 on the CPU
/// and on lavapipe; seeds 1-6 median 3.8e-7). This test keeps the earlier, looser guard on the
/// median over seeds 1-12 (tournaments of 4, SBX with η 15 variable by variable and 1 %
/// elites gave 2.3e-6; tournaments of 8, line recombination and 3 % elites without the
/// covariance mutation 1.8e-6). Release, about 40 s.
#[test]
#[ignore = "release: case 1 by the GA, 12 seeds of P 1024 x 500"]
fn case_1_ga_median_over_seeds() {
    let points = common::naca4413();
    let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
    let mut sums: Vec<f64> = (1..=12)
        .map(|seed| {
            let opts = FitOptions {
                method: Method::Ga,
                evo: EvoOptions {
                    seed,
                    ..options(1024, 500)
                },
                ..FitOptions::default()
            };
            fit_curve(&points, layout.clone(), &opts).unwrap().closest.sum_sq
        })
        .collect();
    sums.sort_by(f64::total_cmp);
    let median = 0.5 * (sums[5] + sums[6]);
    eprintln!("case 1 ga, seeds 1-12: {sums:?}, median {median:.3e}");
    assert!(median <= 2.0e-6, "{median:e}");
}
