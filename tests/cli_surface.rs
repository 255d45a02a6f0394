//! `bezchain blade`, `fit-surface` and `adapt-surface` end to end: the paper's blade (82 x 12
//! points, 10 x 6 design net, 13 x 7 control net, 4 x 2 bicubic patches) with its report
//! checked from the JSON alone (the tests' own Bezier evaluation and closest-point search), its
//! OBJ, STL and PNG; a blade cloud with named columns in its own order (`station,point,...`);
//! the evolutionary methods; and bad blade files and clouds answered with exit status 2.

mod common;

use common::cli::{assert_user_error_naming, ok, run, stderr};

use common::check::{check_surface_report, IndependentGrid};
use common::{crate_root, scratch};
use glam::DVec3;
use serde_json::Value;
use std::path::Path;

/// Exit status 2, exactly one `error:` line containing every needle, and no panic.
/// The `x,y,z` columns of a cloud CSV written by `bezchain blade`, parsed here.
fn read_xyz(path: &Path) -> Vec<DVec3> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("x,y,z"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').take(3).map(|t| t.parse().unwrap()).collect();
            DVec3::new(v[0], v[1], v[2])
        })
        .collect()
}

fn point(v: &Value) -> DVec3 {
    let a: Vec<f64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(a.len(), 3);
    DVec3::new(a[0], a[1], a[2])
}

fn net(v: &Value) -> Vec<Vec<DVec3>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|row| row.as_array().unwrap().iter().map(point).collect())
        .collect()
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The largest relative jump of the first derivative across every patch border of a control
/// net (rows along u) with the given breaks, in both directions.
fn c1_jump(net: &[Vec<DVec3>], d: [usize; 2], bu: &[f64], bv: &[f64]) -> f64 {
    let mut worst: f64 = 0.0;
    let mut jump = |l: DVec3, r: DVec3| {
        let scale = l.length().max(r.length()).max(1e-300);
        worst = worst.max((l - r).length() / scale);
    };
    for k in 1..bu.len() - 1 {
        let r = k * d[0];
        let (hl, hr) = (bu[k] - bu[k - 1], bu[k + 1] - bu[k]);
        for ((&a, &b), &c) in net[r - 1].iter().zip(&net[r]).zip(&net[r + 1]) {
            jump((b - a) / hl, (c - b) / hr);
        }
    }
    for k in 1..bv.len() - 1 {
        let c = k * d[1];
        let (hl, hr) = (bv[k] - bv[k - 1], bv[k + 1] - bv[k]);
        for row in net {
            jump((row[c] - row[c - 1]) / hl, (row[c + 1] - row[c]) / hr);
        }
    }
    worst
}

#[test]
fn the_papers_blade_end_to_end_with_a_report_checked_from_its_json() {
    let dir = scratch("cli-surface");
    let cloud = dir.join("blade.csv");
    let (json, obj, stl, png, svg) = (
        dir.join("r.json"),
        dir.join("b.obj"),
        dir.join("b.stl"),
        dir.join("b.png"),
        dir.join("b.svg"),
    );
    let out = ok(run(&[
        "blade",
        "data/blade_paper.json",
        "-o",
        cloud.to_str().unwrap(),
    ]));
    assert!(
        stderr(&out).contains("12 sections × 82 points"),
        "{}",
        stderr(&out)
    );
    let points = read_xyz(&cloud);
    assert_eq!(points.len(), 82 * 12);
    let out = ok(run(&[
        "fit-surface",
        cloud.to_str().unwrap(),
        "--degree",
        "3x3",
        "--patches",
        "4x2",
        "--json",
        json.to_str().unwrap(),
        "--obj",
        obj.to_str().unwrap(),
        "--stl",
        stl.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--svg",
        svg.to_str().unwrap(),
        "--png-size",
        "400x240",
    ]));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("design net 10x6"), "{summary}");
    assert!(summary.contains("control net 13x7"), "{summary}");

    // The counts and the layout.
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(rep["kind"], "surface");
    assert_eq!(rep["dimension"], 3);
    assert_eq!(numbers(&rep["degree"]), [3.0, 3.0]);
    assert_eq!(numbers(&rep["patches"]), [4.0, 2.0]);
    assert_eq!(rep["continuity"], serde_json::json!(["C1", "C1"]));
    let design = net(&rep["design_net"]);
    assert_eq!((design.len(), design[0].len()), (10, 6));
    let control = net(&rep["control_net"]);
    assert_eq!(control.len(), 13);
    assert!(control.iter().all(|r| r.len() == 7));
    let (bu, bv) = (numbers(&rep["breaks_u"]), numbers(&rep["breaks_v"]));
    assert_eq!((bu.len(), bv.len()), (5, 3));
    assert_eq!(rep["input"]["points"], 984);

    // The design points are control points: the ends and the interior rows and columns of the
    // net outside the generated ones (a C1 join of degree 3 generates its middle point).
    assert_eq!(design[0][0], control[0][0]);
    assert_eq!(design[9][5], control[12][6]);
    assert_eq!(design[1][1], control[1][1]);

    // C1 across every border, from the JSON net and breaks.
    let jump = c1_jump(&control, [3, 3], &bu, &bv);
    assert!(jump < 1e-9, "C1 jump {jump}");
    let reported = rep["continuity_error"].as_f64().unwrap();
    assert!(reported < 1e-9, "reported continuity error {reported}");

    // The offsets, recomputed from the JSON control net by the tests' own evaluation and
    // closest-point search, agree with the reported ones.
    let check = IndependentGrid::new(&control, 3, 3);
    check_surface_report(&rep, &points, 1e-6);
    let off = &rep["offset"];
    assert_eq!(off["metric"], "closest");
    let max_at = point(&off["max_at"]);
    assert!(points.contains(&max_at), "max_at {max_at} is not a data point");

    // OBJ: a 16 x 16 sample per patch, every vertex on the surface of the JSON net.
    let text = std::fs::read_to_string(&obj).unwrap();
    let vertices: Vec<DVec3> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            DVec3::new(v[0], v[1], v[2])
        })
        .collect();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(vertices.len(), (4 * 16 + 1) * (2 * 16 + 1));
    assert_eq!(faces, 2 * 4 * 16 * 2 * 16);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("vn ")).count(),
        vertices.len()
    );
    for v in vertices.iter().step_by(97) {
        // Meshes come from the dense evaluator: f32 about the grid's centre, within
        // about 4 · 2⁻²⁴ of its extent of the f64 surface (2.2e-7 measured on this blade).
        assert!(check.distance(*v) < 1e-6, "OBJ vertex {v} off the surface");
    }

    // Binary STL: header, count, 50 bytes a triangle, unit normals, vertices on the surface.
    let bytes = std::fs::read(&stl).unwrap();
    let count = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert_eq!(count, faces);
    assert_eq!(bytes.len(), 84 + 50 * count);
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as f64;
    for t in (0..count).step_by(211) {
        let o = 84 + 50 * t;
        let n = DVec3::new(f32_at(o), f32_at(o + 4), f32_at(o + 8));
        assert!((n.length() - 1.0).abs() < 1e-5, "normal {n}");
        let v = DVec3::new(f32_at(o + 12), f32_at(o + 16), f32_at(o + 20));
        assert!(check.distance(v) < 1e-6, "STL vertex {v} off the surface");
    }

    // PNG: the size asked for, and not blank.
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (400, 240));
    let first = &buf[..3];
    let differing = buf
        .chunks(info.line_size / info.width as usize)
        .filter(|p| &p[..3] != first)
        .count();
    assert!(
        differing > 400 * 240 / 20,
        "{differing} pixels differ from the background"
    );
    // SVG: the same size, every net point drawn (design and generated).
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with(r#"<svg xmlns="http://www.w3.org/2000/svg" width="400" height="240""#));
    assert!(
        text.matches("<circle").count() >= 2 * 13 * 7,
        "two views of the net"
    );
    // Coloured by offset / local chord: a colour bar with both scales, the worst point ringed
    // and labelled with its section, the 12 stations drawn and numbered.
    let bar = &text[text.find(r#"<g id="colour-bar""#).expect("a colour bar")..];
    assert_eq!(bar.matches(r#"class="percent-of-local-chord""#).count(), 5);
    assert_eq!(bar.matches(r#"class="data-units""#).count(), 5);
    assert!(
        bar.contains("at largest chord"),
        "the data-unit scale names its chord"
    );
    assert_eq!(
        text.matches(r#"<g class="worst-point""#).count(),
        2,
        "one ring a view"
    );
    assert!(text.contains("of local chord: ") && text.contains(", section "));
    assert!(text.contains(r#"class="station""#) && text.contains(r#"class="station-numbers""#));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn evolutionary_methods_report_their_stages_and_backend() {
    let dir = scratch("cli-surface-evo");
    let cloud = dir.join("blade.csv");
    let json = dir.join("r.json");
    let history = dir.join("h.csv");
    ok(run(&[
        "blade",
        "data/blade_paper.json",
        "--points-per-section",
        "30",
        "-o",
        cloud.to_str().unwrap(),
    ]));
    let out = ok(run(&[
        "fit-surface",
        cloud.to_str().unwrap(),
        "--degree",
        "3x3",
        "--patches",
        "2x1",
        "--method",
        "cmaes+lsq",
        "--backend",
        "cpu",
        "--generations",
        "6",
        "--history",
        history.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]));
    assert!(String::from_utf8_lossy(&out.stdout).contains("cmaes+lsq: rms"));
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let fit = &rep["fit"];
    assert_eq!(fit["method"], "cmaes+lsq");
    assert_eq!(fit["backend"], "cpu");
    let stages: Vec<&str> = fit["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["method"].as_str().unwrap())
        .collect();
    assert_eq!(stages, ["cmaes", "lsq"]);
    assert_eq!(fit["stages"][0]["iterations"], 6);
    assert!(fit["evals_per_second"].as_f64().unwrap() > 0.0);
    // The header, then one line per generation from the start (generation 0) to the last.
    let text = std::fs::read_to_string(&history).unwrap();
    let generations: Vec<&str> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(generations, ["0", "1", "2", "3", "4", "5", "6"]);
    // The polished fit lands near least squares alone (a 2 x 1 grid on a blade has several
    // local optima; measured: cmaes+lsq rms 5.51e-4, lsq 5.05e-4).
    let lsq = ok(run(&[
        "fit-surface",
        cloud.to_str().unwrap(),
        "--degree",
        "3x3",
        "--patches",
        "2x1",
        "--json",
        "-",
    ]));
    let lsq: Value = serde_json::from_slice(&lsq.stdout).unwrap();
    let (a, b) = (
        rep["offset"]["rms"].as_f64().unwrap(),
        lsq["offset"]["rms"].as_f64().unwrap(),
    );
    assert!(a < 1.25 * b, "cmaes+lsq rms {a}, lsq {b}");
    // Evolutionary flags are refused for least squares.
    assert_user_error_naming(
        &run(&[
            "fit-surface",
            cloud.to_str().unwrap(),
            "--degree",
            "3x3",
            "--patches",
            "2x1",
            "--generations",
            "5",
        ]),
        &["--generations", "evolutionary"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_blade_files_exit_2_naming_the_field() {
    let dir = scratch("cli-bad-blade");
    let cases = [
        (
            r#"{"radius": [0.5, 0.7, 0.6], "chord": [0.2, 0.1, 0.05], "twist_deg": 0, "aerofoil": "4413"}"#,
            "field 'radius'",
        ),
        (
            r#"{"radius": [0.5, 0.7, 0.9], "chord": [0.2, 0.1], "twist_deg": 0, "aerofoil": "4413"}"#,
            "field 'chord'",
        ),
        (
            r#"{"radius": [0.5, 0.7], "chord": [0.2, -0.1], "twist_deg": 0, "aerofoil": "4413"}"#,
            "field 'chord'",
        ),
        (
            r#"{"radius": [0.5, 0.7], "chord": [0.2, 0.1], "twist_deg": 0, "aerofoil": "NACA 12345678"}"#,
            "field 'aerofoil'",
        ),
        (
            r#"{"radius": [0.5, 0.7], "chord": [0.2, 0.1], "twist_deg": 0, "aerofoil": "nosuchfoil.dat"}"#,
            "field 'aerofoil'",
        ),
        (
            r#"{"radius": [0.5], "chord": [0.2], "twist_deg": 0, "aerofoil": "4413"}"#,
            "at least 2 stations",
        ),
    ];
    for (k, (json, needle)) in cases.iter().enumerate() {
        let path = dir.join(format!("blade{k}.json"));
        std::fs::write(&path, json).unwrap();
        let out_csv = dir.join(format!("cloud{k}.csv"));
        let o = run(&["blade", path.to_str().unwrap(), "-o", out_csv.to_str().unwrap()]);
        assert_user_error_naming(&o, &[needle, path.to_str().unwrap()]);
        assert!(!out_csv.exists(), "a cloud was written for a bad blade file");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_clouds_and_arguments_exit_2_with_nothing_written() {
    let dir = scratch("cli-bad-cloud");
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let json = p("r.json");
    let fit = |cloud: &str, extra: &[&str]| {
        let mut args = vec![
            "fit-surface",
            cloud,
            "--degree",
            "3x3",
            "--patches",
            "4x2",
            "--json",
            &json,
        ];
        args.extend_from_slice(extra);
        run(&args)
    };
    // A bad line, named by file and line.
    std::fs::write(p("bad.csv"), "x,y,z\n0.1,0.2,0.3\n0.1,zz,0.3\n0.2,0.2,0.3\n").unwrap();
    assert_user_error_naming(&fit(&p("bad.csv"), &[]), &[&format!("{}:3", p("bad.csv"))]);
    // Too few points for the 10 x 6 design net (an unordered 20-point cloud).
    ok(run(&[
        "blade",
        "data/blade_paper.json",
        "--points-per-section",
        "5",
        "--sections",
        "4",
        "--shuffle",
        "-o",
        &p("few.csv"),
    ]));
    assert_user_error_naming(&fit(&p("few.csv"), &[]), &[&p("few.csv"), "at least 60"]);
    // No data, a missing file, a bad layout, an unknown method, an output in a missing folder.
    std::fs::write(p("empty.csv"), "x,y,z\n").unwrap();
    assert_user_error_naming(&fit(&p("empty.csv"), &[]), &[&p("empty.csv")]);
    assert_user_error_naming(&fit(&p("missing.csv"), &[]), &[&p("missing.csv")]);
    ok(run(&["blade", "data/blade_paper.json", "-o", &p("blade.csv")]));
    let o = run(&[
        "fit-surface",
        &p("blade.csv"),
        "--degree",
        "3",
        "--patches",
        "4x2",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_user_error_naming(
        &fit(&p("blade.csv"), &["--breaks-u", "0.5,0.2,0.7"]),
        &["breaks along u"],
    );
    // Span breaks from a blade file whose stations do not fit the patches: the error names the
    // option and the blade file, not the cloud.
    let stations = "stations:data/blade_paper.json";
    let o = fit(&p("blade.csv"), &["--breaks-v", stations]);
    assert_user_error_naming(&o, &["--breaks-v", stations, "breaks along v"]);
    let error = stderr(&o)
        .lines()
        .find(|l| l.starts_with("error:"))
        .unwrap_or_default()
        .to_string();
    assert!(!error.contains("blade.csv"), "{error}");
    // A stations file that cannot be read is named with the option too.
    for bad in ["data/no-such-blade.json", "data/naca4413.dat"] {
        let o = fit(&p("blade.csv"), &["--breaks-v", &format!("stations:{bad}")]);
        assert_user_error_naming(&o, &["--breaks-v", bad]);
    }
    assert_user_error_naming(&fit(&p("blade.csv"), &["--method", "bfgs"]), &["bfgs"]);
    assert_user_error_naming(
        &fit(
            &p("blade.csv"),
            &["--obj", &format!("{}/no/such/dir/b.obj", p(""))],
        ),
        &["--obj", "does not exist"],
    );
    assert!(!Path::new(&json).exists(), "a report was written by a failed run");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The cloud `bezchain blade` wrote (`x,y,z,section,index`) rewritten as the blade tables people
/// have: `station,point,radius,chord,twist_deg,airfoil,x,y,z`, the station's chord and twist from
/// the blade file, a text column, and the rows in reverse order (the station and point columns
/// give the order back).
fn station_csv(cloud: &Path, blade: &Path, out: &Path) {
    let b: Value = serde_json::from_str(&std::fs::read_to_string(blade).unwrap()).unwrap();
    let (chord, twist) = (numbers(&b["chord"]), numbers(&b["twist_deg"]));
    let text = std::fs::read_to_string(cloud).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("x,y,z,section,index"));
    let mut rows: Vec<String> = lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let s: usize = f[3].parse().unwrap();
            format!(
                "{},{},{},{},{},\"NACA 4413, {}\",{},{},{}",
                f[3], f[4], f[2], chord[s], twist[s], "lofted", f[0], f[1], f[2]
            )
        })
        .collect();
    rows.reverse();
    let body = format!(
        "station,point,radius,chord,twist_deg,airfoil,x,y,z\n{}\n",
        rows.join("\n")
    );
    std::fs::write(out, body).unwrap();
}

#[test]
fn a_station_point_cloud_with_text_columns_fits_and_adapts_like_the_blade_cloud() {
    let dir = scratch("cli-surface-stations");
    let (cloud, stations) = (dir.join("blade.csv"), dir.join("stations.csv"));
    ok(run(&[
        "blade",
        "data/blade_paper_to_tip.json",
        "--points-per-section",
        "24",
        "-o",
        cloud.to_str().unwrap(),
    ]));
    station_csv(
        &cloud,
        &crate_root().join("data/blade_paper_to_tip.json"),
        &stations,
    );
    let points = read_xyz(&cloud);
    let fit = |input: &Path, json: &Path| {
        ok(run(&[
            "fit-surface",
            input.to_str().unwrap(),
            "--degree",
            "3x3",
            "--patches",
            "4x2",
            "--json",
            json.to_str().unwrap(),
        ]))
    };
    let (a, b) = (dir.join("a.json"), dir.join("b.json"));
    fit(&cloud, &a);
    let out = fit(&stations, &b);
    let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), stderr(&out));
    assert!(said.contains("240 points (10 sections x 24 points)"), "{said}");
    assert!(
        stderr(&out).contains("ignored column(s) radius, chord, twist_deg, airfoil"),
        "{}",
        stderr(&out)
    );
    let (a, b): (Value, Value) = (
        serde_json::from_str(&std::fs::read_to_string(&a).unwrap()).unwrap(),
        serde_json::from_str(&std::fs::read_to_string(&b).unwrap()).unwrap(),
    );
    assert_eq!(a["control_net"], b["control_net"]);
    assert_eq!(a["offset"], b["offset"]);
    check_surface_report(&b, &points, 1e-6);

    // adapt-surface needs the sections: the station and point columns give them.
    let json = dir.join("adapt.json");
    let out = ok(run(&[
        "adapt-surface",
        stations.to_str().unwrap(),
        "--tol",
        "2e-3",
        "--relative",
        "--degrees-u",
        "3-4",
        "--degrees-v",
        "2",
        "--json",
        json.to_str().unwrap(),
    ]));
    assert!(String::from_utf8_lossy(&out.stdout).contains("met            yes"));
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(rep["adapt"]["met"], true);
    // The command warns exactly when the report's section ends double back.
    let ends = &rep["adapt"]["section_ends"];
    assert!(ends["passes"].is_boolean(), "{ends}");
    assert_eq!(
        stderr(&out).contains("doubles back on itself"),
        ends["passes"] == false,
        "{}",
        stderr(&out)
    );
    let o = check_surface_report(&rep, &points, 1e-6);
    assert!(
        o.max <= rep["adapt"]["tol"].as_f64().unwrap(),
        "independent max {}",
        o.max
    );

    // The same table without x and y columns: exit 2 naming the file and line 1.
    let bad = dir.join("no_xy.csv");
    std::fs::write(&bad, "station,point,radius,chord\n0,0,0.344,0.177\n").unwrap();
    assert_user_error_naming(
        &run(&[
            "fit-surface",
            bad.to_str().unwrap(),
            "--degree",
            "3x3",
            "--patches",
            "1x1",
        ]),
        &[
            &format!("{}:1: the header", bad.display()),
            "names no x and no y column",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
