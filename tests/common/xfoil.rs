//! XFOIL 6.99 as the opt-in cross-checks run it: one aerofoil file, PANE (160 nodes), one
//! session of OPER commands, the polar file's rows read back. Needs `xvfb-run` and `xfoil` on
//! the path (`apt-get install -y xfoil xvfb xauth xfonts-base`: XFOIL opens an X font when it
//! plots and dies without one).

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// True when `BEZCHAIN_XFOIL=1` asks for the cross-checks; otherwise says how to ask.
pub fn wanted() -> bool {
    let on = std::env::var("BEZCHAIN_XFOIL").as_deref() == Ok("1");
    if !on {
        eprintln!("skipped: set BEZCHAIN_XFOIL=1 to run XFOIL");
    }
    on
}

/// XFOIL's polar rows for `file` (each row: α, CL, CD, CDp, CM, top and bottom transition),
/// after `setup` (OPER commands before the polar is opened, e.g. `VISC 1e6\nITER 200\n`) and
/// `sweep` (e.g. `ASEQ -2 8 1` or `ALFA 0\nALFA 4`). A point that did not converge has no row.
/// `Err` holds XFOIL's exit status and the first lines it printed on standard error when it
/// wrote no polar at all.
pub fn polar(file: &Path, setup: &str, sweep: &str) -> Result<Vec<Vec<f64>>, String> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(file, dir.path().join("a.dat")).unwrap();
    let mut child = Command::new("xvfb-run")
        .args(["-a", "xfoil"])
        .current_dir(dir.path())
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("xvfb-run and xfoil are installed (apt-get install -y xfoil xvfb xauth xfonts-base)");
    let script = format!("LOAD a.dat\n\nPANE\nOPER\n{setup}PACC\npol.txt\n\n{sweep}\n\nQUIT\n");
    child.stdin.take().unwrap().write_all(script.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    let text = std::fs::read_to_string(dir.path().join("pol.txt")).map_err(|_| {
        let err = String::from_utf8_lossy(&out.stderr);
        let first: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).take(2).collect();
        format!("{} ({})", out.status, first.join("; "))
    })?;
    Ok(text
        .lines()
        .filter(|l| {
            l.trim_start()
                .starts_with(|c: char| c.is_ascii_digit() || c == '-')
        })
        .map(|l| {
            l.split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect::<Vec<f64>>()
        })
        .filter(|f| f.len() >= 7)
        .collect())
}
