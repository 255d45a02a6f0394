//! `bezchain sample`: a fitted patch grid evaluated densely (the dense evaluator, GPU when
//! present) and written as a point cloud.

use super::output::Outputs;
use super::{parse_word, usage};
use anyhow::Result;
use bezchain::eval::dense::{dense_grid, uniform};
use bezchain::eval::Backend;
use bezchain::export::Report;
use bezchain::geometry::{write_csv_to, Grid};
use glam::DVec3;
use std::path::PathBuf;

/// Arguments of `bezchain sample`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A surface fit report (JSON, `"kind": "surface"`).
    pub report: PathBuf,
    /// Samples along u (around the section), evenly spaced in the global parameter, at least 2.
    #[arg(long, default_value_t = 101)]
    pub u: usize,
    /// Samples along v (along the span), evenly spaced in the global parameter, at least 2.
    #[arg(long, default_value_t = 101)]
    pub v: usize,
    /// Where to evaluate: auto (a hardware GPU when one is found, else the CPU), gpu (lavapipe
    /// too) or cpu.
    #[arg(long, default_value = "auto", value_parser = parse_word::<Backend>)]
    pub backend: Backend,
    /// The cloud: CSV `x,y,z,section,index`, one section per v sample (`-` for standard
    /// output). Points are within about 2.4e-7 of the grid's extent of the f64 surface.
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Sample the report's grid and write the cloud.
pub fn run(args: Args) -> Result<()> {
    if args.u < 2 || args.v < 2 {
        return Err(usage(format!(
            "--u and --v need at least 2 samples each (got {} x {})",
            args.u, args.v
        )));
    }
    if args.u.checked_mul(args.v).is_none_or(|n| n > 100_000_000) {
        return Err(usage(format!(
            "{} x {} samples is more than 100 million points",
            args.u, args.v
        )));
    }
    let mut outs = Outputs::new();
    let out = outs.add("--output", &args.output)?;
    let grid = match Report::read(&args.report)? {
        Report::Surface(rep) => rep.grid()?,
        Report::Curve(_) => {
            return Err(usage(format!(
                "{}: a curve report; sample takes a surface report",
                args.report.display()
            )))
        }
    };
    let clock = std::time::Instant::now();
    let (points, info) = dense_grid(&grid, &uniform(args.u), &uniform(args.v), args.backend)?;
    let seconds = clock.elapsed().as_secs_f64();
    // Section-major, one section per v sample: the order `fit-surface` reads sections in.
    let ordered: Vec<DVec3> = (0..args.v)
        .flat_map(|iv| (0..args.u).map(move |iu| iu * args.v + iv))
        .map(|k| points[k].position)
        .collect();
    let sections = Grid {
        sections: args.v,
        per_section: args.u,
    };
    let mut text = Vec::new();
    write_csv_to(&mut text, &ordered, Some(sections))?;
    outs.put(out, &text)?;
    outs.commit()?;
    tell!(
        "{}: {} x {} points ({} sections) evaluated in {seconds:.3} s on {info} → {}",
        args.report.display(),
        args.u,
        args.v,
        args.v,
        args.output.display()
    );
    Ok(())
}
