//! The paper's three NACA 4413 cases (DESIGN.md §1): counts, accuracy against the paper's
//! totals, C1 joins, and the optimisers' comparison.

mod common;

use bezchain::chain::{ChainLayout, Continuity};
use bezchain::fit::{fit_curve, FitOptions, Method};
use bezchain::optim::{lsq, LsqHooks, LsqMethod, LsqOptions, Start};
use bezchain::problem::{CurveProblem, Metric};
use common::check::independent_offsets;
use common::naca4413;

/// (degree, segments, design points, expanded points, the paper's total offset).
const CASES: [(usize, usize, usize, usize, f64); 3] = [
    (3, 5, 12, 16, 2.3751e-6),
    (4, 3, 11, 13, 0.0018),
    (5, 3, 14, 16, 1.2705e-4),
];

#[test]
fn lsq_beats_the_papers_offsets_a_hundredfold() {
    let pts = naca4413();
    assert_eq!(pts.len(), 82);
    for (d, s, design, expanded, paper) in CASES {
        let layout = ChainLayout::uniform(d, s, Continuity::C1).unwrap();
        let fit = fit_curve(&pts, layout, &FitOptions::default()).unwrap();
        assert_eq!(fit.chain.design().len(), design, "case d={d}");
        assert_eq!(fit.chain.ctrl().len(), expanded, "case d={d}");
        // Measured again from the expanded control points, as the checker does.
        let (sum_sq, max) = independent_offsets(fit.chain.ctrl(), d, &pts);
        assert!(
            sum_sq <= paper / 100.0,
            "d={d}: sum_sq {sum_sq:e} above {:e}",
            paper / 100.0
        );
        assert!(
            (sum_sq - fit.closest.sum_sq).abs() <= 1e-6 * sum_sq,
            "d={d}: reported {:e}",
            fit.closest.sum_sq
        );
        assert!(
            (max - fit.closest.max).abs() <= 1e-9,
            "d={d}: max {max:e} vs {:e}",
            fit.closest.max
        );
        assert!(
            fit.chain.continuity_error(1) < 1e-9,
            "d={d}: C1 jump {:e}",
            fit.chain.continuity_error(1)
        );
        // The chain spans the data: its ends sit on the first and last data points.
        assert!(fit.chain.ctrl()[0].distance(pts[0]) < 1e-4);
        assert!(fit.chain.ctrl()[expanded - 1].distance(pts[81]) < 1e-4);
        assert!(fit.report.iterations > 0 && fit.report.evaluations >= fit.report.iterations);
    }
}

#[test]
fn nelder_mead_and_bfgs_reach_the_lsq_optimum_bfgs_far_faster() {
    let pts = naca4413();
    let (d, s, ..) = CASES[0];
    let layout = ChainLayout::uniform(d, s, Continuity::C1).unwrap();
    let fit = |method| {
        let opts = FitOptions {
            method,
            ..FitOptions::default()
        };
        fit_curve(&pts, layout.clone(), &opts).unwrap()
    };
    let lsq = fit(Method::Lsq);
    let bfgs = fit(Method::Bfgs);
    let nm = fit(Method::NelderMead);
    for f in [&bfgs, &nm] {
        let (sum_sq, _) = independent_offsets(f.chain.ctrl(), d, &pts);
        assert!(
            sum_sq <= 10.0 * lsq.closest.sum_sq,
            "{}: {sum_sq:e} vs lsq {:e}",
            f.method,
            lsq.closest.sum_sq
        );
        assert!(f.chain.continuity_error(1) < 1e-9);
    }
    assert!(
        10 * bfgs.report.iterations < nm.report.iterations,
        "BFGS {} iterations, Nelder-Mead {}",
        bfgs.report.iterations,
        nm.report.iterations
    );
    assert!(bfgs.report.evaluations < nm.report.evaluations);
}

#[test]
fn plain_alternation_stays_far_from_the_optimum() {
    let pts = naca4413();
    let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
    let joint = fit_curve(&pts, layout.clone(), &FitOptions::default()).unwrap();
    let problem = CurveProblem::curve(layout, &pts, Metric::Closest).unwrap();
    let alternate = LsqOptions {
        method: LsqMethod::Alternate,
        max_iterations: 300,
        ..LsqOptions::default()
    };
    let start = Start::Params(problem.params().to_vec());
    let slow = lsq(&problem, &[start], &alternate, LsqHooks::default())
        .unwrap()
        .remove(0);
    assert!(
        slow.sum_sq > 10.0 * joint.closest.sum_sq,
        "alternation {:e}, joint {:e}",
        slow.sum_sq,
        joint.closest.sum_sq
    );
}

#[test]
fn corresponding_metric_is_one_linear_solve() {
    let pts = naca4413();
    let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
    let opts = FitOptions {
        metric: Metric::Corresponding,
        ..FitOptions::default()
    };
    let fit = fit_curve(&pts, layout, &opts).unwrap();
    assert_eq!((fit.report.iterations, fit.report.evaluations), (1, 1));
    assert_eq!(fit.offset.metric, Metric::Corresponding);
    // The closest point is never farther than the corresponding one.
    assert!(fit.closest.sum_sq <= fit.offset.sum_sq);
    assert!(fit.chain.continuity_error(1) < 1e-9);
}
