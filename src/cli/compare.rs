//! `bezchain compare`: the paper's optimiser comparison on its three NACA 4413 cases, one table.

use super::fit::load;
use super::{write_json, Target};
use anyhow::Result;
use bezchain::chain::{ChainLayout, Continuity};
use bezchain::fit::{fit_curve, FitOptions, Method, PAPER_CASES};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `bezchain compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The contour (the paper used NACA 4413 with 82 points: `data/naca4413.dat`).
    pub input: PathBuf,
    /// Methods to compare, in table order.
    #[arg(long, value_delimiter = ',', default_value = "lsq,bfgs,nelder-mead", value_parser = parse_method)]
    pub methods: Vec<Method>,
    /// Also write the rows as JSON here (`-` for standard output).
    #[arg(long)]
    pub json: Option<PathBuf>,
}

fn parse_method(s: &str) -> Result<Method, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

/// One line of the table.
#[derive(Serialize)]
struct Row {
    case: usize,
    degree: usize,
    segments: usize,
    design_points: usize,
    expanded_points: usize,
    method: String,
    design_variables: usize,
    iterations: usize,
    evaluations: usize,
    seconds: f64,
    sum_sq: f64,
    max: f64,
    paper_total_offset: f64,
}

/// Run every method on every case and print the table.
pub fn run(args: Args) -> Result<()> {
    let loaded = load(&args.input)?;
    let to_stdout = matches!(args.json.as_deref().map(Target::parse), Some(Target::Stdout));
    let mut rows = Vec::new();
    // Rows are printed as they finish: the whole table takes tens of seconds.
    let emit = |text: &str| {
        if to_stdout {
            eprint!("{text}");
        } else {
            print!("{text}");
            let _ = std::io::Write::flush(&mut std::io::stdout());
        }
    };
    let mut table = String::new();
    table += &format!(
        "{}: {} points. Counts are the paper's; sum_sq is the closest-point sum of squares, re-measured.\n\n",
        args.input.display(),
        loaded.points.len()
    );
    table += "| case | degree | segments | design / expanded points | method | variables | iterations | evaluations | seconds | sum_sq | max | paper's total offset | sum_sq / paper |\n";
    table += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    emit(&table);
    for case in PAPER_CASES {
        for &method in &args.methods {
            let layout = ChainLayout::uniform(case.degree, case.segments, Continuity::C1)?;
            let opts = FitOptions {
                method,
                ..FitOptions::default()
            };
            let fit = fit_curve(&loaded.points, layout, &opts)?;
            let l = fit.chain.layout();
            let row = Row {
                case: case.case,
                degree: l.degree(),
                segments: l.segments(),
                design_points: l.design_count(),
                expanded_points: l.expanded_count(),
                method: method.name().to_string(),
                design_variables: 2 * l.design_count(),
                iterations: fit.report.iterations,
                evaluations: fit.report.evaluations,
                seconds: fit.report.seconds,
                sum_sq: fit.closest.sum_sq,
                max: fit.closest.max,
                paper_total_offset: case.total_offset,
            };
            emit(&format!(
                "| {} | {} | {} | {} / {} | {} | {} | {} | {} | {:.3} | {:.3e} | {:.2e} | {:.4e} | {:.1e} |\n",
                row.case,
                row.degree,
                row.segments,
                row.design_points,
                row.expanded_points,
                row.method,
                row.design_variables,
                row.iterations,
                row.evaluations,
                row.seconds,
                row.sum_sq,
                row.max,
                row.paper_total_offset,
                row.sum_sq / row.paper_total_offset
            ));
            rows.push(row);
        }
    }
    if let Some(path) = &args.json {
        write_json(&Target::parse(path), &rows)?;
    }
    Ok(())
}
