//! The real aerofoil files (`data/airfoils/`) load and fit, and the Selig and
//! Lednicer copies of the Clark Y give the same fit.

mod common;

use bezchain::chain::{ChainLayout, Continuity, CurveChain};
use bezchain::fit::{fit_curve, FitOptions};
use bezchain::problem::offset_stats;
use common::check::independent_offsets;
use common::read_airfoil as read_dat;
use glam::DVec2;

const FILES: [&str; 6] = [
    "clarky.dat",
    "clarky_lednicer.dat",
    "e387.dat",
    "naca4412.dat",
    "naca4415.dat",
    "s1223.dat",
];

fn case1() -> ChainLayout {
    ChainLayout::uniform(3, 5, Continuity::C1).unwrap()
}

#[test]
fn every_real_aerofoil_fits() {
    for name in FILES {
        let pts = read_dat(name);
        assert!(pts.len() >= 30, "{name}: {} points", pts.len());
        let fit = fit_curve(&pts, case1(), &FitOptions::default()).unwrap();
        let (sum_sq, max) = independent_offsets(fit.chain.ctrl(), 3, &pts);
        assert!(
            (sum_sq - fit.closest.sum_sq).abs() <= 1e-6 * sum_sq,
            "{name}: {sum_sq:e} vs {:e}",
            fit.closest.sum_sq
        );
        // Five cubic segments follow a unit-chord aerofoil to a few thousandths of the chord.
        assert!(max < 2e-3, "{name}: max offset {max:e}");
        assert!(fit.chain.continuity_error(1) < 1e-9, "{name}");
        assert!(fit.chain.ctrl()[0].distance(pts[0]) < 1e-3, "{name}: start");
        assert!(
            fit.chain.ctrl()[15].distance(pts[pts.len() - 1]) < 1e-3,
            "{name}: end"
        );
    }
}

/// The largest distance from samples of `a` to the chain `b`.
fn curve_gap(a: &CurveChain<DVec2>, b: &CurveChain<DVec2>) -> f64 {
    let samples: Vec<DVec2> = (0..=2000).map(|i| a.eval(i as f64 / 2000.0)).collect();
    offset_stats(b, &samples).unwrap().max
}

#[test]
fn selig_and_lednicer_clark_y_give_the_same_fit() {
    let selig = read_dat("clarky.dat");
    let lednicer = read_dat("clarky_lednicer.dat");
    assert_eq!(selig.len(), lednicer.len());
    // The files round differently (six and seven decimals); the points are otherwise the same.
    for (a, b) in selig.iter().zip(&lednicer) {
        assert!(a.distance(*b) < 1e-6, "{a} vs {b}");
    }
    let fa = fit_curve(&selig, case1(), &FitOptions::default()).unwrap();
    let fb = fit_curve(&lednicer, case1(), &FitOptions::default()).unwrap();
    let rel = (fa.closest.sum_sq - fb.closest.sum_sq).abs() / fa.closest.sum_sq;
    assert!(
        rel < 0.01,
        "sum_sq {:e} vs {:e}",
        fa.closest.sum_sq,
        fb.closest.sum_sq
    );
    assert!((fa.closest.max - fb.closest.max).abs() < 0.05 * fa.closest.max);
    let gap = curve_gap(&fa.chain, &fb.chain).max(curve_gap(&fb.chain, &fa.chain));
    println!(
        "gap {gap:e} max {:e} {:e} rms {:e}",
        fa.closest.max, fb.closest.max, fa.closest.rms
    );
    assert!(gap < 1e-4, "the two fitted curves are {gap:e} apart");
}

/// No reported chain doubles back on itself. On Clark Y with four quartic segments the
/// closest-point optimum over uniform breaks has a fold (the chain runs forward, back and
/// forward again along the nearly straight lower surface, which moves a join for free); the
/// least-squares fit keeps to fold-free chains, so the data's neighbours stay neighbours on
/// the chain.
#[test]
fn fits_do_not_fold() {
    for name in FILES {
        let pts = read_dat(name);
        for (d, s) in [(4, 4), (3, 6), (5, 3)] {
            let layout = ChainLayout::uniform(d, s, Continuity::C1).unwrap();
            let fit = fit_curve(&pts, layout, &FitOptions::default()).unwrap();
            assert!(
                fit.span_ratio <= 3.0,
                "{name} d{d} s{s}: span ratio {}",
                fit.span_ratio
            );
        }
    }
}
