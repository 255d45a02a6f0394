//! `bezchain aero` end to end: the table, the JSON report (polar and pressures), the SVG, a
//! curve report as input, and bad input answered with exit status 2 and nothing written.

mod common;

use common::cli::{assert_user_error, json, run, stderr};

#[test]
fn an_aerofoil_file_gives_its_polar_pressures_and_picture() {
    let dir = tempfile::tempdir().unwrap();
    let (j, s) = (dir.path().join("a.json"), dir.path().join("a.svg"));
    let o = run(&[
        "aero",
        "data/naca4413.dat",
        "--alpha",
        "-2,0,4",
        "--json",
        j.to_str().unwrap(),
        "--svg",
        s.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("160 panel nodes") && text.contains("blunt trailing edge"),
        "{text}"
    );
    assert_eq!(
        text.lines()
            .filter(|l| l.trim_start().starts_with(['-', '0', '4']))
            .count(),
        3,
        "{text}"
    );
    let v = json(&j);
    let polar = v["polar"].as_array().unwrap();
    assert_eq!(polar.len(), 3);
    for (p, alpha) in polar.iter().zip([-2.0, 0.0, 4.0]) {
        assert_eq!(p["alpha"].as_f64(), Some(alpha));
        assert!(p["cl"].is_f64() && p["cm"].is_f64());
    }
    // XFOIL's numbers at 0° (data/xfoil/inviscid.csv).
    assert!((polar[1]["cl"].as_f64().unwrap() - 0.5252).abs() < 2e-3);
    let pressure = v["pressure"].as_array().unwrap();
    assert_eq!(pressure.len(), 3);
    assert_eq!(pressure[0]["cp"].as_array().unwrap().len(), 160);
    assert_eq!(v["node_points"].as_array().unwrap().len(), 160);
    let svg = std::fs::read_to_string(&s).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("α = 4°"));
}

#[test]
fn a_curve_report_is_analysed_on_its_chain() {
    let dir = tempfile::tempdir().unwrap();
    let fit = dir.path().join("fit.json");
    let o = run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "5",
        "--segments",
        "3",
        "--json",
        fit.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j = dir.path().join("a.json");
    let o = run(&[
        "aero",
        fit.to_str().unwrap(),
        "--alpha",
        "4",
        "--json",
        j.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&j);
    assert_eq!(v["input"]["kind"], "curve report");
    // The fit is within 2e-4 of the data: the same CL to a fraction of a percent.
    let cl = v["polar"][0]["cl"].as_f64().unwrap();
    assert!((cl - 1.0106).abs() < 0.01, "{cl}");
}

/// A chain fitted to a closed trailing edge can end its two surfaces crossed within its
/// tolerance (NACA 63-209 at 1e-4: the upper surface ends 1e-4 below the lower one): `aero`
/// closes the edge where its first and last panels cross, says so, and gives the raw file's
/// lift to a percent, inviscid and viscous.
#[test]
fn a_chain_whose_trailing_edge_ends_cross_is_closed_and_analysed() {
    let dir = tempfile::tempdir().unwrap();
    let raw = "data/airfoils/regressions/naca63209.dat";
    let fit = dir.path().join("adapt.json");
    let o = run(&[
        "adapt",
        raw,
        "--tol",
        "1e-4",
        "--relative",
        "--json",
        fit.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let cl = |file: &str, viscous: bool| {
        let j = dir.path().join("polar.json");
        let mut args = vec!["aero", file, "--alpha", "4", "--json", j.to_str().unwrap()];
        if viscous {
            args.extend(["--re", "1e6"]);
        }
        let o = run(&args);
        assert!(o.status.success(), "{file}: {}", stderr(&o));
        (json(&j)["polar"][0]["cl"].as_f64().unwrap(), stderr(&o))
    };
    for viscous in [false, true] {
        let (c0, _) = cl(raw, viscous);
        let (c1, said) = cl(fit.to_str().unwrap(), viscous);
        assert!(said.contains("trailing edge's two ends overlap"), "{said}");
        assert!(
            (c1 - c0).abs() <= 0.01 * c0.abs(),
            "viscous {viscous}: {c1} against {c0}"
        );
    }
}

#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let j = dir.path().join("a.json");
    let js = j.to_str().unwrap();
    assert_user_error(&run(&["aero", "no/such.dat", "--json", js]), "no/such.dat");
    assert_user_error(
        &run(&["aero", "data/naca4413.dat", "--alpha", "95", "--json", js]),
        "--alpha",
    );
    assert_user_error(
        &run(&["aero", "data/naca4413.dat", "--panels", "3", "--json", js]),
        "--panels",
    );
    let bad = dir.path().join("bad.dat");
    std::fs::write(&bad, "x\n0 0\n1 oops\n").unwrap();
    assert_user_error(&run(&["aero", bad.to_str().unwrap(), "--json", js]), "bad.dat:");
    let open = dir.path().join("open.csv");
    let rows: String = (0..30)
        .map(|i| format!("{},{}\n", i as f64 / 29.0, (i as f64 * 0.2).sin()))
        .collect();
    std::fs::write(&open, rows).unwrap();
    assert_user_error(
        &run(&["aero", open.to_str().unwrap(), "--json", js]),
        "trailing edge",
    );
    // A contour that crosses itself has no inside: refused with its file's name.
    let eight = common::figure_eight(dir.path());
    let out = run(&["aero", eight.to_str().unwrap(), "--json", js]);
    common::cli::assert_user_error_naming(&out, &["crosses itself", "eight.dat"]);
    assert!(!j.exists());
    // An SVG in a folder that does not exist: refused before anything is written.
    let o = run(&[
        "aero",
        "data/naca4413.dat",
        "--json",
        js,
        "--svg",
        "/no/such/dir/a.svg",
    ]);
    assert_user_error(&o, "--svg");
    assert!(!j.exists());
}
