//! What every command shares (`docs/ARCHITECTURE.md` §4.1): `-` reads standard input, `--quiet`
//! prints nothing but warnings and errors, and the 2D plots come as SVG and as PNG alike.

mod common;

use common::cli::{ok, run, stderr};
use common::{bin, crate_root, scratch};
use std::io::Write;
use std::process::{Command, Stdio};

/// `bezchain ARGS` with `input` on standard input.
fn run_with_stdin(args: &[&str], input: &[u8]) -> std::process::Output {
    let mut child = Command::new(bin())
        .args(args)
        .current_dir(crate_root())
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(input).unwrap();
    child.wait_with_output().unwrap()
}

/// A point file and a report read from standard input give what the file gives: `fit` and
/// `adapt` of the NACA 4413, `aero` of a curve report.
#[test]
fn a_dash_reads_standard_input() {
    let dat = std::fs::read(crate_root().join("data/naca4413.dat")).unwrap();
    let design = |out: &std::process::Output| {
        assert!(out.status.success(), "{}", stderr(out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["design_points"].clone()
    };
    for args in [
        &["fit", "--degree", "3", "--segments", "5", "--json", "-"][..],
        &["adapt", "--tol", "1e-3", "--json", "-"][..],
    ] {
        let mut from_file = vec![args[0], "data/naca4413.dat"];
        from_file.extend(&args[1..]);
        let mut from_stdin = vec![args[0], "-"];
        from_stdin.extend(&args[1..]);
        assert_eq!(
            design(&run(&from_file)),
            design(&run_with_stdin(&from_stdin, &dat)),
            "{}",
            args[0]
        );
    }
    let dir = scratch("stdin");
    let report = dir.join("fit.json");
    ok(run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--json",
        report.to_str().unwrap(),
    ]));
    let cl = |out: std::process::Output| {
        assert!(out.status.success(), "{}", stderr(&out));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["polar"][0]["cl"].as_f64().unwrap()
    };
    let a = cl(run(&["aero", report.to_str().unwrap(), "--json", "-"]));
    let b = cl(run_with_stdin(
        &["aero", "-", "--json", "-"],
        &std::fs::read(&report).unwrap(),
    ));
    assert_eq!(a, b);
    // An empty standard input is a user error naming it.
    let out = run_with_stdin(&["fit", "-", "--degree", "3", "--segments", "5"], b"");
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("error: -"), "{}", stderr(&out));
}

/// `--quiet` (before or after the command) leaves the terminal empty and the files written.
#[test]
fn quiet_prints_nothing_and_writes_the_files() {
    let dir = scratch("quiet");
    let json = dir.join("fit.json");
    let cloud = dir.join("cloud.csv");
    for args in [
        vec![
            "fit",
            "data/naca4413.dat",
            "--degree",
            "3",
            "--segments",
            "5",
            "--json",
            json.to_str().unwrap(),
            "--quiet",
        ],
        vec!["--quiet", "adapt", "data/naca4413.dat", "--tol", "1e-3"],
        vec!["-q", "aero", "data/naca4413.dat"],
        vec![
            "blade",
            "data/blade_paper_to_tip.json",
            "-o",
            cloud.to_str().unwrap(),
            "-q",
        ],
    ] {
        let out = ok(run(&args));
        assert!(
            out.stdout.is_empty(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stdout)
        );
        assert!(out.stderr.is_empty(), "{args:?}: {}", stderr(&out));
    }
    assert!(json.is_file() && cloud.is_file());
    // Without it the same commands speak.
    let out = ok(run(&["adapt", "data/naca4413.dat", "--tol", "1e-3"]));
    assert!(!out.stdout.is_empty());
}

/// `fit`, `adapt` and `optimise` draw their plot as PNG as well as SVG: a PNG of the SVG's
/// size, not blank.
#[test]
fn the_2d_plots_come_as_png_too() {
    let dir = scratch("png-plots");
    let cases: [(&str, Vec<&str>); 3] = [
        (
            "fit",
            vec!["fit", "data/naca4413.dat", "--degree", "3", "--segments", "5"],
        ),
        ("adapt", vec!["adapt", "data/naca4413.dat", "--tol", "1e-3"]),
        (
            "optimise",
            vec![
                "optimise",
                "data/naca4413.dat",
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
                "--population",
                "16",
                "--generations",
                "2",
                "--backend",
                "cpu",
            ],
        ),
    ];
    for (name, args) in cases {
        let (svg, png) = (dir.join(format!("{name}.svg")), dir.join(format!("{name}.png")));
        let mut all = args.clone();
        all.extend([
            "--svg",
            svg.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
            "-q",
        ]);
        ok(run(&all));
        let svg = std::fs::read_to_string(&svg).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        let size = format!("width=\"{}\" height=\"{}\"", info.width, info.height);
        assert!(
            svg.contains(&size),
            "{name}: the PNG is {size}, the SVG {}",
            &svg[..200]
        );
        let pixels = &buf[..info.buffer_size()];
        let dark = pixels.chunks(3).filter(|p| p.iter().all(|&c| c < 100)).count();
        let white = pixels.chunks(3).filter(|p| p.iter().all(|&c| c == 255)).count();
        let total = pixels.len() / 3;
        assert!(
            dark > total / 1000 && white > total / 2,
            "{name}: {dark} dark, {white} white of {total}"
        );
    }
}
