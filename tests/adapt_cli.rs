//! `bezchain adapt` end to end: the table, the JSON report (its offsets re-measured from its
//! control points alone by the tests' own closest-point search) and the SVG, sweeps, relative
//! tolerances, exit statuses (0 met, 1 not met with the reports written, 2 bad arguments).

mod common;

use common::check::check_curve_report;
use common::cli::run;
use common::{airfoils_dir, scratch};
use std::path::Path;

fn naca4413() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/naca4413.dat")
        .display()
        .to_string()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn one_tolerance_writes_the_table_the_report_and_the_plot() {
    let dir = scratch("adapt-one");
    let (json, svg) = (dir.join("r.json"), dir.join("r.svg"));
    let out = run(&[
        "adapt",
        &naca4413(),
        "--tol",
        "1e-3",
        "--json",
        json.to_str().unwrap(),
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = text(&out.stdout);
    for key in ["met            yes", "stored scalars", "held out", "search"] {
        assert!(table.contains(key), "missing '{key}' in\n{table}");
    }
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["kind"], "curve");
    let d = v["degree"].as_u64().unwrap() as usize;
    let s = v["segments"].as_u64().unwrap() as usize;
    assert_eq!(v["control_points"].as_array().unwrap().len(), s * d + 1);
    assert_eq!(v["design_points"].as_array().unwrap().len(), s * (d - 1) + 2);
    assert!(v["offset"]["max"].as_f64().unwrap() <= 1e-3);
    let o = check_curve_report(&v, &common::naca4413(), 1e-6);
    assert!(o.max <= 1e-3, "independent max {:e}", o.max);
    let a = &v["adapt"];
    assert_eq!(a["met"], true);
    assert!(a["stored_scalars"].as_u64().unwrap() <= 12, "{a}");
    assert!(a["counting"].as_str().unwrap().contains("not counted"));
    assert!(a["held_out"]["max"].as_f64().is_some());
    assert!(!a["search"].as_array().unwrap().is_empty());
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.contains("<svg"), "not an SVG");
}

#[test]
fn a_sweep_prints_scalars_against_tolerance() {
    let dir = scratch("adapt-sweep");
    let json = dir.join("s.json");
    let out = run(&[
        "adapt",
        &naca4413(),
        "--sweep",
        "1e-3,1e-4,1e-5",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = text(&out.stdout);
    let rows: Vec<&str> = table
        .lines()
        .filter(|l| l.trim_start().starts_with("1.000e-"))
        .collect();
    assert_eq!(rows.len(), 3, "{table}");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["schema"], "bezchain.sweep/1");
    let reports = v["reports"].as_array().unwrap();
    let counts: Vec<u64> = reports
        .iter()
        .map(|r| r["adapt"]["stored_scalars"].as_u64().unwrap())
        .collect();
    assert!(counts.windows(2).all(|w| w[0] <= w[1]), "{counts:?}");
    for (r, tol) in reports.iter().zip([1e-3, 1e-4, 1e-5]) {
        let o = check_curve_report(r, &common::naca4413(), 1e-6);
        assert!(o.max <= tol, "{tol:e}: independent max {:e}", o.max);
    }
}

#[test]
fn json_to_standard_output_moves_the_table_to_standard_error() {
    let out = run(&["adapt", &naca4413(), "--tol", "1e-3", "--json", "-"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(v["adapt"]["met"], true);
    assert!(text(&out.stderr).contains("stored scalars"));
}

#[test]
fn a_relative_tolerance_scales_with_the_chord() {
    let dir = scratch("adapt-relative");
    let scaled = dir.join("big.dat");
    let src = std::fs::read_to_string(naca4413()).unwrap();
    let mut lines = src.lines();
    let mut body = format!("{}\n", lines.next().unwrap());
    for l in lines {
        let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
        body += &format!("{} {}\n", 250.0 * v[0], 250.0 * v[1]);
    }
    std::fs::write(&scaled, body).unwrap();
    let count = |args: &[&str]| -> u64 {
        let out = run(args);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["adapt"]["stored_scalars"].as_u64().unwrap()
    };
    let unit = count(&["adapt", &naca4413(), "--tol", "1e-3", "--json", "-"]);
    let big = count(&[
        "adapt",
        scaled.to_str().unwrap(),
        "--tol",
        "1e-3",
        "--relative",
        "--json",
        "-",
    ]);
    assert_eq!(unit, big);
}

#[test]
fn an_unmeetable_tolerance_exits_1_with_the_reports_written() {
    let dir = scratch("adapt-unmet");
    let json = dir.join("u.json");
    let file = airfoils_dir().join("naca4412.dat");
    let out = run(&[
        "adapt",
        file.to_str().unwrap(),
        "--tol",
        "1e-9",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(
        err.contains("error: tolerance") && err.contains("not met"),
        "{err}"
    );
    assert!(text(&out.stdout).contains("met            NO"));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["adapt"]["met"], false);
    assert!(v["adapt"]["message"].as_str().unwrap().contains("not met"));
    assert!(v["control_points"].as_array().is_some_and(|c| !c.is_empty()));
}

#[test]
fn bad_arguments_exit_2() {
    let cases: [&[&str]; 5] = [
        &["adapt", &naca4413(), "--tol", "-1e-3"],
        &["adapt", &naca4413(), "--tol", "1e-3", "--degrees", "1-12"],
        &["adapt", &naca4413(), "--tol", "1e-3", "--degrees", "x"],
        &["adapt", "no/such/file.dat", "--tol", "1e-3"],
        &["adapt", &naca4413()],
    ];
    for args in cases {
        let out = run(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", text(&out.stderr));
        assert!(text(&out.stderr).contains("error"), "{args:?}");
    }
}
