//! The compression table of the README: `bezchain adapt` on every aerofoil file in the given
//! folders (or files) at each tolerance, beside the peer figures found in a `README.md` next
//! to the files (the table of `data/airfoils/README.md`).
//!
//! ```text
//! cargo run --release --example adapt_table -- data/airfoils data \
//!     [--tols 1e-3,1e-4] [--json-dir DIR] [--repeat N]
//! ```
//!
//! Tolerances are in units of the chord (the files have unit chord). With `--json-dir` each
//! report is written as `DIR/<stem>_<tol>.json` (the adapt report of `docs/ARCHITECTURE.md`,
//! for any outside checker). `--repeat N` runs each case N times and reports the median seconds.

use anyhow::{bail, Context, Result};
use bezchain::adaptive::{adapt_curve, AdaptOptions};
use bezchain::export::AdaptReport;
use bezchain::export::InputInfo;
use bezchain::geometry::read_curve;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Peer figures: (stem, tol) → (splprep coefficients, CST coefficients).
type Peers = HashMap<(String, String), (usize, usize)>;

fn first_int(cell: &str) -> Option<usize> {
    let digits: String = cell.trim().chars().take_while(|c| c.is_ascii_digit()).collect();
    digits.parse().ok()
}

/// The peer table of a README next to the data files, if any.
fn read_peers(dir: &Path, peers: &mut Peers) {
    let Ok(text) = std::fs::read_to_string(dir.join("README.md")) else {
        return;
    };
    for line in text.lines() {
        let cells: Vec<&str> = line.trim().trim_matches('|').split('|').map(str::trim).collect();
        if cells.len() >= 4 && cells[1].starts_with("1e-") {
            if let (Some(sp), Some(cst)) = (first_int(cells[2]), first_int(cells[3])) {
                peers.insert((cells[0].to_string(), cells[1].to_string()), (sp, cst));
            }
        }
    }
}

fn main() -> Result<()> {
    let mut inputs = Vec::new();
    let mut tols = vec!["1e-3".to_string(), "1e-4".to_string()];
    let mut json_dir: Option<PathBuf> = None;
    let mut repeat = 1usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--tols" => {
                tols = args
                    .next()
                    .context("--tols needs a list")?
                    .split(',')
                    .map(String::from)
                    .collect()
            }
            "--json-dir" => json_dir = Some(args.next().context("--json-dir needs a folder")?.into()),
            "--repeat" => repeat = args.next().context("--repeat needs a count")?.parse()?,
            _ => inputs.push(PathBuf::from(a)),
        }
    }
    if inputs.is_empty() {
        bail!("usage: adapt_table FOLDER_OR_FILE... [--tols 1e-3,1e-4] [--json-dir DIR] [--repeat N]");
    }
    let mut files = Vec::new();
    let mut peers = Peers::new();
    for input in &inputs {
        if input.is_dir() {
            read_peers(input, &mut peers);
            let mut found: Vec<PathBuf> = std::fs::read_dir(input)?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|e| e == "dat"))
                .collect();
            found.sort();
            files.extend(found);
        } else {
            files.push(input.clone());
        }
    }
    if let Some(dir) = &json_dir {
        std::fs::create_dir_all(dir)?;
    }
    println!("| file | points | tol | scalars | splprep | CST | scalars / CST | max | rms | held-out max | seconds | layout |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for file in &files {
        let loaded = read_curve(file)?;
        let stem = file
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        for tol_text in &tols {
            let tol: f64 = tol_text
                .parse()
                .with_context(|| format!("tolerance {tol_text}"))?;
            let opts = AdaptOptions {
                tol,
                ..AdaptOptions::default()
            };
            let mut times = Vec::new();
            let mut result = None;
            for _ in 0..repeat.max(1) {
                let r = adapt_curve(&loaded.points, &opts)?;
                times.push(r.seconds);
                result = Some(r);
            }
            let Some(r) = result else { continue };
            times.sort_by(f64::total_cmp);
            let seconds = times[times.len() / 2];
            // `clarky_lednicer` holds the same points as `clarky` in Lednicer's layout: the
            // same peer figures apply.
            let peer = peers.get(&(stem.clone(), tol_text.clone())).or_else(|| {
                let base = stem.strip_suffix("_lednicer")?;
                peers.get(&(base.to_string(), tol_text.clone()))
            });
            let (sp, cst, ratio) = match peer {
                Some(&(sp, cst)) => (
                    sp.to_string(),
                    cst.to_string(),
                    format!("{:.2}", r.count.total as f64 / cst as f64),
                ),
                None => ("".into(), "".into(), "".into()),
            };
            let held = r.held_out.map_or("n/a".to_string(), |h| format!("{:.2e}", h.max));
            let mark = if r.met { "" } else { " (not met)" };
            println!(
                "| {stem} | {} | {tol_text} | {}{mark} | {sp} | {cst} | {ratio} | {:.2e} | {:.2e} | {held} | {seconds:.3} | {} |",
                loaded.points.len(),
                r.count.total,
                r.offset.max,
                r.offset.rms,
                r.family
            );
            if let Some(dir) = &json_dir {
                let report = AdaptReport::new(
                    &r,
                    &opts,
                    InputInfo {
                        path: file.display().to_string(),
                        points: loaded.points.len(),
                    },
                );
                let path = dir.join(format!("{stem}_{tol_text}.json"));
                std::fs::write(&path, serde_json::to_string_pretty(&report)? + "\n")?;
            }
        }
    }
    Ok(())
}
