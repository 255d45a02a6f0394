//! Helpers of the integration tests: the repository's data files, the binary, scratch folders,
//! and ([`check`]) the tests' own offset measure, independent of the library's foot-point code.
//! Everything here reads only files inside the repository.

#![allow(dead_code)]

pub mod check;
pub mod cli;
pub mod xfoil;

use std::path::PathBuf;

/// The crate root.
pub fn crate_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The real aerofoil files shipped with the repository (`data/airfoils/`, provenance in its
/// README).
pub fn airfoils_dir() -> PathBuf {
    crate_root().join("data/airfoils")
}

/// One of the real aerofoil files.
pub fn airfoil(name: &str) -> PathBuf {
    airfoils_dir().join(name)
}

/// A fresh empty folder under the system temporary directory, unique to this test: removed
/// when the test passes, kept for a look (and named on standard error) when it fails.
pub fn scratch(tag: &str) -> Scratch {
    let dir = std::env::temp_dir().join(format!("bezchain-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a scratch folder");
    Scratch(dir)
}

/// The folder of [`scratch`]; it derefs to its path.
pub struct Scratch(PathBuf);

impl Scratch {
    /// The path, the folder left in place: for one shared through a static by a test
    /// binary's tests (a static is never dropped; the next run's [`scratch`] empties it).
    pub fn keep(mut self) -> PathBuf {
        std::mem::take(&mut self.0)
    }
}

impl std::ops::Deref for Scratch {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.0
    }
}

impl AsRef<std::path::Path> for Scratch {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if self.0.as_os_str().is_empty() {
            return;
        }
        if std::thread::panicking() {
            eprintln!("the failed test's files are kept in {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
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

/// One of the real aerofoil files, read by the library's reader (Selig order).
pub fn read_airfoil(name: &str) -> Vec<glam::DVec2> {
    bezchain::geometry::read_curve(&airfoil(name))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .points
}

/// A figure-eight contour written as a Selig file `eight.dat` in `dir`: closed, sharp at both
/// ends, crossing itself at mid-chord (what a fitted chain that folds back over its data looks
/// like to an analysis, in the large).
pub fn figure_eight(dir: &std::path::Path) -> PathBuf {
    let path = dir.join("eight.dat");
    let mut text = String::from("figure eight\n");
    for k in 0..=80 {
        let t = std::f64::consts::TAU * f64::from(k) / 80.0;
        text += &format!("{:.6} {:.6}\n", 0.5 + 0.5 * t.cos(), 0.1 * (2.0 * t).sin());
    }
    std::fs::write(&path, text).expect("write eight.dat");
    path
}

/// The NACA 4-digit aerofoil `code` (`points` along its contour), adapted at 1e-3 of the chord,
/// as the design space of an optimisation on `nodes` panel nodes with each variable within
/// ± `margin` chord of its start and the chord line held.
pub fn naca_design_space(
    code: &str,
    points: usize,
    nodes: usize,
    margin: f64,
) -> bezchain::aero::DesignSpace {
    use bezchain::adaptive::{adapt_curve, AdaptOptions};
    use bezchain::aero::{DesignSpace, Hold, Paneling};
    use bezchain::geometry::{Naca, NacaOptions};
    let pts = Naca::parse(code)
        .unwrap()
        .contour(&NacaOptions {
            points,
            ..NacaOptions::default()
        })
        .unwrap();
    let options = AdaptOptions {
        tol: 1e-3,
        ..AdaptOptions::default()
    };
    let a = adapt_curve(&pts, &options).unwrap();
    DesignSpace::new(&a.encoding, &Paneling::with_nodes(nodes), margin, Hold::ChordLine).unwrap()
}
