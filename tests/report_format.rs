//! The report formats of `docs/ARCHITECTURE.md` §5.4–§5.7 as an outside tool would read them:
//! every key the document lists is there (and no other), and the shapes are regenerated from
//! the stored numbers by the document's recipe, written here apart from the library (knot
//! vectors, the aerofoil rule's coefficients, the span rule, Boehm's knot insertion), to the
//! reports' own control points.

mod common;

use common::{bin, crate_root, scratch};
use serde_json::Value;
use std::collections::BTreeSet;
use std::process::Command;

fn run(args: &[&str]) -> Value {
    let out = Command::new(bin())
        .args(args)
        .args(["--json", "-"])
        .current_dir(crate_root())
        .output()
        .expect("run bezchain");
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    unstamped(serde_json::from_slice(&out.stdout).expect("a JSON report on standard output"))
}

/// The stamp every report starts with (§5.10; its values are checked against the schemas by
/// `tests/report_schemas.rs`).
const STAMP: [&str; 4] = ["bezchain_version", "schema", "command", "units"];

/// `report` without its stamp, which must be there.
fn unstamped(mut report: Value) -> Value {
    let map = report.as_object_mut().expect("an object");
    for k in STAMP {
        assert!(map.remove(k).is_some(), "no stamp key '{k}'");
    }
    report
}

fn keys(v: &Value) -> BTreeSet<&str> {
    v.as_object()
        .expect("an object")
        .keys()
        .map(String::as_str)
        .collect()
}

/// The object's keys are `required` plus any of `optional`, nothing else.
fn assert_keys(v: &Value, required: &[&str], optional: &[&str], what: &str) {
    let have = keys(v);
    for k in required {
        assert!(have.contains(k), "{what}: no key '{k}' in {have:?}");
    }
    for k in &have {
        assert!(
            required.contains(k) || optional.contains(k),
            "{what}: key '{k}' is not in docs/ARCHITECTURE.md"
        );
    }
}

const CURVE: [&str; 11] = [
    "kind",
    "dimension",
    "degree",
    "segments",
    "continuity",
    "breaks",
    "design_points",
    "control_points",
    "offset",
    "fit",
    "input",
];
const SURFACE: [&str; 13] = [
    "kind",
    "dimension",
    "degree",
    "patches",
    "continuity",
    "breaks_u",
    "breaks_v",
    "design_net",
    "control_net",
    "continuity_error",
    "offset",
    "fit",
    "input",
];
const OFFSET: [&str; 6] = ["metric", "sum_sq", "sum", "rms", "max", "max_at"];
const FIT: [&str; 5] = ["method", "iterations", "evaluations", "seconds", "backend"];
const FIT_OPTIONAL: [&str; 3] = ["stages", "evals_per_second", "stopped"];

fn assert_common_blocks(rep: &Value, dims: usize) {
    assert_keys(&rep["offset"], &OFFSET, &[], "offset");
    assert_eq!(rep["offset"]["max_at"].as_array().unwrap().len(), dims);
    assert_keys(&rep["fit"], &FIT, &FIT_OPTIONAL, "fit");
    for stage in rep["fit"]["stages"].as_array().into_iter().flatten() {
        assert_keys(stage, &FIT, &FIT_OPTIONAL, "fit.stages[]");
    }
    assert_keys(&rep["input"], &["path", "points"], &[], "input");
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn points(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().unwrap().iter().map(numbers).collect()
}

/// The largest coordinate difference between two lists of points, relative to their size.
fn gap(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    assert_eq!(a.len(), b.len(), "point counts");
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| (x - y).abs() / (1.0 + y.abs())))
        .fold(0.0, f64::max)
}

/// The clamped knot vector of §5.6: 0 and 1 each `d + 1` times, interior break `j` repeated
/// `d - joins[j]` times.
fn knot_vector(d: usize, breaks: &[f64], joins: &[usize]) -> Vec<f64> {
    assert_eq!(joins.len() + 2, breaks.len(), "one join order per interior break");
    let mut knots = vec![0.0; d + 1];
    for (&b, &k) in breaks[1..breaks.len() - 1].iter().zip(joins) {
        knots.extend(std::iter::repeat_n(b, d - k));
    }
    knots.extend(std::iter::repeat_n(1.0, d + 1));
    knots
}

/// Insert knot `x` once into the B-spline of degree `d` (Boehm).
fn insert(d: usize, knots: &mut Vec<f64>, coeffs: &mut Vec<Vec<f64>>, x: f64) {
    let r = knots.iter().rposition(|&t| t <= x).unwrap();
    let s = knots.iter().filter(|&&t| t == x).count();
    let mut out = Vec::with_capacity(coeffs.len() + 1);
    for i in 0..=coeffs.len() {
        if i + d <= r {
            out.push(coeffs[i].clone());
        } else if i + s <= r {
            let a = (x - knots[i]) / (knots[i + d] - knots[i]);
            out.push(
                coeffs[i - 1]
                    .iter()
                    .zip(&coeffs[i])
                    .map(|(p, q)| (1.0 - a) * p + a * q)
                    .collect(),
            );
        } else {
            out.push(coeffs[i - 1].clone());
        }
    }
    knots.insert(r + 1, x);
    *coeffs = out;
}

/// Every interior knot raised to multiplicity `d`: the Bezier control points.
fn bezier(d: usize, knots: &[f64], coeffs: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let (mut t, mut c) = (knots.to_vec(), coeffs.to_vec());
    let interior: BTreeSet<u64> = knots
        .iter()
        .filter(|&&x| x > 0.0 && x < 1.0)
        .map(|x| x.to_bits())
        .collect();
    for bits in interior {
        let x = f64::from_bits(bits);
        while t.iter().filter(|&&y| y == x).count() < d {
            insert(d, &mut t, &mut c, x);
        }
    }
    c
}

/// The break list of a `breaks` object (§5.6); `le` adds the aerofoil rule's 1/2 to stored
/// breaks.
fn break_list(b: &Value, le: bool) -> Vec<f64> {
    let equal = |n: u64, from: f64, to: f64| -> Vec<f64> {
        (0..n).map(|k| from + (to - from) * k as f64 / n as f64).collect()
    };
    let mut list = if let Some(u) = b.get("uniform") {
        equal(u["segments"].as_u64().unwrap(), 0.0, 1.0)
    } else if let Some(u) = b.get("uniform_per_side") {
        let mut v = equal(u["first"].as_u64().unwrap(), 0.0, 0.5);
        v.extend(equal(u["second"].as_u64().unwrap(), 0.5, 1.0));
        v
    } else {
        let mut v = vec![0.0];
        v.extend(numbers(&b["stored"]));
        if le {
            v.push(0.5);
        }
        v
    };
    list.push(1.0);
    list.sort_by(f64::total_cmp);
    list
}

/// The control points of an adapt report's `encoding`, by the recipe of §5.6 and §2.8.
fn regenerate_curve(enc: &Value) -> Vec<Vec<f64>> {
    let d = enc["degree"].as_u64().unwrap() as usize;
    let joins: Vec<usize> = numbers(&enc["joins"]).iter().map(|&k| k as usize).collect();
    let rule = enc["x"].get("aerofoil_rule").map(numbers);
    let knots = knot_vector(d, &break_list(&enc["breaks"], rule.is_some()), &joins);
    let n = knots.len() - d - 1;
    let y = numbers(&enc["y"]);
    assert_eq!(y.len(), n, "one y per design point");
    let x: Vec<f64> = match &rule {
        Some(theta) => {
            let (le, te1) = (theta[0], theta[1]);
            let te2 = *theta.get(2).unwrap_or(&te1);
            (0..n)
                .map(|i| {
                    let w = &knots[i + 1..=i + d];
                    let mut s = 0.0;
                    for a in 0..d {
                        for b in a + 1..d {
                            s += (w[a] - 0.5) * (w[b] - 0.5);
                        }
                    }
                    let q = 4.0 * s / (d * (d - 1) / 2) as f64;
                    let te = if w.iter().any(|&t| t < 0.5) { te1 } else { te2 };
                    (1.0 - q) * le + q * te
                })
                .collect()
        }
        None => numbers(&enc["x"]["free"]),
    };
    let coeffs: Vec<Vec<f64>> = x.iter().zip(&y).map(|(&x, &y)| vec![x, y]).collect();
    bezier(d, &knots, &coeffs)
}

#[test]
fn curve_reports_have_the_documented_keys_and_c1_and_c2_chains_regenerate() {
    for continuity in ["c1", "c2"] {
        let rep = run(&[
            "fit",
            "data/naca4413.dat",
            "--degree",
            "4",
            "--segments",
            "3",
            "--continuity",
            continuity,
        ]);
        assert_keys(&rep, &CURVE, &[], "curve report");
        assert_common_blocks(&rep, 2);
        assert_eq!(rep["kind"], "curve");
        assert_eq!(rep["continuity"], continuity.to_uppercase());
        // The design points are the chain's de Boor points (§2.2).
        let k = if continuity == "c1" { 1 } else { 2 };
        let knots = knot_vector(4, &numbers(&rep["breaks"]), &[k, k]);
        let design = points(&rep["design_points"]);
        assert_eq!(design.len(), knots.len() - 4 - 1);
        let ctrl = points(&rep["control_points"]);
        assert_eq!(ctrl.len(), 3 * 4 + 1);
        let g = gap(&bezier(4, &knots, &design), &ctrl);
        assert!(
            g < 1e-12,
            "{continuity}: regenerated control points differ by {g:e}"
        );
    }
}

#[test]
fn adapt_reports_regenerate_from_their_encoding() {
    let dir = scratch("report-format-adapt");
    let free_file = dir.join("free.dat");
    std::fs::copy(crate_root().join("data/airfoils/e387.dat"), &free_file).unwrap();
    // (input, tolerance, mode): the aerofoil rule with equal breaks per side, with stored
    // breaks, and free x.
    let mut kinds = BTreeSet::new();
    for (input, tol, mode) in [
        ("data/naca4413.dat", "1e-4", "auto"),
        ("data/naca4413.dat", "1e-5", "aerofoil"),
        (free_file.to_str().unwrap(), "1e-4", "free"),
    ] {
        let rep = run(&["adapt", input, "--tol", tol, "--mode", mode]);
        let mut top = CURVE.to_vec();
        top.push("adapt");
        assert_keys(&rep, &top, &[], "adapt report");
        assert_common_blocks(&rep, 2);
        assert_eq!(rep["continuity"], "C1");
        assert_eq!(rep["fit"]["method"], "adapt");
        let a = &rep["adapt"];
        assert_keys(
            a,
            &[
                "tol",
                "norm",
                "met",
                "stored_scalars",
                "scalars",
                "counting",
                "encoding",
                "family",
                "fits",
                "search",
            ],
            &["message", "held_out", "held_out_ratio", "sign_changes", "follows"],
            "adapt block",
        );
        if let Some(f) = a.get("follows") {
            assert_keys(
                f,
                &["away", "allowed", "at", "turning_deg", "source_turning_deg"],
                &[],
                "follows",
            );
        }
        if let Some(c) = a.get("sign_changes") {
            assert_keys(
                c,
                &["chain", "source", "threshold", "scatter"],
                &[],
                "sign_changes",
            );
        }
        if let (Some(r), Some(h)) = (a.get("held_out_ratio"), a.get("held_out")) {
            let (r, max, tol) = (
                r.as_f64().unwrap(),
                h["max"].as_f64().unwrap(),
                a["tol"].as_f64().unwrap(),
            );
            if a["norm"] == "max" {
                assert!((r - max / tol).abs() <= 1e-12 * r.max(1.0), "{r} {max} {tol}");
            }
        }
        assert_keys(
            &a["scalars"],
            &["x", "y", "rule", "breaks", "total"],
            &[],
            "scalars",
        );
        assert_keys(
            &a["held_out"],
            &["fitted", "measured", "max", "rms"],
            &[],
            "held_out",
        );
        for f in a["search"].as_array().unwrap() {
            assert_keys(
                f,
                &[
                    "family",
                    "steps",
                    "best_scalars",
                    "best_measure",
                    "outcome",
                    "fits",
                    "seconds",
                ],
                &[],
                "search[]",
            );
        }
        let enc = &a["encoding"];
        assert_keys(enc, &["degree", "joins", "breaks", "x", "y"], &[], "encoding");
        kinds.extend(keys(&enc["breaks"]).into_iter().map(String::from));
        let ctrl = regenerate_curve(enc);
        let g = gap(&ctrl, &points(&rep["control_points"]));
        assert!(
            g < 1e-12,
            "{input} {tol} {mode}: regenerated control points differ by {g:e}"
        );
        // The count is the stored numbers.
        let s = &a["scalars"];
        let stored_breaks = enc["breaks"]
            .get("stored")
            .map_or(0, |b| b.as_array().unwrap().len());
        let (x, rule) = match enc["x"].get("free") {
            Some(x) => (x.as_array().unwrap().len(), 0),
            None => (0, enc["x"]["aerofoil_rule"].as_array().unwrap().len()),
        };
        assert_eq!(s["x"], x);
        assert_eq!(s["rule"], rule);
        assert_eq!(s["breaks"], stored_breaks);
        assert_eq!(s["y"], enc["y"].as_array().unwrap().len());
        let total = x + rule + stored_breaks + enc["y"].as_array().unwrap().len();
        assert_eq!(s["total"], total);
        assert_eq!(a["stored_scalars"], total);
        // The report's breaks are the encoding's full list.
        let le = enc["x"].get("aerofoil_rule").is_some();
        assert_eq!(numbers(&rep["breaks"]), break_list(&enc["breaks"], le));
        assert_eq!(le, mode != "free", "{input} {tol} {mode}: how x is stored");
    }
    assert!(
        kinds.contains("uniform_per_side") && kinds.contains("stored"),
        "the cases cover equal breaks per side and stored breaks: {kinds:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The Greville abscissae of a knot vector of degree `d`.
fn greville(d: usize, knots: &[f64]) -> Vec<f64> {
    (0..knots.len() - d - 1)
        .map(|j| knots[j + 1..=j + d].iter().sum::<f64>() / d as f64)
        .collect()
}

#[test]
fn surface_and_adapt_surface_reports_regenerate() {
    let dir = scratch("report-format-surface");
    let cloud = dir.join("blade.csv");
    let out = Command::new(bin())
        .args([
            "blade",
            "data/blade_paper.json",
            "--points-per-section",
            "24",
            "-o",
        ])
        .arg(&cloud)
        .current_dir(crate_root())
        .output()
        .unwrap();
    assert!(out.status.success());
    let c = cloud.to_str().unwrap();

    let rep = run(&["fit-surface", c, "--degree", "3x3", "--patches", "4x2"]);
    assert_keys(&rep, &SURFACE, &[], "surface report");
    assert_common_blocks(&rep, 3);
    check_net_shape(&rep);

    let adapt = |cloud: &str, chord_rule: &str| {
        run(&[
            "adapt-surface",
            cloud,
            "--tol",
            "2e-3",
            "--relative",
            "--degrees-u",
            "3-4",
            "--degrees-v",
            "2",
            "--chord-rule",
            chord_rule,
        ])
    };
    // The blade without its last two sections (which close the tip to a point within 5 mm,
    // where no layout of this small cloud is fair between them).
    let text = std::fs::read_to_string(&cloud).unwrap();
    let tipless: String = text
        .lines()
        .filter(|l| !matches!(l.split(',').nth(3), Some("10" | "11")))
        .map(|l| format!("{l}\n"))
        .collect();
    let tipless_cloud = dir.join("tipless.csv");
    std::fs::write(&tipless_cloud, tipless).unwrap();
    let plain = adapt(tipless_cloud.to_str().unwrap(), "off");
    let chord = adapt(tipless_cloud.to_str().unwrap(), "on");
    assert_eq!(chord["adapt"]["encoding"]["chord_rule"], true);
    for rep in [plain, chord] {
        check_adapt_surface(&rep);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The adapt-surface report's documented keys, and its control net regenerated by the recipe
/// of §5.7 (with or without the chord rule).
fn check_adapt_surface(rep: &Value) {
    let mut top = SURFACE.to_vec();
    top.push("adapt");
    assert_keys(rep, &top, &[], "adapt-surface report");
    assert_common_blocks(rep, 3);
    check_net_shape(rep);
    let a = &rep["adapt"];
    assert_keys(
        a,
        &[
            "tol",
            "norm",
            "met",
            "stored_scalars",
            "scalars",
            "counting",
            "encoding",
            "family",
            "checked",
            "fits",
            "search",
        ],
        &[
            "message",
            "held_out",
            "fold",
            "section_ends",
            "projection_agreement",
            "fairness",
            "between_sections",
            "scatter",
        ],
        "adapt-surface block",
    );
    if let Some(e) = a.get("section_ends") {
        assert_keys(
            e,
            &["cuts", "excess", "span", "end", "at", "passes"],
            &[],
            "section_ends",
        );
    }
    if let Some(f) = a.get("fairness") {
        assert_keys(
            f,
            &["stations", "worst", "measure", "span", "passes"],
            &[],
            "fairness",
        );
    }
    if let Some(b) = a.get("between_sections") {
        assert_keys(
            b,
            &["method", "sections", "points", "max", "rms", "span", "skipped"],
            &[],
            "between_sections",
        );
    }
    if let Some(sc) = a.get("scatter") {
        assert_keys(
            sc,
            &["sigma", "relative", "section", "above_tolerance"],
            &[],
            "scatter",
        );
    }
    assert_keys(
        &a["scalars"],
        &["coords", "frames", "rule", "breaks", "total"],
        &[],
        "scalars",
    );
    assert_keys(&a["checked"], &["max", "rms"], &[], "checked");
    for f in a["search"].as_array().unwrap() {
        assert_keys(
            f,
            &[
                "family",
                "fits",
                "best_scalars",
                "best_measure",
                "outcome",
                "seconds",
            ],
            &[],
            "search[]",
        );
    }
    let enc = &a["encoding"];
    assert_keys(
        enc,
        &[
            "degree",
            "joins_u",
            "joins_v",
            "breaks_u",
            "breaks_v",
            "span_rule",
            "coords",
        ],
        &["chord_rule", "te_term"],
        "encoding",
    );

    // The recipe of §5.7.
    let deg = numbers(&enc["degree"]);
    let (du, dv) = (deg[0] as usize, deg[1] as usize);
    let orders = |v: &Value| -> Vec<usize> { numbers(v).iter().map(|&k| k as usize).collect() };
    let ku = knot_vector(du, &break_list(&enc["breaks_u"], false), &orders(&enc["joins_u"]));
    let kv = knot_vector(dv, &break_list(&enc["breaks_v"], false), &orders(&enc["joins_v"]));
    let (nu, nv) = (ku.len() - du - 1, kv.len() - dv - 1);
    let rule = &enc["span_rule"];
    let coords = numbers(&enc["coords"]);
    let chord_rule = enc["chord_rule"].as_bool().unwrap_or(false);
    let per = if rule.is_null() { 3 } else { 2 };
    let g = greville(dv, &kv);
    // The chord rule: [O_j (2), θ_j, c_j] a column ([O_j (2), θ_j, c_j, b_j] with the
    // trailing-edge term), then y_ij row-major; design point (i, j) is
    // O_j + c_j (x_i + b_j w_i) d_j + y_ij n_j in the two axes besides the span axis, with
    // t_a = 2τ_a - 1 over the u knots τ_{i+1} … τ_{i+du} and e_k their elementary symmetric
    // polynomials, x_i = e_2 / C(du, 2) (the blossom of (2u - 1)²), w_i = x_i - e_4 / C(du, 4)
    // (of t² (1 - t²)).
    let te_term = enc["te_term"].as_bool().unwrap_or(false);
    let fl = if te_term { 5 } else { 4 };
    let choose = |n: usize, r: usize| (0..r).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64);
    let chord_design = |k: usize| -> Vec<f64> {
        let (i, j) = (k / nv, k % nv);
        let mut es = [1.0, 0.0, 0.0, 0.0, 0.0];
        for tau in &ku[i + 1..=i + du] {
            for r in (1..5).rev() {
                es[r] += (2.0 * tau - 1.0) * es[r - 1];
            }
        }
        let mut x = es[2] / choose(du, 2);
        let f = &coords[fl * j..fl * j + fl];
        if te_term {
            x += f[4] * (es[2] / choose(du, 2) - es[4] / choose(du, 4));
        }
        let y = coords[fl * nv + k];
        let (dx, dy) = (f[2].cos(), f[2].sin());
        let flat = [f[0] + f[3] * x * dx - y * dy, f[1] + f[3] * x * dy + y * dx];
        let axis = rule["axis"].as_u64().unwrap() as usize;
        let ends = numbers(&rule["ends"]);
        let mut it = flat.iter();
        (0..3)
            .map(|a| {
                if a == axis {
                    ends[0] + g[j] * (ends[1] - ends[0])
                } else {
                    *it.next().unwrap()
                }
            })
            .collect()
    };
    if chord_rule {
        assert_eq!(coords.len(), nv * (nu + fl));
    } else {
        assert_eq!(coords.len(), nu * nv * per);
    }
    let design: Vec<Vec<f64>> = (0..nu * nv)
        .map(|k| {
            if chord_rule {
                return chord_design(k);
            }
            let c = &coords[k * per..(k + 1) * per];
            if rule.is_null() {
                return c.to_vec();
            }
            let axis = rule["axis"].as_u64().unwrap() as usize;
            let ends = numbers(&rule["ends"]);
            let mut it = c.iter();
            (0..3)
                .map(|a| {
                    if a == axis {
                        ends[0] + g[k % nv] * (ends[1] - ends[0])
                    } else {
                        *it.next().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    let rows: Vec<Vec<Vec<f64>>> = (0..nu)
        .map(|i| bezier(dv, &kv, &design[i * nv..(i + 1) * nv]))
        .collect();
    let mv = rows[0].len();
    let cols: Vec<Vec<Vec<f64>>> = (0..mv)
        .map(|j| bezier(du, &ku, &rows.iter().map(|r| r[j].clone()).collect::<Vec<_>>()))
        .collect();
    let net: Vec<Vec<f64>> = (0..cols[0].len())
        .flat_map(|i| cols.iter().map(move |c| c[i].clone()))
        .collect();
    let stored: Vec<Vec<f64>> = rep["control_net"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(points)
        .collect();
    let gap = gap(&net, &stored);
    assert!(gap < 1e-12, "regenerated control net differs by {gap:e}");
}

/// `design_net` and `control_net` have the shapes `degree`, `patches` and the breaks say.
fn check_net_shape(rep: &Value) {
    let (d, p) = (numbers(&rep["degree"]), numbers(&rep["patches"]));
    let net = rep["control_net"].as_array().unwrap();
    assert_eq!(net.len() as f64, p[0] * d[0] + 1.0);
    assert!(net
        .iter()
        .all(|r| r.as_array().unwrap().len() as f64 == p[1] * d[1] + 1.0));
    assert_eq!(numbers(&rep["breaks_u"]).len() as f64, p[0] + 1.0);
    assert_eq!(numbers(&rep["breaks_v"]).len() as f64, p[1] + 1.0);
    assert_eq!(rep["continuity"].as_array().unwrap().len(), 2);
    assert!(!rep["design_net"].as_array().unwrap().is_empty());
}
