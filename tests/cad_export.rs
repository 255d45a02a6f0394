//! STEP and IGES export: the files of a chain (the paper's case 1), an adapted chain and a blade
//! grid parsed back here (entities, knot vectors with multiplicity `degree - continuity`,
//! control points exact), `bezchain export` reproducing them from the saved report, bad
//! arguments refused; and, with BEZCHAIN_GMSH=1, gmsh (OpenCASCADE) loading each file as one
//! B-spline entity that passes through points sampled from the report, and meshing it.

mod common;

use common::cli::{ok, run};

use bezchain::export::{CadShape, Report};
use common::{crate_root, scratch};
use glam::DVec3;
use serde_json::Value;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The entities of a STEP file's DATA section: id → body.
fn step_entities(text: &str) -> HashMap<usize, String> {
    let data = &text[text.find("DATA;").unwrap() + 5..text.find("ENDSEC;\nEND-ISO").unwrap()];
    let joined: String = data.lines().map(str::trim).collect::<Vec<_>>().join("");
    joined
        .split(';')
        .filter(|e| !e.is_empty())
        .map(|e| {
            let (id, body) = e.split_once('=').unwrap();
            (
                id.trim().trim_start_matches('#').parse().unwrap(),
                body.trim().to_string(),
            )
        })
        .collect()
}

/// The numbers of a `(...)` list.
fn numbers(list: &str) -> Vec<f64> {
    list.trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(|t| t.trim().replace('E', "e").parse().unwrap())
        .collect()
}

/// The point a `#id` reference names.
fn point(ents: &HashMap<usize, String>, r: &str) -> DVec3 {
    let body = &ents[&r.trim().trim_start_matches('#').parse::<usize>().unwrap()];
    let inner = &body[body.find(",(").unwrap() + 1..body.len() - 1];
    let v = numbers(inner);
    DVec3::new(v[0], v[1], v[2])
}

/// The top-level fields of an entity body `NAME(a,b,(c,d),...)`.
fn fields(body: &str) -> Vec<String> {
    let inner = &body[body.find('(').unwrap() + 1..body.rfind(')').unwrap()];
    let (mut out, mut depth, mut cur) = (Vec::new(), 0, String::new());
    for c in inner.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            ',' if depth == 0 => {
                out.push(std::mem::take(&mut cur));
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    out.push(cur);
    out
}

fn of_kind<'a>(ents: &'a HashMap<usize, String>, kind: &str) -> Vec<&'a String> {
    ents.values()
        .filter(|b| b.starts_with(&format!("{kind}(")))
        .collect()
}

/// Degree, control points, multiplicities and knots of the only B-spline curve that is not a
/// surface boundary (the one a TRIMMED_CURVE trims).
fn step_curve(text: &str) -> (usize, Vec<DVec3>, Vec<f64>, Vec<f64>) {
    let ents = step_entities(text);
    let trimmed = of_kind(&ents, "TRIMMED_CURVE");
    assert_eq!(trimmed.len(), 1, "one curve");
    let basis = fields(trimmed[0])[1]
        .trim_start_matches('#')
        .parse::<usize>()
        .unwrap();
    let f = fields(&ents[&basis]);
    let pts = f[2]
        .trim_matches(|c| c == '(' || c == ')')
        .split(',')
        .map(|r| point(&ents, r))
        .collect();
    (f[1].parse().unwrap(), pts, numbers(&f[6]), numbers(&f[7]))
}

/// The parameters of IGES entities: `(type, numbers)`.
fn iges_entities(text: &str) -> Vec<(u32, Vec<f64>)> {
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines.iter().all(|l| l.len() == 80), "80 columns");
    let d: Vec<&str> = lines.iter().filter(|l| &l[72..73] == "D").copied().collect();
    let p: Vec<&str> = lines.iter().filter(|l| &l[72..73] == "P").copied().collect();
    d.chunks(2)
        .map(|de| {
            let start: usize = de[0][8..16].trim().parse().unwrap();
            let count: usize = de[1][24..32].trim().parse().unwrap();
            let data: String = p[start - 1..start - 1 + count].iter().map(|l| &l[..64]).collect();
            let v: Vec<f64> = data
                .trim()
                .trim_end_matches(';')
                .split(',')
                .map(|f| f.trim().parse().unwrap())
                .collect();
            (v[0] as u32, v)
        })
        .collect()
}

/// Case 1 of the paper fitted, with its report, STEP and IGES files.
fn case1(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let (json, step, iges) = (
        dir.join("case1.json"),
        dir.join("case1.step"),
        dir.join("case1.igs"),
    );
    ok(run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--json",
        s(&json),
        "--step",
        s(&step),
        "--iges",
        s(&iges),
    ]));
    (json, step, iges)
}

#[test]
fn a_chain_is_one_bspline_curve_in_step_and_iges() {
    let dir = scratch("cad-chain");
    let (json, step, iges) = case1(&dir);
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let design: Vec<DVec3> = rep["design_points"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| DVec3::new(p[0].as_f64().unwrap(), p[1].as_f64().unwrap(), 0.0))
        .collect();
    assert_eq!(design.len(), 12);
    let text = std::fs::read_to_string(&step).unwrap();
    assert!(text.starts_with("ISO-10303-21;") && text.contains("AUTOMOTIVE_DESIGN"));
    let ents = step_entities(&text);
    assert_eq!(of_kind(&ents, "B_SPLINE_CURVE_WITH_KNOTS").len(), 1);
    assert_eq!(
        of_kind(&ents, "GEOMETRICALLY_BOUNDED_WIREFRAME_SHAPE_REPRESENTATION").len(),
        1
    );
    assert_eq!(of_kind(&ents, "PRODUCT").len(), 1);
    let (degree, pts, mults, knots) = step_curve(&text);
    assert_eq!(degree, 3);
    // C1 joins of a cubic: interior knots of multiplicity 3 - 1 = 2.
    assert_eq!(mults, vec![4.0, 2.0, 2.0, 2.0, 2.0, 4.0]);
    assert_eq!(knots, vec![0.0, 0.2, 0.4, 0.6, 0.8, 1.0]);
    assert_eq!(pts, design, "the design points, exactly");
    let ig = iges_entities(&std::fs::read_to_string(&iges).unwrap());
    assert_eq!(ig.len(), 1);
    let (kind, v) = &ig[0];
    assert_eq!((*kind, v[1], v[2]), (126, 11.0, 3.0));
    assert_eq!(
        &v[7..23],
        &[0.0, 0.0, 0.0, 0.0, 0.2, 0.2, 0.4, 0.4, 0.6, 0.6, 0.8, 0.8, 1.0, 1.0, 1.0, 1.0]
    );
    let ctrl: Vec<DVec3> = v[35..71]
        .chunks(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect();
    assert_eq!(ctrl, design);
    // `export` writes the same files from the report (only the date and the product's name,
    // here the report's, differ).
    let (step2, iges2) = (dir.join("again.step"), dir.join("again.igs"));
    ok(run(&[
        "export",
        s(&json),
        "--step",
        s(&step2),
        "--iges",
        s(&iges2),
    ]));
    let undated = |t: String| {
        t.lines()
            .filter(|l| !l.starts_with("FILE_NAME") && !l.contains("PRODUCT("))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    assert_eq!(undated(std::fs::read_to_string(&step2).unwrap()), undated(text));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_adapted_chain_keeps_each_joins_multiplicity() {
    let dir = scratch("cad-adapt");
    let (json, step) = (dir.join("a.json"), dir.join("a.step"));
    ok(run(&[
        "adapt",
        "data/naca4413.dat",
        "--tol",
        "1e-3",
        "--json",
        s(&json),
        "--step",
        s(&step),
    ]));
    let rep: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let enc = &rep["adapt"]["encoding"];
    let d = enc["degree"].as_u64().unwrap() as usize;
    let joins: Vec<usize> = enc["joins"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| j.as_u64().unwrap() as usize)
        .collect();
    let (degree, pts, mults, _) = step_curve(&std::fs::read_to_string(&step).unwrap());
    assert_eq!(degree, d);
    let mut want = vec![(d + 1) as f64];
    want.extend(joins.iter().map(|k| (d - k) as f64));
    want.push((d + 1) as f64);
    assert_eq!(
        mults, want,
        "multiplicity degree - continuity order at every join"
    );
    // The curve is the report's: its Bezier extraction is the stored control points.
    let shapes = CadShape::read_reports(&json).unwrap();
    let CadShape::Curve(c) = &shapes[0] else {
        panic!("a curve")
    };
    assert_eq!(&c.ctrl, &pts);
    let Report::Curve(r) = Report::read(&json).unwrap() else {
        panic!("a curve report")
    };
    let chain = r.chain().unwrap();
    for i in 0..=500 {
        let t = i as f64 / 500.0;
        assert!((c.eval(t).truncate() - chain.eval(t)).length() < 1e-12, "t = {t}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The paper's blade lofted and fitted (4 x 2 bicubic patches), with report, STEP and IGES.
fn paper_grid(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let cloud = dir.join("blade.csv");
    ok(run(&["blade", "data/blade_paper.json", "-o", s(&cloud)]));
    let (json, step, iges) = (dir.join("grid.json"), dir.join("grid.step"), dir.join("grid.igs"));
    ok(run(&[
        "fit-surface",
        s(&cloud),
        "--degree",
        "3x3",
        "--patches",
        "4x2",
        "--json",
        s(&json),
        "--step",
        s(&step),
        "--iges",
        s(&iges),
    ]));
    (json, step, iges)
}

/// The IEA 3.4 MW blade from its AeroDyn files (30 nodes x 60 points) fitted with 6 x 4
/// bicubic patches, with report, STEP and IGES.
fn real_grid(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let cloud = dir.join("iea34.csv");
    ok(run(&[
        "blade",
        "data/blades/iea-3.4-130-rwt/openfast/IEA-3.4-130-RWT_AeroDyn15.dat",
        "--points-per-section",
        "60",
        "-o",
        s(&cloud),
    ]));
    let (json, step, iges) = (
        dir.join("iea34.json"),
        dir.join("iea34.step"),
        dir.join("iea34.igs"),
    );
    ok(run(&[
        "fit-surface",
        s(&cloud),
        "--degree",
        "3x3",
        "--patches",
        "6x4",
        "--breaks-v",
        "uniform",
        "--json",
        s(&json),
        "--step",
        s(&step),
        "--iges",
        s(&iges),
    ]));
    (json, step, iges)
}

#[test]
fn a_grid_is_one_bspline_surface_on_one_face() {
    let dir = scratch("cad-grid");
    let (json, step, iges) = paper_grid(&dir);
    let Report::Surface(rep) = Report::read(&json).unwrap() else {
        panic!("a surface report")
    };
    let text = std::fs::read_to_string(&step).unwrap();
    let ents = step_entities(&text);
    let surfaces = of_kind(&ents, "B_SPLINE_SURFACE_WITH_KNOTS");
    assert_eq!(surfaces.len(), 1);
    assert_eq!(of_kind(&ents, "ADVANCED_FACE").len(), 1);
    assert_eq!(of_kind(&ents, "EDGE_CURVE").len(), 4);
    assert_eq!(of_kind(&ents, "VERTEX_POINT").len(), 4);
    assert_eq!(of_kind(&ents, "MANIFOLD_SURFACE_SHAPE_REPRESENTATION").len(), 1);
    let f = fields(surfaces[0]);
    assert_eq!((f[1].as_str(), f[2].as_str()), ("3", "3"));
    let rows: Vec<Vec<DVec3>> = f[3][1..f[3].len() - 1]
        .split("),(")
        .map(|row| {
            row.trim_matches(|c| c == '(' || c == ')')
                .split(',')
                .map(|r| point(&ents, r))
                .collect()
        })
        .collect();
    let design: Vec<Vec<DVec3>> = rep
        .design_net
        .iter()
        .map(|r| r.iter().map(|p| DVec3::from_array(*p)).collect())
        .collect();
    assert_eq!(rows, design, "rows along u, the design net exactly");
    let m = |k: usize| -> Vec<f64> { numbers(&f[k]) };
    let interior = |c: bezchain::chain::Continuity| (3 - c.order()) as f64;
    assert_eq!(m(8).len(), rep.breaks_u.len());
    assert!(m(8)[1..m(8).len() - 1]
        .iter()
        .all(|&x| x == interior(rep.continuity[0])));
    assert_eq!(m(10), rep.breaks_u);
    assert_eq!(m(11), rep.breaks_v);
    let ig = iges_entities(&std::fs::read_to_string(&iges).unwrap());
    assert_eq!(ig.len(), 1);
    let (kind, v) = &ig[0];
    let (nu, nv) = (design.len(), design[0].len());
    assert_eq!(
        (*kind, v[1] as usize, v[2] as usize, v[3], v[4]),
        (128, nu - 1, nv - 1, 3.0, 3.0)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The IGES global section's fields (after the two delimiters, `1H,` and `1H;`, no field here
/// holds one).
fn iges_global(text: &str) -> Vec<String> {
    let g: String = text
        .lines()
        .filter(|l| &l[72..73] == "G")
        .map(|l| &l[..72])
        .collect();
    let rest = g.strip_prefix("1H,,1H;,").expect("the delimiters , and ;");
    ["1H,", "1H;"]
        .into_iter()
        .map(str::to_string)
        .chain(
            rest.trim()
                .trim_end_matches(';')
                .split(',')
                .map(|f| f.trim().to_string()),
        )
        .collect()
}

/// Where an IGES entity's control points lie among its numbers.
fn iges_ctrl_range(kind: u32, v: &[f64]) -> std::ops::Range<usize> {
    let n = |k: usize| v[k] as usize;
    let (start, count) = if kind == 126 {
        let (k, m) = (n(1), n(2));
        (7 + (k + m + 2) + (k + 1), k + 1)
    } else {
        let (k1, k2, m1, m2) = (n(1), n(2), n(3), n(4));
        let count = (k1 + 1) * (k2 + 1);
        (10 + (k1 + m1 + 2) + (k2 + m2 + 2) + count, count)
    };
    start..start + 3 * count
}

/// The 3D points of a STEP file's B-spline curves and surfaces, in entity order.
fn step_ctrl(ents: &HashMap<usize, String>) -> Vec<DVec3> {
    let mut ids: Vec<usize> = ents
        .iter()
        .filter(|(_, b)| b.starts_with("B_SPLINE_"))
        .map(|(id, _)| *id)
        .collect();
    ids.sort_unstable();
    ids.iter()
        .flat_map(|id| {
            let f = fields(&ents[id]);
            let list = if ents[id].starts_with("B_SPLINE_CURVE") {
                &f[2]
            } else {
                &f[3]
            };
            list.split(',')
                .map(|r| point(ents, r.trim_matches(|c| c == '(' || c == ')')))
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn millimetres_write_the_coordinates_times_1000() {
    let dir = scratch("cad-mm");
    let (json, _, _) = case1(&dir);
    let (gjson, _, _) = paper_grid(&dir);
    for report in [&json, &gjson] {
        let files = |unit: Option<&str>| {
            let tag = unit.unwrap_or("default");
            let (step, iges) = (dir.join(format!("{tag}.step")), dir.join(format!("{tag}.igs")));
            let mut args = vec!["export", s(report), "--step", s(&step), "--iges", s(&iges)];
            args.extend(unit.map(|u| ["--cad-unit", u]).into_iter().flatten());
            ok(run(&args));
            let read = |p: &Path| std::fs::read_to_string(p).unwrap();
            (read(&step), read(&iges))
        };
        let (m_step, m_iges) = files(Some("m"));
        let (mm_step, mm_iges) = files(Some("mm"));
        let undated = |t: &str| {
            t.lines()
                .filter(|l| !l.starts_with("FILE_NAME") && !l.contains("H20"))
                .map(str::to_string)
                .collect::<Vec<_>>()
        };
        let (d_step, d_iges) = files(None);
        assert_eq!(undated(&d_step), undated(&m_step), "m is the default");
        assert_eq!(undated(&d_iges), undated(&m_iges), "m is the default");

        // STEP: the same entities; every 3D point × 1000 (the control points exactly), the
        // unit millimetres, the uncertainty the same 0.1 µm; knots and all else unchanged.
        let (m, mm) = (step_entities(&m_step), step_entities(&mm_step));
        assert_eq!(m.len(), mm.len());
        let ctrl = step_ctrl(&m);
        assert!(ctrl.len() > 10);
        let scaled: Vec<DVec3> = ctrl.iter().map(|p| *p * 1000.0).collect();
        assert_eq!(step_ctrl(&mm), scaled, "control points × 1000 exactly");
        for (id, a) in &m {
            let b = &mm[id];
            if a.starts_with("CARTESIAN_POINT") {
                let (pa, pb) = (numbers(&fields(a)[1]), numbers(&fields(b)[1]));
                for (x, y) in pa.iter().zip(&pb) {
                    let want = if pa.len() == 3 { x * 1000.0 } else { *x };
                    assert!(
                        (y - want).abs() <= 1e-12 * want.abs().max(1.0),
                        "#{id}: {a} vs {b}"
                    );
                }
            } else if a.contains("LENGTH_UNIT") {
                assert!(a.contains("SI_UNIT($,.METRE.)") && b.contains("SI_UNIT(.MILLI.,.METRE.)"));
            } else if a.starts_with("UNCERTAINTY_MEASURE_WITH_UNIT") {
                assert!(
                    a.contains("LENGTH_MEASURE(1.E-07)") && b.contains("LENGTH_MEASURE(1.E-04)"),
                    "{b}"
                );
            } else if !a.starts_with("PRODUCT(") {
                assert_eq!(a, b, "#{id}: only points and the unit change");
            }
        }

        // IGES: the control points × 1000 exactly, knots, weights and the rest unchanged; the
        // global section declares millimetres with the resolution and the largest coordinate
        // in them.
        let (m, mm) = (iges_entities(&m_iges), iges_entities(&mm_iges));
        assert_eq!(m.len(), mm.len());
        for ((kind, a), (_, b)) in m.iter().zip(&mm) {
            let r = iges_ctrl_range(*kind, a);
            assert!(r.end < a.len());
            for k in 0..a.len() {
                let want = if r.contains(&k) { a[k] * 1000.0 } else { a[k] };
                assert_eq!(b[k], want, "entity {kind}, number {k}");
            }
        }
        let (gm, gmm) = (iges_global(&m_iges), iges_global(&mm_iges));
        assert_eq!(
            (gm[13].as_str(), gm[14].as_str(), gm[18].as_str()),
            ("6", "1HM", "1.E-7")
        );
        assert_eq!(
            (gmm[13].as_str(), gmm[14].as_str(), gmm[18].as_str()),
            ("2", "2HMM", "1.E-4")
        );
        let largest = |g: &[String]| g[19].replace('E', "e").parse::<f64>().unwrap();
        assert_eq!(largest(&gmm), largest(&gm) * 1000.0, "the largest coordinate");
        assert_eq!(gm[12], "1.", "model space scale");
        assert_eq!(gmm[12], "1.", "model space scale");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_export_arguments_exit_2() {
    let dir = scratch("cad-bad");
    let report = dir.join("r.json");
    std::fs::write(&report, "{\"kind\": \"polygon\"}").unwrap();
    for (args, needle) in [
        (vec!["export", s(&report)], "give --step FILE and/or --iges FILE"),
        (
            vec!["export", s(&report), "--step", s(&dir.join("x.step"))],
            "not a bezchain report",
        ),
        (vec!["export", "missing.json", "--iges", "x.igs"], "missing.json"),
        (vec!["export", s(&report), "--step", "-"], "give a file name"),
        (
            vec![
                "fit",
                "data/naca4413.dat",
                "--degree",
                "3",
                "--segments",
                "5",
                "--step",
                "/no/such/folder/c.step",
            ],
            "does not exist",
        ),
        (
            vec!["export", s(&report), "--iges", "x.igs", "--cad-unit", "ft"],
            "unknown CAD unit",
        ),
    ] {
        let o = run(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    assert!(!dir.join("x.step").exists(), "nothing written for a bad report");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Points on the report's chain or grid by the library's own evaluation, with their
/// parameters: `x,y,z,t` or `x,y,z,u,v`.
fn samples(report: &Path, out: &Path) -> f64 {
    let mut text = String::new();
    let size = match Report::read(report).unwrap() {
        Report::Curve(r) => {
            let chain = r.chain().unwrap();
            text.push_str("x,y,z,t\n");
            for i in 0..=2000 {
                let t = i as f64 / 2000.0;
                let p = chain.eval(t);
                text.push_str(&format!("{:?},{:?},0.0,{t:?}\n", p.x, p.y));
            }
            1.0
        }
        Report::Surface(r) => {
            let grid = r.grid().unwrap();
            text.push_str("x,y,z,u,v\n");
            for i in 0..=80 {
                for j in 0..=40 {
                    let (u, v) = (i as f64 / 80.0, j as f64 / 40.0);
                    let p = grid.eval(u, v);
                    text.push_str(&format!("{:?},{:?},{:?},{u:?},{v:?}\n", p.x, p.y, p.z));
                }
            }
            // The largest chord: the largest extent across the span.
            let net = grid.net();
            let lo = net.iter().fold(DVec3::splat(f64::MAX), |a, p| a.min(*p));
            let hi = net.iter().fold(DVec3::splat(f64::MIN), |a, p| a.max(*p));
            (hi - lo).truncate().length()
        }
    };
    std::fs::write(out, text).unwrap();
    size
}

/// Run tests/gmsh_check.py on `file` with `args` (`samples` in metres; `--unit` the unit gmsh
/// reads the file into), with `$BEZCHAIN_PYTHON` (a virtual environment's python with gmsh, say)
/// or `python3`.
fn gmsh_check(file: &Path, samples: &Path, args: &[&str]) -> Value {
    let python = std::env::var_os("BEZCHAIN_PYTHON").unwrap_or_else(|| "python3".into());
    let o = Command::new(python)
        .arg(crate_root().join("tests/gmsh_check.py"))
        .args([s(file), s(samples)])
        .args(args)
        .output()
        .expect("python3");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{out}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let line = out
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .expect("a JSON line");
    serde_json::from_str(line).unwrap()
}

/// The bounding box gmsh reports, `[xmin, ymin, zmin, xmax, ymax, zmax]`.
fn bbox(r: &Value) -> Vec<f64> {
    r["bbox"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Each file, in metres and in millimetres (`--cad-unit mm`), loaded by gmsh (OpenCASCADE) in
/// its own unit as one B-spline entity through the report's points (× 1000 in millimetres),
/// meshed; its bounding box in millimetres 1000 × the metre file's in metres; and both files
/// read into OpenCASCADE's default unit (millimetres) the same size.
#[test]
fn gmsh_loads_each_file_as_one_bspline_that_passes_through_the_report() {
    if std::env::var_os("BEZCHAIN_GMSH").is_none() {
        eprintln!(
            "skipped: set BEZCHAIN_GMSH=1 (needs python3, or $BEZCHAIN_PYTHON, with `pip install gmsh numpy`)"
        );
        return;
    }
    let dir = scratch("cad-gmsh");
    let (json, step, iges) = case1(&dir);
    let (gjson, gstep, giges) = paper_grid(&dir);
    let (rjson, rstep, riges) = real_grid(&dir);
    for (report, files, dim, kind) in [
        (&json, [&step, &iges], 1, "BSpline"),
        (&gjson, [&gstep, &giges], 2, "BSpline surface"),
        (&rjson, [&rstep, &riges], 2, "BSpline surface"),
    ] {
        let csv = dir.join("samples.csv");
        let chord = samples(report, &csv);
        let (mm_step, mm_iges) = (dir.join("mm.step"), dir.join("mm.igs"));
        ok(run(&[
            "export",
            s(report),
            "--step",
            s(&mm_step),
            "--iges",
            s(&mm_iges),
            "--cad-unit",
            "mm",
        ]));
        for ((file, mm_file), bar) in files.iter().zip([&mm_step, &mm_iges]).zip([1e-9, 1e-8]) {
            let mut boxes = Vec::new();
            for (file, unit, per_metre) in [(*file, "m", 1.0), (mm_file, "mm", 1000.0)] {
                let size = chord * per_metre;
                let mesh = (size / 20.0).to_string();
                let r = gmsh_check(file, &csv, &["--unit", unit, "--mesh-size", &mesh]);
                eprintln!("{}", r);
                let top: Vec<&Value> = r["entities"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .filter(|e| e["dim"] == dim)
                    .collect();
                assert_eq!(
                    top.len(),
                    1,
                    "{}: exactly one entity of dimension {dim}",
                    file.display()
                );
                assert_eq!(top[0]["type"], kind);
                let d = r["max_distance"].as_f64().unwrap();
                assert!(d <= bar * size, "{}: {d} > {bar} x {size}", file.display());
                assert!(r["mesh_nodes"].as_u64().unwrap() > 10);
                boxes.push(bbox(&r));
            }
            // gmsh pads a box by about 1e-7 of its unit.
            let extent = |b: &[f64]| (0..3).map(|k| b[k + 3] - b[k]).fold(0.0, f64::max);
            let close = |a: &[f64], b: &[f64], what: &str| {
                let worst = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
                assert!(
                    worst <= 1e-6 * extent(b),
                    "{}: {what}: {a:?} vs {b:?}",
                    file.display()
                );
            };
            let in_mm: Vec<f64> = boxes[0].iter().map(|x| x * 1000.0).collect();
            close(
                &boxes[1],
                &in_mm,
                "the mm file's box in mm is 1000 x the m file's in m",
            );
            for f in [*file, mm_file] {
                let r = gmsh_check(f, &csv, &["--unit", "default", "--bbox-only"]);
                eprintln!("{}", r);
                close(
                    &bbox(&r),
                    &boxes[1],
                    "OpenCASCADE's default unit (mm) reads both the same",
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
