//! `bezchain naca`, `fit`, `eval` and `compare` end to end: every report's offsets re-measured
//! from its control points alone by the tests' own closest-point search (`common::check`), CSV
//! files with named columns, and every kind of bad input answered with exit status 2 and one
//! error line.

mod common;

use common::cli::{assert_user_error, run, stderr};

use common::check::{check_curve_report, report_c1_error};
use common::{crate_root, naca4413, scratch};
use std::path::Path;

/// Exit status 2, exactly one `error:` line naming `needle`, and no panic.
fn report(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
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
        let rep = report(&json);
        assert_eq!(rep["design_points"].as_array().unwrap().len(), design);
        assert_eq!(rep["control_points"].as_array().unwrap().len(), expanded);
        // The report's offsets agree with the independent measure of every data point.
        let o = check_curve_report(&rep, &naca4413(), 1e-6);
        assert!(
            o.sum_sq <= bar,
            "d={d}: independent sum_sq {:e} above {bar:e}",
            o.sum_sq
        );
        assert!(report_c1_error(&rep) < 1e-9);
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
        let rep = report(&json);
        let o = check_curve_report(&rep, &common::read_airfoil(name), 1e-6);
        sums.push(o.sum_sq);
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

/// `data/naca4413.dat` as CSV under the header `label,y,x`: the columns in another order and a
/// text column (which surface each point is on).
fn label_y_x(dir: &Path) -> std::path::PathBuf {
    let pts = naca4413();
    let le = pts
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.x.total_cmp(&b.1.x))
        .unwrap()
        .0;
    let mut text = String::from("label,y,x\n");
    for (k, p) in pts.iter().enumerate() {
        let label = match k.cmp(&le) {
            std::cmp::Ordering::Less => "upper surface",
            std::cmp::Ordering::Equal => "leading edge",
            std::cmp::Ordering::Greater => "lower surface",
        };
        text += &format!("{label},{:?},{:?}\n", p.y, p.x);
    }
    let path = dir.join("naca4413_label_y_x.csv");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_csv_with_named_columns_fits_like_the_dat_file() {
    let dir = scratch("cli-fit-csv");
    let csv = label_y_x(&dir);
    let fit = |input: &str, json: &Path| {
        let out = run(&[
            "fit",
            input,
            "--degree",
            "3",
            "--segments",
            "5",
            "--json",
            json.to_str().unwrap(),
        ]);
        assert!(out.status.success(), "{input}: {}", stderr(&out));
        out
    };
    let (a, b) = (dir.join("dat.json"), dir.join("csv.json"));
    fit("data/naca4413.dat", &a);
    let out = fit(csv.to_str().unwrap(), &b);
    assert!(String::from_utf8_lossy(&out.stdout).contains("82 points"));
    assert!(
        stderr(&out).contains("ignored column(s) label"),
        "{}",
        stderr(&out)
    );
    let (a, b) = (report(&a), report(&b));
    assert_eq!(a["design_points"], b["design_points"]);
    assert_eq!(a["offset"], b["offset"]);
    check_curve_report(&b, &naca4413(), 1e-6);

    // `eval --points` reads the same CSV: the report's own design evaluates alike on both files.
    let population = dir.join("pop.csv");
    let design: Vec<String> = b["design_points"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|p| p.as_array().unwrap().iter().map(|c| c.to_string()))
        .collect();
    std::fs::write(&population, design.join(",") + "\n").unwrap();
    let eval = |points: &str| {
        let out = run(&[
            "eval",
            dir.join("csv.json").to_str().unwrap(),
            "--population",
            population.to_str().unwrap(),
            "--points",
            points,
            "--backend",
            "cpu",
        ]);
        assert!(out.status.success(), "{points}: {}", stderr(&out));
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let (from_dat, from_csv) = (eval("data/naca4413.dat"), eval(csv.to_str().unwrap()));
    assert_eq!(from_dat, from_csv);
    let sum_sq: f64 = from_csv.trim().split(',').next().unwrap().parse().unwrap();
    let claimed = b["offset"]["sum_sq"].as_f64().unwrap();
    // `eval` sums in f32 about the data's centre: each offset (about 1.4e-5 here) carries
    // about 2⁻²⁴ of the extent, some 0.2 % of its square, so the sum is good to a few 1e-3
    // (1.1e-3 here).
    assert!(
        (sum_sq - claimed).abs() <= 3e-3 * claimed,
        "eval {sum_sq:e}, report {claimed:e}"
    );
}

#[test]
fn a_header_without_x_and_y_exits_2_naming_the_file_and_line_1() {
    let dir = scratch("cli-fit-csv-bad");
    let path = dir.join("no_xy.csv");
    std::fs::write(&path, "label,u,v\nte,1,0\nle,0,0\nte,1,-0.01\n").unwrap();
    let file = path.to_str().unwrap();
    let out = run(&["fit", file, "--degree", "3", "--segments", "1"]);
    assert_user_error(
        &out,
        &format!("{file}:1: the header 'label,u,v' names no x and no y column"),
    );
    let out = run(&["adapt", file, "--tol", "1e-3"]);
    assert_user_error(&out, &format!("{file}:1:"));
    // A wrong value in a named column names the column and the line.
    let bad = dir.join("bad_y.csv");
    std::fs::write(&bad, "label,y,x\nte,0,1\nle,zero,0\nte,-0.01,1\n").unwrap();
    let out = run(&["fit", bad.to_str().unwrap(), "--degree", "2", "--segments", "1"]);
    assert_user_error(&out, "bad_y.csv:3: expected a number in column 'y', found 'zero'");
}
