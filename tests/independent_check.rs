//! The tests' own closest-point check (`common::check`) against analytic distances: a parabola
//! as a chain of two quadratic segments, a paraboloid as a 2 x 2 grid of biquadratic patches,
//! and reports whose claimed offsets are wrong.

mod common;

use common::check::{check_curve_report, report_c1_error, IndependentChain, IndependentGrid, Offsets};
use glam::{DVec2, DVec3};
use serde_json::json;

/// `y = x²` on `[-1, 1]` as two quadratic segments: on `[a, b]` the control points are
/// `(a, a²), ((a + b) / 2, a b), (b, b²)`.
fn parabola() -> Vec<DVec2> {
    [(-1.0, 1.0), (-0.5, 0.0), (0.0, 0.0), (0.5, 0.0), (1.0, 1.0)]
        .map(|(x, y)| DVec2::new(x, y))
        .to_vec()
}

#[test]
fn distances_to_a_parabola_are_exact() {
    let chain = IndependentChain::new(&parabola(), 2);
    // Above the vertex: the closest points are (±1/√2, 1/2), at √3/2 (the vertex, a local
    // maximum of the distance, is at 1).
    let d = chain.distance(DVec2::new(0.0, 1.0));
    assert!((d - 0.75_f64.sqrt()).abs() < 1e-12, "{d}");
    // Below it: the vertex.
    assert!((chain.distance(DVec2::new(0.0, -0.25)) - 0.25).abs() < 1e-14);
    // Off a point of the curve along its normal, nearer than the curvature radius.
    for x in [-0.9, -0.3, 0.2, 0.7] {
        let (foot, n) = (DVec2::new(x, x * x), DVec2::new(-2.0 * x, 1.0).normalize());
        for h in [1e-6, 1e-3, -1e-3] {
            let d = chain.distance(foot + h * n);
            assert!((d - h.abs()).abs() < 1e-12, "x {x}, h {h}: {d}");
        }
    }
    // Beyond an end: the end.
    let d = chain.distance(DVec2::new(2.0, 1.0));
    assert!((d - 1.0).abs() < 1e-14, "{d}");
}

/// `z = x² + y²` on `[-1, 1]²` as 2 x 2 biquadratic patches: the net of a sum `f(x) + g(y)` is
/// `f_i + g_j` (the Bernstein basis sums to one).
fn paraboloid() -> Vec<Vec<DVec3>> {
    let (x, f) = ([-1.0, -0.5, 0.0, 0.5, 1.0], [1.0, 0.0, 0.0, 0.0, 1.0]);
    (0..5)
        .map(|i| (0..5).map(|j| DVec3::new(x[i], x[j], f[i] + f[j])).collect())
        .collect()
}

#[test]
fn distances_to_a_paraboloid_are_exact() {
    let grid = IndependentGrid::new(&paraboloid(), 2, 2);
    // On the axis at height h > 1/2: the circle r² = h - 1/2, at √(h - 1/4).
    for h in [0.75, 1.0, 1.5] {
        let d = grid.distance(DVec3::new(0.0, 0.0, h));
        assert!((d - (h - 0.25_f64).sqrt()).abs() < 1e-9, "h {h}: {d}");
    }
    // Below the vertex: the vertex.
    assert!((grid.distance(DVec3::new(0.0, 0.0, -0.1)) - 0.1).abs() < 1e-12);
    // Off points of the surface along the normal, in every patch and across borders.
    for (x, y) in [(0.3, -0.7), (-0.6, -0.2), (0.0, 0.45), (0.8, 0.8)] {
        let foot = DVec3::new(x, y, x * x + y * y);
        let n = DVec3::new(-2.0 * x, -2.0 * y, 1.0).normalize();
        for h in [1e-5, 1e-2, -1e-2] {
            let d = grid.distance(foot + h * n);
            assert!((d - h.abs()).abs() < 1e-9, "({x}, {y}), h {h}: {d}");
        }
    }
}

/// A curve report of the parabola claiming the given offsets for its two data points.
fn parabola_report(sum_sq: f64, max: f64) -> serde_json::Value {
    let ctrl: Vec<[f64; 2]> = parabola().iter().map(|p| p.to_array()).collect();
    json!({
        "kind": "curve", "dimension": 2, "degree": 2, "segments": 2, "continuity": "C1",
        "breaks": [0.0, 0.5, 1.0], "control_points": ctrl,
        "offset": {"metric": "closest", "sum_sq": sum_sq, "sum": 0.0, "rms": (sum_sq / 2.0).sqrt(),
                   "max": max, "max_at": [0.0, 1.0]},
        "input": {"path": "-", "points": 2}
    })
}

#[test]
fn a_report_is_held_to_what_it_claims() {
    let points = [DVec2::new(0.0, 1.0), DVec2::new(0.0, -0.25)];
    let (a, b) = (0.75_f64.sqrt(), 0.25);
    let right = parabola_report(a * a + b * b, a);
    let o = check_curve_report(&right, &points, 1e-9);
    assert_eq!(o.n, 2);
    // The parabola's segments meet with equal derivatives in the global parameter.
    assert!(report_c1_error(&right) < 1e-15);
    let wrong = parabola_report(1.0 + b * b, 1.0); // the vertex's distance, not the closest
    let caught = std::panic::catch_unwind(|| check_curve_report(&wrong, &points, 1e-6));
    assert!(caught.is_err(), "a report claiming too large offsets passed");
    let small = Offsets::of([a, b]);
    assert!((small.rms - ((a * a + b * b) / 2.0).sqrt()).abs() < 1e-15);
}
