//! The paper's three NACA 4413 cases (WCE 2008, Figs. 9–11; `docs/ARCHITECTURE.md` §2.5) and its
//! optimiser comparison on them ([`compare`]).

use super::curve::{fit_curve, FitOptions};
use super::report::backend_label;
use crate::chain::{ChainLayout, Continuity};
use crate::error::Result;
use crate::eval::BackendInfo;
use crate::optim::evo::{EvoOptions, GA_GENERATIONS, GA_POPULATION};
use crate::optim::Method;
use glam::DVec2;
use serde::Serialize;

/// One of the paper's 2D cases: its layout, counts and reported total offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperCase {
    /// Case number as in the paper (1, 2, 3).
    pub case: usize,
    /// Degree of every segment.
    pub degree: usize,
    /// Number of chained segments.
    pub segments: usize,
    /// Design points the paper lists.
    pub design_points: usize,
    /// Expanded control points the paper lists.
    pub expanded_points: usize,
    /// The paper's "total offset" over the 82 points (matches a sum of squares at unit chord).
    pub total_offset: f64,
}

/// The three cases, in the paper's order.
pub const PAPER_CASES: [PaperCase; 3] = [
    PaperCase {
        case: 1,
        degree: 3,
        segments: 5,
        design_points: 12,
        expanded_points: 16,
        total_offset: 2.3751e-6,
    },
    PaperCase {
        case: 2,
        degree: 4,
        segments: 3,
        design_points: 11,
        expanded_points: 13,
        total_offset: 0.0018,
    },
    PaperCase {
        case: 3,
        degree: 5,
        segments: 3,
        design_points: 14,
        expanded_points: 16,
        total_offset: 1.2705e-4,
    },
];

/// One row of the paper's optimiser comparison: a case, a method, its effort and offsets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CompareRow {
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
    #[serde(skip_serializing_if = "Option::is_none")]
    backend: Option<String>,
}

impl CompareRow {
    /// The row as a line of the Markdown table (the last column: `sum_sq` over the paper's
    /// total offset).
    #[must_use]
    pub fn line(&self) -> String {
        format!(
            "| {} | {} | {} | {} / {} | {} | {} | {} | {} | {:.3} | {:.3e} | {:.2e} | {:.4e} | {:.1e} |\n",
            self.case,
            self.degree,
            self.segments,
            self.design_points,
            self.expanded_points,
            self.method,
            self.design_variables,
            self.iterations,
            self.evaluations,
            self.seconds,
            self.sum_sq,
            self.max,
            self.paper_total_offset,
            self.sum_sq / self.paper_total_offset
        )
    }
}

/// The head of the comparison's Markdown table: the contour `input` and its `points`, the
/// evolutionary settings of `evo` when `methods` has an evolutionary one, the column titles.
#[must_use]
pub fn compare_head(input: &str, points: usize, methods: &[Method], evo: &EvoOptions) -> String {
    let mut head = format!(
        "{input}: {points} points. Counts are the paper's; sum_sq is the closest-point sum of squares, re-measured.\n\n"
    );
    if methods.iter().any(|m| m.evolutionary().is_some()) {
        head += &format!(
            "ga and cmaes: population {}, at most {} generations, seed {}; cmaes restarts {}; iterations are \
             generations and evaluations individuals.\n\n",
            evo.population.unwrap_or(GA_POPULATION),
            evo.generations.unwrap_or(GA_GENERATIONS),
            evo.seed,
            match evo.cmaes.restarts {
                usize::MAX => "while generations remain".to_string(),
                r => format!("at most {r} times"),
            }
        );
    }
    head += "| case | degree | segments | design / expanded points | method | variables | iterations | evaluations | seconds | sum_sq | max | paper's total offset | sum_sq / paper |\n";
    head += "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    head
}

/// The end of the comparison's table: the `backends` the evolutionary methods ran on, and the
/// `seconds` the whole comparison took.
#[must_use]
pub fn compare_tail(backends: &[BackendInfo], seconds: f64) -> String {
    let mut tail = String::new();
    for b in backends {
        tail += &format!("\nga and cmaes evaluated on {b}");
    }
    tail += &format!("\ntotal {seconds:.1} s\n");
    tail
}

/// The JSON report of the comparison: the table's rows, one a case and method.
#[derive(Serialize)]
pub struct CompareReport<'a> {
    /// The rows in table order.
    pub rows: &'a [CompareRow],
}

/// The paper's optimiser comparison: every method of `methods` on every case of
/// [`PAPER_CASES`] fitted to `points` (C1 chains), the evolutionary ones with `evo`; each row
/// goes to `on_row` when it is done. Returns the rows and the backends the evolutionary methods
/// ran on.
pub fn compare(
    points: &[DVec2],
    methods: &[Method],
    evo: &EvoOptions,
    on_row: &mut dyn FnMut(&CompareRow),
) -> Result<(Vec<CompareRow>, Vec<BackendInfo>)> {
    let mut rows = Vec::new();
    let mut backends: Vec<BackendInfo> = Vec::new();
    for case in PAPER_CASES {
        for &method in methods {
            let layout = ChainLayout::uniform(case.degree, case.segments, Continuity::C1)?;
            let opts = FitOptions {
                method,
                evo: evo.clone(),
                ..FitOptions::default()
            };
            let fit = fit_curve(points, layout, &opts)?;
            let backend = fit.evolution.as_ref().map(|e| e.run.backend.clone());
            let l = fit.chain.layout();
            let row = CompareRow {
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
                backend: backend.as_ref().map(backend_label),
            };
            if let Some(info) = backend {
                if !backends.contains(&info) {
                    backends.push(info);
                }
            }
            on_row(&row);
            rows.push(row);
        }
    }
    Ok((rows, backends))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The head names the input and, only when an evolutionary method is compared, its
    /// settings (restarts unbounded: while generations remain); the tail every backend.
    #[test]
    fn the_table_head_and_tail_say_what_ran() {
        let evo = EvoOptions {
            population: Some(64),
            generations: Some(20),
            cmaes: crate::optim::evo::CmaesOptions {
                restarts: usize::MAX,
                ..Default::default()
            },
            ..EvoOptions::default()
        };
        let head = compare_head("a.dat", 82, &[Method::Bfgs, Method::Cmaes], &evo);
        assert!(head.starts_with("a.dat: 82 points."), "{head}");
        assert!(
            head.contains(
                "population 64, at most 20 generations, seed 1; cmaes restarts while generations remain"
            ),
            "{head}"
        );
        assert_eq!(head.lines().filter(|l| l.starts_with('|')).count(), 2);
        let evo = EvoOptions {
            cmaes: crate::optim::evo::CmaesOptions {
                restarts: 2,
                ..Default::default()
            },
            ..evo
        };
        let head = compare_head("a.dat", 82, &[Method::Cmaes], &evo);
        assert!(head.contains("cmaes restarts at most 2 times"), "{head}");
        assert!(!compare_head("a.dat", 82, &[Method::Lsq], &evo).contains("ga and cmaes"));
        assert_eq!(compare_tail(&[], 1.04), "\ntotal 1.0 s\n");
    }
}
