//! Blade files and lofting: the paper's 82 × 12 blade, the zero-chord tip, section geometry
//! recovered analytically from the lofted points, interpolation, blending, noise, shuffling,
//! and every bad blade file naming its field.

mod common;

use bezchain::geometry::{
    read_cloud, read_curve, write_cloud_csv, Blade, Grid, LoftOptions, Naca, NacaOptions,
};
use bezchain::Error;
use common::{airfoil, crate_root, scratch, Scratch};
use glam::{DVec2, DVec3};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const RADII: [f64; 12] = [
    0.344, 0.472, 0.600, 0.728, 0.856, 0.984, 1.112, 1.240, 1.368, 1.496, 1.505, 1.510,
];
const CHORDS: [f64; 12] = [
    0.177, 0.168, 0.160, 0.151, 0.143, 0.134, 0.126, 0.117, 0.109, 0.100, 0.08, 0.0,
];
const TWISTS: [f64; 12] = [11.0, 9.4, 8.0, 6.7, 5.6, 4.6, 3.8, 3.1, 2.5, 2.1, 2.1, 2.1];

fn paper() -> Blade {
    Blade::from_file(&crate_root().join("data/blade_paper.json")).unwrap()
}

/// Chord length, twist (degrees, positive = leading edge raised to +y) and pitch-axis point
/// of a lofted NACA section with an odd number of points: the middle point is the leading
/// edge (0, 0) and the trailing-edge midpoint is (1, 0).
fn chord_twist_axis(section: &[DVec3], pitch_axis: f64) -> (f64, f64, DVec2) {
    let n = section.len();
    assert!(n % 2 == 1);
    let le = section[n / 2].truncate();
    let te = 0.5 * (section[0] + section[n - 1]).truncate();
    let d = te - le;
    (d.length(), (-d.y).atan2(d.x).to_degrees(), le + pitch_axis * d)
}

#[test]
fn paper_blade_lofts_to_82_by_12() {
    let blade = paper();
    assert_eq!(blade.stations.len(), 12);
    assert_eq!(blade.aerofoils.len(), 1);
    assert_eq!(blade.aerofoils[0].name(), "NACA 4413");
    let cloud = blade.loft(&LoftOptions::default()).unwrap();
    assert_eq!(cloud.points.len(), 82 * 12);
    assert_eq!(
        cloud.grid,
        Some(Grid {
            sections: 12,
            per_section: 82
        })
    );
    let contour = Naca::parse("4413")
        .unwrap()
        .contour(&NacaOptions::default())
        .unwrap();
    for (k, section) in cloud.points.chunks(82).enumerate() {
        assert!(
            section.iter().all(|p| p.z == RADII[k]),
            "section {k} lies in z = r"
        );
        // Congruent to the aerofoil scaled by the chord: every distance scales by c.
        for (i, j) in [(0, 40), (5, 70), (20, 61), (81, 1)] {
            let lofted = (section[i] - section[j]).length();
            let unit = (contour[i] - contour[j]).length();
            assert!(
                (lofted - CHORDS[k] * unit).abs() < 1e-14,
                "section {k} points {i}, {j}"
            );
        }
        // The trailing-edge midpoint (1, 0) lands at c (1 - 1/4) (cos θ, -sin θ).
        let te = 0.5 * (section[0] + section[81]).truncate();
        let t = TWISTS[k].to_radians();
        let want = 0.75 * CHORDS[k] * DVec2::new(t.cos(), -t.sin());
        assert!((te - want).length() < 1e-14, "section {k}: {te} vs {want}");
    }
}

#[test]
fn sections_recover_chord_twist_and_the_quarter_chord_on_the_pitch_axis() {
    let cloud = paper()
        .loft(&LoftOptions {
            points_per_section: Some(81),
            ..Default::default()
        })
        .unwrap();
    for (k, section) in cloud.points.chunks(81).enumerate().take(11) {
        let (chord, twist, axis) = chord_twist_axis(section, 0.25);
        assert!((chord - CHORDS[k]).abs() < 1e-14, "section {k}: chord {chord}");
        assert!((twist - TWISTS[k]).abs() < 1e-11, "section {k}: twist {twist}");
        assert!(axis.length() < 1e-15, "section {k}: quarter chord at {axis}");
        // Positive twist raises the leading edge.
        assert!(section[40].y > 0.0 && section[40].x < 0.0);
    }
}

#[test]
fn zero_chord_tip_collapses_to_a_point_and_survives_a_round_trip() {
    let cloud = paper().loft(&LoftOptions::default()).unwrap();
    let tip = &cloud.points[11 * 82..];
    assert!(
        tip.iter().all(|&p| p == DVec3::new(0.0, 0.0, 1.510)),
        "{:?}",
        &tip[..3]
    );
    let dir = scratch("tip");
    let path = dir.join("paper.csv");
    write_cloud_csv(&path, &cloud).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text.lines().next(), Some("x,y,z,section,index"));
    assert_eq!(text.lines().count(), 1 + 984);
    let back = read_cloud(&path).unwrap();
    assert_eq!(back.points, cloud.points, "exact, duplicates of the tip kept");
    assert_eq!(back.grid, cloud.grid);
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    // Interpolated sections reach the tip too, and noise there stays finite.
    let noisy = paper()
        .loft(&LoftOptions {
            sections: Some(40),
            noise: 1e-3,
            ..Default::default()
        })
        .unwrap();
    assert!(noisy.points.iter().all(|p| p.is_finite()));
}

#[test]
fn interpolated_sections_follow_a_monotone_cubic_between_stations() {
    let m = 60;
    let blade = paper();
    let opts = LoftOptions {
        points_per_section: Some(81),
        sections: Some(m),
        ..Default::default()
    };
    let radii = blade.section_radii(&opts);
    assert_eq!(radii.len(), m);
    assert_eq!((radii[0], radii[m - 1]), (0.344, 1.510));
    let cloud = blade.loft(&opts).unwrap();
    assert_eq!(
        cloud.grid,
        Some(Grid {
            sections: m,
            per_section: 81
        })
    );
    for (k, section) in cloud.points.chunks(81).enumerate() {
        let r = radii[k];
        assert!(section.iter().all(|p| p.z == r));
        // Bracketing stations: the chord and twist stay between theirs (no overshoot).
        let j = RADII.partition_point(|&x| x <= r).clamp(1, 11) - 1;
        if k == m - 1 {
            assert!(section.iter().all(|p| *p == section[0]), "the tip is a point");
            continue;
        }
        let (chord, twist, axis) = chord_twist_axis(section, 0.25);
        let (c0, c1) = (CHORDS[j].min(CHORDS[j + 1]), CHORDS[j].max(CHORDS[j + 1]));
        assert!(
            chord >= c0 - 1e-14 && chord <= c1 + 1e-14,
            "r {r}: chord {chord} outside [{c0}, {c1}]"
        );
        let (t0, t1) = (TWISTS[j].min(TWISTS[j + 1]), TWISTS[j].max(TWISTS[j + 1]));
        assert!(
            twist >= t0 - 1e-9 && twist <= t1 + 1e-9,
            "r {r}: twist {twist} outside [{t0}, {t1}]"
        );
        assert!(axis.length() < 1e-15);
    }
    // The first section is the first station exactly.
    let stations = blade
        .loft(&LoftOptions {
            points_per_section: Some(81),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(&cloud.points[..81], &stations.points[..81]);
}

/// Write `json` as `blade.json` in a fresh folder (with `extra` files beside it): the folder
/// (removed when dropped) and the file.
fn blade_file(tag: &str, json: &str, extra: &[(&str, &Path)]) -> (Scratch, PathBuf) {
    let dir = scratch(tag);
    for (name, from) in extra {
        std::fs::copy(from, dir.join(name)).unwrap();
    }
    let path = dir.join("blade.json");
    std::fs::write(&path, json).unwrap();
    (dir, path)
}

#[test]
fn two_stations_interpolate_linearly_with_offsets_and_pitch_axis() {
    let (_dir, path) = blade_file(
        "linear",
        r#"{"stations": [
            {"radius": 1.0, "chord": 0.4, "twist_deg": 20, "pitch_axis": 0.3, "prebend": 0.0, "sweep": 0.02},
            {"radius": 3.0, "chord": 0.2, "twist_deg": -10, "pitch_axis": 0.5, "prebend": 0.1, "sweep": -0.02}],
           "aerofoil": "NACA 0012"}"#,
        &[],
    );
    let blade = Blade::from_file(&path).unwrap();
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(101),
            sections: Some(5),
            ..Default::default()
        })
        .unwrap();
    for (k, section) in cloud.points.chunks(101).enumerate() {
        let w = k as f64 / 4.0;
        let lerp = |a: f64, b: f64| a + (b - a) * w;
        let (chord, twist, axis) = chord_twist_axis(section, lerp(0.3, 0.5));
        assert!((section[0].z - lerp(1.0, 3.0)).abs() < 1e-15);
        assert!((chord - lerp(0.4, 0.2)).abs() < 1e-14, "{k}: chord {chord}");
        assert!((twist - lerp(20.0, -10.0)).abs() < 1e-11, "{k}: twist {twist}");
        let want = DVec2::new(lerp(0.02, -0.02), lerp(0.0, 0.1));
        assert!(
            (axis - want).length() < 1e-15,
            "{k}: pitch axis at {axis}, want {want}"
        );
    }
}

/// Smallest distance from `p` to the polyline `line`.
fn distance_to_polyline(p: DVec2, line: &[DVec2]) -> f64 {
    line.windows(2)
        .map(|w| {
            let d = w[1] - w[0];
            let t = ((p - w[0]).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            (w[0] + t * d - p).length()
        })
        .fold(f64::MAX, f64::min)
}

#[test]
fn file_aerofoils_resample_along_the_contour_and_blend() {
    let naca = Naca::parse("4413").unwrap();
    let dense = naca
        .contour(&NacaOptions {
            points: 40001,
            ..Default::default()
        })
        .unwrap();
    let (_dir, path) = blade_file(
        "blend",
        r#"{"radius": [1, 2, 3], "chord": 1, "twist_deg": 0, "pitch_axis": 0,
            "aerofoil": ["naca4413.dat", "naca4413.dat", "clarky.dat"]}"#,
        &[
            ("naca4413.dat", &crate_root().join("data/naca4413.dat")),
            ("clarky.dat", &airfoil("clarky.dat")),
        ],
    );
    let blade = Blade::from_file(&path).unwrap();
    assert_eq!(blade.aerofoils.len(), 2, "one entry per distinct aerofoil");
    assert_eq!(blade.aerofoils[1].name(), "CLARK Y AIRFOIL");
    // Default: the larger native count (clarky's 121) for every section.
    let opts = LoftOptions {
        sections: Some(5),
        ..Default::default()
    };
    assert_eq!(blade.points_per_section(&opts), 121);
    let cloud = blade.loft(&opts).unwrap();
    let unit = |s: &[DVec3]| s.iter().map(|p| p.truncate()).collect::<Vec<_>>();
    // At radius 1 the section is NACA 4413 resampled from its 82 points: close to the true
    // contour, far closer than the 82-point polygon gets (its chords cut the leading edge and
    // the camber-curvature jump at x = 0.4 by up to ~4e-4).
    let first = unit(&cloud.points[..121]);
    let worst = first
        .iter()
        .map(|&p| distance_to_polyline(p, &dense))
        .fold(0.0, f64::max);
    let file = read_curve(&crate_root().join("data/naca4413.dat"))
        .unwrap()
        .points;
    let polygon = dense
        .iter()
        .step_by(10)
        .map(|&p| distance_to_polyline(p, &file))
        .fold(0.0, f64::max);
    assert!(
        worst < 3e-5 && worst < 0.1 * polygon,
        "resampled NACA 4413 is {worst} off the contour"
    );
    // At radius 3 it is the Clark Y, on the file's points where they coincide.
    let clarky = read_curve(&airfoil("clarky.dat")).unwrap().points;
    let last = unit(&cloud.points[4 * 121..]);
    assert!((last[0] - clarky[0]).length() < 1e-15 && (last[60] - clarky[60]).length() < 1e-15);
    let worst = last
        .iter()
        .map(|&p| distance_to_polyline(p, &clarky))
        .fold(0.0, f64::max);
    // The cubic bulges out of the file's polygon by about that polygon's own chord sagitta.
    assert!(worst < 5e-4, "resampled Clark Y is {worst} off its polyline");
    // Half-way between (radius 2.5) the maximum thickness lies between the two aerofoils'.
    let thickness = |s: &[DVec2]| (1..60).map(|i| s[i].y - s[120 - i].y).fold(0.0, f64::max);
    let (a, mid, b) = (
        thickness(&first),
        thickness(&unit(&cloud.points[3 * 121..4 * 121])),
        thickness(&last),
    );
    assert!(mid > a.min(b) && mid < a.max(b), "{a} {mid} {b}");
}

#[test]
fn a_single_file_aerofoil_keeps_its_points_unless_asked() {
    let (_dir, path) = blade_file(
        "file",
        r#"{"radius": [0, 1], "chord": [2, 1], "twist_deg": 0, "pitch_axis": 0, "aerofoil": "clarky.dat"}"#,
        &[("clarky.dat", &airfoil("clarky.dat"))],
    );
    let blade = Blade::from_file(&path).unwrap();
    let clarky = read_curve(&airfoil("clarky.dat")).unwrap().points;
    let cloud = blade.loft(&LoftOptions::default()).unwrap();
    assert_eq!(cloud.points.len(), 2 * 121);
    for (p, q) in cloud.points.iter().zip(&clarky) {
        assert!((p.truncate() - 2.0 * *q).length() < 1e-15);
    }
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(200),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(cloud.points.len(), 400);
    // A coarse file needs an explicit count, and is then resampled through its points.
    std::fs::write(
        path.with_file_name("clarky.dat"),
        "COARSE\n1 0.001\n0.5 0.05\n0 0\n0.5 -0.05\n",
    )
    .unwrap();
    let blade = Blade::from_file(&path).unwrap();
    let e = blade.loft(&LoftOptions::default()).unwrap_err();
    assert!(e.to_string().contains("only 4 points"), "{e}");
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(9),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(
        cloud.points[4].truncate(),
        DVec2::ZERO,
        "the middle point is the leading edge"
    );
}

#[test]
fn noise_and_shuffle_are_seeded_and_sized_by_the_largest_chord() {
    let blade = paper();
    let clean = blade.loft(&LoftOptions::default()).unwrap();
    let opts = LoftOptions {
        noise: 0.01,
        seed: 7,
        ..Default::default()
    };
    let noisy = blade.loft(&opts).unwrap();
    assert_eq!(noisy.grid, clean.grid, "noise alone keeps the order");
    let residuals: Vec<f64> = noisy
        .points
        .iter()
        .zip(&clean.points)
        .flat_map(|(a, b)| (*a - *b).to_array())
        .collect();
    let n = residuals.len() as f64;
    let mean = residuals.iter().sum::<f64>() / n;
    let sd = (residuals.iter().map(|r| (r - mean) * (r - mean)).sum::<f64>() / n).sqrt();
    let sigma = 0.01 * 0.177;
    assert!(mean.abs() < 4.0 * sigma / n.sqrt(), "mean {mean}");
    assert!((sd / sigma - 1.0).abs() < 0.05, "sd {sd} vs sigma {sigma}");
    // Reproducible, seed-dependent, and the same on one thread as on many.
    assert_eq!(blade.loft(&opts).unwrap(), noisy);
    assert_ne!(blade.loft(&LoftOptions { seed: 8, ..opts }).unwrap(), noisy);
    let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    assert_eq!(one_thread.install(|| blade.loft(&opts)).unwrap(), noisy);
    // Shuffled: the same points in another order, no grid.
    let shuffled = blade
        .loft(&LoftOptions {
            shuffle: true,
            ..opts
        })
        .unwrap();
    assert_eq!(shuffled.grid, None);
    assert_ne!(shuffled.points, noisy.points);
    let key = |p: &DVec3| p.to_array().map(f64::to_bits);
    let mut a: Vec<_> = shuffled.points.iter().map(key).collect();
    let mut b: Vec<_> = noisy.points.iter().map(key).collect();
    a.sort_unstable();
    b.sort_unstable();
    assert_eq!(a, b);
}

#[test]
fn bad_loft_options_are_refused() {
    let blade = paper();
    for opts in [
        LoftOptions {
            points_per_section: Some(4),
            ..Default::default()
        },
        LoftOptions {
            sections: Some(1),
            ..Default::default()
        },
        LoftOptions {
            noise: -0.1,
            ..Default::default()
        },
        LoftOptions {
            noise: f64::NAN,
            ..Default::default()
        },
        LoftOptions {
            points_per_section: Some(1 << 20),
            sections: Some(1 << 20),
            ..Default::default()
        },
    ] {
        let e = blade.loft(&opts).unwrap_err();
        assert!(
            matches!(e, Error::Invalid(_)) && e.is_user_error(),
            "{opts:?}: {e}"
        );
    }
}

#[test]
fn bad_blade_files_name_the_field() {
    let ok = r#""chord": [0.2, 0.1, 0.05], "twist_deg": [5, 3, 1], "aerofoil": "NACA 4413""#;
    let cases: Vec<(String, &str)> = vec![
        (format!(r#"{{"radius": [0.5, 0.7, 0.6], {ok}}}"#), "field 'radius': values must increase (0.6 after 0.7 at index 2)"),
        (r#"{"radius": [0.5, 0.7, 0.9], "chord": [0.2, 0.1], "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'chord': 2 values, but 'radius' has 3"),
        (r#"{"radius": [0.5, 0.7, 0.9], "chord": [0.2, 0.1, 0.1], "twist_deg": [1, 2], "aerofoil": "4413"}"#.into(), "field 'twist_deg': 2 values, but 'radius' has 3"),
        (r#"{"radius": [0.5, 0.7], "chord": [0.2, -0.1], "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'chord': chord -0.1 at index 1 is negative"),
        (format!(r#"{{"radius": [0.5, 0.7, 0.9], {}}}"#, ok.replace("NACA 4413", "NACA 4013")), "field 'aerofoil' at index 0: NACA 4013: camber and its position"),
        (format!(r#"{{"radius": [0.5, 0.7, 0.9], {}}}"#, ok.replace("NACA 4413", "NACA 44x3")), "field 'aerofoil' at index 0: 'NACA 44x3' is neither"),
        (format!(r#"{{"radius": [0.5, 0.7, 0.9], {}}}"#, ok.replace("NACA 4413", "missing.dat")), "field 'aerofoil' at index 0: 'missing.dat' is neither a NACA 4/5-digit code nor an existing file"),
        (r#"{"radius": [0.5], "chord": [0.2], "twist_deg": 0, "aerofoil": "4413"}"#.into(), "field 'radius': at least 2 stations are needed (got 1)"),
        (r#"{"stations": [{"radius": 1, "chord": 1, "twist_deg": 0, "aerofoil": "4413"}]}"#.into(), "field 'stations': at least 2 stations are needed (got 1)"),
        (r#"{"radius": [1, 2], "chord": [1, 1], "twist_deg": 0, "aerofoil": ["4413", "bad.dat"]}"#.into(), "field 'aerofoil' at index 1: "),
        ("{\"radius\": [1, 2],\n\"chord\": [1 1]}".into(), "blade.json:2: not valid JSON"),
    ];
    for (json, needle) in cases {
        let (_dir, path) = blade_file("bad", &json, &[]);
        if json.contains("bad.dat") {
            std::fs::write(path.with_file_name("bad.dat"), "BAD\n1 0\n0.5 zzz\n").unwrap();
        }
        let e = Blade::from_file(&path).unwrap_err();
        let msg = e.to_string();
        assert!(e.is_user_error(), "{msg}");
        assert!(matches!(e, Error::Input { .. } | Error::Parse { .. }), "{msg}");
        assert!(msg.contains(needle), "{json}\n  gave: {msg}\n  want: {needle}");
        assert!(msg.starts_with(&path.display().to_string()), "{msg}");
        assert_eq!(msg.lines().count(), 1, "{msg}");
    }
    // An aerofoil file's own error (its line) comes through.
    let (_dir, path) = blade_file(
        "bad-aerofoil",
        r#"{"radius": [1, 2], "chord": 1, "twist_deg": 0, "aerofoil": "foil.dat"}"#,
        &[],
    );
    std::fs::write(path.with_file_name("foil.dat"), "FOIL\n1 0\n0.5 nan\n0 0\n").unwrap();
    let msg = Blade::from_file(&path).unwrap_err().to_string();
    assert!(msg.contains("foil.dat:3: 'nan' is not a finite number"), "{msg}");
    // An aerofoil file in millimetres is refused rather than lofted 1000 times too big.
    std::fs::write(
        path.with_file_name("foil.dat"),
        "FOIL\n1000 0\n500 60\n0 0\n500 -40\n1000 0\n",
    )
    .unwrap();
    let msg = Blade::from_file(&path).unwrap_err().to_string();
    assert!(msg.contains("expected chord fractions"), "{msg}");
    // A missing blade file.
    let e = Blade::from_file(Path::new("no/such/blade.json")).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e}");
}

/// Scale check (run in release): `cargo test --release --test geometry_blade -- --ignored
/// --nocapture`. Lofts and writes a 1,000,000-point noisy shuffled cloud and reads it back.
#[test]
#[ignore = "timing; run in release with --ignored"]
fn million_point_noisy_shuffled_cloud() {
    let blade = paper();
    let opts = LoftOptions {
        points_per_section: Some(1000),
        sections: Some(1000),
        noise: 1e-3,
        shuffle: true,
        seed: 42,
    };
    let t = std::time::Instant::now();
    let cloud = blade.loft(&opts).unwrap();
    let loft = t.elapsed();
    let dir = scratch("million");
    let path = dir.join("cloud.csv");
    let t = std::time::Instant::now();
    write_cloud_csv(&path, &cloud).unwrap();
    let write = t.elapsed();
    let t = std::time::Instant::now();
    let back = read_cloud(&path).unwrap();
    let read = t.elapsed();
    let bytes = std::fs::metadata(&path).unwrap().len();
    println!(
        "1,000,000 points: loft {loft:.3?}, write {write:.3?} ({:.1} MB), read back {read:.3?}",
        bytes as f64 / 1e6
    );
    assert_eq!(cloud.points.len(), 1_000_000);
    assert_eq!(back.points, cloud.points);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A blade file with the given column values (any numbers, any lengths).
fn columns_json(radius: &[f64], chord: &[f64], twist: &[f64], extra: &str) -> String {
    let list = |v: &[f64]| v.iter().map(|x| format!("{x:e}")).collect::<Vec<_>>().join(", ");
    format!(
        r#"{{"radius": [{}], "chord": [{}], "twist_deg": [{}], "aerofoil": "NACA 4413"{extra}}}"#,
        list(radius),
        list(chord),
        list(twist)
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_blades_loft_or_fail_cleanly(
        radius in proptest::collection::vec(prop_oneof![-1.0..3.0, Just(1.0), Just(1e300), Just(0.0)], 0..6),
        chord in proptest::collection::vec(prop_oneof![-0.1..0.5, Just(0.0), Just(1e300)], 0..6),
        twist in proptest::collection::vec(prop_oneof![-90.0..90.0, Just(1e300)], 0..6),
        extra in prop_oneof![
            Just(String::new()),
            Just(r#", "pitch_axis": 1"#.to_string()),
            Just(r#", "prebend": [0, 0.1]"#.to_string()),
            Just(r#", "sweep": 1e300"#.to_string()),
            Just(r#", "pitch_axis": null"#.to_string()),
        ],
        sections in prop_oneof![Just(None), (0usize..30).prop_map(Some)],
        points in prop_oneof![Just(None), (0usize..120).prop_map(Some)],
        noise in prop_oneof![Just(0.0), 0.0..0.1, Just(f64::INFINITY)],
        shuffle in any::<bool>(),
    ) {
        let json = columns_json(&radius, &chord, &twist, &extra);
        match Blade::from_json(&json, Path::new("fuzz.json")) {
            Err(e) => prop_assert!(e.is_user_error() && e.to_string().starts_with("fuzz.json"), "{e}"),
            Ok(blade) => {
                prop_assert!(blade.stations.len() >= 2);
                prop_assert!(blade.stations.windows(2).all(|w| w[0].radius < w[1].radius));
                let opts = LoftOptions { points_per_section: points, sections, noise, shuffle, seed: 1 };
                match blade.loft(&opts) {
                    Err(e) => prop_assert!(matches!(e, Error::Invalid(_)), "{e}"),
                    Ok(cloud) => {
                        let n = blade.points_per_section(&opts);
                        prop_assert_eq!(cloud.points.len(), n * blade.section_radii(&opts).len());
                        prop_assert!(cloud.points.iter().all(|p| p.is_finite()));
                    }
                }
            }
        }
    }

    #[test]
    fn mutated_blade_files_never_panic(
        text in "[\\[\\]{}:,\"a-z0-9. _-]{0,120}",
        at in 0usize..1000,
        with in "[\\[\\]{}:,\"a-z0-9. _-]{0,3}",
    ) {
        let paper = std::fs::read_to_string(crate_root().join("data/blade_paper.json")).unwrap();
        let at = (0..=at.min(paper.len())).rev().find(|&i| paper.is_char_boundary(i)).unwrap_or(0);
        let end = (at + with.len()).min(paper.len());
        let end = (end..=paper.len()).find(|&i| paper.is_char_boundary(i)).unwrap_or(paper.len());
        let mutated = format!("{}{with}{}", &paper[..at], &paper[end..]);
        for json in [text.as_str(), mutated.as_str()] {
            match Blade::from_json(json, Path::new("fuzz.json")) {
                Err(e) => prop_assert!(e.is_user_error(), "{e}"),
                Ok(blade) => {
                    if let Err(e) = blade.loft(&LoftOptions::default()) {
                        prop_assert!(matches!(e, Error::Invalid(_)), "{e}");
                    }
                }
            }
        }
    }
}
