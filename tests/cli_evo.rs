//! `bezchain fit --method ga|cmaes|ga+lsq|cmaes+lsq` and `bezchain compare` end to end: the report
//! (its offsets re-measured by the tests' own closest-point search), the history file, checkpoints
//! that resume bit-identically and survive a killed run, and every bad setting answered with exit
//! status 2.

mod common;

use common::cli::{assert_user_error, assert_user_error_naming, json, run, stderr};

use bezchain::optim::evo::Checkpoint;
use common::check::check_curve_report;
use common::{bin, crate_root, naca4413, scratch};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// `fit` on case 1 with the given method and extra arguments.
fn fit(method: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--method",
        method,
        "--backend",
        "cpu",
    ];
    args.extend_from_slice(extra);
    run(&args)
}

#[test]
fn ga_reports_history_and_checkpoints_and_resumes_bit_identically() {
    let dir = scratch("cli-evo-ga");
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let common = ["--population", "64", "--seed", "3"];
    let (report, history, ck) = (p("ga.json"), p("ga.csv"), p("ga.ckpt"));
    let mut args = common.to_vec();
    args.extend_from_slice(&["--generations", "12", "--json", &report, "--history", &history]);
    args.extend_from_slice(&["--checkpoint", &ck, "--checkpoint-every", "5"]);
    let out = fit("ga", &args);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("point evaluations/s"), "{summary}");
    let rep = json(Path::new(&report));
    assert_eq!(rep["fit"]["method"], "ga");
    assert_eq!(rep["fit"]["iterations"], 12);
    assert_eq!(rep["fit"]["evaluations"], 64 * 13);
    assert_eq!(rep["fit"]["backend"], "cpu");
    assert!(rep["fit"]["evals_per_second"].as_f64().unwrap() > 0.0);
    // The report's offsets agree with the tests' own measure of every data point.
    check_curve_report(&rep, &naca4413(), 1e-6);
    // One history line per generation, the best never worse.
    let text = std::fs::read_to_string(&history).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "generation,best,mean,evaluations,seconds");
    assert_eq!(lines.len(), 14);
    let best: Vec<f64> = lines[1..]
        .iter()
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert!(best.windows(2).all(|w| w[1] <= w[0]), "{best:?}");
    assert_eq!(Checkpoint::read(Path::new(&ck)).unwrap().generation, 12);
    // Interrupted after generation 6 (the run's last checkpoint), resumed to 12: the same
    // design as the uninterrupted run, and the same history.
    let (part, part_ck, rest, rest_h) = (p("part.json"), p("part.ckpt"), p("rest.json"), p("rest.csv"));
    let mut a = common.to_vec();
    a.extend_from_slice(&["--generations", "6", "--json", &part, "--checkpoint", &part_ck]);
    assert!(fit("ga", &a).status.success());
    let mut b = common.to_vec();
    b.extend_from_slice(&[
        "--generations",
        "12",
        "--resume",
        &part_ck,
        "--json",
        &rest,
        "--history",
        &rest_h,
    ]);
    let out = fit("ga", &b);
    assert!(out.status.success(), "{}", stderr(&out));
    let (full, resumed) = (rep, json(Path::new(&rest)));
    assert_eq!(full["design_points"], resumed["design_points"]);
    assert_eq!(full["offset"], resumed["offset"]);
    assert_eq!(resumed["fit"]["evaluations"], 64 * 13);
    let cols = |t: &str| {
        t.lines()
            .map(|l| l.split(',').take(4).collect::<Vec<_>>().join(","))
            .collect::<Vec<_>>()
    };
    assert_eq!(cols(&text), cols(&std::fs::read_to_string(&rest_h).unwrap()));
    // Resumed from the finished run's checkpoint: nothing is left to do, and every output is
    // written from the checkpoint (exit 0), not refused.
    let (done, done_ck, done_h) = (p("done.json"), p("done.ckpt"), p("done.csv"));
    let mut c = common.to_vec();
    c.extend_from_slice(&["--generations", "12", "--resume", &ck, "--json", &done]);
    c.extend_from_slice(&["--checkpoint", &done_ck, "--history", &done_h]);
    let out = fit("ga", &c);
    assert!(out.status.success(), "{}", stderr(&out));
    let again = json(Path::new(&done));
    assert_eq!(again["design_points"], full["design_points"]);
    assert_eq!(again["fit"]["iterations"], 12);
    assert_eq!(Checkpoint::read(Path::new(&done_ck)).unwrap().generation, 12);
    assert_eq!(cols(&text), cols(&std::fs::read_to_string(&done_h).unwrap()));
}

#[test]
fn hybrids_report_both_stages_and_end_at_a_least_squares_optimum() {
    let dir = scratch("cli-evo-hybrid");
    let bfgs = dir.join("bfgs.json");
    let out = run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--method",
        "bfgs",
        "--json",
        bfgs.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let b = json(&bfgs)["offset"]["sum_sq"].as_f64().unwrap();
    let lsq = dir.join("lsq.json");
    let out = run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--json",
        lsq.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let l = json(&lsq)["offset"]["sum_sq"].as_f64().unwrap();
    for (method, population, generations) in [("cmaes+lsq", "64", "60"), ("ga+lsq", "256", "30")] {
        let report = dir.join(format!("{method}.json"));
        let out = fit(
            method,
            &[
                "--population",
                population,
                "--generations",
                generations,
                "--json",
                report.to_str().unwrap(),
            ],
        );
        assert!(out.status.success(), "{}", stderr(&out));
        let rep = json(&report);
        assert_eq!(rep["fit"]["method"], method);
        let stages = rep["fit"]["stages"].as_array().unwrap();
        assert_eq!(stages.len(), 2);
        assert_eq!(stages[0]["method"], &method[..method.len() - 4]);
        assert_eq!(stages[0]["iterations"], generations.parse::<u64>().unwrap());
        assert!(stages[0]["evals_per_second"].as_f64().unwrap() > 0.0);
        assert_eq!(stages[1]["method"], "lsq");
        assert!(stages[1]["iterations"].as_u64().unwrap() > 0);
        // The polish also tries lsq's own starts, so it ends at the lsq optimum (within 1 %),
        // below the minimum that BFGS reaches from the paper's start.
        let h = rep["offset"]["sum_sq"].as_f64().unwrap();
        assert!((h - l).abs() <= 0.01 * l, "{method} {h:e} vs lsq {l:e}");
        assert!(h <= b, "{method} {h:e} vs bfgs {b:e}");
    }
}

/// A CMA-ES checkpoint whose step size has underflowed to a denormal has converged: resumed
/// with generations left, the run takes no step and writes every output from the checkpoint
/// (exit 0).
#[test]
fn a_cmaes_run_whose_step_underflowed_resumes_to_its_outputs() {
    let dir = scratch("cli-evo-denormal");
    let p = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let out = fit("cmaes", &["--generations", "3", "--checkpoint", &p("a.ckpt")]);
    assert!(out.status.success(), "{}", stderr(&out));
    let mut c = Checkpoint::read(&dir.join("a.ckpt")).unwrap();
    c.cmaes.as_mut().unwrap().sigma = 5e-324;
    std::fs::write(dir.join("tiny.ckpt"), c.to_bytes()).unwrap();
    let out = fit(
        "cmaes",
        &[
            "--generations",
            "10",
            "--resume",
            &p("tiny.ckpt"),
            "--checkpoint",
            &p("b.ckpt"),
            "--json",
            &p("b.json"),
            "--history",
            &p("b.csv"),
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(json(&dir.join("b.json"))["fit"]["iterations"], 3);
    let back = Checkpoint::read(&dir.join("b.ckpt")).unwrap();
    assert_eq!(back.generation, 3);
    assert_eq!(back.cmaes.unwrap().sigma, 5e-324);
    let history = std::fs::read_to_string(dir.join("b.csv")).unwrap();
    assert_eq!(history.lines().count(), 5, "{history}");
}

#[test]
fn bad_settings_exit_2_with_a_clear_message() {
    let dir = scratch("cli-evo-bad");
    assert_user_error(
        &fit("ga", &["--population", "3"]),
        "--population must be at least 4",
    );
    assert_user_error(
        &fit("cmaes", &["--generations", "0"]),
        "--generations must be at least 1",
    );
    assert_user_error(
        &fit("ga", &["--mutation-rate", "-0.1"]),
        "mutation rate must lie in [0, 1]",
    );
    assert_user_error(
        &fit("ga", &["--crossover-rate=-1"]),
        "crossover rate must lie in [0, 1]",
    );
    assert_user_error(&fit("ga", &["--spread", "0"]), "spread");
    assert_user_error(&fit("ga", &["--target", "-1"]), "target");
    let lsq = run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "5",
        "--population",
        "64",
    ]);
    assert_user_error(&lsq, "--population applies only");
    // A checkpoint of another problem (another layout), of another seed, of another method.
    let ck = dir.join("c.ckpt");
    let out = fit(
        "ga",
        &[
            "--population",
            "16",
            "--generations",
            "2",
            "--checkpoint",
            ck.to_str().unwrap(),
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let c = ck.to_str().unwrap();
    let other = run(&[
        "fit",
        "data/naca4413.dat",
        "--degree",
        "3",
        "--segments",
        "4",
        "--method",
        "ga",
        "--population",
        "16",
        "--backend",
        "cpu",
        "--resume",
        c,
    ]);
    assert_user_error(&other, "another problem");
    // A failed resume leaves an existing history file alone.
    let history = dir.join("keep.csv");
    std::fs::write(&history, "precious").unwrap();
    let h = history.to_str().unwrap();
    let seed5 = fit(
        "ga",
        &["--population", "16", "--seed", "5", "--resume", c, "--history", h],
    );
    assert_user_error(&seed5, "another problem");
    assert_eq!(std::fs::read_to_string(&history).unwrap(), "precious");
    assert_user_error(&fit("cmaes", &["--population", "16", "--resume", c]), "ga run");
    // Unreadable checkpoints: garbage, truncated, missing.
    let garbage = dir.join("garbage.ckpt");
    std::fs::write(&garbage, "not a checkpoint").unwrap();
    assert_user_error(
        &fit("ga", &["--resume", garbage.to_str().unwrap()]),
        "garbage.ckpt",
    );
    let bytes = std::fs::read(&ck).unwrap();
    let cut = dir.join("cut.ckpt");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    assert_user_error(
        &fit("ga", &["--population", "16", "--resume", cut.to_str().unwrap()]),
        "cut.ckpt",
    );
    let missing = dir.join("missing.ckpt");
    assert_user_error(
        &fit("ga", &["--resume", missing.to_str().unwrap()]),
        "missing.ckpt",
    );
    // A checkpoint whose history does not reach its generation (its checksum recomputed),
    // resumed with its generations spent: refused with the reason, and nothing written.
    let mut short = Checkpoint::read(&ck).unwrap();
    short.history.clear();
    let short_ck = dir.join("short.ckpt");
    std::fs::write(&short_ck, short.to_bytes()).unwrap();
    let (next_ck, short_json) = (dir.join("next.ckpt"), dir.join("short.json"));
    let resumed = fit(
        "ga",
        &[
            "--population",
            "16",
            "--generations",
            "2",
            "--resume",
            short_ck.to_str().unwrap(),
            "--checkpoint",
            next_ck.to_str().unwrap(),
            "--json",
            short_json.to_str().unwrap(),
        ],
    );
    assert_user_error_naming(&resumed, &["short.ckpt", "0 lines for generation 2"]);
    assert!(!next_ck.exists() && !short_json.exists());
    // The good checkpoint was never touched by the failed runs.
    assert_eq!(std::fs::read(&ck).unwrap(), bytes);
}

#[test]
fn a_killed_run_leaves_a_whole_checkpoint_that_resumes() {
    let dir = scratch("cli-evo-kill");
    let ck = dir.join("k.ckpt");
    let c = ck.to_str().unwrap();
    // A checkpoint every generation of a large population: the kill lands during or between
    // writes, never leaving a partial file under the checkpoint's name.
    let mut child = Command::new(bin())
        .args([
            "fit",
            "data/naca4413.dat",
            "--degree",
            "3",
            "--segments",
            "5",
            "--method",
            "ga",
            "--backend",
            "cpu",
            "--population",
            "4096",
            "--generations",
            "100000",
            "--checkpoint",
            c,
            "--checkpoint-every",
            "1",
            "--quiet",
        ])
        .current_dir(crate_root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let clock = Instant::now();
    while !ck.exists() && clock.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(700));
    child.kill().unwrap();
    child.wait().unwrap();
    let saved = Checkpoint::read(&ck).expect("the last checkpoint is whole");
    assert!(saved.generation >= 1);
    let next = (saved.generation + 1).to_string();
    let out = fit(
        "ga",
        &["--population", "4096", "--generations", &next, "--resume", c],
    );
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn compare_prints_every_method_on_the_three_cases() {
    let out = run(&[
        "compare",
        "data/naca4413.dat",
        "--methods",
        "ga,cmaes,ga+lsq",
        "--population",
        "16",
        "--generations",
        "4",
        "--backend",
        "cpu",
        "--json",
        "-",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["schema"], "bezchain.compare/1");
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 9);
    for (row, method) in rows.iter().zip(["ga", "cmaes", "ga+lsq"].iter().cycle()) {
        assert_eq!(row["method"], *method);
        assert_eq!(row["backend"], "cpu");
        assert!(row["sum_sq"].as_f64().unwrap() > 0.0);
    }
    assert_eq!(rows[0]["iterations"], 4);
    assert_eq!(rows[0]["evaluations"], 16 * 5);
    let table = stderr(&out);
    assert!(table.contains("| 3 | 5 | 3 | 14 / 16 | cmaes | 28 |"), "{table}");
    assert_user_error(
        &run(&["compare", "data/naca4413.dat", "--population", "2"]),
        "--population",
    );
}
