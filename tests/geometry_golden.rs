//! Golden check: the committed `data/naca4413.dat` is what the NACA generator and the Selig
//! writer produce now. Regenerate only on purpose, with `BEZCHAIN_REGENERATE=1`.

mod common;

use bezchain::geometry::{read_curve, write_selig, write_selig_to, Format, Naca, NacaOptions};

#[test]
fn naca4413_dat_matches_the_generator() {
    let naca = Naca::parse("4413").unwrap();
    let points = naca.contour(&NacaOptions::default()).unwrap();
    let path = common::crate_root().join("data/naca4413.dat");
    if std::env::var_os("BEZCHAIN_REGENERATE").is_some_and(|v| v == "1") {
        write_selig(&path, &naca.name(), &points).unwrap();
    }
    let mut fresh = Vec::new();
    write_selig_to(&mut fresh, &naca.name(), &points).unwrap();
    let fresh = String::from_utf8(fresh).unwrap();
    let committed = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (BEZCHAIN_REGENERATE=1 writes it)", path.display()));
    let (c, f): (Vec<&str>, Vec<&str>) = (committed.lines().collect(), fresh.lines().collect());
    assert_eq!(
        c.len(),
        f.len(),
        "line count changed; BEZCHAIN_REGENERATE=1 rewrites the file"
    );
    assert_eq!(c[0], "NACA 4413");
    for (k, (a, b)) in c.iter().zip(&f).enumerate().skip(1) {
        if a == b {
            continue;
        }
        // Only a last-digit rounding flip (a different libm) is tolerated: 1e-12 in model units.
        let nums = |s: &str| {
            s.split_whitespace()
                .map(|t| t.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        };
        let close = nums(a)
            .iter()
            .zip(nums(b))
            .all(|(x, y)| (x - y).abs() <= 1.0000001e-12);
        assert!(
            close,
            "line {}: committed '{a}', generated '{b}'; BEZCHAIN_REGENERATE=1 rewrites the file",
            k + 1
        );
    }
    // And the committed file reads back as the 82 distinct points of the contour.
    let loaded = read_curve(&path).unwrap();
    assert_eq!(loaded.format, Format::Selig);
    assert_eq!(loaded.name, "NACA 4413");
    assert_eq!(loaded.points.len(), 82);
    assert!(loaded.warnings.is_empty());
    for (a, b) in loaded.points.iter().zip(&points) {
        assert!((*a - *b).abs().max_element() <= 5e-13, "{a} vs {b}");
    }
}
