//! Fitting degenerate and awkward input: too few points, coincident points, closed contours,
//! non-finite coordinates, and data that lie exactly on a chain.

mod common;

use bezchain::chain::{ChainLayout, Continuity, CurveChain};
use bezchain::fit::{fit_curve, FitOptions, Method};
use bezchain::Error;
use common::naca4413;
use glam::DVec2;

fn case1() -> ChainLayout {
    ChainLayout::uniform(3, 5, Continuity::C1).unwrap()
}

#[test]
fn fewer_points_than_design_points_is_invalid() {
    let pts: Vec<DVec2> = naca4413().into_iter().step_by(8).collect(); // 11 points, 12 needed
    for method in [Method::Lsq, Method::NelderMead, Method::Bfgs] {
        let opts = FitOptions {
            method,
            ..FitOptions::default()
        };
        match fit_curve(&pts, case1(), &opts) {
            Err(Error::Invalid(msg)) => assert!(msg.contains("11") && msg.contains("12"), "{msg}"),
            other => panic!("{method}: expected Error::Invalid, got {other:?}"),
        }
    }
}

#[test]
fn unusable_points_are_invalid() {
    let same = vec![DVec2::new(0.3, 0.1); 40];
    assert!(matches!(
        fit_curve(&same, case1(), &FitOptions::default()),
        Err(Error::Invalid(_))
    ));
    assert!(matches!(
        fit_curve::<DVec2>(&[], case1(), &FitOptions::default()),
        Err(Error::Invalid(_))
    ));
    let mut bad = naca4413();
    bad[17].x = f64::NAN;
    assert!(matches!(
        fit_curve(&bad, case1(), &FitOptions::default()),
        Err(Error::Invalid(_))
    ));
}

#[test]
fn repeated_points_fit_like_the_originals() {
    let pts = naca4413();
    let mut doubled = Vec::new();
    for p in &pts {
        doubled.push(*p);
        doubled.push(*p);
    }
    let a = fit_curve(&pts, case1(), &FitOptions::default()).unwrap();
    let b = fit_curve(&doubled, case1(), &FitOptions::default()).unwrap();
    // Every offset counts twice.
    assert!(b.closest.sum_sq.is_finite() && b.chain.continuity_error(1) < 1e-9);
    assert!(
        (b.closest.sum_sq - 2.0 * a.closest.sum_sq).abs() < 0.05 * a.closest.sum_sq,
        "{:e} vs 2 x {:e}",
        b.closest.sum_sq,
        a.closest.sum_sq
    );
}

#[test]
fn a_closed_contour_starts_and_ends_at_its_closing_point() {
    let mut pts = naca4413();
    let first = pts[0];
    pts.push(first);
    let fit = fit_curve(&pts, case1(), &FitOptions::default()).unwrap();
    let ctrl = fit.chain.ctrl();
    // The closing chord meets the lower surface at a corner that a C1 chain can only turn with
    // a loop; fits stay loop-free, so the corner is rounded and the ends sit near, not on, the
    // closing point.
    assert!(fit.span_ratio <= 3.0, "span ratio {}", fit.span_ratio);
    assert!(ctrl[0].distance(first) < 5e-4 && ctrl[15].distance(first) < 5e-4);
    assert!(fit.closest.max < 1e-3, "max {:e}", fit.closest.max);
    assert!(fit.chain.continuity_error(1) < 1e-9);
}

#[test]
fn points_on_a_chain_are_fitted_exactly() {
    let layout = ChainLayout::uniform(3, 4, Continuity::C1).unwrap();
    let design: Vec<DVec2> = (0..layout.design_count())
        .map(|i| DVec2::new(i as f64 * 0.15, 0.2 * (1.3 * i as f64).sin()))
        .collect();
    let chain = CurveChain::new(layout.clone(), design).unwrap();
    let pts: Vec<DVec2> = (0..60).map(|i| chain.eval((i as f64 / 59.0).powf(1.2))).collect();
    let fit = fit_curve(&pts, layout, &FitOptions::default()).unwrap();
    assert!(fit.closest.max < 1e-10, "max {:e}", fit.closest.max);
    for (a, b) in fit.chain.design().iter().zip(chain.design()) {
        assert!(a.distance(*b) < 1e-8, "{a} vs {b}");
    }
}
