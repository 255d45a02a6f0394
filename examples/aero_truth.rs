//! The panel method against the Kármán–Trefftz aerofoil's exact potential flow: CL, CM and Cp
//! errors against the number of nodes, with the observed order of convergence, for XFOIL's
//! default paneling and for one with twice its trailing-edge density.
//!
//! `cargo run --release --example aero_truth` prints the Markdown tables of the README.

use bezchain::aero::{KarmanTrefftz, Paneling};
use glam::DVec2;

fn main() -> bezchain::Result<()> {
    let kt = KarmanTrefftz::new(DVec2::new(-0.1, 0.1), 10.0);
    println!(
        "Kármán–Trefftz aerofoil: circle centre (-0.1, 0.1), b = 1, trailing-edge angle 10°, chord {:.4}",
        kt.chord().length
    );
    for te_ratio in [0.15, 0.3] {
        println!();
        println!("trailing-edge density ratio {te_ratio}:");
        println!();
        println!("| α | nodes | CL exact | CL | CL error | order | CM error | max abs Cp error (TE nodes excluded) | order | Cp error at the TE nodes |");
        println!("|---|---|---|---|---|---|---|---|---|---|");
        for alpha in [0.0, 4.0, 8.0] {
            let mut last: Option<(f64, f64, f64)> = None;
            for nodes in [40, 80, 160, 320, 640] {
                let e = kt.errors(&Paneling { nodes, te_ratio }, alpha)?;
                let order = |now: f64, before: f64, n0: f64| (before / now).ln() / (nodes as f64 / n0).ln();
                let (ocl, ocp) = match last {
                    Some((cl0, cp0, n0)) => (
                        format!("{:.2}", order(e.cl_rel, cl0, n0)),
                        format!("{:.2}", order(e.cp_max, cp0, n0)),
                    ),
                    None => (String::new(), String::new()),
                };
                println!(
                    "| {alpha} | {nodes} | {:.6} | {:.6} | {:.2}% | {ocl} | {:.1e} | {:.1e} | {ocp} | {:.2} |",
                    e.cl_exact,
                    e.cl,
                    100.0 * e.cl_rel,
                    e.cm_abs,
                    e.cp_max,
                    e.cp_te
                );
                last = Some((e.cl_rel, e.cp_max, nodes as f64));
            }
        }
    }
    Ok(())
}
