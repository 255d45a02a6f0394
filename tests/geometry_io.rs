//! Aerofoil and point-file readers and writers on the real UIUC files and on every kind of bad
//! input: detection, Selig/Lednicer equality, errors with file and line, no panics.

mod common;

use bezchain::geometry::{
    parse_cloud, parse_curve, parse_points, read_cloud, read_curve, read_points, write_cloud_csv,
    write_curve_csv, write_selig, Cloud, Format, Grid, LoadedPoints,
};
use bezchain::Error;
use common::{airfoil, scratch};
use glam::{DVec2, DVec3};
use proptest::prelude::*;
use std::path::Path;

/// The numeric rows of a `.dat` file as the plain-text layout shows them (for cross-checks).
fn numeric_rows(path: &Path) -> Vec<DVec2> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .filter_map(|l| {
            let v: Vec<f64> = l.split_whitespace().filter_map(|t| t.parse().ok()).collect();
            (v.len() == 2 && l.split_whitespace().count() == 2).then(|| DVec2::new(v[0], v[1]))
        })
        .collect()
}

#[test]
fn clarky_selig_and_lednicer_give_the_same_points() {
    let selig = read_curve(&airfoil("clarky.dat")).unwrap();
    let led = read_curve(&airfoil("clarky_lednicer.dat")).unwrap();
    assert_eq!(selig.format, Format::Selig);
    assert_eq!(led.format, Format::Lednicer);
    assert_eq!(selig.name, "CLARK Y AIRFOIL");
    assert_eq!(led.name, "CLARK Y AIRFOIL");
    // Lednicer repeats the leading edge (61 + 61 rows); merged, the sequences match.
    assert_eq!(led.points.len(), 121);
    assert_eq!(selig.points.len(), led.points.len());
    for (k, (a, b)) in selig.points.iter().zip(&led.points).enumerate() {
        // The Selig copy has 6 decimals, the Lednicer one 7: equal to rounding.
        assert!((*a - *b).abs().max_element() <= 5.1e-7, "point {k}: {a} vs {b}");
    }
    assert!(selig.warnings.is_empty() && led.warnings.is_empty());
    // Selig order: upper TE first, leading edge in the middle, lower TE last.
    assert_eq!(led.points[0], DVec2::new(1.0, 0.0005993));
    assert_eq!(led.points[60], DVec2::ZERO);
    assert_eq!(led.points[120], DVec2::new(1.0, -0.0005993));
}

#[test]
fn every_real_aerofoil_reads_in_selig_order() {
    for name in [
        "e387.dat",
        "s1223.dat",
        "naca4412.dat",
        "naca4415.dat",
        "clarky.dat",
    ] {
        let path = airfoil(name);
        let l = read_curve(&path).unwrap();
        let rows = numeric_rows(&path);
        assert_eq!(l.format, Format::Selig, "{name}");
        assert_eq!(l.points, rows, "{name}: every row, in file order");
        assert!(l.warnings.is_empty(), "{name}: {:?}", l.warnings);
        // Upper surface first: the first point lies above the last, the LE near x = 0.
        let le = l.points.iter().map(|p| p.x).fold(f64::MAX, f64::min);
        assert!(le.abs() < 1e-3, "{name}: leading edge at x = {le}");
        assert!((l.points[0].x - 1.0).abs() < 1e-9 && l.points[0].y >= l.points.last().unwrap().y);
        // The generic reader finds the same 2D curve.
        match read_points(&path).unwrap() {
            LoadedPoints::Curve(c) => assert_eq!(c.points, l.points),
            LoadedPoints::Cloud(_) => panic!("{name} is 2D"),
        }
    }
}

/// The error of reading `text` as a curve.
fn curve_err(text: &str) -> Error {
    parse_curve(text, Path::new("bad.dat")).unwrap_err()
}

/// Assert `e` is a parse error at `line` whose message contains `needle`.
fn assert_parse(e: &Error, line: usize, needle: &str) {
    match e {
        Error::Parse {
            line: l,
            message,
            path,
        } => {
            assert_eq!(*l, line, "{e}");
            assert!(message.contains(needle), "'{needle}' not in: {e}");
            assert_eq!(path, Path::new("bad.dat"));
        }
        other => panic!("expected a parse error at line {line}, got {other}"),
    }
    assert!(e.is_user_error());
}

#[test]
fn bad_inputs_name_the_file_and_line() {
    // Missing file.
    let e = read_curve(Path::new("no/such/file.dat")).unwrap_err();
    assert!(
        matches!(e, Error::Io { .. }) && e.to_string().contains("no/such/file.dat"),
        "{e}"
    );
    // Empty and content-free files.
    for (text, needle) in [
        ("", "empty"),
        ("\n\n# only a comment\n", "empty"),
        ("NACA 4413\n", "no points after the name"),
        ("x,y\n", "no data rows"),
        ("NAME\n61. 61.\n", "no points after the counts"),
    ] {
        match curve_err(text) {
            Error::Input { message, .. } => assert!(message.contains(needle), "{text:?}: {message}"),
            other => panic!("{text:?}: {other}"),
        }
    }
    // A non-numeric line, shown shortened.
    let long = format!("NAME\n1 0\n0.5 {}\n0 0\n", "abc".repeat(40));
    let e = curve_err(&long);
    assert_parse(&e, 3, "expected numbers, found '0.5 abcabc");
    assert!(e.to_string().len() < 120, "{e}");
    assert_eq!(e.to_string().lines().count(), 1);
    // Notes after the coordinates end them, with a warning naming the line; a number row
    // after the notes makes them an error again.
    let loaded = parse_curve(
        "NAME\n1 0\n0 0.1\n0 0\n1 0\n\nhttp://example.org/notes here\nfrom a book\n",
        Path::new("notes.dat"),
    )
    .unwrap();
    assert_eq!(loaded.points.len(), 4);
    assert!(
        loaded
            .warnings
            .iter()
            .any(|w| w.contains("line 7") && w.contains("after the coordinates")),
        "{:?}",
        loaded.warnings
    );
    assert_parse(
        &curve_err("NAME\n1 0\n0 0.1\nsee below\n0 0\n"),
        4,
        "expected numbers",
    );
    // A name of two lines is one name.
    let two = parse_curve(
        "Ornithopter airfoil.\nS1020\n1 0\n0 0.1\n0 0\n1 0\n",
        Path::new("s.dat"),
    )
    .unwrap();
    assert_eq!(two.points.len(), 4);
    assert_eq!(two.name, "Ornithopter airfoil. S1020");
    // NaN and infinities.
    assert_parse(
        &curve_err("NAME\n1 0\nnan 0.1\n"),
        3,
        "'nan' is not a finite number",
    );
    assert_parse(&curve_err("1,0\n0.5,inf\n"), 2, "'inf' is not a finite number");
    assert_parse(&curve_err("1 0\n0.5 1e999\n"), 2, "not a finite number");
    // Wrong column counts.
    assert_parse(
        &curve_err("NAME\n1 0\n0.5 0.1 7\n"),
        3,
        "3 fields, but the first row has 2",
    );
    assert_parse(
        &curve_err("1 0 0\n"),
        1,
        "expected 2 numbers (x y) per row, found 3",
    );
    assert_parse(
        &curve_err("x,y,w\n1,2,3\n4,5\n"),
        3,
        "2 fields, but the header names 3",
    );
    assert_parse(&curve_err("1,,0\n"), 1, "empty field");
    assert_parse(&curve_err("x,y\n1,0\n0;;1\n"), 3, "empty field");
    // Lednicer counts that do not match the rows.
    let led = std::fs::read_to_string(airfoil("clarky_lednicer.dat")).unwrap();
    let wrong = led.replacen("61.0      61.0", "60.0      61.0", 1);
    assert_parse(
        &curve_err(&wrong),
        2,
        "60 upper + 61 lower = 121 points, but 122 rows follow",
    );
    let moved_blank = "N\n3 3\n0 0\n0.5 0.1\n\n1 0\n0 0\n0.5 -0.1\n1 0\n";
    assert_parse(
        &curve_err(moved_blank),
        2,
        "3 upper-surface points, but the blank line comes after 2 rows",
    );
    let wrong = led.replacen("61.0      61.0", "61.0      62.0", 1);
    assert_parse(
        &curve_err(&wrong),
        2,
        "61 upper + 62 lower = 123 points, but 122 rows follow",
    );
    // A 3D cloud is not a curve, and the reverse.
    assert_parse(&curve_err("x y z\n0 0 0\n"), 1, "3D cloud");
    let e = parse_cloud("x,y\n0,0\n1,1\n", Path::new("bad.dat")).unwrap_err();
    assert_parse(&e, 1, "2D curve");
    // Fewer than two points.
    match curve_err("NAME\n1 0\n1 0\n") {
        Error::Input { message, .. } => assert!(message.contains("at least 2"), "{message}"),
        other => panic!("{other}"),
    }
    match curve_err("1 0\n") {
        Error::Input { message, .. } => assert!(message.contains("only 1 point"), "{message}"),
        other => panic!("{other}"),
    }
    // Binary junk.
    let dir = scratch("bad-bytes");
    let bin = dir.join("junk.dat");
    std::fs::write(&bin, b"NAME\n1 0\n\x00\xff\xfe\x01\n").unwrap();
    let e = read_curve(&bin).unwrap_err();
    assert!(matches!(e, Error::Parse { line: 3, .. }), "{e}");
}

#[test]
fn separators_headers_comments_and_line_ends() {
    let expected = vec![DVec2::new(1.0, 0.0), DVec2::new(0.5, 0.25), DVec2::new(0.0, -0.5)];
    for text in [
        "1 0\n0.5 0.25\n0 -0.5\n",
        "1\t0\r\n0.5\t0.25\r\n0\t-0.5\r\n",
        "1,0\n0.5,0.25\n0,-0.5\n",
        "1;0\n0.5 ; 0.25\n0;-.5\n",
        "# exported\nx,y\n1,0 # first\n\n0.5,0.25\n0,-0.5\n",
        "\"Y\";\"X\";comment\n0;1;9\n0.25;0.5;9\n-0.5;0;9\n",
        "1 0\r0.5 0.25\r0 -0.5",
        "\u{feff}NAME\n1 0\n0.5 0.25\n0 -0.5\n",
    ] {
        let l = parse_curve(text, Path::new("s.csv")).unwrap_or_else(|e| panic!("{text:?}: {e}"));
        assert_eq!(l.points, expected, "{text:?}");
    }
    let l = parse_curve("x,y\n1,0\n0,1\n", Path::new("dir/pts.csv")).unwrap();
    assert_eq!((l.name.as_str(), l.format), ("pts", Format::Csv));
    let l = parse_curve("1 0\n0 1\n", Path::new("pts.xy")).unwrap();
    assert_eq!(l.format, Format::Xyz);
    match parse_points("x y z\n1 2 3\n4 5 6\n", Path::new("c.xyz")).unwrap() {
        LoadedPoints::Cloud(c) => assert_eq!(c.points[1], DVec3::new(4.0, 5.0, 6.0)),
        LoadedPoints::Curve(_) => panic!("a z column makes a cloud"),
    }
}

#[test]
fn writers_round_trip_through_files() {
    let dir = scratch("round-trip");
    // Selig.
    let pts: Vec<DVec2> = (0..33)
        .map(|i| DVec2::new(1.0 / (i + 1) as f64, (i as f64).sin() / 7.0))
        .collect();
    let dat = dir.join("foil.dat");
    write_selig(&dat, "TEST FOIL", &pts).unwrap();
    let back = read_curve(&dat).unwrap();
    assert_eq!(back.name, "TEST FOIL");
    for (a, b) in pts.iter().zip(&back.points) {
        assert!((*a - *b).abs().max_element() <= 5e-13);
    }
    // CSV curve: exact.
    let csv = dir.join("foil.csv");
    write_curve_csv(&csv, &pts).unwrap();
    assert_eq!(read_curve(&csv).unwrap().points, pts);
    // Cloud with a grid: exact, grid kept, duplicate rows kept (a collapsed tip section).
    let mut points: Vec<DVec3> = (0..8).map(|i| DVec3::new(i as f64 / 3.0, 0.1, 0.0)).collect();
    points.extend([DVec3::new(0.0, 0.0, 1.5); 4]);
    let cloud = Cloud {
        points,
        grid: Some(Grid {
            sections: 3,
            per_section: 4,
        }),
    };
    let path = dir.join("cloud.csv");
    write_cloud_csv(&path, &cloud).unwrap();
    let back = read_cloud(&path).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    assert_eq!(back.into_cloud(), cloud);
    // Overwriting leaves no temporary files behind.
    write_cloud_csv(&path, &cloud).unwrap();
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");
    // A writer that cannot write names the file.
    let e = write_selig(&dir.join("no/such/dir/x.dat"), "X", &pts).unwrap_err();
    assert!(
        e.is_user_error() && e.to_string().contains("no/such/dir/x.dat"),
        "{e}"
    );
}

/// Invariants of anything a reader accepts.
fn check_loaded<P: bezchain::bezier::Vector>(points: &[P], grid: Option<Grid>) {
    assert!(points.len() >= 2);
    assert!(points.iter().all(|p| p.is_finite_point()));
    match grid {
        Some(g) => assert_eq!(g.sections * g.per_section, points.len()),
        None => assert!(points.windows(2).all(|w| w[0] != w[1])),
    }
}

/// Check one input against every reader: accepted with the invariants, or refused with a user
/// error whose line (if any) lies within the text.
fn check_all_readers(text: &str) {
    let lines = text.split('\n').count().max(text.split('\r').count());
    let path = Path::new("fuzz.txt");
    let refused = |e: Error| {
        assert!(e.is_user_error(), "{e}");
        if let Error::Parse { line, .. } = e {
            assert!(line >= 1 && line <= lines, "line {line} of {lines}");
        }
    };
    match parse_curve(text, path) {
        Ok(l) => check_loaded(&l.points, l.grid),
        Err(e) => refused(e),
    }
    match parse_cloud(text, path) {
        Ok(l) => check_loaded(&l.points, l.grid),
        Err(e) => refused(e),
    }
    match parse_points(text, path) {
        Ok(LoadedPoints::Curve(l)) => check_loaded(&l.points, l.grid),
        Ok(LoadedPoints::Cloud(l)) => check_loaded(&l.points, l.grid),
        Err(e) => refused(e),
    }
}

/// Tokens that random lines are built from: numbers, junk, separators and layout keywords.
const TOKENS: &[&str] = &[
    "1", "0.5", "-.3", "61.", "2", "0", "1e999", "nan", "inf", "-0", "1D-3", "x", "y", "z", "section",
    "index", "NACA", "\"x\"", ",", ";", " ", "\t", "#", "", "\r", "\u{feff}", "é", "\0",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        check_all_readers(&String::from_utf8_lossy(&bytes));
    }

    #[test]
    fn random_lines_never_panic(
        lines in proptest::collection::vec(proptest::collection::vec(0..TOKENS.len(), 0..8), 0..12),
        crlf in any::<bool>(),
    ) {
        let text: Vec<String> = lines
            .iter()
            .map(|l| l.iter().map(|&t| TOKENS[t]).collect::<Vec<_>>().join(" "))
            .collect();
        check_all_readers(&text.join(if crlf { "\r\n" } else { "\n" }));
    }

    #[test]
    fn mutated_real_files_never_panic(pos in 0usize..4000, byte in any::<u8>(), cut in 0usize..4000) {
        for name in ["clarky_lednicer.dat", "e387.dat"] {
            let mut bytes = std::fs::read(airfoil(name)).unwrap();
            let n = bytes.len();
            bytes[pos % n] = byte;
            bytes.truncate(cut % (n + 1));
            check_all_readers(&String::from_utf8_lossy(&bytes));
        }
    }
}
