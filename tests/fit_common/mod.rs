//! Test helpers shared by the `fit_*` tests: the paper's data and a minimal reader of the
//! shared aerofoil files (numeric rows only), until the library's `.dat` readers land.

#![allow(dead_code)]

use bezchain::geometry::{Naca, NacaOptions};
use glam::DVec2;
use std::path::PathBuf;

/// The paper's data: NACA 4413, 82 points, Selig order (as `data/naca4413.dat` will be).
pub fn naca4413() -> Vec<DVec2> {
    Naca::parse("4413")
        .and_then(|n| n.contour(&NacaOptions::default()))
        .expect("NACA 4413 contour")
}

/// The folder of the shared aerofoil files: `shared/data/airfoils` next to the checkout
/// (`../shared` from the repository root) or next to any folder above it (worktrees).
pub fn airfoil_dir() -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    root.ancestors()
        .skip(1)
        .map(|a| a.join("shared/data/airfoils"))
        .find(|p| p.is_dir())
        .unwrap_or_else(|| root.join("../shared/data/airfoils"))
}

/// Read a Selig or Lednicer `.dat` into Selig order (upper trailing edge → leading edge →
/// lower trailing edge). Test-only: numeric rows with two values are points; a first numeric
/// row of two integers above 1 is Lednicer's counts line; a blank line or a return to the
/// leading edge separates Lednicer's surfaces.
pub fn read_dat(name: &str) -> Vec<DVec2> {
    let path = airfoil_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut rows: Vec<Option<DVec2>> = Vec::new();
    let mut counts = None;
    for line in text.lines() {
        let vals: Vec<f64> = line.split_whitespace().filter_map(|t| t.parse().ok()).collect();
        if vals.len() != 2 || line.split_whitespace().count() != 2 {
            if line.trim().is_empty() {
                rows.push(None);
            }
            continue;
        }
        if counts.is_none()
            && rows.iter().all(Option::is_none)
            && vals[0] > 1.5
            && vals[1] > 1.5
            && vals[0].fract() == 0.0
        {
            counts = Some((vals[0] as usize, vals[1] as usize));
            continue;
        }
        rows.push(Some(DVec2::new(vals[0], vals[1])));
    }
    let pts: Vec<DVec2> = rows.into_iter().flatten().collect();
    match counts {
        None => pts,
        Some((nu, nl)) => {
            assert_eq!(pts.len(), nu + nl, "{name}: Lednicer counts");
            let mut selig: Vec<DVec2> = pts[..nu].iter().rev().copied().collect();
            let lower = &pts[nu..];
            // The leading edge appears on both surfaces; keep it once.
            let skip = usize::from(lower[0] == selig[selig.len() - 1]);
            selig.extend_from_slice(&lower[skip..]);
            selig
        }
    }
}

/// Closest-point `(sum_sq, max)` of `points` from the chain with expanded control points
/// `ctrl` (segment `k` uses `ctrl[k d ..= (k + 1) d]`), measured the way `verify.py` does and
/// independently of the library's foot-point code: every segment sampled at 200 parameters by
/// de Casteljau, then golden-section search around the best sample of each segment.
pub fn independent_offsets(ctrl: &[DVec2], degree: usize, points: &[DVec2]) -> (f64, f64) {
    use bezchain::bezier::BezierCurve;
    let segments: Vec<BezierCurve<DVec2>> = ctrl
        .windows(degree + 1)
        .step_by(degree)
        .map(|w| BezierCurve::new(w.to_vec()))
        .collect();
    assert_eq!(segments.len() * degree + 1, ctrl.len(), "control point count");
    let samples = 200;
    let mut sum_sq = 0.0;
    let mut max: f64 = 0.0;
    for &q in points {
        let mut best = f64::INFINITY;
        for seg in &segments {
            let d2 = |u: f64| (seg.eval(u) - q).length_squared();
            let (mut bu, mut bd) = (0.0, f64::INFINITY);
            for i in 0..=samples {
                let u = i as f64 / samples as f64;
                let d = d2(u);
                if d < bd {
                    (bu, bd) = (u, d);
                }
            }
            let h = 1.0 / samples as f64;
            let (mut a, mut b) = ((bu - h).max(0.0), (bu + h).min(1.0));
            let g = (5f64.sqrt() - 1.0) / 2.0;
            let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
            let (mut fc, mut fd) = (d2(c), d2(d));
            for _ in 0..80 {
                if fc < fd {
                    (b, d, fd) = (d, c, fc);
                    c = b - g * (b - a);
                    fc = d2(c);
                } else {
                    (a, c, fc) = (c, d, fd);
                    d = a + g * (b - a);
                    fd = d2(d);
                }
            }
            best = best.min(bd).min(fc).min(fd).min(d2(0.0)).min(d2(1.0));
        }
        sum_sq += best;
        max = max.max(best.sqrt());
    }
    (sum_sq, max)
}
