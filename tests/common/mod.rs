//! Helpers shared by the integration tests: where the shared files live, the paper's data,
//! the binary, and an offset measure independent of the library's foot-point code.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The crate root.
pub fn crate_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The folder of real aerofoil files: `$BEZCHAIN_SHARED/data/airfoils` when that variable is
/// set, otherwise the first `shared/data/airfoils` found beside the crate root or one of its
/// ancestors (CI keeps `shared/` beside the clone). Panics with directions when absent.
pub fn airfoils_dir() -> PathBuf {
    if let Some(shared) = std::env::var_os("BEZCHAIN_SHARED") {
        let dir = Path::new(&shared).join("data/airfoils");
        assert!(
            dir.is_dir(),
            "BEZCHAIN_SHARED is set but {} is not a folder",
            dir.display()
        );
        return dir;
    }
    let root = crate_root();
    root.ancestors()
        .map(|a| a.join("shared/data/airfoils"))
        .find(|d| d.is_dir())
        .unwrap_or_else(|| {
            panic!(
                "no shared/data/airfoils beside {} or any folder above it; \
                 set BEZCHAIN_SHARED to the shared folder",
                root.display()
            )
        })
}

/// One of the shared aerofoil files.
pub fn airfoil(name: &str) -> PathBuf {
    airfoils_dir().join(name)
}

/// A fresh empty folder under the system temporary directory, unique to this test.
pub fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("bezchain-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a scratch folder");
    dir
}

/// The shared folder (`$BEZCHAIN_SHARED`, or `shared/` beside the crate root or an ancestor).
pub fn shared_dir() -> PathBuf {
    airfoils_dir().join("../..")
}

/// The independent checker `shared/tools/verify.py`.
pub fn verify_py() -> PathBuf {
    shared_dir().join("tools/verify.py")
}

/// The `bezchain` binary built for these tests.
pub fn bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_bezchain"))
}

/// The paper's data, `data/naca4413.dat`, read by the library's reader.
pub fn naca4413() -> Vec<glam::DVec2> {
    bezchain::geometry::read_curve(&crate_root().join("data/naca4413.dat"))
        .expect("data/naca4413.dat")
        .points
}

/// One of the shared aerofoil files, read by the library's reader (Selig order).
pub fn read_airfoil(name: &str) -> Vec<glam::DVec2> {
    bezchain::geometry::read_curve(&airfoil(name))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .points
}

/// Closest-point `(sum_sq, max)` of `points` from the chain with expanded control points
/// `ctrl` (segment `k` uses `ctrl[k d ..= (k + 1) d]`), measured the way `verify.py` does and
/// independently of the library's foot-point code: every segment sampled at 200 parameters by
/// de Casteljau, then golden-section search around the best sample of each segment.
pub fn independent_offsets(ctrl: &[glam::DVec2], degree: usize, points: &[glam::DVec2]) -> (f64, f64) {
    use bezchain::bezier::BezierCurve;
    let segments: Vec<BezierCurve<glam::DVec2>> = ctrl
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
