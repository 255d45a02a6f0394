//! `--features mpi`: the binary under `mpirun` (docs/ARCHITECTURE.md §4.3). The same run on
//! 1, 2 and 3 ranks gives the same bits (design points, history, the outputs' every number
//! but the clocks'), a checkpoint written under MPI resumes, `eval` shares its rows and
//! `adapt-surface` its families, and a bad
//! input or a failing rank ends every rank with one `error:` line and a non-zero status, never
//! a hang. Run with `cargo test --features mpi --test mpi`; needs `mpirun` (OpenMPI) on the
//! path. The ranks are oversubscribed (3 on 2 cores), one thread each.
#![cfg(feature = "mpi")]

mod common;

use bezchain::optim::evo::Checkpoint;
use common::{bin, scratch};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Longest a launch may take before the test calls it a hang.
const TIMEOUT: Duration = Duration::from_secs(120);

/// One launch at a time: OpenMPI's launchers started together by the parallel tests
/// occasionally failed one of them (1 run in 5), and 3 ranks already fill the 2 cores.
static LAUNCH: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn launch_lock() -> std::sync::MutexGuard<'static, ()> {
    LAUNCH.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// `mpirun --oversubscribe -n ranks bezchain ARGS` in `dir` (ranks 0: the binary alone, no
/// launcher), one thread a rank; killed and failed after [`TIMEOUT`].
fn mpirun(ranks: usize, args: &[&str], dir: &Path) -> Output {
    let mut cmd = if ranks == 0 {
        Command::new(bin())
    } else {
        let mut c = Command::new("mpirun");
        c.args(["--oversubscribe", "-n", &ranks.to_string()]).arg(bin());
        c
    };
    cmd.args(args)
        .current_dir(dir)
        .env("RAYON_NUM_THREADS", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let _one = launch_lock();
    let mut child = cmd.spawn().expect("mpirun (OpenMPI) on the path");
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            return child.wait_with_output().unwrap();
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let o = child.wait_with_output().unwrap();
            panic!(
                "{ranks} ranks, {args:?}: no end after {TIMEOUT:?} (a hang)\n{}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "exit {:?}: {}\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr),
        String::from_utf8_lossy(&o.stdout)
    );
    o
}

/// A report without its clocks (every field whose name speaks of seconds or a rate) and without
/// the command line of its stamp (the runs name their own output files).
fn without_clocks(v: &Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.iter()
                .filter(|(k, _)| {
                    !(k.contains("second") || k.contains("elapsed") || k.contains("per_s") || *k == "command")
                })
                .map(|(k, x)| (k.clone(), without_clocks(x)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.iter().map(without_clocks).collect()),
        x => x.clone(),
    }
}

fn report(path: &Path) -> Value {
    without_clocks(&serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap())
}

/// The aerofoils of the runs, written by the binary itself.
fn aerofoils(dir: &Path) {
    for code in ["0012", "4412"] {
        ok(mpirun(0, &["naca", code, "-o", &format!("n{code}.dat")], dir));
    }
}

/// A checkpoint's run without its clocks: the history (generation, best and mean by their
/// bits, evaluations), the best individual and score, the population and scores or the
/// CMA-ES strategy, the scorer's state.
fn run_of(path: &Path) -> String {
    let mut c = Checkpoint::read(path).unwrap();
    for h in &mut c.history {
        h.seconds = 0.0;
    }
    c.seconds = 0.0;
    c.eval_seconds = 0.0;
    let history: Vec<(u64, u64, u64, u64)> = c
        .history
        .iter()
        .map(|h| (h.generation, h.best.to_bits(), h.mean.to_bits(), h.evaluations))
        .collect();
    format!(
        "{history:?} {:?} {:?} {:?} {:?} {:?} {:?}",
        c.best, c.best_score, c.population, c.scores, c.cmaes, c.params
    )
}

/// `optimise` with `method` and `objective` on 0 (no launcher), 1, 2 and 3 ranks: the report
/// (design points, counts, the kernel's best; clocks aside), the Selig file and the final
/// checkpoint (the history, population or strategy) are the same bits.
fn same_on_every_rank_count(dir: &Path, method: &str, objective: &str, extra: &[&str]) {
    let mut first: Option<(Value, Vec<u8>, String)> = None;
    for ranks in [0, 1, 2, 3] {
        let json = format!("o{ranks}.json");
        let dat = format!("o{ranks}.dat");
        let ckpt = format!("o{ranks}.ckpt");
        let mut args = vec![
            "optimise",
            "n0012.dat",
            "--objective",
            objective,
            "--method",
            method,
            "--tol",
            "1e-3",
            "--panels",
            "60",
            "--backend",
            "cpu",
            "--json",
            &json,
            "--dat",
            &dat,
            "--checkpoint",
            &ckpt,
        ];
        args.extend_from_slice(extra);
        ok(mpirun(ranks, &args, dir));
        let got = (
            report(&dir.join(&json)),
            std::fs::read(dir.join(&dat)).unwrap(),
            run_of(&dir.join(&ckpt)),
        );
        assert!(got.0["design_points"].as_array().is_some_and(|a| !a.is_empty()));
        match &first {
            None => first = Some(got),
            Some(f) => {
                assert_eq!(f.0, got.0, "{method} {objective}: report on {ranks} ranks");
                assert_eq!(f.1, got.1, "{method} {objective}: Selig file on {ranks} ranks");
                assert_eq!(
                    f.2, got.2,
                    "{method} {objective}: history and state on {ranks} ranks"
                );
            }
        }
    }
}

#[test]
fn optimise_gives_the_same_bits_on_1_2_and_3_ranks() {
    let d = scratch("mpi-same");
    aerofoils(&d);
    same_on_every_rank_count(
        &d,
        "cmaes",
        "max-cl",
        &["--generations", "8", "--min-thickness", "0.1"],
    );
    same_on_every_rank_count(
        &d,
        "ga",
        "inverse:n4412.dat",
        &["--generations", "4", "--population", "13"],
    );
    same_on_every_rank_count(
        &d,
        "ga+cmaes",
        "max-cl",
        &[
            "--generations",
            "6",
            "--population",
            "11",
            "--min-thickness",
            "0.1",
        ],
    );
    // Only rank 0 wrote: no other file appeared.
    let mut files: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(files.len(), 2 + 4 * 3, "{files:?}");
}

#[test]
fn a_checkpoint_written_under_mpi_resumes_to_the_same_bits() {
    let d = scratch("mpi-resume");
    aerofoils(&d);
    let base = [
        "optimise",
        "n0012.dat",
        "--objective",
        "max-cl",
        "--min-thickness",
        "0.1",
        "--method",
        "ga",
        "--population",
        "10",
        "--tol",
        "1e-3",
        "--panels",
        "60",
        "--backend",
        "cpu",
    ];
    let with = |extra: &[&str]| -> Vec<String> { base.iter().chain(extra).map(|s| s.to_string()).collect() };
    let run = |ranks: usize, args: Vec<String>| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        ok(mpirun(ranks, &args, &d))
    };
    // Whole on one process; 4 generations and a checkpoint on 3 ranks, the rest on 2. (The GA:
    // `ga+cmaes` hands over halfway through its generation limit, which a longer resumed run
    // moves.)
    run(0, with(&["--generations", "8", "--json", "whole.json"]));
    run(3, with(&["--generations", "4", "--checkpoint", "half.ckpt"]));
    run(
        2,
        with(&[
            "--generations",
            "8",
            "--resume",
            "half.ckpt",
            "--json",
            "resumed.json",
        ]),
    );
    assert_eq!(report(&d.join("whole.json")), report(&d.join("resumed.json")));
}

#[test]
fn eval_gives_the_same_fitness_on_1_2_and_3_ranks() {
    let d = scratch("mpi-eval");
    let data = common::crate_root().join("data/naca4413.dat");
    let data = data.to_str().unwrap();
    ok(mpirun(
        0,
        &[
            "fit",
            data,
            "--degree",
            "3",
            "--segments",
            "5",
            "--json",
            "fit.json",
        ],
        &d,
    ));
    let design: Vec<f64> = serde_json::from_slice::<Value>(&std::fs::read(d.join("fit.json")).unwrap())
        .unwrap()["design_points"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|p| {
            p.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect::<Vec<_>>()
        })
        .collect();
    // 31 individuals around the fit.
    let mut text = String::new();
    for k in 0..31 {
        let row: Vec<String> = design
            .iter()
            .enumerate()
            .map(|(i, x)| {
                format!(
                    "{}",
                    x + 1e-3 * (((k * 7 + i * 3) % 11) as f64 - 5.0) * f64::from(k != 0)
                )
            })
            .collect();
        text.push_str(&row.join(","));
        text.push('\n');
    }
    std::fs::write(d.join("pop.csv"), text).unwrap();
    let args = [
        "eval",
        "fit.json",
        "--population",
        "pop.csv",
        "--points",
        data,
        "--backend",
        "cpu",
    ];
    let one = ok(mpirun(0, &args, &d)).stdout;
    assert_eq!(String::from_utf8_lossy(&one).lines().count(), 31);
    for ranks in [1, 2, 3] {
        assert_eq!(ok(mpirun(ranks, &args, &d)).stdout, one, "{ranks} ranks");
    }
}

#[test]
fn adapt_surface_gives_the_same_surface_on_1_2_and_3_ranks() {
    let d = scratch("mpi-adapt-surface");
    let blade = common::crate_root().join("data/blade_paper_to_tip.json");
    let blade = blade.to_str().unwrap();
    ok(mpirun(
        0,
        &["blade", blade, "--points-per-section", "24", "-o", "b.csv"],
        &d,
    ));
    // The cloud without the chord rule (30 families, bulk and greedy, spread over the ranks),
    // and the blade definition itself (the chord rule's families, lofted and checked between
    // its stations).
    let runs: [&[&str]; 2] = [
        &[
            "b.csv",
            "--tol",
            "1e-3",
            "--relative",
            "--degrees-u",
            "3-5",
            "--degrees-v",
            "2-3",
            "--chord-rule",
            "off",
        ],
        &[
            blade,
            "--points-per-section",
            "24",
            "--tol",
            "2e-3",
            "--relative",
            "--degrees-u",
            "3-4",
            "--degrees-v",
            "2",
        ],
    ];
    for (k, run) in runs.iter().enumerate() {
        let mut first: Option<Value> = None;
        for ranks in [0, 1, 2, 3] {
            let json = format!("s{k}-{ranks}.json");
            let mut args = vec!["adapt-surface"];
            args.extend_from_slice(run);
            args.extend_from_slice(&["--json", &json]);
            ok(mpirun(ranks, &args, &d));
            // The surface (control net, encoding), its checks, every family's trace.
            let got = report(&d.join(&json));
            assert!(got["adapt"]["search"].as_array().is_some_and(|a| a.len() > 2));
            match &first {
                None => first = Some(got),
                Some(f) => assert_eq!(f, &got, "{run:?}: report on {ranks} ranks"),
            }
        }
    }
}

/// Exit status, and the `error:` lines of standard error (the launcher's own notes aside).
fn errors(o: &Output) -> (Option<i32>, Vec<String>) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    let lines = err
        .lines()
        .filter(|l| l.starts_with("error:") && !l.contains("XDG_RUNTIME_DIR"))
        .map(str::to_string)
        .collect();
    (o.status.code(), lines)
}

#[test]
fn a_bad_input_ends_every_rank_with_one_error_line() {
    let d = scratch("mpi-error");
    aerofoils(&d);
    for ranks in [1, 3] {
        // Every rank fails alike before any collective: a missing file, a bad option.
        let o = mpirun(
            ranks,
            &[
                "optimise",
                "missing.dat",
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
            ],
            &d,
        );
        let (code, lines) = errors(&o);
        assert_eq!(code, Some(2), "{ranks} ranks: {lines:?}");
        assert_eq!(lines.len(), 1, "{ranks} ranks: {lines:?}");
        assert!(lines[0].contains("missing.dat"), "{lines:?}");
        let o = mpirun(
            ranks,
            &[
                "optimise",
                "n0012.dat",
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
                "--alpha",
                "99",
            ],
            &d,
        );
        let (code, lines) = errors(&o);
        assert_eq!((code, lines.len()), (Some(2), 1), "{ranks} ranks: {lines:?}");
        assert!(lines[0].contains("--alpha"), "{lines:?}");
        // An output rank 0 cannot write, found when it checks its outputs: the other ranks
        // write nothing and check nothing, and still end.
        let o = mpirun(
            ranks,
            &[
                "optimise",
                "n0012.dat",
                "--objective",
                "max-cl",
                "--min-thickness",
                "0.1",
                "--tol",
                "1e-3",
                "--panels",
                "60",
                "--generations",
                "2",
                "--backend",
                "cpu",
                "--json",
                "no/such/folder/o.json",
            ],
            &d,
        );
        let (code, lines) = errors(&o);
        assert_eq!((code, lines.len()), (Some(2), 1), "{ranks} ranks: {lines:?}");
        assert!(lines[0].contains("--json"), "{lines:?}");
    }
}

/// `bezchain ARGS` on 3 ranks, rank 2 failing every shared batch (`BEZCHAIN_TEST_FAIL_RANK`, a
/// test hook read only in builds with the mpi feature: mid-run, inside the collective): every
/// rank ends, with one `error:` line naming rank 2 and a non-zero status.
fn rank_2_fails(args: &[&str], dir: &Path) {
    let mut cmd = Command::new("mpirun");
    cmd.args(["--oversubscribe", "-n", "3", "-x", "BEZCHAIN_TEST_FAIL_RANK=2"])
        .arg(bin())
        .args(args);
    cmd.current_dir(dir)
        .env("BEZCHAIN_TEST_FAIL_RANK", "2")
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    let start = Instant::now();
    let o = {
        let _one = launch_lock();
        cmd.output().unwrap()
    };
    assert!(start.elapsed() < TIMEOUT);
    let (code, lines) = errors(&o);
    assert!(code.is_some_and(|c| c != 0), "{args:?}: {code:?}");
    assert_eq!(lines.len(), 1, "{args:?}: {lines:?}");
    assert!(lines[0].contains("rank 2"), "{args:?}: {lines:?}");
}

#[test]
fn a_failing_rank_ends_every_rank_with_one_error_line() {
    let d = scratch("mpi-rank-fails");
    aerofoils(&d);
    rank_2_fails(
        &[
            "optimise",
            "n0012.dat",
            "--objective",
            "max-cl",
            "--min-thickness",
            "0.1",
            "--method",
            "ga",
            "--population",
            "12",
            "--tol",
            "1e-3",
            "--panels",
            "60",
            "--generations",
            "3",
            "--backend",
            "cpu",
        ],
        &d,
    );
    let blade = common::crate_root().join("data/blade_paper_to_tip.json");
    rank_2_fails(
        &[
            "adapt-surface",
            blade.to_str().unwrap(),
            "--points-per-section",
            "24",
            "--tol",
            "2e-3",
            "--relative",
            "--degrees-u",
            "3",
            "--degrees-v",
            "2",
        ],
        &d,
    );
}
