//! Mutation fuzzing of every reader: point files (Selig, Lednicer, CSV with and without a
//! header, clouds), blade files (JSON, windIO YAML, AeroDyn 15), reports (curve, adapt,
//! surface; read by `eval` and by `export`), population files and checkpoints. Each case takes
//! a valid seed file, applies a short list of mutations (flipped, inserted, deleted and
//! duplicated bytes, planted tokens such as `nan`, `1e999`, `18446744073709551615`, a NUL, a
//! byte-order mark, a run of brackets or digits) and reads it. A reader must return (never
//! panic, never take long), and its error must name the file.
//!
//! **In `cargo test`**: `CASES` cases per reader (12 readers) and `COMMAND_CASES` command
//! lines with an extreme argument value (every command), proptest with shrinking, so a
//! failure prints its smallest case. `BEZCHAIN_FUZZ_CASES=N` sets the reader count (the
//! command count follows in proportion).
//!
//! **The long run** (CI does not run it; cargo-fuzz needs nightly, this runs on stable):
//!
//! ```text
//! BEZCHAIN_FUZZ_SECONDS=3600 cargo test --release --test fuzz -- --ignored --nocapture
//! ```
//!
//! mutates seeds at random for that many seconds (seeded by `BEZCHAIN_FUZZ_SEED`, default the
//! clock; printed so a run can be repeated), feeding every reader in process and every command
//! of the binary (mutated input files, and argument values drawn from extremes such as 0, 1,
//! 2^32, 2^64 - 1, -1, 1e308, NaN). A command must exit with 0, 1 or 2 within
//! `BEZCHAIN_FUZZ_TIMEOUT` seconds (default 60), print one `error:` line when it fails, and
//! leave no temporary file behind. Every failing case is written to `target/fuzz-failures/`
//! (the file and the command line) and counted; the test fails if there is any.

mod common;

use bezchain::export::{CadShape, Report};
use bezchain::geometry::{read_cloud, read_curve, read_points, Blade};
use bezchain::optim::evo::Checkpoint;
use proptest::prelude::*;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Cases per reader in the default test run.
const CASES: u32 = 48;

/// Command lines with an extreme argument in the default test run.
const COMMAND_CASES: u32 = 96;

/// The longest a reader may take on one case (debug build, a loaded machine).
const SLOW: Duration = Duration::from_secs(5);

fn cases() -> u32 {
    std::env::var("BEZCHAIN_FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(CASES)
}

/// Tokens planted by the mutations: what breaks readers.
const TOKENS: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e999",
    "1e308",
    "1e200",
    "-1e-320",
    "-0",
    "0",
    "18446744073709551615",
    "4000000000",
    "-1",
    "1.5D-03",
    "\0",
    "\u{feff}",
    "\r",
    "\n",
    "\r\n",
    ",",
    ";",
    "\"",
    "#",
    "[",
    "]",
    "{",
    "}",
    ":",
    "- ",
    "x,y,z",
    "x y",
    "section,index",
    "null",
    "true",
    "\"kind\": \"surface\"",
    "\u{e9}",
];

/// One edit of a byte string; positions and lengths are fractions of its length.
#[derive(Clone, Debug)]
enum Mutation {
    Flip {
        at: f64,
        mask: u8,
    },
    Insert {
        at: f64,
        token: usize,
    },
    Delete {
        at: f64,
        len: usize,
    },
    Duplicate {
        at: f64,
        len: usize,
    },
    Truncate {
        at: f64,
    },
    /// A long run of one byte (digits, brackets, a line without an end).
    Run {
        at: f64,
        byte: u8,
        len: usize,
    },
    /// A raw byte that is not UTF-8.
    Raw {
        at: f64,
        byte: u8,
    },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let at = 0.0..1.0f64;
    prop_oneof![
        (at.clone(), 1u8..=255).prop_map(|(at, mask)| Mutation::Flip { at, mask }),
        (at.clone(), 0..TOKENS.len()).prop_map(|(at, token)| Mutation::Insert { at, token }),
        (at.clone(), 1usize..64).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (at.clone(), 1usize..400).prop_map(|(at, len)| Mutation::Duplicate { at, len }),
        at.clone().prop_map(|at| Mutation::Truncate { at }),
        (
            at.clone(),
            prop::sample::select(vec![b'9', b'[', b'{', b' ', b'x', b'-']),
            prop::sample::select(vec![300usize, 5000, 70_000])
        )
            .prop_map(|(at, byte, len)| Mutation::Run { at, byte, len }),
        (at, 0x80u8..=0xff).prop_map(|(at, byte)| Mutation::Raw { at, byte }),
    ]
}

fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    prop::collection::vec(mutation(), 1..6)
}

/// `seed` with the mutations applied in order.
fn mutate(seed: &[u8], ms: &[Mutation]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for m in ms {
        let pos = |at: f64, len: usize| ((at * len as f64) as usize).min(len);
        match *m {
            Mutation::Flip { at, mask } => {
                if !b.is_empty() {
                    let i = pos(at, b.len() - 1);
                    b[i] ^= mask;
                }
            }
            Mutation::Insert { at, token } => {
                let i = pos(at, b.len());
                b.splice(i..i, TOKENS[token].bytes());
            }
            Mutation::Delete { at, len } => {
                let i = pos(at, b.len());
                let j = (i + len).min(b.len());
                b.drain(i..j);
            }
            Mutation::Duplicate { at, len } => {
                let i = pos(at, b.len());
                let j = (i + len).min(b.len());
                let copy = b[i..j].to_vec();
                b.splice(j..j, copy);
            }
            Mutation::Truncate { at } => {
                let i = pos(at, b.len());
                b.truncate(i);
            }
            Mutation::Run { at, byte, len } => {
                let i = pos(at, b.len());
                b.splice(i..i, std::iter::repeat_n(byte, len));
            }
            Mutation::Raw { at, byte } => {
                let i = pos(at, b.len());
                b.insert(i, byte);
            }
        }
    }
    b
}

/// The seed files: the repository's own data, plus reports, a cloud, a population and a
/// checkpoint made once by the binary (so they are always in today's format).
struct Seeds {
    dir: PathBuf,
    curve_report: Vec<u8>,
    adapt_report: Vec<u8>,
    surface_report: Vec<u8>,
    cloud: Vec<u8>,
    population: Vec<u8>,
    checkpoint: Vec<u8>,
    /// A copy of the AeroDyn folder (the primary file names the others by relative path).
    aerodyn: PathBuf,
}

fn run_ok(args: &[&str], dir: &Path) {
    let out = Command::new(common::bin())
        .args(args)
        .current_dir(dir)
        .env("BEZCHAIN_NO_GPU", "1")
        .output()
        .expect("run bezchain");
    assert!(
        out.status.success(),
        "bezchain {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn seeds() -> &'static Seeds {
    static SEEDS: OnceLock<Seeds> = OnceLock::new();
    SEEDS.get_or_init(|| {
        let dir = common::scratch("fuzz-seeds").keep();
        let data = common::crate_root().join("data");
        let naca = data.join("naca4413.dat");
        let naca = naca.to_str().unwrap();
        run_ok(
            &[
                "fit",
                naca,
                "--degree",
                "3",
                "--segments",
                "5",
                "--json",
                "curve.json",
            ],
            &dir,
        );
        run_ok(&["adapt", naca, "--tol", "1e-3", "--json", "adapt.json"], &dir);
        let blade = data.join("blade_paper.json");
        run_ok(
            &[
                "blade",
                blade.to_str().unwrap(),
                "--points-per-section",
                "16",
                "-o",
                "cloud.csv",
            ],
            &dir,
        );
        run_ok(
            &[
                "fit-surface",
                "cloud.csv",
                "--degree",
                "3x3",
                "--patches",
                "2x1",
                "--breaks-v",
                "uniform",
                "--json",
                "surface.json",
            ],
            &dir,
        );
        run_ok(
            &[
                "fit",
                naca,
                "--degree",
                "3",
                "--segments",
                "5",
                "--method",
                "ga",
                "--population",
                "8",
                "--generations",
                "2",
                "--backend",
                "cpu",
                "--quiet",
                "--checkpoint",
                "run.ckpt",
            ],
            &dir,
        );
        let read = |name: &str| std::fs::read(dir.join(name)).expect(name);
        let curve_report = read("curve.json");
        let report: serde_json::Value = serde_json::from_slice(&curve_report).unwrap();
        let design: Vec<String> = report["design_points"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|p| p.as_array().unwrap().iter().map(|v| v.to_string()))
            .collect();
        let population = format!("# two individuals\n{}\n{}\n", design.join(","), design.join(" "));
        let aerodyn = dir.join("openfast");
        copy_dir(&data.join("blades/iea-3.4-130-rwt/openfast"), &aerodyn);
        Seeds {
            curve_report,
            adapt_report: read("adapt.json"),
            surface_report: read("surface.json"),
            cloud: read("cloud.csv"),
            population: population.into_bytes(),
            checkpoint: read("run.ckpt"),
            aerodyn,
            dir,
        }
    })
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// A fresh file name in the seeds' folder (cases run on several threads).
fn case_path(tag: &str, ext: &str) -> PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    seeds().dir.join(format!("case-{tag}-{n}.{ext}"))
}

/// Read the mutated bytes, written to `path`, with `read`: no panic (proptest reports one with
/// its mutation list), quick, and an error that names the file.
fn check_reader<T>(
    path: &Path,
    bytes: &[u8],
    read: impl Fn(&Path) -> bezchain::Result<T>,
) -> Result<(), TestCaseError> {
    std::fs::write(path, bytes).unwrap();
    let clock = Instant::now();
    let result = read(path);
    let took = clock.elapsed();
    let _ = std::fs::remove_file(path);
    prop_assert!(took < SLOW, "{} took {took:?}", path.display());
    if let Err(e) = result {
        let text = e.to_string();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        prop_assert!(text.contains(&name), "the error does not name the file: {text}");
        prop_assert!(!text.trim().is_empty());
    }
    Ok(())
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

fn data_file(rel: &str) -> Vec<u8> {
    std::fs::read(common::crate_root().join("data").join(rel)).unwrap()
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn selig_files(ms in mutations()) {
        let seed = data_file("naca4413.dat");
        check_reader(&case_path("selig", "dat"), &mutate(&seed, &ms), read_curve)?;
    }

    #[test]
    fn lednicer_files(ms in mutations()) {
        let seed = data_file("airfoils/clarky_lednicer.dat");
        check_reader(&case_path("lednicer", "dat"), &mutate(&seed, &ms), read_curve)?;
    }

    #[test]
    fn csv_curves_with_a_header(ms in mutations()) {
        let seed = b"index,x,y,label\n0,1,0,te\n1,0.5,0.06,\"upper, mid\"\n2,0,0,le\n3,0.5,-0.04,lower\n4,1,0,te\n";
        check_reader(&case_path("csv", "csv"), &mutate(seed, &ms), read_curve)?;
    }

    #[test]
    fn clouds(ms in mutations()) {
        check_reader(&case_path("cloud", "csv"), &mutate(&seeds().cloud, &ms), read_cloud)?;
    }

    #[test]
    fn points_of_either_dimension(ms in mutations()) {
        let seed = data_file("airfoils/e387.dat");
        check_reader(&case_path("points", "dat"), &mutate(&seed, &ms), read_points)?;
    }

    #[test]
    fn blade_json(ms in mutations()) {
        let seed = data_file("blade_paper.json");
        check_reader(&case_path("blade", "json"), &mutate(&seed, &ms), Blade::from_file)?;
    }

    #[test]
    fn blade_windio(ms in mutations()) {
        let seed = data_file("blades/iea-3.4-130-rwt/windio/IEA-3.4-130-RWT.yaml");
        check_reader(&case_path("windio", "yaml"), &mutate(&seed, &ms), Blade::from_file)?;
    }

    #[test]
    fn blade_aerodyn(ms in mutations(), primary in any::<bool>()) {
        // The primary file or the blade file it names, mutated in place in the copy.
        let dir = &seeds().aerodyn;
        let (main, other) = ("IEA-3.4-130-RWT_AeroDyn15.dat", "IEA-3.4-130-RWT_AeroDyn15_blade.dat");
        let case = case_path("aerodyn", "d");
        std::fs::create_dir_all(&case).unwrap();
        for e in std::fs::read_dir(dir).unwrap() {
            let e = e.unwrap();
            let target = case.join(e.file_name());
            #[cfg(unix)]
            std::os::unix::fs::symlink(e.path(), &target).unwrap();
            #[cfg(not(unix))]
            std::fs::copy(e.path(), &target).unwrap();
        }
        let victim = if primary { main } else { other };
        let bytes = mutate(&std::fs::read(dir.join(victim)).unwrap(), &ms);
        std::fs::remove_file(case.join(victim)).unwrap();
        let result = check_reader(&case.join(victim), &bytes, |_| Blade::from_file(&case.join(main)));
        let _ = std::fs::remove_dir_all(&case);
        // An error in the blade file may be reported by the primary file that names it.
        match result {
            Err(e) if !primary && e.to_string().contains("does not name the file") => {
                prop_assert!(e.to_string().contains(main), "{e}");
            }
            other => other?,
        }
    }

    #[test]
    fn curve_reports(ms in mutations()) {
        check_reader(&case_path("curve", "json"), &mutate(&seeds().curve_report, &ms), Report::read)?;
    }

    #[test]
    fn reports_for_export(ms in mutations(), which in 0..3usize) {
        let s = seeds();
        let seed = [&s.curve_report, &s.adapt_report, &s.surface_report][which];
        check_reader(&case_path("export", "json"), &mutate(seed, &ms), CadShape::read_reports)?;
    }

    #[test]
    fn populations(ms in mutations()) {
        let n = 24; // case 1: 12 design points
        check_reader(&case_path("pop", "csv"), &mutate(&seeds().population, &ms), |p| {
            bezchain::geometry::read_population(p, n)
        })?;
    }

    #[test]
    fn checkpoints(ms in mutations(), fix_checksum in any::<bool>()) {
        // With the checksum recomputed, the mutations reach the checks behind it.
        let mut bytes = mutate(&seeds().checkpoint, &ms);
        if fix_checksum && bytes.len() > 8 {
            let body = bytes.len() - 8;
            let sum = fnv1a(&bytes[..body]);
            bytes[body..].copy_from_slice(&sum.to_le_bytes());
        }
        check_reader(&case_path("ckpt", "bin"), &bytes, Checkpoint::read)?;
    }
}

/// The checkpoint's checksum (FNV-1a over every byte before it).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

// ---------------------------------------------------------------------------------------------
// Command lines: every command with one argument set to an extreme value.

/// Values that break size and number arguments.
const EXTREMES: &[&str] = &[
    "0",
    "1",
    "2",
    "-1",
    "4000000000",
    "4294967296",
    "18446744073709551615",
    "99999999999999999999999",
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "1e-320",
    "",
    "x",
];

/// Command lines with one `{}` for the extreme value; `{naca}`, `{cloud}`, `{blade}`,
/// `{curve}` and `{surface}` name seed files, `{out}` a fresh output folder.
const COMMANDS: &[&str] = &[
    "naca 4413 --points {} -o {out}/a.dat",
    "naca {} -o {out}/a.dat",
    "blade {blade} --sections {} -o {out}/c.csv",
    "blade {blade} --points-per-section {} -o {out}/c.csv",
    "blade {blade} --noise {} -o {out}/c.csv",
    "fit {naca} --degree {} --segments 5 --json {out}/f.json",
    "fit {naca} --degree 3 --segments {} --json {out}/f.json --svg {out}/f.svg",
    "fit {naca} --degree 3 --segments 5 --method ga --population {} --generations 2 --backend cpu --quiet --history {out}/h.csv --checkpoint {out}/c.ckpt",
    "fit {naca} --degree 3 --segments 5 --method ga --population 8 --generations {} --backend cpu --quiet --stall 2",
    "fit {naca} --degree 3 --segments 5 --method cmaes --population {} --generations 2 --backend cpu --quiet",
    "fit {naca} --degree 3 --segments 5 --method ga --population 8 --generations 2 --backend cpu --quiet --spread {}",
    "fit {naca} --degree 3 --segments 5 --method ga --population 8 --generations 2 --backend cpu --quiet --target {}",
    "fit-surface {cloud} --degree 3x3 --patches {}x1 --breaks-v uniform --json {out}/s.json",
    "fit-surface {cloud} --degree {}x3 --patches 2x1 --breaks-v uniform",
    "fit-surface {cloud} --degree 3x3 --patches 2x1 --breaks-v {}",
    "fit-surface {cloud} --degree 3x3 --patches 2x1 --breaks-v uniform --method ga --population {} --generations 2 --backend cpu --quiet",
    "fit-surface {cloud} --degree 3x3 --patches 2x1 --breaks-v uniform --mesh-density {} --obj {out}/s.obj",
    "fit-surface {cloud} --degree 3x3 --patches 2x1 --breaks-v uniform --png-size {}x100 --png {out}/s.png",
    "compare {naca} --methods ga --population {} --generations 1 --backend cpu",
    "compare {naca} --methods ga --population 8 --generations {} --backend cpu",
    "bench --points {} --population 8 --runs 5 --backend cpu",
    "bench --population {} --points 64 --runs 5 --backend cpu",
    "bench --patches {}x2 --points 64 --population 8 --runs 5 --backend cpu",
    "bench --runs {} --points 64 --population 8 --backend cpu",
    "adapt {naca} --tol {} --json {out}/a.json",
    "adapt {naca} --tol 1e-3 --max-scalars {}",
    "adapt {naca} --tol 1e-3 --degrees {}",
    "adapt {naca} --tol 1e-3 --search-points {}",
    "adapt-surface {cloud} --tol {} --max-scalars 60",
    "adapt-surface {cloud} --tol 1e-2 --max-scalars {}",
    "eval {curve} --population {out}/../pop.csv --points {naca} --backend {}",
    "export {surface} --step {out}/s.step --cad-unit {}",
];

/// How long a command may take before it counts as a hang (a debug build on a loaded machine).
fn command_timeout() -> Duration {
    Duration::from_secs(
        std::env::var("BEZCHAIN_FUZZ_TIMEOUT")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(60),
    )
}

/// What a command did.
struct Outcome {
    status: Option<i32>,
    stderr: String,
    took: Duration,
}

/// Run `bezchain args` in `dir` with a deadline (killed past it: `status` None).
fn run_command(args: &[String], dir: &Path) -> Outcome {
    let clock = Instant::now();
    let mut child = Command::new(common::bin())
        .args(args)
        .current_dir(dir)
        .env("BEZCHAIN_NO_GPU", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run bezchain");
    let mut stderr = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let deadline = clock + command_timeout();
    let status = loop {
        match child.try_wait().expect("wait") {
            Some(st) => break st.code(),
            None if Instant::now() > deadline => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            None => std::thread::sleep(Duration::from_millis(5)),
        }
    };
    Outcome {
        status,
        stderr: reader.join().unwrap_or_default(),
        took: clock.elapsed(),
    }
}

/// `template` filled in: the extreme `value`, the seed files, and `out`.
fn command_line(template: &str, value: &str, out: &Path) -> Vec<String> {
    let s = seeds();
    let naca = common::crate_root().join("data/naca4413.dat");
    let blade = common::crate_root().join("data/blade_paper.json");
    template
        .split(' ')
        .map(|w| {
            w.replace("{}", value)
                .replace("{naca}", &naca.display().to_string())
                .replace("{blade}", &blade.display().to_string())
                .replace("{cloud}", &s.dir.join("cloud.csv").display().to_string())
                .replace("{curve}", &s.dir.join("curve.json").display().to_string())
                .replace("{surface}", &s.dir.join("surface.json").display().to_string())
                .replace("{out}", &out.display().to_string())
        })
        .collect()
}

/// The contract of a command run: an exit status of 0, 1 or 2 (no panic, no abort, no
/// signal) within the deadline; a failure says `error:` on its last line; no temporary
/// file is left in `out`. Returns the problem, if any.
fn check_outcome(o: &Outcome, out: &Path) -> Option<String> {
    let last = o.stderr.lines().last().unwrap_or("");
    match o.status {
        None => return Some(format!("no exit within {:?}", command_timeout())),
        Some(0) => {}
        // bezchain's one line, or clap's first.
        Some(1 | 2) if o.stderr.lines().any(|l| l.starts_with("error: ")) => {}
        Some(1 | 2) => return Some(format!("failed without an error line: {last}")),
        Some(code) => return Some(format!("exit status {code}: {last}")),
    }
    let left: Vec<String> = std::fs::read_dir(out)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.contains(".tmp-"))
                .collect()
        })
        .unwrap_or_default();
    if !left.is_empty() {
        return Some(format!("temporary files left: {left:?}"));
    }
    None
}

/// A fresh output folder for one command case.
fn out_dir() -> PathBuf {
    let d = case_path("out", "d");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The population file `eval` reads (two copies of the curve seed's design).
fn write_population() {
    let path = seeds().dir.join("pop.csv");
    if !path.exists() {
        std::fs::write(&path, &seeds().population).unwrap();
    }
}

fn command_config() -> ProptestConfig {
    ProptestConfig {
        cases: cases() * COMMAND_CASES / CASES,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(command_config())]

    #[test]
    fn commands_with_extreme_arguments(
        template in 0..COMMANDS.len(),
        value in 0..EXTREMES.len(),
    ) {
        write_population();
        let out = out_dir();
        let args = command_line(COMMANDS[template], EXTREMES[value], &out);
        let outcome = run_command(&args, &seeds().dir);
        let problem = check_outcome(&outcome, &out);
        let _ = std::fs::remove_dir_all(&out);
        prop_assert!(problem.is_none(), "bezchain {}: {}", args.join(" "), problem.unwrap_or_default());
        // A refused argument is refused at once, before any work.
        if outcome.status == Some(2) {
            prop_assert!(outcome.took < Duration::from_secs(20), "bezchain {}: refused after {:?}", args.join(" "), outcome.took);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The long run (ignored; see the module docs).

/// The readers, by name, as the long run calls them on a mutated file.
type ReaderFn = fn(&Path) -> bool;

fn readers() -> Vec<(&'static str, Vec<u8>, &'static str, ReaderFn)> {
    let s = seeds();
    vec![
        ("selig", data_file("naca4413.dat"), "dat", |p| {
            read_curve(p).is_ok()
        }),
        (
            "lednicer",
            data_file("airfoils/clarky_lednicer.dat"),
            "dat",
            |p| read_curve(p).is_ok(),
        ),
        ("cloud", s.cloud.clone(), "csv", |p| read_cloud(p).is_ok()),
        ("points", data_file("airfoils/e387.dat"), "dat", |p| {
            read_points(p).is_ok()
        }),
        ("blade", data_file("blade_paper.json"), "json", |p| {
            Blade::from_file(p).is_ok()
        }),
        (
            "windio",
            data_file("blades/iea-3.4-130-rwt/windio/IEA-3.4-130-RWT.yaml"),
            "yaml",
            |p| Blade::from_file(p).is_ok(),
        ),
        ("curve report", s.curve_report.clone(), "json", |p| {
            Report::read(p).is_ok()
        }),
        ("adapt report", s.adapt_report.clone(), "json", |p| {
            CadShape::read_reports(p).is_ok()
        }),
        ("surface report", s.surface_report.clone(), "json", |p| {
            CadShape::read_reports(p).is_ok()
        }),
        ("population", s.population.clone(), "csv", |p| {
            bezchain::geometry::read_population(p, 24).is_ok()
        }),
        ("checkpoint", s.checkpoint.clone(), "bin", |p| {
            Checkpoint::read(p).is_ok()
        }),
    ]
}

/// Commands the long run feeds a mutated file to (`{in}`), with their input's seed.
fn file_commands() -> Vec<(&'static str, Vec<u8>)> {
    let s = seeds();
    vec![
        ("fit {in} --degree 3 --segments 5 --json {out}/f.json --svg {out}/f.svg", data_file("naca4413.dat")),
        ("adapt {in} --tol 1e-3 --json {out}/a.json", data_file("naca4413.dat")),
        ("fit-surface {in} --degree 3x3 --patches 2x1 --breaks-v uniform --json {out}/s.json --obj {out}/s.obj", s.cloud.clone()),
        ("adapt-surface {in} --tol 1e-2 --max-scalars 60", s.cloud.clone()),
        ("blade {in} --points-per-section 16 -o {out}/c.csv", data_file("blade_paper.json")),
        ("eval {in} --population {pop} --points {naca} --backend cpu", s.curve_report.clone()),
        ("eval {curve} --population {in} --points {naca} --backend cpu", s.population.clone()),
        ("export {in} --step {out}/x.step --iges {out}/x.igs", s.surface_report.clone()),
        (
            "fit {naca} --degree 3 --segments 5 --method ga --population 8 --generations 4 --backend cpu --quiet --resume {in} --checkpoint {out}/c.ckpt",
            s.checkpoint.clone(),
        ),
    ]
}

/// Mutate seeds at random for `BEZCHAIN_FUZZ_SECONDS`, feeding the readers in process and the
/// commands through the binary; every failing case is saved under `target/fuzz-failures/`.
#[test]
#[ignore = "long-running fuzz target: BEZCHAIN_FUZZ_SECONDS=3600 cargo test --release --test fuzz -- --ignored --nocapture"]
fn fuzz_long_run() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{RngAlgorithm, TestRng, TestRunner};
    let seconds: u64 = std::env::var("BEZCHAIN_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(60);
    let seed: u64 = std::env::var("BEZCHAIN_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(1, |d| d.as_nanos() as u64)
        });
    println!("fuzz: {seconds} s, BEZCHAIN_FUZZ_SEED={seed}");
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let mut runner = TestRunner::new_with_rng(
        ProptestConfig::default(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &bytes),
    );
    let failures_dir = common::crate_root().join("target/fuzz-failures");
    write_population();
    let readers = readers();
    let commands = file_commands();
    let (mut cases, mut failures) = (0u64, 0u64);
    let mut per_kind = std::collections::BTreeMap::<String, u64>::new();
    let deadline = Instant::now() + Duration::from_secs(seconds);
    while Instant::now() < deadline {
        let ms = mutations().new_tree(&mut runner).expect("mutations").current();
        let pick = (0..3usize).new_tree(&mut runner).expect("pick").current();
        cases += 1;
        let mut fail = |kind: &str, input: &[u8], what: String| {
            failures += 1;
            std::fs::create_dir_all(&failures_dir).unwrap();
            let stem = failures_dir.join(format!("{seed}-{cases}"));
            std::fs::write(stem.with_extension("input"), input).unwrap();
            std::fs::write(stem.with_extension("txt"), format!("{kind}\n{what}\n")).unwrap();
            println!("FAIL {kind}: {what}");
        };
        match pick {
            // A reader in process.
            0 => {
                let k = (0..readers.len()).new_tree(&mut runner).unwrap().current();
                let (name, seed_bytes, ext, read) = &readers[k];
                *per_kind.entry(format!("reader {name}")).or_default() += 1;
                let input = mutate(seed_bytes, &ms);
                let path = case_path("long", ext);
                std::fs::write(&path, &input).unwrap();
                let clock = Instant::now();
                let caught = std::panic::catch_unwind(|| read(&path));
                let took = clock.elapsed();
                let _ = std::fs::remove_file(&path);
                if caught.is_err() {
                    fail(name, &input, "panicked".into());
                } else if took > SLOW {
                    fail(name, &input, format!("took {took:?}"));
                }
            }
            // A command on a mutated file.
            1 => {
                let k = (0..commands.len()).new_tree(&mut runner).unwrap().current();
                let (template, seed_bytes) = &commands[k];
                *per_kind
                    .entry(format!("command {}", template.split(' ').next().unwrap_or("")))
                    .or_default() += 1;
                let input = mutate(seed_bytes, &ms);
                let out = out_dir();
                let file = out.join("input");
                std::fs::write(&file, &input).unwrap();
                let template = template
                    .replace("{in}", &file.display().to_string())
                    .replace("{pop}", &seeds().dir.join("pop.csv").display().to_string());
                let args = command_line(&template, "", &out);
                let o = run_command(&args, &seeds().dir);
                if let Some(problem) = check_outcome(&o, &out) {
                    fail(&args.join(" "), &input, problem);
                }
                let _ = std::fs::remove_dir_all(&out);
            }
            // A command with an extreme argument.
            _ => {
                let t = (0..COMMANDS.len()).new_tree(&mut runner).unwrap().current();
                let v = (0..EXTREMES.len()).new_tree(&mut runner).unwrap().current();
                *per_kind.entry("extreme argument".into()).or_default() += 1;
                let out = out_dir();
                let args = command_line(COMMANDS[t], EXTREMES[v], &out);
                let o = run_command(&args, &seeds().dir);
                if let Some(problem) = check_outcome(&o, &out) {
                    fail(&args.join(" "), &[], problem);
                }
                let _ = std::fs::remove_dir_all(&out);
            }
        }
    }
    println!("fuzz: {cases} cases, {failures} failures (seed {seed})");
    for (kind, n) in &per_kind {
        println!("  {kind}: {n}");
    }
    assert_eq!(failures, 0, "failing cases are in {}", failures_dir.display());
}
