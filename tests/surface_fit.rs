//! Surface fitting against analytic truth (a cloud sampled from a known patch grid), the
//! paper's blade (82 x 12 points, 4 x 2 bicubic patches) and a noisy unordered blade cloud.

mod common;

use bezchain::chain::{ChainLayout, Continuity, GridLayout, PatchGrid};
use bezchain::export::{FitInfo, InputInfo, OffsetReport, SurfaceReport};
use bezchain::fit::{fit_surface, Breaks, ParamSource, SurfaceLayout, SurfaceOptions, SurfaceProgress};
use bezchain::geometry::{Blade, Grid, LoftOptions};
use common::check::IndependentGrid;
use glam::DVec3;

fn paper_blade() -> Blade {
    Blade::from_file(&common::crate_root().join("data/blade_paper.json")).expect("data/blade_paper.json")
}

/// A smooth, doubly curved sheet as a bicubic 3 x 2 grid with non-uniform breaks.
fn known_grid() -> PatchGrid<DVec3> {
    let layout = GridLayout::new(
        ChainLayout::with_breaks(3, vec![0.0, 0.3, 0.7, 1.0], Continuity::C1).unwrap(),
        ChainLayout::with_breaks(3, vec![0.0, 0.45, 1.0], Continuity::C1).unwrap(),
    );
    let (nu, nv) = layout.design_shape();
    let design = (0..nu * nv)
        .map(|i| {
            let (a, b) = (
                (i / nv) as f64 / (nu - 1) as f64,
                (i % nv) as f64 / (nv - 1) as f64,
            );
            let ang = 2.2 * a;
            DVec3::new(
                0.6 * ang.cos(),
                0.4 * ang.sin() + 0.05 * b,
                1.5 * b + 0.1 * (3.0 * a).sin(),
            )
        })
        .collect();
    PatchGrid::new(layout, design).unwrap()
}

#[test]
fn a_cloud_sampled_from_a_known_grid_is_recovered() {
    let truth = known_grid();
    // 40 sections (iso-v curves) of 60 points each, unevenly spaced in u, so the sections'
    // chord-length parameters are off and the fit must move them.
    let (m, n) = (40, 60);
    let mut points = Vec::with_capacity(m * n);
    for k in 0..m {
        let v = k as f64 / (m - 1) as f64;
        for i in 0..n {
            let u = (i as f64 / (n - 1) as f64).powf(1.3);
            points.push(truth.eval(u, v));
        }
    }
    let grid = Grid {
        sections: m,
        per_section: n,
    };
    let layout = SurfaceLayout::from(truth.layout());
    let opts = SurfaceOptions {
        lsq: bezchain::optim::LsqOptions {
            ftol: 1e-12,
            window: 10,
            max_iterations: 3000,
            ..SurfaceOptions::default().lsq
        },
        // The sheet runs along its own v; blade-aware axes do not apply.
        blade: bezchain::problem::BladeParamOptions {
            span: None,
            ..Default::default()
        },
        ..SurfaceOptions::default()
    };
    let mut stages = Vec::new();
    let fit = fit_surface(&points, Some(grid), &layout, &opts, &mut |p| {
        if let SurfaceProgress::Stage { name, .. } = p {
            stages.push(name);
        }
    })
    .unwrap();
    assert_eq!(stages, vec!["lsq"], "a small cloud is fitted in one stage");
    assert_eq!(fit.param_source, "sections");
    assert!(
        fit.stats.max < 1e-8,
        "max offset {} {:?}",
        fit.stats.max,
        fit.report
    );
    assert!(fit.report.converged(), "{:?}", fit.report);
    assert!(fit.grid.continuity_error() < 1e-9);
    // The known surface lies on the fitted one. (Not the converse: the closest-point objective
    // does not see how far the fitted edges reach past the data, and they may overhang it.)
    let fitted = IndependentGrid::new(&nest(&fit.grid), 3, 3);
    for k in 0..=10 {
        for j in 0..=10 {
            let q = truth.eval(k as f64 / 10.0, j as f64 / 10.0);
            assert!(
                fitted.distance(q) < 1e-7,
                "true point {q} is {} off the fit",
                fitted.distance(q)
            );
        }
    }
}

/// The control net as rows of points.
fn nest(grid: &PatchGrid<DVec3>) -> Vec<Vec<DVec3>> {
    let mv = grid.layout().net_shape().1;
    grid.net().chunks(mv).map(|r| r.to_vec()).collect()
}

#[test]
fn the_papers_blade_with_four_by_two_bicubic_patches() {
    let cloud = paper_blade().loft(&LoftOptions::default()).unwrap();
    assert_eq!(cloud.points.len(), 82 * 12);
    let layout = SurfaceLayout::uniform([3, 3], [4, 2], [Continuity::C1, Continuity::C1]);
    let fit = fit_surface(
        &cloud.points,
        cloud.grid,
        &layout,
        &SurfaceOptions::default(),
        &mut |_| {},
    )
    .unwrap();
    let l = fit.grid.layout();
    assert_eq!(l.design_shape(), (10, 6));
    assert_eq!(l.net_shape(), (13, 7));
    assert_eq!(l.patches(), (4, 2));
    assert!(fit.grid.continuity_error() < 1e-9);
    // The paper's layout is coarse for this blade (a tip that closes over the last 1% of the
    // span): measured rms 1.07e-4, max 8.7e-4 (chord 0.177 at the root).
    assert!(fit.stats.rms < 2e-4 && fit.stats.max < 2e-3, "{:?}", fit.stats);
    // The report carries the net; the offsets recomputed from it alone agree.
    let rep = SurfaceReport::new(
        &fit.grid,
        OffsetReport {
            metric: "closest".into(),
            sum_sq: fit.stats.sum_sq,
            sum: fit.stats.sum,
            rms: fit.stats.rms,
            max: fit.stats.max,
            max_at: fit.stats.max_at.to_array().to_vec(),
        },
        FitInfo {
            method: "lsq".into(),
            iterations: fit.report.iterations as u64,
            evaluations: fit.report.evaluations as u64,
            seconds: fit.report.seconds,
            backend: "cpu".into(),
            stages: Vec::new(),
            evals_per_second: None,
            stopped: None,
        },
        InputInfo {
            path: "paper".into(),
            points: cloud.points.len(),
        },
    );
    let text = serde_json::to_string(&rep).unwrap();
    let back: SurfaceReport = serde_json::from_str(&text).unwrap();
    let net: Vec<Vec<DVec3>> = back
        .control_net
        .iter()
        .map(|r| r.iter().map(|&p| DVec3::from_array(p)).collect())
        .collect();
    let check = IndependentGrid::new(&net, 3, 3);
    let d: Vec<f64> = cloud.points.iter().map(|&q| check.distance(q)).collect();
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    let max = d.iter().fold(0.0_f64, |m, &x| m.max(x));
    assert!(
        (rms - back.offset.rms).abs() < 1e-9 * rms,
        "rms {rms} vs {}",
        back.offset.rms
    );
    assert!(
        (max - back.offset.max).abs() < 1e-9 * max,
        "max {max} vs {}",
        back.offset.max
    );
}

#[test]
fn a_noisy_unordered_blade_cloud_is_fitted_to_the_noise() {
    // 150 points x 80 sections, shuffled, noise 1e-4 of the largest chord; bicubic 8 x 11 with
    // the patches ending at the stations (where the loft is only C1).
    let blade = paper_blade();
    let noise = 1e-4;
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(150),
            sections: Some(80),
            noise,
            shuffle: true,
            seed: 11,
        })
        .unwrap();
    assert!(cloud.grid.is_none());
    let stations: Vec<f64> = blade.stations.iter().map(|s| s.radius).collect();
    let opts = SurfaceOptions {
        params: ParamSource::Blade,
        subsample: 6000,
        ..SurfaceOptions::default()
    };
    // Breaks at every station make a patch 9 mm wide at the tip (stations 1.496 and 1.505),
    // which the 80 sections, 15 mm apart, barely reach: the fit puts a control point 5 km
    // off this 1.2 m blade, and is refused with advice.
    let every = SurfaceLayout {
        breaks_v: Breaks::Span(stations.clone()),
        ..SurfaceLayout::uniform([3, 3], [8, 11], [Continuity::C1, Continuity::C1])
    };
    let Err(e) = fit_surface(&cloud.points, None, &every, &opts, &mut |_| {}) else {
        panic!("a net far off the cloud was accepted")
    };
    assert!(
        e.is_user_error() && e.to_string().contains("fewer patches"),
        "{e}"
    );
    // With sections 3 mm apart every patch holds several: the fit stays near the blade and
    // reaches the noise.
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(60),
            sections: Some(400),
            noise,
            shuffle: true,
            seed: 11,
        })
        .unwrap();
    let layout = every;
    let fit = fit_surface(&cloud.points, None, &layout, &opts, &mut |_| {}).unwrap();
    assert_eq!(fit.param_source, "blade");
    assert_eq!(
        fit.stages.iter().map(|s| s.name).collect::<Vec<_>>(),
        vec!["subsample", "full"]
    );
    // The whole-cloud stage runs its fixed iterations by design and always ends at its cap:
    // only the subsample stage's cap would cut the fit short.
    assert_eq!(fit.stages[1].report.cap(), Some("iteration cap"));
    assert_eq!(fit.stopped(), fit.stages[0].report.cap());
    let sigma = noise * blade.max_chord();
    // Closest-point offsets of points with Gaussian noise of sigma per coordinate have an rms
    // of about sigma (the normal component); the model error must add little.
    assert!(
        fit.stats.rms < 1.5 * sigma,
        "rms {} for sigma {sigma}",
        fit.stats.rms
    );
    assert!(
        fit.stats.rms > 0.8 * sigma,
        "rms {} below the noise {sigma}: overfitting?",
        fit.stats.rms
    );
    assert!(fit.grid.continuity_error() < 1e-9);
    // v breaks at the stations, mapped along the span.
    let bv = fit.grid.layout().v.breaks().to_vec();
    let r = |v: f64| fit.axis.lo + v * (fit.axis.hi - fit.axis.lo);
    assert!(
        (r(bv[9]) - 1.496).abs() < 1e-9 && (r(bv[10]) - 1.505).abs() < 1e-9,
        "{bv:?}"
    );
}

#[test]
fn bad_layouts_and_clouds_are_refused() {
    let cloud = paper_blade().loft(&LoftOptions::default()).unwrap();
    let opts = SurfaceOptions::default();
    let fit = |layout: SurfaceLayout, pts: &[DVec3]| fit_surface(pts, None, &layout, &opts, &mut |_| {});
    let c1 = [Continuity::C1, Continuity::C1];
    let e = fit(SurfaceLayout::uniform([3, 3], [40, 30], c1), &cloud.points).unwrap_err();
    assert!(e.is_user_error() && e.to_string().contains("at least"), "{e}");
    let e = fit(
        SurfaceLayout {
            breaks_u: Breaks::Params(vec![0.5, 0.2, 0.7]),
            ..SurfaceLayout::uniform([3, 3], [4, 2], c1)
        },
        &cloud.points,
    )
    .unwrap_err();
    assert!(e.to_string().contains("breaks along u"), "{e}");
    let e = fit(
        SurfaceLayout {
            breaks_u: Breaks::Span(vec![0.5, 0.7, 0.9]),
            ..SurfaceLayout::uniform([3, 3], [4, 2], c1)
        },
        &cloud.points,
    )
    .unwrap_err();
    assert!(e.to_string().contains("breaks along u"), "{e}");
    let e = fit(
        SurfaceLayout::uniform([2, 3], [4, 2], [Continuity::C2, Continuity::C1]),
        &cloud.points,
    )
    .unwrap_err();
    assert!(e.to_string().contains("along u"), "{e}");
    let flat = vec![DVec3::new(0.1, 0.2, 0.3); 500];
    assert!(fit(SurfaceLayout::uniform([3, 3], [2, 2], c1), &flat)
        .unwrap_err()
        .is_user_error());
    let mut nan = cloud.points.clone();
    nan[7].y = f64::NAN;
    assert!(fit(SurfaceLayout::uniform([3, 3], [2, 2], c1), &nan).is_err());
    let sections = SurfaceOptions {
        params: ParamSource::Sections,
        ..SurfaceOptions::default()
    };
    let e = fit_surface(
        &cloud.points,
        None,
        &SurfaceLayout::uniform([3, 3], [4, 2], c1),
        &sections,
        &mut |_| {},
    )
    .unwrap_err();
    assert!(e.to_string().contains("section,index"), "{e}");
}

/// The paper's blade lofted to `per_section x sections` points with noise of `1e-4` of the
/// largest chord, shuffled, and fitted as an unordered cloud by bicubic 8 x 11 patches ending
/// at the stations, the first stage on a subsample of about `subsample` points. Returns the
/// fit's rms over the noise's sigma and the fit's seconds.
fn noisy_unordered_fit(per_section: usize, sections: usize, subsample: usize) -> (f64, f64) {
    let blade = paper_blade();
    let noise = 1e-4;
    let cloud = blade
        .loft(&LoftOptions {
            points_per_section: Some(per_section),
            sections: Some(sections),
            noise,
            shuffle: true,
            seed: 5,
        })
        .unwrap();
    assert_eq!(cloud.points.len(), per_section * sections);
    assert!(cloud.grid.is_none());
    let layout = SurfaceLayout {
        breaks_v: Breaks::Span(blade.stations.iter().map(|s| s.radius).collect()),
        ..SurfaceLayout::uniform([3, 3], [8, 11], [Continuity::C1, Continuity::C1])
    };
    let t = std::time::Instant::now();
    let opts = SurfaceOptions {
        subsample,
        ..SurfaceOptions::default()
    };
    let fit = fit_surface(&cloud.points, None, &layout, &opts, &mut |_| {}).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    assert_eq!(
        fit.stages.iter().map(|s| s.name).collect::<Vec<_>>(),
        vec!["subsample", "full"]
    );
    // The whole-cloud stage runs its fixed iterations by design and always ends at its cap:
    // only the subsample stage's cap would cut the fit short.
    assert_eq!(fit.stages[1].report.cap(), Some("iteration cap"));
    assert_eq!(fit.stopped(), fit.stages[0].report.cap());
    assert_eq!(fit.stats.points, cloud.points.len());
    assert!(fit.grid.continuity_error() < 1e-9);
    let sigma = noise * blade.max_chord();
    println!(
        "{} points: rms {:.4e} = {:.3} sigma, max {:.3e}, fit {seconds:.2} s ({:?})",
        cloud.points.len(),
        fit.stats.rms,
        fit.stats.rms / sigma,
        fit.stats.max,
        fit.stages
            .iter()
            .map(|s| (s.name, s.points, s.report.iterations, s.report.seconds))
            .collect::<Vec<_>>()
    );
    (fit.stats.rms / sigma, seconds)
}

#[test]
fn a_noisy_unordered_100k_cloud_is_fitted_to_the_noise() {
    // A smaller first stage than the default keeps this quick in debug builds.
    let (ratio, _) = noisy_unordered_fit(250, 400, 5000);
    assert!(ratio < 1.5 && ratio > 0.8, "rms = {ratio} sigma");
}

/// The scale check (run in release): `cargo test --release --test surface_fit --
/// --ignored --nocapture`. One million noisy, shuffled points in at most 20 s.
#[test]
#[ignore = "timing; run in release with --ignored"]
fn a_noisy_unordered_million_point_cloud_in_twenty_seconds() {
    let (ratio, seconds) = noisy_unordered_fit(1000, 1000, SurfaceOptions::default().subsample);
    assert!(ratio < 1.5 && ratio > 0.8, "rms = {ratio} sigma");
    if !cfg!(debug_assertions) {
        assert!(seconds <= 20.0, "fit took {seconds:.1} s");
    }
}
