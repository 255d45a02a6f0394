//! `bezchain aero --re`: the viscous polar of one file (JSON with `polar` at the top, the
//! table), of two files (`aerofoils`, one CSV table, an SVG), and bad viscous input refused with
//! exit status 2 and nothing written.

mod common;

use common::cli::{assert_user_error, assert_user_error_naming, json, run, stderr};

#[test]
fn one_and_two_files_give_viscous_polars() {
    let dir = tempfile::tempdir().unwrap();
    let j = dir.path().join("a.json");
    let o = run(&[
        "aero",
        "data/naca4413.dat",
        "--re",
        "1e6",
        "--alpha",
        "2:4:2",
        "--json",
        j.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&j);
    assert_eq!(v["re"].as_f64(), Some(1e6));
    let polar = v["polar"].as_array().unwrap();
    assert_eq!(polar.len(), 2);
    // XFOIL 6.99 at α 2°: CL 0.7115, CD 0.00643.
    let p = &polar[0];
    assert_eq!(p["alpha"].as_f64(), Some(2.0));
    assert_eq!(p["converged"], true);
    assert!((p["cl"].as_f64().unwrap() - 0.7115).abs() < 0.01, "{p}");
    assert!((p["cd"].as_f64().unwrap() - 0.00643).abs() < 3e-4, "{p}");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("Re 1.000e6") && text.contains("xtr_top"), "{text}");

    let (j2, c, s) = (
        dir.path().join("b.json"),
        dir.path().join("b.csv"),
        dir.path().join("b.svg"),
    );
    let o = run(&[
        "aero",
        "data/naca4413.dat",
        "data/airfoils/e387.dat",
        "--re",
        "1e6",
        "--alpha",
        "4",
        "--json",
        j2.to_str().unwrap(),
        "--csv",
        c.to_str().unwrap(),
        "--svg",
        s.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = json(&j2);
    let foils = v["aerofoils"].as_array().unwrap();
    assert_eq!(foils.len(), 2);
    assert_eq!(foils[1]["file"], "data/airfoils/e387.dat");
    let csv = std::fs::read_to_string(&c).unwrap();
    assert!(
        csv.starts_with("file,alpha,cl,cd,cdp,cm,xtr_top,xtr_bottom,converged\n"),
        "{csv}"
    );
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(std::fs::read_to_string(&s).unwrap().contains("<svg"));
}

#[test]
fn bad_viscous_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let j = dir.path().join("a.json");
    let js = j.to_str().unwrap();
    for (args, needle) in [
        (vec!["--re", "10"], "Reynolds"),
        (vec!["--re", "1e6", "--ncrit", "25"], "Ncrit"),
        (vec!["--re", "1e6", "--xtr-top", "2"], "forced transition"),
        (vec!["--re", "1e6", "--alpha", "40"], "--alpha"),
        (vec!["--re", "1e6", "--alpha", "0:4"], "--alpha"),
        (vec!["--csv", "x.csv"], "--re"),
    ] {
        let mut all = vec!["aero", "data/naca4413.dat", "--json", js];
        all.extend(args);
        assert_user_error(&run(&all), needle);
    }
    assert_user_error(
        &run(&[
            "aero",
            "data/naca4413.dat",
            "data/airfoils/e387.dat",
            "--json",
            js,
        ]),
        "--re",
    );
    // A contour that crosses itself (a figure eight; a fitted chain that folds back over its
    // data in a small loop is the case met in practice) is refused with its file's name.
    let eight = common::figure_eight(dir.path());
    let out = run(&["aero", eight.to_str().unwrap(), "--re", "1e6", "--json", js]);
    assert_user_error_naming(&out, &["crosses itself", "eight.dat"]);
    assert!(!j.exists());
}
