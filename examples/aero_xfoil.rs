//! The panel method beside XFOIL's inviscid numbers (`data/xfoil/inviscid.csv`) on every
//! aerofoil file the project ships: `cargo run --release --example aero_xfoil` prints the
//! README's table.

use bezchain::aero::{Analysis, Paneling};
use bezchain::geometry::read_curve;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let text = std::fs::read_to_string("data/xfoil/inviscid.csv")?;
    let rows: Vec<(String, f64, f64, f64)> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("file,"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Ok((f[0].to_string(), f[1].parse()?, f[2].parse()?, f[3].parse()?))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut files: Vec<String> = rows.iter().map(|r| r.0.clone()).collect();
    files.dedup();
    files.insert(
        files
            .iter()
            .position(|f| f.ends_with("clarky.dat"))
            .map_or(0, |k| k + 1),
        "data/airfoils/clarky_lednicer.dat".into(),
    );
    println!("| file | α | CL | CL XFOIL | ΔCL | CM | CM XFOIL | ΔCM |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut worst_cl, mut worst_cm) = (0.0f64, 0.0f64);
    for file in &files {
        let source = if file.ends_with("clarky_lednicer.dat") {
            "data/airfoils/clarky.dat"
        } else {
            file
        };
        let pts = read_curve(Path::new(file))?.points;
        let a = Analysis::of_points(&pts, &Paneling::default())?;
        for r in rows.iter().filter(|r| r.0 == source) {
            let c = a.solution.coefficients(r.1);
            let dcl = (c.cl - r.2) / r.2;
            worst_cl = worst_cl.max(dcl.abs());
            worst_cm = worst_cm.max((c.cm - r.3).abs());
            let name = Path::new(file).file_stem().unwrap_or_default().to_string_lossy();
            println!(
                "| {name} | {} | {:.4} | {:.4} | {:+.2} % | {:.4} | {:.4} | {:+.4} |",
                r.1,
                c.cl,
                r.2,
                100.0 * dcl,
                c.cm,
                r.3,
                c.cm - r.3
            );
        }
    }
    println!();
    println!(
        "largest |ΔCL| {:.2} %, largest |ΔCM| {:.4}",
        100.0 * worst_cl,
        worst_cm
    );
    Ok(())
}
