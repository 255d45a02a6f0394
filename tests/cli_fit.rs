//! `bezchain naca`, `fit` and `compare` end to end: outputs checked by the independent
//! `verify.py`, and every kind of bad input answered with exit status 2 and one error line.

mod common;

use common::{bin, crate_root, scratch, verify_py};
use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(crate_root())
        .output()
        .expect("run bezchain")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit status 2, exactly one `error:` line naming `needle`, and no panic.
fn assert_user_error(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error:")).collect();
    assert_eq!(lines.len(), 1, "one error line expected: {err}");
    assert!(lines[0].contains(needle), "'{needle}' not in: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

fn verify(report: &Path, data: &Path) -> serde_json::Value {
    let out = Command::new("python3")
        .arg(verify_py())
        .arg("curve")
        .arg(report)
        .arg(data)
        .output()
        .expect("python3 runs verify.py");
    assert!(out.status.success(), "verify.py: {}", stderr(&out));
    serde_json::from_slice(&out.stdout).expect("verify.py prints JSON")
}

#[test]
fn naca_writes_the_shipped_data_file() {
    let out = run(&["naca", "4413", "--points", "82"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let shipped = std::fs::read(crate_root().join("data/naca4413.dat")).unwrap();
    assert_eq!(out.stdout, shipped);
}

#[test]
fn the_papers_cases_pass_the_independent_check() {
    let dir = scratch("cli-fit-paper");
    let data = crate_root().join("data/naca4413.dat");
    // (degree, segments, design points, expanded points, 1/100 of the paper's total offset)
    for (d, s, design, expanded, bar) in [
        (3, 5, 12, 16, 2.4e-8),
        (4, 3, 11, 13, 1.8e-5),
        (5, 3, 14, 16, 1.3e-6),
    ] {
        let json = dir.join(format!("case-d{d}.json"));
        let svg = dir.join(format!("case-d{d}.svg"));
        let out = run(&[
            "fit",
            "data/naca4413.dat",
            "--degree",
            &d.to_string(),
            "--segments",
            &s.to_string(),
            "--method",
            "lsq",
            "--json",
            json.to_str().unwrap(),
            "--svg",
            svg.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let v = verify(&json, &data);
        assert_eq!(v["design_points"], design);
        assert_eq!(v["control_points"], expanded);
        let sum_sq = v["sum_sq"].as_f64().unwrap();
        assert!(sum_sq <= bar, "d={d}: verify.py sum_sq {sum_sq:e} above {bar:e}");
        assert!(v["c1_error"].as_f64().unwrap() < 1e-9);
        // The report's own figure agrees with the independent one.
        let rep: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        let ours = rep["offset"]["sum_sq"].as_f64().unwrap();
        assert!(
            (ours - sum_sq).abs() <= 1e-6 * sum_sq,
            "report {ours:e} vs verify.py {sum_sq:e}"
        );
        assert_eq!(rep["fit"]["method"], "lsq");
        assert!(rep["fit"]["iterations"].as_u64().unwrap() > 0);
        let plot = std::fs::read_to_string(&svg).unwrap();
        assert!(plot.contains(&format!("design points ({design})")));
    }
}

#[test]
fn json_to_stdout_is_the_report_alone() {
    let out = run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--json",
        "-",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is JSON");
    assert_eq!(v["kind"], "curve");
    assert_eq!(v["continuity"], "C1");
    assert!(stderr(&out).contains("sum_sq"), "the summary goes to stderr");
}

#[test]
fn selig_and_lednicer_clark_y_fit_alike() {
    let dir = scratch("cli-fit-clarky");
    let mut sums = Vec::new();
    for name in ["clarky.dat", "clarky_lednicer.dat"] {
        let json = dir.join(format!("{name}.json"));
        let path = common::airfoil(name);
        let out = run(&[
            "fit",
            path.to_str().unwrap(),
            "--degree",
            "4",
            "--segments",
            "4",
            "--json",
            json.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        sums.push(verify(&json, &path)["sum_sq"].as_f64().unwrap());
    }
    assert!((sums[0] - sums[1]).abs() <= 0.01 * sums[0], "{sums:?}");
}

#[test]
fn bad_input_exits_2_with_one_clear_line() {
    let dir = scratch("cli-fit-bad");
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let fit = |file: &str, d: &str, s: &str| run(&["fit", file, "--degree", d, "--segments", s]);
    assert_user_error(&fit("no/such/file.dat", "3", "5"), "no/such/file.dat");
    let empty = write("empty.dat", "");
    assert_user_error(&fit(&empty, "3", "5"), "empty.dat");
    let text = write(
        "text.dat",
        "NACA 0012\n1.0 0.0\n0.5 0.05\nzero point five 0.1\n0.0 0.0\n",
    );
    assert_user_error(&fit(&text, "3", "5"), "text.dat:4");
    let nan = write("nan.dat", "x y\n1.0 0.0\n0.5 NaN\n0.0 0.0\n");
    assert_user_error(&fit(&nan, "3", "5"), "nan.dat:3");
    let inf = write("inf.dat", "1.0 0.0\n0.5 inf\n0.0 0.0\n");
    assert_user_error(&fit(&inf, "3", "5"), "inf.dat:2");
    let few = write("few.dat", "1.0 0.0\n0.5 0.1\n0.0 0.0\n0.5 -0.1\n1.0 0.0\n");
    assert_user_error(&fit(&few, "3", "5"), "12");
    assert_user_error(&fit("data/naca4413.dat", "0", "5"), "degree");
    assert_user_error(&fit("data/naca4413.dat", "3", "0"), "segments");
    assert_user_error(&fit("data/naca4413.dat", "1", "5"), "C1");
    assert_user_error(
        &run(&[
            "fit",
            "data/naca4413.dat",
            "--degree",
            "3",
            "--segments",
            "5",
            "--method",
            "simplex",
        ]),
        "simplex",
    );
    // Nothing already written is lost: a failed run leaves an existing report untouched.
    let report = dir.join("keep.json");
    std::fs::write(&report, "precious").unwrap();
    let out = run(&[
        "fit",
        &few,
        "--degree",
        "3",
        "--segments",
        "5",
        "--json",
        report.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(std::fs::read_to_string(&report).unwrap(), "precious");
}

#[test]
fn consecutive_duplicates_are_dropped_with_a_warning() {
    let dir = scratch("cli-fit-dup");
    let mut text = std::fs::read_to_string(crate_root().join("data/naca4413.dat")).unwrap();
    let third = text.lines().nth(3).unwrap().to_string();
    text = text.replacen(&format!("{third}\n"), &format!("{third}\n{third}\n"), 1);
    let path = dir.join("dup.dat");
    std::fs::write(&path, text).unwrap();
    let out = run(&["fit", path.to_str().unwrap(), "--degree", "3", "--segments", "5"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("warning:") && err.contains("dup"), "{err}");
    assert!(String::from_utf8_lossy(&out.stdout).contains("82 points"));
}
