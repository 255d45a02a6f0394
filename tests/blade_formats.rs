//! Real blade files: the IEA 3.4 MW turbine as OpenFAST AeroDyn 15 input and as windIO v1, the
//! IEA 15 MW turbine as windIO v2 (all in data/blades), their agreement, and every bad-file
//! case naming its file and line or field.

mod common;

use bezchain::geometry::{Axes, Blade, BladeFormat, Blend, LoftOptions};
use bezchain::Error;
use common::{bin, crate_root, scratch};
use glam::{DVec2, DVec3};
use std::path::PathBuf;
use std::process::Command;

fn aerodyn_dir() -> PathBuf {
    crate_root().join("data/blades/iea-3.4-130-rwt/openfast")
}

fn aerodyn() -> PathBuf {
    aerodyn_dir().join("IEA-3.4-130-RWT_AeroDyn15.dat")
}

fn windio1() -> PathBuf {
    crate_root().join("data/blades/iea-3.4-130-rwt/windio/IEA-3.4-130-RWT.yaml")
}

fn windio2() -> PathBuf {
    crate_root().join("data/blades/iea-15-240-rwt/windio/IEA-15-240-RWT.yaml")
}

/// The largest distance from a point of `a` to the closed polyline `b`, both in one plane.
fn polyline_distance(a: &[DVec2], b: &[DVec2]) -> f64 {
    a.iter()
        .map(|p| {
            b.windows(2)
                .map(|w| {
                    let d = w[1] - w[0];
                    let t = ((*p - w[0]).dot(d) / d.length_squared().max(1e-300)).clamp(0.0, 1.0);
                    (*p - (w[0] + t * d)).length()
                })
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}

#[test]
fn aerodyn_primary_file_resolves_blade_polars_and_coordinates() {
    let blade = Blade::from_file(&aerodyn()).unwrap();
    assert_eq!(blade.format, BladeFormat::AeroDyn15);
    assert_eq!(blade.axes, Axes::Turbine);
    assert_eq!(blade.blend, Blend::Radius);
    assert_eq!(blade.stations.len(), 30);
    assert_eq!(blade.aerofoils.len(), 30);
    let (root, tip) = (&blade.stations[0], &blade.stations[29]);
    // Node 1: BlSpn 0, BlTwist 19.996 deg (towards feather), BlChord 2.6, BlAFID 1, whose
    // coordinates file has the reference point (0.5, 0).
    assert_eq!((root.radius, root.chord, root.aerofoil), (0.0, 2.6, 0));
    assert!((root.twist_deg + 19.996_227_050_065_73).abs() < 1e-12);
    assert_eq!(root.pitch_axis, 0.5);
    assert!((tip.radius - 62.908_521_122_288_99).abs() < 1e-12);
    assert!((tip.prebend + 2.5).abs() < 1e-12, "BlCrvAC is the prebend");
    assert_eq!(tip.pitch_axis, 0.25);
    assert_eq!(blade.stations[5].aerofoil, 5);
    // The IEA 3.4 MW coordinates run TE → pressure side → LE → suction side: read clockwise,
    // they are reversed into Selig order, so the first half is the upper (suction) surface.
    let bezchain::geometry::Aerofoil::File { points, .. } = &blade.aerofoils[15] else {
        panic!("a file aerofoil")
    };
    assert_eq!(points.len(), 200);
    let upper_mid = points[50];
    let lower_mid = points[150];
    assert!(upper_mid.y > lower_mid.y, "{upper_mid} above {lower_mid}");
    let cloud = blade.loft(&LoftOptions::default()).unwrap();
    assert_eq!(cloud.points.len(), 30 * 200);
}

#[test]
fn windio_v1_reads_radians_pitch_axis_and_the_reference_axis() {
    let blade = Blade::from_file(&windio1()).unwrap();
    assert_eq!(blade.format, BladeFormat::WindIo1);
    assert_eq!(blade.axes, Axes::Turbine);
    // 50 shape stations and the 9 aerofoil positions, 2 of which are shared (0 and 1).
    assert_eq!(blade.stations.len(), 57);
    let (root, tip) = (&blade.stations[0], &blade.stations[56]);
    assert!(
        (root.twist_deg + 0.349_f64.to_degrees()).abs() < 1e-12,
        "radians, negated"
    );
    assert_eq!((root.radius, root.chord, root.pitch_axis), (0.0, 2.6, 0.5));
    assert_eq!((tip.radius, tip.chord, tip.prebend), (63.0, 0.2, -2.5));
    let Blend::Thickness { masters, rthick } = &blade.blend else {
        panic!("windIO blends by thickness")
    };
    // Seven masters (the cylinder placed twice counts once), thinnest first.
    let t: Vec<f64> = masters.iter().map(|m| m.0).collect();
    assert_eq!(t, vec![0.21, 0.25, 0.3, 0.35, 0.4, 0.5, 1.0]);
    assert_eq!(rthick[0], 1.0);
    assert!((rthick[56] - 0.21).abs() < 1e-12);
}

#[test]
fn windio_v2_is_lofted_with_degrees_offsets_and_its_masters() {
    let blade = Blade::from_file(&windio2()).unwrap();
    assert_eq!(blade.format, BladeFormat::WindIo2);
    let Blend::Thickness { masters, .. } = &blade.blend else {
        panic!("windIO blends by thickness")
    };
    assert_eq!(masters.len(), 8);
    let root = &blade.stations[0];
    assert!(
        (root.twist_deg + 15.594_553_019_711_718).abs() < 1e-12,
        "degrees, negated"
    );
    // section_offset_y 2.6236 m of a 5.2 m chord: the pitch axis at 50.45 % of the chord.
    assert!((root.pitch_axis - 2.623_636_363_636_363_5 / 5.2).abs() < 1e-12);
    let cloud = blade
        .loft(&LoftOptions {
            sections: Some(40),
            points_per_section: Some(121),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(cloud.points.len(), 40 * 121);
    let tip = &cloud.points[39 * 121..];
    let r = blade.stations.last().unwrap().radius;
    assert!(tip.iter().all(|p| p.z == r), "the last section lies in z = {r}");
    // Every section's chord (leading edge to trailing-edge midpoint) is the interpolated chord,
    // in the windIO frame: leading edge towards -y.
    let root = &cloud.points[..121];
    let te = 0.5 * (root[0] + root[120]);
    let le = root[60];
    assert!(
        ((te - le).length() - 5.2).abs() < 0.02,
        "root chord {}",
        (te - le).length()
    );
    assert!(te.y > le.y, "y points to the trailing edge");
}

/// Every section of the IEA 15 MW lofted at 160 points closes at its trailing edge: the seam is
/// a corner of the section's convex hull, no point of the section runs past it. The root
/// sections blend the SNL-FFA-W3-500 flatback, closed by a short, nearly vertical segment;
/// resampled with free end slopes, they ran up to 9 mm past their seam (1.7e-3 of the chord),
/// a notch the fitted surface then doubled back to follow.
#[test]
fn windio_v2_sections_close_at_their_trailing_edge() {
    let blade = Blade::from_file(&windio2()).unwrap();
    let per = 160;
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(per),
            ..Default::default()
        })
        .unwrap();
    assert_eq!(cloud.points.len(), blade.stations.len() * per);
    for (k, sec) in cloud.points.chunks(per).enumerate() {
        let seam = DVec2::new(sec[0].x, sec[0].y);
        // The directions from the seam to every other point: on the hull, they leave a gap of
        // at least half a turn.
        let mut angles: Vec<f64> = sec[1..per - 1]
            .iter()
            .map(|p| DVec2::new(p.x, p.y) - seam)
            .filter(|d| d.length() > 0.0)
            .map(|d| d.y.atan2(d.x))
            .collect();
        if angles.len() < 3 {
            continue;
        }
        angles.sort_by(f64::total_cmp);
        let wrap = angles[0] + std::f64::consts::TAU - angles[angles.len() - 1];
        let gap = angles.windows(2).map(|w| w[1] - w[0]).fold(wrap, f64::max);
        assert!(
            gap >= std::f64::consts::PI - 1e-9,
            "section {k} (r = {}): the seam lies inside its section (largest gap {gap})",
            sec[0].z
        );
    }
}

/// The two files of the IEA 3.4 MW blade describe the same blade: lofted at the AeroDyn nodes
/// (30 sections at the same fractions of the span), each section of one lies within 7 cm of
/// the other's (4.3 m largest chord: 1.5 %), and the spans differ by the 0.145 % that the
/// AeroDyn file's `BlSpn` (62.909 m at the tip) is shorter than windIO's reference axis
/// (63.000 m). The largest in-plane difference is at the trailing edge of the thick sections,
/// where WISDEM, which wrote the AeroDyn coordinates, smooths the trailing edges of blended
/// sections thinner than 40 % and bezchain does not.
#[test]
fn aerodyn_and_windio_v1_clouds_of_the_iea_3_4_agree() {
    let opts = LoftOptions {
        sections: Some(30),
        points_per_section: Some(200),
        ..Default::default()
    };
    let a = Blade::from_file(&aerodyn()).unwrap().loft(&opts).unwrap();
    let b = Blade::from_file(&windio1()).unwrap().loft(&opts).unwrap();
    let mut worst = (0.0, 0);
    for k in 0..30 {
        let sa: Vec<DVec3> = a.points[k * 200..(k + 1) * 200].to_vec();
        let sb: Vec<DVec3> = b.points[k * 200..(k + 1) * 200].to_vec();
        let ratio = sb[0].z / 63.0 - sa[0].z / 62.908_521_122_288_99;
        assert!(ratio.abs() < 1e-12, "section {k} at the same span fraction");
        let flat = |s: &[DVec3]| -> Vec<DVec2> { s.iter().map(|p| p.truncate()).collect() };
        let (fa, fb) = (flat(&sa), flat(&sb));
        let d = polyline_distance(&fa, &fb).max(polyline_distance(&fb, &fa));
        if d > worst.0 {
            worst = (d, k);
        }
    }
    assert!(
        worst.0 < 0.07,
        "largest in-plane difference {} m at section {}",
        worst.0,
        worst.1
    );
}

/// Copy the AeroDyn set to a scratch folder, apply `edit` to one of its files, and return the
/// error of reading the primary file.
fn aerodyn_error(tag: &str, file: &str, edit: impl Fn(String) -> String) -> Error {
    let Err(e) = aerodyn_edited(tag, file, edit) else {
        panic!("a bad file was read ({tag})")
    };
    assert!(e.is_user_error(), "{e}");
    e
}

/// The shipped AeroDyn files, `file` among them edited, read from a scratch copy.
fn aerodyn_edited(tag: &str, file: &str, edit: impl Fn(String) -> String) -> bezchain::Result<Blade> {
    let dir = scratch(tag);
    std::fs::create_dir_all(dir.join("Airfoils")).unwrap();
    for entry in std::fs::read_dir(aerodyn_dir())
        .unwrap()
        .chain(std::fs::read_dir(aerodyn_dir().join("Airfoils")).unwrap())
    {
        let p = entry.unwrap().path();
        if p.is_file() {
            let rel = p.strip_prefix(aerodyn_dir()).unwrap();
            std::fs::copy(&p, dir.join(rel)).unwrap();
        }
    }
    let target = dir.join(file);
    let text = std::fs::read_to_string(&target).unwrap();
    std::fs::write(&target, edit(text)).unwrap();
    let read = Blade::from_file(&dir.join("IEA-3.4-130-RWT_AeroDyn15.dat"));
    let _ = std::fs::remove_dir_all(&dir);
    read
}

fn windio_error(text: String) -> Error {
    let dir = scratch("windio-bad");
    let path = dir.join("bad.yaml");
    std::fs::write(&path, text).unwrap();
    let Err(e) = Blade::from_file(&path) else {
        panic!("a bad file was read")
    };
    assert!(e.is_user_error(), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
    e
}

fn line_of(e: &Error) -> (String, usize) {
    match e {
        Error::Parse { path, line, .. } => (path.file_name().unwrap().to_string_lossy().into_owned(), *line),
        other => panic!("expected a parse error with a line, got {other}"),
    }
}

#[test]
fn bad_aerodyn_files_name_the_file_and_line() {
    // A missing aerofoil (polar) file: the primary file's AFNames line.
    let e = aerodyn_error("ad-missing", "IEA-3.4-130-RWT_AeroDyn15.dat", |t| {
        t.replace("Polar_07.dat", "Polar_77.dat")
    });
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AeroDyn15.dat".into(), 55));
    assert!(
        e.to_string().contains("AFNames entry 8") && e.to_string().contains("Polar_77.dat"),
        "{e}"
    );
    // A missing coordinates file: the polar file's NumCoords line.
    let e = aerodyn_error(
        "ad-coords",
        "Airfoils/IEA-3.4-130-RWT_AeroDyn15_Polar_03.dat",
        |t| t.replace("AF03_Coords", "AF99_Coords"),
    );
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AeroDyn15_Polar_03.dat".into(), 8));
    assert!(e.to_string().contains("AF99_Coords.txt"), "{e}");
    // An unreadable coordinates file (a row that is not two numbers).
    let e = aerodyn_error("ad-garbled", "Airfoils/IEA-3.4-130-RWT_AF04_Coords.txt", |t| {
        t.replacen(" 9.95825558916260e-01", " x.95825558916260e-01", 1)
    });
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AF04_Coords.txt".into(), 10));
    assert!(e.to_string().contains("expected row"), "{e}");
    // NumCoords against the rows present.
    let e = aerodyn_error("ad-numcoords", "Airfoils/IEA-3.4-130-RWT_AF04_Coords.txt", |t| {
        t.replacen("201", "205", 1)
    });
    assert!(
        e.to_string().contains("NumCoords says 205") && e.to_string().contains("ends after 201"),
        "{e}"
    );
    // NumBlNds against the rows present, both ways.
    let e = aerodyn_error("ad-fewer", "IEA-3.4-130-RWT_AeroDyn15_blade.dat", |t| {
        t.replacen("30          NumBlNds", "31          NumBlNds", 1)
    });
    assert_eq!(line_of(&e).0, "IEA-3.4-130-RWT_AeroDyn15_blade.dat");
    assert!(
        e.to_string()
            .contains("NumBlNds says 31 nodes, but the file ends after 30"),
        "{e}"
    );
    let e = aerodyn_error("ad-more", "IEA-3.4-130-RWT_AeroDyn15_blade.dat", |t| {
        t.replacen("30          NumBlNds", "29          NumBlNds", 1)
    });
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AeroDyn15_blade.dat".into(), 36));
    assert!(e.to_string().contains("another row follows"), "{e}");
    // A non-increasing span.
    let e = aerodyn_error("ad-span", "IEA-3.4-130-RWT_AeroDyn15_blade.dat", |t| {
        t.replacen(" 4.338518698088897e+00", " 1.0e+00", 1)
    });
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AeroDyn15_blade.dat".into(), 9));
    assert!(e.to_string().contains("span does not increase"), "{e}");
    // An unknown aerofoil label.
    let e = aerodyn_error("ad-afid", "IEA-3.4-130-RWT_AeroDyn15_blade.dat", |t| {
        t.replacen("        2\n", "       31\n", 1)
    });
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AeroDyn15_blade.dat".into(), 8));
    assert!(
        e.to_string()
            .contains("BlAFID 31: unknown aerofoil (NumAFfiles is 30)"),
        "{e}"
    );
    // NumAFfiles against the names present.
    let e = aerodyn_error("ad-numaf", "IEA-3.4-130-RWT_AeroDyn15.dat", |t| {
        t.replace(
            "30                     NumAFfiles",
            "31                     NumAFfiles",
        )
    });
    assert_eq!(line_of(&e), ("IEA-3.4-130-RWT_AeroDyn15.dat".into(), 78));
    assert!(
        e.to_string()
            .contains("NumAFfiles says 31, but this line is not an aerofoil file name (AFNames has 30)"),
        "{e}"
    );
}

#[test]
fn bad_windio_files_name_the_field_and_line() {
    let v1 = std::fs::read_to_string(windio1()).unwrap();
    // Grids of different lengths (the chord grid loses a value).
    let e = windio_error(v1.replacen("values: [2.6, 2.6, ", "values: [2.6, ", 1));
    assert_eq!(line_of(&e).1, 19);
    assert!(
        e.to_string().contains(
            "outer_shape_bem.chord': the grids differ in length ('grid' has 50 values, 'values' 49)"
        ),
        "{e}"
    );
    // A non-increasing span grid.
    let e = windio_error(v1.replacen("grid: [0.0, 0.02, 0.1371", "grid: [0.0, 0.2, 0.1371", 1));
    assert_eq!(line_of(&e).1, 17);
    assert!(e.to_string().contains("span does not increase"), "{e}");
    // An unknown aerofoil label.
    let e = windio_error(v1.replacen("FX77-W-400, DU00", "FX77-W-444, DU00", 1));
    assert_eq!(line_of(&e).1, 17);
    assert!(
        e.to_string().contains("unknown aerofoil label 'FX77-W-444'"),
        "{e}"
    );
    // Aerofoil coordinates of different lengths.
    let e = windio_error(v1.replacen("y: [0.00, 0.0061,", "y: [0.0061,", 1));
    assert!(
        e.to_string()
            .contains("airfoils 'DU91-W2-250'.coordinates: the grids differ in length"),
        "{e}"
    );
    // A missing required field, and not YAML at all.
    let e = windio_error(v1.replacen("            pitch_axis:", "            pitch_axiz:", 1));
    assert!(e.to_string().contains("pitch_axis"), "{e}");
    let e = windio_error("a: [1, 2\nb: 3\n".into());
    assert!(e.to_string().contains("bad.yaml"), "{e}");
    let v2 = std::fs::read_to_string(windio2()).unwrap();
    let e = windio_error(v2.replacen(
        "name: FFA-W3-360\n                  spanwise_position",
        "name: FFA-W3-999\n                  spanwise_position",
        1,
    ));
    assert!(
        e.to_string().contains("unknown aerofoil label 'FFA-W3-999'"),
        "{e}"
    );
}

#[test]
fn the_cli_lofts_every_format_and_exits_2_on_a_bad_file() {
    for (file, shape) in [
        (aerodyn(), "30 sections × 200 points"),
        (windio1(), "57 sections × 361 points"),
        (windio2(), "sections × 257 points"),
    ] {
        let out = Command::new(bin())
            .arg("blade")
            .arg(&file)
            .args(["-o", "/dev/null"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{}: {err}", file.display());
        assert!(err.contains(shape), "{err}");
    }
    let dir = scratch("cli-bad-blade");
    let bad = dir.join("b.yaml");
    let text =
        std::fs::read_to_string(windio1())
            .unwrap()
            .replacen("FX77-W-400, DU00", "FX77-W-444, DU00", 1);
    std::fs::write(&bad, text).unwrap();
    let out = Command::new(bin()).arg("blade").arg(&bad).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: ") && err.contains("b.yaml:17:"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stations that coincide within 1e-6 of the span are merged, in every reader, with one note;
/// twins that differ are an error naming both.
#[test]
fn coincident_stations_are_merged_with_a_note_and_different_twins_refused() {
    // windIO: a twist grid point 1e-10 of the span after another (as grids of different
    // quantities meet in real files), with the same value.
    let text = std::fs::read_to_string(windio2()).unwrap();
    let (s0, t0) = ("0.5102040816326531, ", "1.5587834208773341, ");
    let twist = text.find("twist:").unwrap();
    let grid = twist + text[twist..].find(s0).unwrap();
    let mut edited = text.clone();
    edited.insert_str(grid + s0.len(), "0.5102040817326531, ");
    let values = grid + edited[grid..].find(t0).unwrap();
    edited.insert_str(values + t0.len(), t0);
    let dir = scratch("twins");
    let path = dir.join("twins.yaml");
    std::fs::write(&path, &edited).unwrap();
    let plain = Blade::from_file(&windio2()).unwrap();
    let twins = Blade::from_file(&path).unwrap();
    assert!(plain.notes.is_empty());
    assert_eq!(twins.notes.len(), 1, "{:?}", twins.notes);
    assert!(twins.notes[0].contains("merged 1 station"), "{}", twins.notes[0]);
    assert_eq!(twins.stations.len(), plain.stations.len());
    // The CLI says it on one note line.
    let out = Command::new(bin())
        .args([
            "blade",
            path.to_str().unwrap(),
            "-o",
            dir.join("c.xyz").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(err.lines().filter(|l| l.starts_with("note:")).count(), 1, "{err}");

    // JSON: the same radius twice, the same section: merged; a different chord: refused.
    let json = |chord2: f64| {
        format!(
            r#"{{"radius": [1.0, 2.0, 2.0, 3.0], "chord": [1.0, 0.8, {chord2}, 0.5],
                "twist_deg": [5.0, 3.0, 3.0, 1.0], "aerofoil": "naca4412"}}"#
        )
    };
    let same = Blade::from_json(&json(0.8), &dir.join("same.json")).unwrap();
    assert_eq!(same.stations.len(), 3);
    assert_eq!(same.notes.len(), 1);
    let Err(e) = Blade::from_json(&json(0.7), &dir.join("differ.json")) else {
        panic!("twins with different chords were read")
    };
    let msg = e.to_string();
    assert!(e.is_user_error(), "{msg}");
    assert!(
        msg.contains("index 1") && msg.contains("index 2") && msg.contains("chord 0.8 against 0.7"),
        "{msg}"
    );
    // AeroDyn: node 2 listed twice is merged; listed again with another aerofoil, refused.
    let blade_file = "IEA-3.4-130-RWT_AeroDyn15_blade.dat";
    let twice = |line: &'static str| {
        move |t: String| {
            let mut lines: Vec<String> = t.lines().map(str::to_string).collect();
            lines[3] = lines[3].replacen("30", "31", 1);
            let node2 = lines[7].clone();
            lines.insert(
                8,
                if line.is_empty() {
                    node2
                } else {
                    node2.replace("        2", line)
                },
            );
            lines.join("\n") + "\n"
        }
    };
    let merged = aerodyn_edited("twins-ad", blade_file, twice("")).unwrap();
    assert_eq!((merged.stations.len(), merged.notes.len()), (30, 1));
    let e = aerodyn_error("twins-ad-bad", blade_file, twice("        3"));
    assert!(
        e.to_string().contains("node 2 (line 8)") && e.to_string().contains("differ: "),
        "{e}"
    );
    assert_eq!(line_of(&e).1, 9, "{e}");
    // Radii that go down by more than the tolerance are still an error.
    let down =
        r#"{"radius": [1.0, 2.0, 1.5], "chord": [1, 1, 1], "twist_deg": [0, 0, 0], "aerofoil": "naca4412"}"#;
    assert!(Blade::from_json(down, &dir.join("down.json")).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}
