//! The bars on the real aerofoil files: at 1e-3 and 1e-4 of the chord, no more
//! stored scalars than scipy's `splprep` needs (its free knots not even counted), with the
//! tolerance holding at every file point by an independent closest-point measure.

mod common;

use bezchain::adaptive::{adapt_curve, AdaptOptions};
use bezchain::geometry::read_curve;
use common::check::independent_offsets;
use common::{airfoils_dir, read_airfoil};

/// `(file, tolerance, splprep's coefficients, CST's coefficients)` from the peer table in
/// `data/airfoils/README.md`.
/// `clarky_lednicer` holds the same points as `clarky` in Lednicer's layout: same bars.
const PEERS: [(&str, f64, usize, usize); 12] = [
    ("e387", 1e-3, 28, 27),
    ("s1223", 1e-3, 38, 31),
    ("naca4412", 1e-3, 28, 9),
    ("naca4415", 1e-3, 26, 9),
    ("clarky", 1e-3, 26, 19),
    ("clarky_lednicer", 1e-3, 26, 19),
    ("e387", 1e-4, 44, 57),
    ("s1223", 1e-4, 70, 69),
    ("naca4412", 1e-4, 46, 23),
    ("naca4415", 1e-4, 50, 41),
    ("clarky", 1e-4, 46, 67),
    ("clarky_lednicer", 1e-4, 46, 67),
];

#[test]
fn fewer_stored_scalars_than_splprep_on_every_file_at_both_tolerances() {
    let mut table = String::from("file tol scalars splprep CST ratio max\n");
    for (name, tol, splprep, cst) in PEERS {
        let path = airfoils_dir().join(format!("{name}.dat"));
        let loaded = read_curve(&path).unwrap();
        let r = adapt_curve(
            &loaded.points,
            &AdaptOptions {
                tol,
                ..AdaptOptions::default()
            },
        )
        .unwrap();
        assert!(r.met, "{name} at {tol:e}: {:?}", r.message);
        // Every point of the file, measured independently of the library's foot-point code.
        let file_points = read_airfoil(&format!("{name}.dat"));
        let (_, max) = independent_offsets(r.chain.ctrl(), r.encoding.degree, &file_points);
        assert!(max <= tol, "{name} at {tol:e}: independent max {max:e}");
        assert!(
            r.count.total <= splprep,
            "{name} at {tol:e}: {} stored scalars, splprep {splprep} ({})",
            r.count.total,
            r.family
        );
        table += &format!(
            "{name} {tol:e} {} {splprep} {cst} {:.2} {max:.3e}\n",
            r.count.total,
            r.count.total as f64 / cst as f64
        );
    }
    eprintln!("{table}");
}

#[test]
fn both_layouts_of_clark_y_need_the_same_scalars() {
    // The same points in Selig and in Lednicer order (the Lednicer file lists the leading
    // edge twice; the reader keeps it once).
    let opts = AdaptOptions {
        tol: 1e-3,
        ..AdaptOptions::default()
    };
    let a = adapt_curve(
        &read_curve(&airfoils_dir().join("clarky.dat")).unwrap().points,
        &opts,
    )
    .unwrap();
    let b = adapt_curve(
        &read_curve(&airfoils_dir().join("clarky_lednicer.dat"))
            .unwrap()
            .points,
        &opts,
    )
    .unwrap();
    assert!(a.met && b.met);
    assert_eq!(a.count.total, b.count.total);
}

/// "Met" includes the held-out check (refitted on every other point, the
/// others within 3 tolerances) and no more curvature sign changes than a spline through the
/// source points; at 1e-4 every shipped file either meets all three, or says which fails.
#[test]
fn met_includes_the_held_out_check_and_no_extra_waves_at_1e_4() {
    use bezchain::adaptive::HELD_OUT_FACTOR;
    let mut table = String::from("file met scalars held-out/tol waves(chain/source)\n");
    for name in [
        "e387",
        "s1223",
        "naca4412",
        "naca4415",
        "clarky",
        "clarky_lednicer",
    ] {
        let tol = 1e-4;
        let loaded = read_curve(&airfoils_dir().join(format!("{name}.dat"))).unwrap();
        let r = adapt_curve(
            &loaded.points,
            &AdaptOptions {
                tol,
                ..AdaptOptions::default()
            },
        )
        .unwrap();
        let waves = r.sign_changes.expect("a spline goes through every shipped file");
        let ratio = r.held_out.map(|h| h.max / tol);
        table += &format!(
            "{name} {} {} {ratio:?} {}/{}\n",
            r.met, r.count.total, waves.chain, waves.source
        );
        if r.met {
            assert!(r.offset.max <= tol, "{name}: {:e}", r.offset.max);
            let ratio = ratio.unwrap_or_else(|| panic!("{name}: met without a held-out check"));
            assert!(ratio <= HELD_OUT_FACTOR, "{name}: held-out {ratio} tolerances");
            assert!(waves.chain <= waves.source, "{name}: {waves:?}");
        } else {
            let m = r.message.as_deref().unwrap_or_default();
            let reason = (r.offset.max > tol && m.contains("not met"))
                || (ratio.is_none_or(|x| x > HELD_OUT_FACTOR) && m.contains("held-out"))
                || (waves.chain > waves.source && m.contains("waves"));
            assert!(reason, "{name}: not met without its reason: {m}");
        }
    }
    eprintln!("{table}");
}

/// Between the data points, where their offsets cannot see: at 1e-4 a met chain stays within
/// `AWAY_FACTOR` tolerances of the cubic spline through the points and neither loops nor folds
/// (turns at most `EXTRA_TURN_DEG` more than that spline), measured here on its own: the chain
/// at 400 points a segment, the spline at 100 an interval, every distance by brute force, the
/// turning from the chords of those samples. The files include two on which an earlier build
/// reported met chains that flew metres off (as6097) or looped at the trailing edge (s1221);
/// a file that is not met must say why.
#[test]
fn met_chains_stay_with_their_points_between_them() {
    use bezchain::adaptive::fairness::{turning_deg, AWAY_FACTOR, EXTRA_TURN_DEG};
    use bezchain::geometry::SplineContour;
    use glam::DVec2;
    let regressions = airfoils_dir().join("regressions");
    let files = ["e387", "s1223", "naca4415", "clarky"]
        .iter()
        .map(|n| airfoils_dir().join(format!("{n}.dat")))
        .chain(
            ["as6097", "s1221"]
                .iter()
                .map(|n| regressions.join(format!("{n}.dat"))),
        );
    let mut table = String::new();
    for path in files {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let tol = 1e-4;
        let points = read_curve(&path).unwrap().points;
        let r = adapt_curve(
            &points,
            &AdaptOptions {
                tol,
                ..AdaptOptions::default()
            },
        )
        .unwrap();
        let layout = r.chain.layout();
        let chain: Vec<DVec2> = bezchain::chain::samples(layout.breaks(), 400)
            .into_iter()
            .map(|t| r.chain.eval(t))
            .collect();
        let spline: Vec<DVec2> = SplineContour::new(&points)
            .unwrap()
            .curvature_samples(100)
            .into_iter()
            .map(|s| s.0)
            .collect();
        let away = chain
            .iter()
            .map(|p| {
                spline
                    .windows(2)
                    .map(|w| {
                        let ab = w[1] - w[0];
                        let t = ((*p - w[0]).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                        p.distance(w[0] + t * ab)
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max);
        let extra = turning_deg(chain.iter().copied()) - turning_deg(spline.iter().copied());
        table += &format!(
            "{name}: met {} away {:.2} tol, extra turning {extra:.1}°\n",
            r.met,
            away / tol
        );
        if r.met {
            assert!(
                away <= AWAY_FACTOR * tol,
                "{name}: {:.2} tolerances off",
                away / tol
            );
            assert!(extra <= EXTRA_TURN_DEG, "{name}: turns {extra:.0}° more");
            let f = r.follows.expect("a spline goes through every file");
            assert!(
                (f.away - away).abs() <= 0.05 * away + 1e-3 * tol,
                "{name}: {f:?} against {away:e}"
            );
        } else {
            let m = r.message.as_deref().unwrap_or_default();
            assert!(!m.is_empty(), "{name}: not met without a reason");
        }
    }
    eprintln!("{table}");
}
