//! `adapt_surface` and `bezchain adapt-surface` on lofted blades: the tolerance at every point
//! by a closest-point search independent of the library's, the stored scalars counted from
//! the encoding and regenerating the reported grid, the span rule's planes, unmeetable
//! tolerances, the CLI's exit statuses; and (ignored, run in release) the issue's bars on the
//! paper's 82 x 12 blade.

mod common;

use bezchain::adaptive::{
    adapt_surface, sampled_offsets, AdaptedSurface, Breaks, ChordRule, Norm, SpanBreaks, SurfaceAdaptOptions,
};
use bezchain::chain::PatchGrid;
use bezchain::export::SurfaceAdaptReport;
use bezchain::geometry::{Blade, Grid, LoftOptions};
use common::check::{check_surface_report, IndependentGrid};
use common::{bin, crate_root, scratch};
use glam::DVec3;
use std::process::Command;

/// The paper's blade to its last full section (`data/blade_paper_to_tip.json`, its first 10
/// stations; the last two close the tip to a point within 0.9 % of the span,
/// [`a_tip_spike_between_sections_is_not_met`]).
fn paper_to_tip() -> Blade {
    Blade::from_file(&crate_root().join("data/blade_paper_to_tip.json")).unwrap()
}

/// [`paper_to_tip`] lofted with `per` points per section at its 10 stations.
fn blade(per: Option<usize>) -> (Vec<DVec3>, Grid, f64) {
    let b = paper_to_tip();
    let cloud = b
        .loft(&LoftOptions {
            points_per_section: per,
            ..LoftOptions::default()
        })
        .unwrap();
    (cloud.points, cloud.grid.unwrap(), b.max_chord())
}

/// Closest-point distance of every point from the grid, by the tests' own search
/// ([`IndependentGrid`], from the grid's control net alone).
fn independent_offsets(grid: &PatchGrid<DVec3>, points: &[DVec3]) -> Vec<f64> {
    let (_, cols) = grid.layout().net_shape();
    let net: Vec<Vec<DVec3>> = grid.net().chunks(cols).map(<[DVec3]>::to_vec).collect();
    let l = grid.layout();
    let check = IndependentGrid::new(&net, l.u.degree(), l.v.degree());
    points.iter().map(|&q| check.distance(q)).collect()
}

/// Everything a met result must show: the tolerance at every point by the independent search
/// and by the checker's, the count from the encoding, the grid regenerated from the stored
/// numbers alone, every section of the surface in its data section's plane.
fn check_met(r: &AdaptedSurface, points: &[DVec3], grid: Grid, tol: f64) {
    assert!(r.met, "{:?}", r.message);
    let ind = independent_offsets(&r.grid, points);
    let max = ind.iter().fold(0.0_f64, |m, e| m.max(*e));
    assert!(max <= tol * (1.0 + 1e-9), "independent max {max:e} > {tol:e}");
    assert!(r.offset.max <= tol && r.checked.max <= tol);
    // The library's closest points are never farther than the independent search's.
    assert!(r.offset.max <= max * (1.0 + 1e-6) + 1e-12);
    let (lu, lv) = r.encoding.layouts().unwrap();
    if r.encoding.chord_rule {
        assert_eq!(r.count.coords, lu.design_count() * lv.design_count());
        // Four numbers a column frame, five with the trailing-edge term.
        let per_frame = 4 + usize::from(r.encoding.te_term);
        assert_eq!(r.count.frames, per_frame * lv.design_count());
        assert!(!r.encoding.te_term || lu.degree() >= 4);
    } else {
        let per = if r.encoding.span_rule.is_some() { 2 } else { 3 };
        assert_eq!(r.count.coords, lu.design_count() * lv.design_count() * per);
        assert_eq!(r.count.frames, 0);
    }
    assert_eq!(
        r.count.total,
        r.count.coords + r.count.frames + r.count.rule + r.count.breaks
    );
    assert_eq!(r.encoding.grid().unwrap().net(), r.grid.net());
    let rule = r
        .encoding
        .span_rule
        .expect("the blade's sections are planes z = r");
    assert_eq!(rule.axis, 2);
    let (first, last) = (points[0].z, points[points.len() - 1].z);
    for k in 0..grid.sections {
        let z = points[k * grid.per_section].z;
        let v = (z - first) / (last - first);
        for i in 0..=10 {
            let s = r.grid.eval(i as f64 / 10.0, v);
            assert!((s.z - z).abs() <= 1e-12, "section {k}: surface z {} != {z}", s.z);
        }
    }
    // Fair between the sections, by the test's own cut of the surface at every mid-station.
    for k in 0..grid.sections - 1 {
        let m = independent_mid_station(&r.grid, points, grid, k, tol);
        assert!(
            m.chord <= 1.05 && m.thickness <= 1.05 && m.centroid_ratio <= 1.05,
            "mid-station {k}: {m:?}"
        );
    }
}

/// The surface's cut half-way between sections `k` and `k + 1` of a cloud in planes z = r,
/// against those sections, each measured by the test's own code: chord (trailing edge the
/// mid-point of the ends, leading edge the farthest point), thickness (the largest extent
/// across the chord, in 200 bins along it), area centroid. `chord` and `thickness`: how far
/// the cut's lies outside the neighbours' range, over the allowance (2 % of their mean chord
/// plus `tol`); `centroid`: its distance from the mid-point of theirs; `centroid_ratio`: that
/// over 5 % of the mean chord plus `tol`.
#[derive(Debug)]
struct MidStation {
    chord: f64,
    thickness: f64,
    centroid: f64,
    centroid_ratio: f64,
}

fn independent_mid_station(
    surface: &PatchGrid<DVec3>,
    points: &[DVec3],
    grid: Grid,
    k: usize,
    tol: f64,
) -> MidStation {
    let per = grid.per_section;
    let sec = |j: usize| -> Vec<[f64; 2]> {
        points[j * per..(j + 1) * per]
            .iter()
            .map(|p| [p.x, p.y])
            .collect()
    };
    let (first, last) = (points[0].z, points[points.len() - 1].z);
    let z = 0.5 * (points[k * per].z + points[(k + 1) * per].z);
    let v = (z - first) / (last - first);
    let cut: Vec<[f64; 2]> = (0..=400)
        .map(|i| {
            let p = surface.eval(i as f64 / 400.0, v);
            [p.x, p.y]
        })
        .collect();
    let measure = |c: &[[f64; 2]]| -> (f64, f64, [f64; 2]) {
        let n = c.len();
        let te = [0.5 * (c[0][0] + c[n - 1][0]), 0.5 * (c[0][1] + c[n - 1][1])];
        let d = |p: &[f64; 2]| ((p[0] - te[0]).powi(2) + (p[1] - te[1]).powi(2)).sqrt();
        let le = *c.iter().max_by(|a, b| d(a).total_cmp(&d(b))).unwrap();
        let chord = d(&le);
        let mut a2 = 0.0;
        let (mut cx, mut cy) = (0.0, 0.0);
        for i in 0..n {
            let (p, q) = (c[i], c[(i + 1) % n]);
            let cr = p[0] * q[1] - q[0] * p[1];
            a2 += cr;
            cx += (p[0] + q[0]) * cr;
            cy += (p[1] + q[1]) * cr;
        }
        let centroid = if a2.abs() > 1e-12 * chord * chord {
            [cx / (3.0 * a2), cy / (3.0 * a2)]
        } else {
            let m = c.iter().fold([0.0, 0.0], |m, p| [m[0] + p[0], m[1] + p[1]]);
            [m[0] / n as f64, m[1] / n as f64]
        };
        let mut thickness = 0.0_f64;
        if chord > 0.0 {
            let e = [(te[0] - le[0]) / chord, (te[1] - le[1]) / chord];
            // Densify the polygon, then the y-extent of its vertices in each of 200 bins.
            let mut bins = vec![(f64::INFINITY, f64::NEG_INFINITY); 200];
            for i in 0..n {
                let (p, q) = (c[i], c[(i + 1) % n]);
                for s in 0..20 {
                    let t = s as f64 / 20.0;
                    let r = [p[0] + t * (q[0] - p[0]) - le[0], p[1] + t * (q[1] - p[1]) - le[1]];
                    let (x, y) = (r[0] * e[0] + r[1] * e[1], e[0] * r[1] - e[1] * r[0]);
                    let b = ((x / chord * 200.0).floor().max(0.0) as usize).min(199);
                    bins[b] = (bins[b].0.min(y), bins[b].1.max(y));
                }
            }
            thickness = bins
                .iter()
                .filter(|b| b.1 > b.0)
                .map(|b| b.1 - b.0)
                .fold(0.0, f64::max);
        }
        (chord, thickness, centroid)
    };
    let (ca, ta, ga) = measure(&sec(k));
    let (cb, tb, gb) = measure(&sec(k + 1));
    let (cm, tm, gm) = measure(&cut);
    let c = 0.5 * (ca + cb);
    let allow = 0.02 * c + tol;
    let outside = |x: f64, p: f64, q: f64| (x - p.max(q)).max(p.min(q) - x).max(0.0) / allow;
    let centroid = ((gm[0] - 0.5 * (ga[0] + gb[0])).powi(2) + (gm[1] - 0.5 * (ga[1] + gb[1])).powi(2)).sqrt();
    MidStation {
        chord: outside(cm, ca, cb),
        thickness: outside(tm, ta, tb),
        centroid,
        centroid_ratio: centroid / (0.05 * c + tol),
    }
}

/// The whole paper blade, whose last two stations (5 mm apart, chords 0.08 and 0) close the
/// tip: a layout meets 2e-3 of the chord at every section, but without the mid-station check
/// its cut half-way between them strays metres from both (a spike no held-out check sees).
/// The search refuses such layouts, and the result says it is not met.
#[test]
fn a_tip_spike_between_sections_is_not_met() {
    let b = Blade::from_file(&crate_root().join("data/blade_paper.json")).unwrap();
    let cloud = b
        .loft(&LoftOptions {
            points_per_section: Some(24),
            ..LoftOptions::default()
        })
        .unwrap();
    let (points, grid) = (cloud.points, cloud.grid.unwrap());
    let opts = SurfaceAdaptOptions {
        tol: 2e-3 * b.max_chord(),
        degrees_u: [3, 4],
        degrees_v: [2, 2],
        held_out: false,
        ..SurfaceAdaptOptions::default()
    };
    let unchecked = adapt_surface(
        &points,
        grid,
        &SurfaceAdaptOptions {
            span_checks: false,
            ..opts
        },
    )
    .unwrap();
    assert!(unchecked.at_sections && !unchecked.met, "{:?}", unchecked.message);
    let f = unchecked.fairness.clone().unwrap();
    assert!(!f.passes && f.span > 1.505 && f.span < 1.51, "{f:?}");
    assert!(unchecked.message.unwrap().contains("not between them"));
    // The cut there, measured by the test itself: its centroid strays from the mid-point of
    // its neighbours' by more than the chord of the wider one.
    let stray = independent_mid_station(&unchecked.grid, &points, grid, 10, opts.tol);
    assert!(stray.centroid > 0.08, "{stray:?}");
    let checked = adapt_surface(&points, grid, &opts).unwrap();
    assert!(!checked.met, "{}", checked.family);
}

#[test]
fn a_coarse_blade_meets_the_tolerance_at_every_point() {
    let (points, grid, chord) = blade(Some(24));
    let tol = 2e-3 * chord;
    let opts = SurfaceAdaptOptions {
        tol,
        degrees_u: [3, 4],
        degrees_v: [2, 2],
        ..SurfaceAdaptOptions::default()
    };
    let r = adapt_surface(&points, grid, &opts).unwrap();
    check_met(&r, &points, grid, tol);
    // Fewer stored scalars than the cloud's own numbers, by far.
    assert!(r.count.total * 4 < 3 * points.len(), "{} scalars", r.count.total);
    let h = r.held_out.expect("held-out check");
    assert_eq!(h.fitted + h.measured, points.len());
    assert!(h.max.is_finite() && h.max > 0.0);
}

#[test]
fn the_bulk_families_put_their_span_breaks_where_they_are_told() {
    // The bulk families alone (the greedy ones place their breaks where the offsets are):
    // every span break of the result at a section, or half-way between two neighbouring
    // ones, and the tolerance met either way.
    let (points, grid, chord) = blade(Some(24));
    let tol = 5e-4 * chord;
    let per = grid.per_section;
    let z: Vec<f64> = (0..grid.sections).map(|k| points[k * per].z).collect();
    let v: Vec<f64> = z.iter().map(|s| (s - z[0]) / (z[z.len() - 1] - z[0])).collect();
    let mid: Vec<f64> = v.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
    for (rule, sites) in [(SpanBreaks::Sections, &v), (SpanBreaks::Midway, &mid)] {
        let r = adapt_surface(
            &points,
            grid,
            &SurfaceAdaptOptions {
                tol,
                degrees_u: [3, 4],
                degrees_v: [3, 3],
                greedy: false,
                span_breaks: rule,
                ..SurfaceAdaptOptions::default()
            },
        )
        .unwrap();
        check_met(&r, &points, grid, tol);
        let (_, lv) = r.encoding.layouts().unwrap();
        let all = lv.breaks();
        let breaks = &all[1..all.len() - 1];
        assert!(!breaks.is_empty(), "{rule:?}: one span");
        for b in breaks {
            assert!(
                sites.iter().any(|s| (s - b).abs() < 1e-12),
                "{rule:?}: span break {b} at none of {sites:?}"
            );
        }
    }
}

/// The chord rule's design net regenerated the way an outside tool would, from the report's
/// stored numbers and knot vectors alone: with `t_a = 2τ_a - 1` over the knots
/// `τ_{i+1} … τ_{i+d}` and `e_k` their elementary symmetric polynomials, `x_i = e_2 / C(d, 2)`
/// (the blossom of `(2u - 1)²`) and, with the trailing-edge term, `w_i = e_2 / C(d, 2) -
/// e_4 / C(d, 4)` (of `t² (1 - t²)`); design point `(i, j) = O_j + c_j (x_i + b_j w_i) d_j +
/// y_ij n_j` in the x-y plane.
fn chord_rule_net(r: &AdaptedSurface) -> Vec<DVec3> {
    let e = &r.encoding;
    let (lu, lv) = e.layouts().unwrap();
    let (nu, nv, d) = (lu.design_count(), lv.design_count(), lu.degree());
    let knots = lu.knots();
    let rule = e.span_rule.unwrap();
    let g = lv.greville();
    let k = 4 + usize::from(e.te_term);
    let choose = |n: usize, r: usize| (0..r).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64);
    let mut net = Vec::new();
    for i in 0..nu {
        let t: Vec<f64> = knots[i + 1..=i + d].iter().map(|tau| 2.0 * tau - 1.0).collect();
        // Elementary symmetric polynomials e_0 ..= e_4 of the t_a.
        let mut es = [1.0, 0.0, 0.0, 0.0, 0.0];
        for &ta in &t {
            for r in (1..5).rev() {
                es[r] += ta * es[r - 1];
            }
        }
        let x = es[2] / choose(d, 2);
        let w = if d >= 4 { x - es[4] / choose(d, 4) } else { 0.0 };
        for (j, gj) in g.iter().enumerate() {
            let f = &e.coords[k * j..k * j + k];
            let chordwise = x + if e.te_term { f[4] * w } else { 0.0 };
            let (dx, dy) = (f[2].cos(), f[2].sin());
            let y = e.coords[k * nv + i * nv + j];
            net.push(DVec3::new(
                f[0] + f[3] * chordwise * dx - y * dy,
                f[1] + f[3] * chordwise * dy + y * dx,
                rule.ends[0] + gj * (rule.ends[1] - rule.ends[0]),
            ));
        }
    }
    net
}

#[test]
fn the_chord_rule_neither_folds_nor_overhangs_and_counts_its_frames() {
    // Without the tip section, which the paper's blade collapses to a point: near it the
    // sections shrink below the tolerance and the normal of the fitted surface is not
    // defined by anything in the data (the fold check reports it there).
    let (mut points, mut grid, chord) = blade(Some(24));
    points.truncate(points.len() - grid.per_section);
    grid.sections -= 1;
    let tol = 2e-3 * chord;
    let r = adapt_surface(
        &points,
        grid,
        &SurfaceAdaptOptions {
            tol,
            degrees_u: [3, 4],
            degrees_v: [2, 2],
            chord_rule: ChordRule::On,
            ..SurfaceAdaptOptions::default()
        },
    )
    .unwrap();
    assert!(r.encoding.chord_rule);
    check_met(&r, &points, grid, tol);
    // Fold-free: the normal never turns by more than 90° between neighbouring samples, and
    // the checker's sampled search agrees with the exact offsets within 10 %.
    assert!(r.fold.passes && r.fold.max_turn_deg <= 90.0, "{:?}", r.fold);
    assert!(r.agreement <= 1.1, "checker/exact {}", r.agreement);
    // Counting: one number a design point, four a design column (five with the
    // trailing-edge term), two for the span rule, the stored breaks.
    let (lu, lv) = r.encoding.layouts().unwrap();
    let (nu, nv) = (lu.design_count(), lv.design_count());
    let breaks = |b: &Breaks| match b {
        Breaks::Stored(v) => v.len(),
        _ => 0,
    };
    assert_eq!(
        r.count.total,
        nu * nv
            + (4 + usize::from(r.encoding.te_term)) * nv
            + 2
            + breaks(&r.encoding.breaks_u)
            + breaks(&r.encoding.breaks_v)
    );
    // An outside tool regenerates the design net from the stored numbers.
    let net = chord_rule_net(&r);
    for (a, b) in net.iter().zip(r.encoding.design().unwrap()) {
        assert!((*a - b).length() <= 1e-12 * chord, "{a} != {b}");
    }
    // And the report carries both checks.
    let report = SurfaceAdaptReport::new(
        &r,
        &SurfaceAdaptOptions {
            tol,
            ..SurfaceAdaptOptions::default()
        },
        bezchain::export::InputInfo {
            path: "blade".into(),
            points: points.len(),
        },
    );
    let json = serde_json::to_value(&report).unwrap();
    assert!(json["adapt"]["counting"].as_str().unwrap().contains("chord rule"));
    assert_eq!(json["adapt"]["fold"]["passes"], true);
    assert!(json["adapt"]["projection_agreement"].as_f64().unwrap() <= 1.1);
}

#[test]
fn an_unmeetable_tolerance_ends_with_the_closest_layout_and_a_message() {
    let (points, grid, _) = blade(Some(12));
    let r = adapt_surface(
        &points,
        grid,
        &SurfaceAdaptOptions {
            tol: 1e-12,
            degrees_u: [3, 3],
            degrees_v: [2, 2],
            held_out: false,
            ..SurfaceAdaptOptions::default()
        },
    )
    .unwrap();
    assert!(!r.met);
    let m = r.message.expect("a message");
    assert!(m.contains("not met") && m.contains("closest layout"), "{m}");
    assert!(r.offset.max > 1e-12 && r.offset.max.is_finite());
    // The limits hold: at most half a section's points around, a column per section.
    let (lu, lv) = r.encoding.layouts().unwrap();
    assert!(lu.design_count() <= 6 && lv.design_count() <= 12);
}

#[test]
fn the_rms_norm_and_a_budget_are_honoured() {
    let (points, grid, chord) = blade(Some(16));
    let tol = 1e-3 * chord;
    let base = SurfaceAdaptOptions {
        tol,
        degrees_u: [3, 3],
        degrees_v: [2, 2],
        held_out: false,
        ..SurfaceAdaptOptions::default()
    };
    let rms = adapt_surface(
        &points,
        grid,
        &SurfaceAdaptOptions {
            norm: Norm::Rms,
            ..base
        },
    )
    .unwrap();
    assert!(rms.met && rms.offset.rms <= tol);
    let budget = adapt_surface(
        &points,
        grid,
        &SurfaceAdaptOptions {
            max_scalars: Some(30),
            ..base
        },
    )
    .unwrap();
    assert!(!budget.met && budget.count.total <= 30, "{}", budget.count.total);
    assert!(budget.message.unwrap().contains("at most 30"));
}

#[test]
fn checker_search_is_never_below_the_true_distance() {
    let (points, grid, chord) = blade(Some(16));
    let r = adapt_surface(
        &points,
        grid,
        &SurfaceAdaptOptions {
            tol: 3e-3 * chord,
            degrees_u: [3, 3],
            degrees_v: [2, 2],
            held_out: false,
            ..SurfaceAdaptOptions::default()
        },
    )
    .unwrap();
    let ind = independent_offsets(&r.grid, &points);
    for (s, i) in sampled_offsets(&r.grid, &points).iter().zip(&ind) {
        assert!(*s >= i * (1.0 - 1e-9) - 1e-15, "sampled {s} < independent {i}");
    }
}

#[test]
fn the_cli_writes_a_report_and_exits_by_the_outcome() {
    let dir = scratch("adapt-surface");
    let cloud = dir.join("b.csv");
    let blade_json = crate_root().join("data/blade_paper_to_tip.json");
    let st = Command::new(bin())
        .args([
            "blade",
            blade_json.to_str().unwrap(),
            "--points-per-section",
            "24",
            "-o",
        ])
        .arg(&cloud)
        .status()
        .unwrap();
    assert!(st.success());
    let json = dir.join("r.json");
    let out = Command::new(bin())
        .arg("adapt-surface")
        .arg(&cloud)
        .args([
            "--tol",
            "2e-3",
            "--relative",
            "--degrees-u",
            "3-4",
            "--degrees-v",
            "2",
            "--json",
        ])
        .arg(&json)
        .arg("--png")
        .arg(dir.join("r.png"))
        .arg("--svg")
        .arg(dir.join("r.svg"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    // The pictures of fit-surface, drawn for the adapted surface.
    let png = std::fs::read(dir.join("r.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG\r\n\x1a\n") && png.len() > 10_000);
    let svg = std::fs::read_to_string(dir.join("r.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    // Coloured as fit-surface colours: both scales, the worst point, the stations.
    assert!(svg.contains(r#"class="percent-of-local-chord""#) && svg.contains(r#"class="data-units""#));
    assert!(svg.contains(r#"<g class="worst-point""#) && svg.contains(r#"class="station""#));
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("stored scalars") && stdout.contains("checker"),
        "{stdout}"
    );
    // Standard error is a pipe: plain progress lines, the first family's at once.
    let progress = String::from_utf8_lossy(&out.stderr);
    assert!(
        progress.contains("b.csv at ") && progress.contains(" family 1/") && progress.contains(" pass: d"),
        "{progress}"
    );
    let text = std::fs::read_to_string(&json).unwrap();
    // The offsets the report claims, re-measured from its control net alone.
    let points = bezchain::geometry::read_cloud(&cloud).unwrap().points;
    let o = check_surface_report(&serde_json::from_str(&text).unwrap(), &points, 1e-6);
    let rep: SurfaceAdaptReport = serde_json::from_str(&text).unwrap();
    assert!(
        o.max <= rep.adapt.outcome.tol,
        "independent max {:e} above {:e}",
        o.max,
        rep.adapt.outcome.tol
    );
    assert_eq!(rep.surface.kind, "surface");
    assert!(rep.adapt.outcome.met);
    assert_eq!(
        rep.adapt.outcome.stored_scalars,
        rep.adapt.outcome.encoding.count().total
    );
    let grid = rep.adapt.outcome.encoding.grid().unwrap();
    let flat: Vec<[f64; 3]> = rep.surface.control_net.iter().flatten().copied().collect();
    assert_eq!(grid.net().iter().map(|p| p.to_array()).collect::<Vec<_>>(), flat);
    // Relative: a fraction of the largest distance between two points of one section, the
    // chord 0.177 up to the sampling of the leading edge.
    assert!(
        (rep.adapt.outcome.tol - 2e-3 * 0.177).abs() < 1e-2 * 2e-3 * 0.177,
        "{}",
        rep.adapt.outcome.tol
    );

    // Unmeetable: exit 1, the report still written.
    let _ = std::fs::remove_file(&json);
    let out = Command::new(bin())
        .arg("adapt-surface")
        .arg(&cloud)
        .args([
            "--tol",
            "1e-12",
            "--degrees-u",
            "3",
            "--degrees-v",
            "2",
            "--quiet",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    // `--quiet`: the error alone.
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: ") && err.contains("not met"), "{err}");
    assert!(json.exists());

    // A cloud without sections, and a bad tolerance: exit 2.
    let plain = dir.join("plain.xyz");
    std::fs::write(&plain, "0 0 0\n1 0 0\n0 1 0\n1 1 1\n").unwrap();
    for args in [
        vec!["adapt-surface", plain.to_str().unwrap(), "--tol", "1e-3"],
        vec!["adapt-surface", cloud.to_str().unwrap(), "--tol=-1"],
        vec![
            "adapt-surface",
            cloud.to_str().unwrap(),
            "--tol",
            "1e-3",
            "--degrees-u",
            "x",
        ],
    ] {
        let out = Command::new(bin()).args(&args).output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// A blade definition read by `adapt-surface` directly: lofted at its stations, checked
/// against sections lofted half-way between them (`between_sections.method` "loft", within 3
/// tolerances), fair at every mid-station, the data's scatter reported.
#[test]
fn the_cli_checks_a_blade_definition_between_its_stations() {
    let dir = scratch("adapt-surface-definition");
    let json = dir.join("r.json");
    let out = Command::new(bin())
        .arg("adapt-surface")
        .arg(crate_root().join("data/blade_paper_to_tip.json"))
        .args([
            "--points-per-section",
            "24",
            "--tol",
            "2e-3",
            "--relative",
            "--degrees-u",
            "3-4",
            "--degrees-v",
            "2",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("mid-stations") && stdout.contains("between"),
        "{stdout}"
    );
    let rep: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let a = &rep["adapt"];
    let tol = a["tol"].as_f64().unwrap();
    assert_eq!(a["met"], true);
    assert_eq!(a["between_sections"]["method"], "loft");
    assert_eq!(a["between_sections"]["sections"], 9);
    assert!(a["between_sections"]["max"].as_f64().unwrap() <= 3.0 * tol);
    assert_eq!(a["fairness"]["passes"], true);
    assert!(a["fairness"]["worst"].as_f64().unwrap() <= 1.0);
    assert!(a["scatter"]["sigma"].as_f64().unwrap() >= 0.0);
    // A point cloud takes no loft option.
    let bad = Command::new(bin())
        .args([
            "adapt-surface",
            "-",
            "--tol",
            "1e-3",
            "--points-per-section",
            "24",
        ])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

/// The issue's bars (run in release: `cargo test --release --test adapt_surface -- --ignored`):
/// the paper's blade to its last full section (10 x 82) at 1e-3 and 1e-4 of the largest chord
/// in at most half the 297 and 496 coefficients of three scipy `RectBivariateSpline`s on the
/// same grid (`benches/peers/blade_surface.py` on `bezchain blade data/blade_paper_to_tip.json`;
/// measured 46 and 209).
#[test]
#[ignore = "seconds in release; run with --release -- --ignored"]
fn the_paper_blade_beats_three_bivariate_splines() {
    let (points, grid, chord) = blade(None);
    assert_eq!((grid.sections, grid.per_section), (10, 82));
    for (rel, scipy) in [(1e-3, 297), (1e-4, 496)] {
        let tol = rel * chord;
        let r = met_with_defaults(&points, grid, tol, &format!("{rel:e} of the chord"));
        assert!(
            2 * r.count.total <= scipy,
            "{rel:e}: {} stored scalars, scipy {scipy}",
            r.count.total
        );
    }
}

/// `adapt_surface` with the default options at `tol`, checked by [`check_met`], its figures
/// printed under `label`.
fn met_with_defaults(points: &[DVec3], grid: Grid, tol: f64, label: &str) -> AdaptedSurface {
    let r = adapt_surface(
        points,
        grid,
        &SurfaceAdaptOptions {
            tol,
            ..SurfaceAdaptOptions::default()
        },
    )
    .unwrap();
    check_met(&r, points, grid, tol);
    eprintln!(
        "{label}: {} stored scalars ({}), max {:.3e}, checker {:.3e}, held-out {:.3e}, fold {:.1} deg, {:.2} s",
        r.count.total,
        r.family,
        r.offset.max,
        r.checked.max,
        r.held_out.map_or(f64::NAN, |h| h.max),
        r.fold.max_turn_deg,
        r.seconds
    );
    r
}

/// The README's blade table on the two shipped blades (`adapt-surface FILE --tol 1e-3 --relative
/// --points-per-section 160`): the IEA 15 MW windIO v2 definition meets 1e-3 of its largest
/// chord in at most half the 2,501 coefficients of three scipy `RectBivariateSpline`s on its
/// stations' cloud, held out within 3 tolerances, without folds or overhangs: 608 stored
/// scalars measured, so held to 0.3 of scipy's. Its sections' ends do not double back. Before
/// the loft held its contours' end slopes monotone, its root sections closed in a notch 9 mm
/// past their trailing edge, and the surface followed it: end 1 ran 3.0 tolerances back at 11
/// m span (713 stored scalars, against scipy's 1,960 on that cloud).
#[test]
#[ignore = "fifteen seconds in release; run with --release -- --ignored"]
fn the_iea_15mw_definition_meets_1e3_in_half_the_scipy_coefficients() {
    let path = "data/blades/iea-15-240-rwt/windio/IEA-15-240-RWT.yaml";
    let r = definition_meets_1e3(path, 2501, 0.3);
    let s = &r.surface;
    assert!(s.encoding.te_term, "{}", s.family);
    let won = s.trace.iter().find(|t| t.family == s.family).unwrap();
    assert_eq!(won.best_scalars, Some(s.count.total));
    let ends = s.ends.expect("the sections' ends are measured");
    assert!(ends.passes, "{ends:?}");
}

/// The IEA 3.4 MW AeroDyn 15 definition (30 stations): its thick flat-back root sections defeat
/// the chord rule's law, and a plain bulk family meets 1e-3 of its largest chord (the second
/// search, after sections lofted between stations joined, without the chord rule), in at most
/// half of scipy's 2,611 coefficients: 1,292 measured (0.495), the winner's polish holding the
/// joined sections to three tolerances in its second round (1,341 after its first).
#[test]
#[ignore = "twenty seconds in release; run with --release -- --ignored"]
fn the_iea_3_4mw_definition_meets_1e3_in_half_the_scipy_coefficients() {
    let path = "data/blades/iea-3.4-130-rwt/openfast/IEA-3.4-130-RWT_AeroDyn15.dat";
    let r = definition_meets_1e3(path, 2611, 0.5);
    assert!(r.surface.family.ends_with(" bulk"), "{}", r.surface.family);
    let joined = r.surface.joined.expect("sections joined between the stations");
    assert_eq!(joined.sections, r.radii.len() - r.stations);
    // The first search's chord-rule families met nothing, so the second searches the plain
    // families alone: no trailing-edge family in its trace.
    assert!(r.rounds >= 2, "{} searches", r.rounds);
    assert!(
        r.surface
            .trace
            .iter()
            .all(|t| !t.family.contains("trailing-edge")),
        "{:?}",
        r.surface.trace.iter().map(|t| &t.family).collect::<Vec<_>>()
    );
}

/// The same blade from its windIO v1 file, its 57 stations lofted at 160 points: no layout
/// meets the tolerance at the stations alone (the definition turns between some of them,
/// where the layouts that follow the stations fold or overhang), so the sections a smooth
/// interpolation of the stations misses join the data and a later search meets it, fair,
/// within 3 tolerances of the definition between the sections, held out within 3, with fewer
/// stored scalars than scipy's 3,416 coefficients on its stations' cloud (2,825 measured;
/// 2,469 against scipy's 2,973 on the loft before its contours' end slopes were held
/// monotone).
#[test]
#[ignore = "a minute in release; run with --release -- --ignored"]
fn the_iea_3_4mw_windio_v1_definition_meets_1e3_with_smooth_sections_added() {
    let path = "data/blades/iea-3.4-130-rwt/windio/IEA-3.4-130-RWT.yaml";
    let r = definition_meets_1e3(path, 3416, 1.0);
    let stations = Blade::from_file(&crate_root().join(path)).unwrap().stations.len();
    assert!(
        r.radii.len() > stations && r.rounds >= 2,
        "{} sections",
        r.radii.len()
    );
}

/// The IEA 15 MW definition at 120 points a section, 1e-3 of its largest chord: the winning
/// trailing-edge layout, swept a second time with the span breaks first, keeps fewer stored
/// scalars than its first sweep (u breaks first) left (701 measured), and the search keeps it
/// (and then polishes it, where that keeps fewer still). On the loft before its contours' end
/// slopes were held monotone, the same held at 80 points a section (1,311 against 1,396); on
/// today's loft no layout meets 1e-3 at 80 points in four searches.
#[test]
#[ignore = "twenty seconds in release; run with --release -- --ignored"]
fn a_trailing_edge_winner_swept_span_breaks_first_keeps_fewer_scalars() {
    let path = "data/blades/iea-15-240-rwt/windio/IEA-15-240-RWT.yaml";
    let r = definition_meets_1e3_at(path, 120, usize::MAX, 1.0);
    let s = &r.surface;
    let won = s.trace.iter().find(|t| t.family == s.family).unwrap();
    // The outcome says so only when the second sweep stored fewer numbers than the first.
    assert!(
        won.outcome.starts_with("met (span breaks removed first)"),
        "{won:?}"
    );
    assert_eq!(won.best_scalars, Some(s.count.total));
}

/// A shipped blade definition searched as `adapt-surface FILE --tol 1e-3 --relative
/// --points-per-section 160` does: met (which holds the mid-station checks), the checker within
/// 10 % of the exact offsets, no fold, held out within 3 tolerances, and at most `ratio` of
/// `scipy`'s coefficients (three scipy `RectBivariateSpline`s on the stations' cloud).
fn definition_meets_1e3(path: &str, scipy: usize, ratio: f64) -> bezchain::adaptive::AdaptedBlade {
    definition_meets_1e3_at(path, 160, scipy, ratio)
}

/// [`definition_meets_1e3`] at `per` points a section.
fn definition_meets_1e3_at(
    path: &str,
    per: usize,
    scipy: usize,
    ratio: f64,
) -> bezchain::adaptive::AdaptedBlade {
    let b = Blade::from_file(&crate_root().join(path)).unwrap();
    let loft = LoftOptions {
        points_per_section: Some(per),
        ..LoftOptions::default()
    };
    let cloud = b.loft(&loft).unwrap();
    let tol = 1e-3 * cloud.grid.unwrap().largest_chord(&cloud.points);
    let opts = SurfaceAdaptOptions {
        tol,
        ..SurfaceAdaptOptions::default()
    };
    let r = bezchain::adaptive::adapt_blade(&b, &loft, &opts, &|_| {}).unwrap();
    let s = &r.surface;
    eprintln!(
        "{path}: {} stored scalars ({}), {} sections, {} searches, {:.1} s",
        s.count.total,
        s.family,
        r.radii.len(),
        r.rounds,
        r.seconds
    );
    assert!(s.met, "{:?}", s.message);
    // Within the tolerance at the stations; sections joined between them within three.
    match &s.joined {
        Some(j) => {
            assert!(j.stations_max <= tol, "stations max {:e}", j.stations_max);
            assert!(j.max <= 3.0 * tol, "joined max {:e}", j.max);
        }
        None => assert!(s.offset.max <= tol, "max {:e}", s.offset.max),
    }
    assert!(
        s.count.total as f64 <= ratio * scipy as f64,
        "{} stored scalars",
        s.count.total
    );
    assert!(s.agreement <= 1.1, "checker/exact {}", s.agreement);
    assert!(s.fold.passes && s.fold.max_turn_deg <= 90.0, "{:?}", s.fold);
    let between = s.between.as_ref().expect("between-section check");
    assert!(between.max <= 3.0 * tol, "between max {:e}", between.max);
    let held = s.held_out.expect("held-out check");
    assert!(held.max <= 3.0 * tol, "held-out max {:e}", held.max);
    // How far a cut's end doubles back (a seam that overlaps itself), by the test's own walk
    // over 401 cuts: the library's report finds as much, less what the stations' own ends do.
    let per_section = cloud.grid.unwrap().per_section;
    let own = (0..cloud.points.len() / per_section)
        .flat_map(|k| {
            let sec = &cloud.points[k * per_section..(k + 1) * per_section];
            let back: Vec<DVec3> = sec.iter().rev().copied().collect();
            let half = per_section / 2;
            [walk_back(&sec[..=half], tol), walk_back(&back[..=half], tol)]
        })
        .fold(0.0_f64, f64::max);
    let worst = (0..=400)
        .flat_map(|i| [0, 1].map(|end| independent_end_backtrack(&s.grid, i as f64 / 400.0, end, tol)))
        .fold(0.0_f64, f64::max);
    let ends = s.ends.expect("the sections' ends are measured");
    eprintln!(
        "{path}: ends double back {:.2} tol (the test's walk {:.2}, the stations' {:.2})",
        ends.excess / tol,
        worst / tol,
        own / tol
    );
    assert!(
        ends.excess >= worst - own - 0.2 * worst - 0.05 * tol,
        "the report's {:e} misses the test's {worst:e}",
        ends.excess
    );
    assert!(
        ends.excess <= worst + 0.2 * worst + 0.05 * tol,
        "the report's {:e} beyond the test's {worst:e}",
        ends.excess
    );
    assert_eq!(ends.passes, ends.excess <= 0.5 * tol);
    r
}

/// How far the cut `S(·, v)` doubles back at end `end` (0 or 1): the cut sampled 10,000 times
/// over the half of u at that end, walked back from the end ([`walk_back`]).
fn independent_end_backtrack(grid: &PatchGrid<DVec3>, v: f64, end: usize, tol: f64) -> f64 {
    let from_end: Vec<DVec3> = (0..=10_000)
        .map(|k| {
            let t = 0.5 * k as f64 / 10_000.0;
            grid.eval(if end == 0 { t } else { 1.0 - t }, v)
        })
        .collect();
    walk_back(&from_end, tol)
}

/// The points `from_end` (half a section, from an end inwards) walked over 3, 10 and 30
/// tolerances of arc, each at most a quarter of the half's: along the direction from the
/// walk's start to the end point, the largest drop below the running maximum, the largest of
/// the three.
fn walk_back(from_end: &[DVec3], tol: f64) -> f64 {
    let half: f64 = from_end.windows(2).map(|w| (w[1] - w[0]).length()).sum();
    [3.0, 10.0, 30.0]
        .iter()
        .map(|w| {
            let w = (w * tol).min(0.25 * half) / tol;
            let mut arc = 0.0;
            let mut n = from_end.len();
            for k in 1..from_end.len() {
                arc += (from_end[k] - from_end[k - 1]).length();
                if arc >= w * tol {
                    n = k + 1;
                    break;
                }
            }
            let d = (from_end[0] - from_end[n - 1]).normalize_or_zero();
            let mut top = f64::NEG_INFINITY;
            from_end[..n].iter().rev().fold(0.0_f64, |back, p| {
                top = top.max(p.dot(d));
                back.max(top - p.dot(d))
            })
        })
        .fold(0.0, f64::max)
}

/// `adapt_blade`'s "met" seen where a user looks: sections lofted from the definition half-way
/// between its stations (none of them fitted) lie within 3 tolerances of the surface by the
/// tests' own closest-point search.
#[test]
fn a_met_blade_definition_is_within_three_tolerances_between_its_stations() {
    let b = paper_to_tip();
    let loft = LoftOptions {
        points_per_section: Some(24),
        ..LoftOptions::default()
    };
    let tol = 2e-3 * b.max_chord();
    let opts = SurfaceAdaptOptions {
        tol,
        degrees_u: [3, 4],
        degrees_v: [2, 2],
        ..SurfaceAdaptOptions::default()
    };
    let r = bezchain::adaptive::adapt_blade(&b, &loft, &opts, &|_| {}).unwrap();
    assert!(r.surface.met, "{:?}", r.surface.message);
    let mids: Vec<f64> = r.radii.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect();
    let between = b.loft_at(&mids, &loft).unwrap();
    let worst = independent_offsets(&r.surface.grid, &between.points)
        .into_iter()
        .fold(0.0_f64, f64::max);
    assert!(
        worst <= 3.0 * tol,
        "independent between-section max {worst:e} > 3 x {tol:e}"
    );
}
