//! `optimise` in the library and on the command line: a resumed run ends bit-identical to one
//! never interrupted (GA, CMA-ES, and across the GA → CMA-ES handover), a population full of
//! bad shapes runs to the end with its reasons counted and nothing NaN, a checkpoint of
//! another problem is refused, and the command's outputs read back (the report as a curve
//! report, the Selig file as an aerofoil).

mod common;

use bezchain::aero::{
    AeroBatch, AeroProblem, Constraints, ExtraConstraints, Method, Objective, Optimisation, OptimiseOptions,
};
use bezchain::eval::Backend;
use bezchain::optim::evo::Checkpoint;
use std::path::PathBuf;
use std::process::{Command, Output};

fn problem(alpha: f64, margin: f64) -> AeroProblem {
    let space = common::naca_design_space("0012", 121, 60, margin);
    let batch = AeroBatch::new(
        space.map().clone(),
        alpha,
        Objective::MaxCl,
        Constraints {
            min_thickness: Some(0.12),
            cm_min: Some(-0.2),
        },
    )
    .unwrap();
    AeroProblem {
        space,
        batch,
        extra: ExtraConstraints::default(),
        viscous: None,
    }
}

fn options(generations: usize) -> OptimiseOptions {
    OptimiseOptions {
        population: Some(16),
        generations: Some(generations),
        backend: Backend::Cpu,
        ..OptimiseOptions::default()
    }
}

#[test]
fn a_resumed_run_ends_where_an_uninterrupted_one_does() {
    let p = problem(4.0, 0.1);
    let dir = tempfile::tempdir().unwrap();
    for method in [Method::Ga, Method::Cmaes, Method::GaCmaes] {
        let whole = {
            let mut run = Optimisation::new(&p, method, &options(8)).unwrap();
            let stop = run.run(|_| Ok(())).unwrap();
            run.finish(stop).unwrap()
        };
        // Some generations, a checkpoint on disk, the rest: for ga+cmaes (handover after 4)
        // once in its GA stage and once in its CMA-ES stage.
        let stops: &[usize] = if method == Method::GaCmaes { &[3, 6] } else { &[3] };
        for &at in stops {
            let path = dir.path().join(format!("{method}-{at}.ckpt"));
            {
                let mut run = Optimisation::new(&p, method, &options(8)).unwrap();
                for _ in 0..at {
                    run.step().unwrap();
                }
                run.checkpoint().write(&path).unwrap();
            }
            let ckpt = Checkpoint::read(&path).unwrap();
            let mut run = Optimisation::resume(&p, method, &options(8), &ckpt).unwrap();
            let stop = run.run(|_| Ok(())).unwrap();
            let resumed = run.finish(stop).unwrap();
            assert_eq!(resumed.design, whole.design, "{method} at {at}");
            assert_eq!(
                resumed.eval.score.to_bits(),
                whole.eval.score.to_bits(),
                "{method} at {at}"
            );
            assert_eq!(resumed.kernel, whole.kernel, "{method} at {at}");
            assert_eq!(resumed.evaluations, whole.evaluations, "{method} at {at}");
            assert_eq!(resumed.reasons, whole.reasons, "{method} at {at}");
            let best =
                |h: &[bezchain::optim::evo::Progress]| h.iter().map(|p| p.best.to_bits()).collect::<Vec<_>>();
            assert_eq!(best(&resumed.history), best(&whole.history), "{method} at {at}");
        }
        // NACA 0012 at 4° has CL 0.48; every method finds more within 8 generations.
        assert!(whole.eval.cl > 0.55, "{method}: {:?}", whole.eval);
    }
}

#[test]
fn a_checkpoint_of_another_problem_is_refused() {
    let p = problem(4.0, 0.1);
    let mut run = Optimisation::new(&p, Method::Ga, &options(4)).unwrap();
    run.step().unwrap();
    let ckpt = run.checkpoint();
    let other = problem(5.0, 0.1);
    assert!(matches!(
        Optimisation::resume(&other, Method::Ga, &options(4), &ckpt),
        Err(bezchain::Error::Invalid(_))
    ));
    assert!(Optimisation::resume(&p, Method::Cmaes, &options(4), &ckpt).is_err());
    let mut seeded = options(4);
    seeded.seed = 2;
    assert!(Optimisation::resume(&p, Method::Ga, &seeded, &ckpt).is_err());
}

/// A box of ± half the chord and a wide first generation: most shapes cross or fold; the run
/// goes on, counts them, and reports finite numbers.
#[test]
fn a_population_of_bad_shapes_is_counted_and_never_nan() {
    let p = problem(4.0, 0.5);
    let opts = OptimiseOptions {
        spread: 0.3,
        ..options(5)
    };
    for method in [Method::Ga, Method::Cmaes] {
        let mut run = Optimisation::new(&p, method, &opts).unwrap();
        let stop = run.run(|r| {
            assert!(r.history().iter().all(|h| !h.best.is_nan() && !h.mean.is_nan()));
            Ok(())
        });
        let result = run.finish(stop.unwrap()).unwrap();
        let r = result.reasons;
        assert_eq!(r.evaluated, result.evaluations);
        assert!(r.crossing + r.fold + r.thin > 0, "{method}: {r:?}");
        assert!(result.eval.score.is_finite() && result.design.iter().all(|x| x.is_finite()));
    }
}

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bezchain(args: &[&str], dir: &std::path::Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_bezchain"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run bezchain")
}

#[test]
fn the_command_writes_a_curve_report_a_selig_file_and_a_picture() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = bezchain(&["naca", "0012", "--points", "121", "-o", "n0012.dat"], d);
    assert!(o.status.success());
    let o = bezchain(&["naca", "4412", "--points", "121", "-o", "n4412.dat"], d);
    assert!(o.status.success());
    let o = bezchain(
        &[
            "optimise",
            "n0012.dat",
            "--objective",
            "inverse:n4412.dat",
            "--tol",
            "1e-3",
            "--panels",
            "60",
            "--generations",
            "30",
            "--backend",
            "cpu",
            "--json",
            "o.json",
            "--dat",
            "o.dat",
            "--svg",
            "o.svg",
            "--checkpoint",
            "o.ckpt",
        ],
        d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("closest-point offsets of the target"), "{text}");
    match bezchain::export::Report::read(&d.join("o.json")).unwrap() {
        bezchain::export::Report::Curve(rep) => {
            rep.chain().unwrap();
        }
        bezchain::export::Report::Surface(_) => panic!("a surface report"),
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("o.json")).unwrap()).unwrap();
    for key in [
        "objective",
        "alpha",
        "reasons",
        "result",
        "start",
        "encoding",
        "variables",
        "constraint_handling",
    ] {
        assert!(v["optimise"].get(key).is_some(), "optimise.{key}");
    }
    let dat = bezchain::geometry::read_curve(&d.join("o.dat")).unwrap();
    assert_eq!(dat.points.len(), 241);
    assert!(std::fs::read_to_string(d.join("o.svg"))
        .unwrap()
        .contains("target"));
    // The same run resumed from its final checkpoint with more generations.
    let o = bezchain(
        &[
            "optimise",
            "n0012.dat",
            "--objective",
            "inverse:n4412.dat",
            "--tol",
            "1e-3",
            "--panels",
            "60",
            "--generations",
            "35",
            "--backend",
            "cpu",
            "--resume",
            "o.ckpt",
            "--checkpoint",
            "o2.ckpt",
        ],
        d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("35 generations"));
    // Resumed from a checkpoint whose generations are spent: the outputs come from it.
    let o = bezchain(
        &[
            "optimise",
            "n0012.dat",
            "--objective",
            "inverse:n4412.dat",
            "--tol",
            "1e-3",
            "--panels",
            "60",
            "--generations",
            "35",
            "--backend",
            "cpu",
            "--resume",
            "o2.ckpt",
            "--json",
            "o3.json",
            "--checkpoint",
            "o3.ckpt",
        ],
        d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("o3.json").exists() && d.join("o3.ckpt").exists());
}

/// An aerofoil whose adapted chain ends its two surfaces crossed at the closed trailing edge
/// (NACA 63-209 at 1e-4) starts an optimisation as `aero` analyses it: closed where the ends
/// cross, the same start CL.
#[test]
fn a_start_whose_trailing_edge_ends_cross_is_closed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let file = root().join("data/airfoils/regressions/naca63209.dat");
    let file = file.to_str().unwrap();
    let o = bezchain(
        &[
            "optimise",
            file,
            "--objective",
            "max-cl",
            "--alpha",
            "4",
            "--min-thickness",
            "0.08",
            "--population",
            "8",
            "--generations",
            "2",
            "--backend",
            "cpu",
            "--json",
            "o.json",
        ],
        d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("o.json")).unwrap()).unwrap();
    let o = bezchain(
        &["adapt", file, "--tol", "1e-4", "--relative", "--json", "a.json"],
        d,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = bezchain(&["aero", "a.json", "--alpha", "4", "--json", "p.json"], d);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let p: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("p.json")).unwrap()).unwrap();
    let (start, analysed) = (
        v["optimise"]["start"]["cl"].as_f64(),
        p["polar"][0]["cl"].as_f64(),
    );
    assert!(start.is_some() && analysed.is_some(), "{v}");
    assert!(
        (start.unwrap() - analysed.unwrap()).abs() <= 1e-3 * analysed.unwrap().abs(),
        "{start:?} {analysed:?}"
    );
}

#[test]
fn bad_arguments_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let start = root().join("data/naca4413.dat");
    let s = start.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["optimise", s, "--objective", "min-drag", "--json", "o.json"],
            "--objective",
        ),
        (
            vec!["optimise", s, "--objective", "inverse:", "--json", "o.json"],
            "--objective",
        ),
        (
            vec![
                "optimise",
                s,
                "--objective",
                "inverse:nope.dat",
                "--json",
                "o.json",
            ],
            "nope.dat",
        ),
        (
            vec![
                "optimise",
                s,
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
                "--alpha",
                "45",
                "--json",
                "o.json",
            ],
            "--alpha",
        ),
        (
            vec![
                "optimise",
                s,
                "--objective",
                "max-cl",
                "--min-thickness",
                "2",
                "--json",
                "o.json",
            ],
            "--min-thickness",
        ),
        (
            vec![
                "optimise",
                s,
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
                "--dat",
                "no/such/o.dat",
                "--json",
                "o.json",
            ],
            "--dat",
        ),
        (
            vec![
                "optimise",
                "nothing.dat",
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
                "--json",
                "o.json",
            ],
            "nothing.dat",
        ),
    ] {
        let o = bezchain(&args, d);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.lines().any(|l| l.starts_with("error:") && l.contains(needle)),
            "{needle}: {err}"
        );
        assert!(!d.join("o.json").exists());
    }
}
