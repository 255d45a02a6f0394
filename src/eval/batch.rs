//! One-shot evaluation of a population file: the library side of `bezchain eval`, the door for
//! optimisers outside bezchain.
//!
//! Offsets are closest-point distances. Each data point's start parameters come from the
//! first individual: the point is projected onto that shape in f64 (sampling every segment or
//! patch, then Newton, see [`nearest`](super::nearest)). Every individual then refines those
//! parameters with [`BatchOptions::newton`] clamped Newton steps of its own in f32, free to
//! cross segment and patch borders, and keeps the least distance met. For individuals in the
//! basin of the first one (a GA or CMA-ES population around a current design) this is the true
//! closest-point distance to f32 accuracy; for an unrelated shape it is an upper bound (a
//! local, not global, foot point).
//!
//! The rows are read in f64 and the evaluator keeps its default reference, the centre of the
//! data (see [`kernel`](super::kernel)): exact for any population, with offsets accurate to
//! about `2⁻²⁴ ×` the data's extent wherever the data sit. (Anchoring at the first individual
//! would sharpen individuals close to it, but its Taylor polynomial grows inexact for
//! individuals whose foot points move far from the first's, across patch borders in
//! particular, which an outside optimiser's population may well do.)

use super::nearest::{curve_nearest, grid_nearest};
use super::{
    build_evaluator, Backend, BackendInfo, EvalLayout, EvalOptions, Fitness, Gene, GpuOptions, Targets,
};
use crate::chain::{ChainLayout, CurveChain, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};

/// Options of a one-shot population evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchOptions {
    /// Where to run. Default: [`Backend::Auto`].
    pub backend: Backend,
    /// Newton steps per point and individual from the first individual's foot points.
    /// Default: 8.
    pub newton: u32,
    /// Samples per segment (curves) or per patch direction (grids) of the f64 projection onto
    /// the first individual. Default: 16.
    pub samples: usize,
    /// Evaluate the population this many more times after the first, timing each (for
    /// comparisons with other tools on the same population). Default: 0.
    pub repeat: usize,
    /// GPU settings. Default: [`GpuOptions::default`].
    pub gpu: GpuOptions,
}

impl Default for BatchOptions {
    fn default() -> Self {
        BatchOptions {
            backend: Backend::Auto,
            newton: 8,
            samples: 16,
            repeat: 0,
            gpu: GpuOptions::default(),
        }
    }
}

/// The fitness of every individual, in input order, and where it was computed.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchResult {
    /// One `(sum_sq, max)` per individual.
    pub fitness: Vec<Fitness>,
    /// The backend and adapter that ran.
    pub info: BackendInfo,
    /// The median seconds of one evaluation of the whole population over the
    /// [`BatchOptions::repeat`] timed ones (`None` without).
    pub seconds_median: Option<f64>,
}

/// The first row of `population`, checked to be a whole number of rows of `n_vars` finite
/// leading values, in f64.
fn first_row<T: Gene>(population: &[T], n_vars: usize) -> Result<Vec<f64>> {
    if population.is_empty() {
        return Err(Error::invalid("the population has no individuals"));
    }
    if !population.len().is_multiple_of(n_vars) {
        return Err(Error::invalid(format!(
            "population of {} values is not a whole number of rows of {n_vars} design variables",
            population.len()
        )));
    }
    let row: Vec<f64> = population[..n_vars].iter().map(|&x| x.to_f64()).collect();
    if row.iter().any(|x| !x.is_finite()) {
        return Err(Error::invalid(
            "the first individual has non-finite design variables",
        ));
    }
    Ok(row)
}

/// Evaluate a population of curve chains of `layout` against `points`: rows of
/// `x0,y0,x1,y1,…` over the layout's design points, in f32 or f64.
pub fn eval_curve_population<T: Gene>(
    layout: &ChainLayout,
    points: &[DVec2],
    population: &[T],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let row = first_row(population, layout.design_count() * 2)?;
    let design: Vec<DVec2> = row.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect();
    let chain = CurveChain::new(layout.clone(), design)?;
    let t: Vec<f64> = curve_nearest(&chain, points, options.samples)
        .into_iter()
        .map(|(t, _)| t)
        .collect();
    let targets = Targets::curve(points, &t)?;
    run(EvalLayout::Curve(layout.clone()), &targets, population, options)
}

/// Evaluate a population of patch grids of `layout` against `points`: rows of `x,y,z` per
/// design point of the row-major design net, in f32 or f64.
pub fn eval_grid_population<T: Gene>(
    layout: &GridLayout,
    points: &[DVec3],
    population: &[T],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let (nu, nv) = layout.design_shape();
    let row = first_row(population, nu * nv * 3)?;
    let design: Vec<DVec3> = row
        .chunks_exact(3)
        .map(|c| DVec3::new(c[0], c[1], c[2]))
        .collect();
    let grid = PatchGrid::new(layout.clone(), design)?;
    let uv: Vec<DVec2> = grid_nearest(&grid, points, options.samples)
        .into_iter()
        .map(|(uv, _)| uv)
        .collect();
    let targets = Targets::grid(points, &uv)?;
    run(EvalLayout::Grid(layout.clone()), &targets, population, options)
}

fn run<T: Gene>(
    layout: EvalLayout,
    targets: &Targets,
    population: &[T],
    options: &BatchOptions,
) -> Result<BatchResult> {
    let mut evaluator = build_evaluator(
        &layout,
        targets,
        &EvalOptions {
            backend: options.backend,
            newton: options.newton,
            cross_patches: true,
            gpu: options.gpu.clone(),
        },
    )?;
    let mut fitness = vec![Fitness::default(); population.len() / evaluator.design_variables()];
    T::evaluate_on(evaluator.as_mut(), population, &mut fitness)?;
    let mut times: Vec<f64> = (0..options.repeat)
        .map(|_| {
            let clock = std::time::Instant::now();
            T::evaluate_on(evaluator.as_mut(), population, &mut fitness)
                .map(|()| clock.elapsed().as_secs_f64())
        })
        .collect::<Result<_>>()?;
    times.sort_by(f64::total_cmp);
    Ok(BatchResult {
        fitness,
        info: evaluator.info().clone(),
        seconds_median: times.get(times.len() / 2).copied(),
    })
}

/// Read a population file: one individual per line, `n_vars` comma- (or blank-) separated
/// numbers each (the design points flattened `x0,y0,x1,y1,…`). Blank lines and lines starting
/// with `#` are skipped, and so is a first line that is not numeric (a header).
pub fn read_population(path: &std::path::Path, n_vars: usize) -> Result<Vec<f32>> {
    let text = read_text(path)?;
    parse_population(&text, path, n_vars)
}

/// [`read_population`] in f64, for designs whose coordinates f32 cannot hold finely enough
/// (data far from the origin).
pub fn read_population_f64(path: &std::path::Path, n_vars: usize) -> Result<Vec<f64>> {
    let text = read_text(path)?;
    parse_rows(&text, path, n_vars, f64::MAX)
}

fn read_text(path: &std::path::Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// [`read_population`] on text in memory; `path` names the source in errors.
pub fn parse_population(text: &str, path: &std::path::Path, n_vars: usize) -> Result<Vec<f32>> {
    let rows = parse_rows(text, path, n_vars, f64::from(f32::MAX))?;
    Ok(rows.iter().map(|&v| v as f32).collect())
}

/// The rows of a population file as f64, every value finite and at most `limit` in size.
fn parse_rows(text: &str, path: &std::path::Path, n_vars: usize, limit: f64) -> Result<Vec<f64>> {
    let parse_error = |line: usize, message: String| Error::Parse {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut out = Vec::new();
    let mut seen_row = false;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        let values: std::result::Result<Vec<f64>, _> = fields.iter().map(|f| f.parse::<f64>()).collect();
        let values = match values {
            Ok(v) => v,
            // A header line before the first individual.
            Err(_) if !seen_row && fields.iter().any(|f| f.chars().any(char::is_alphabetic)) => continue,
            Err(_) => {
                let shown: String = line.chars().take(48).collect();
                return Err(parse_error(i + 1, format!("not a row of numbers: '{shown}'")));
            }
        };
        seen_row = true;
        if values.len() != n_vars {
            return Err(parse_error(
                i + 1,
                format!(
                    "{} values, the layout has {n_vars} design variables",
                    values.len()
                ),
            ));
        }
        if let Some(bad) = values.iter().find(|v| !v.is_finite() || v.abs() > limit) {
            let kind = if limit < f64::MAX { "f32 " } else { "" };
            return Err(parse_error(i + 1, format!("{bad} is not a finite {kind}number")));
        }
        out.extend_from_slice(&values);
    }
    if out.is_empty() {
        return Err(Error::Input {
            path: path.to_path_buf(),
            message: "no individuals (one row of design variables per individual expected)".into(),
        });
    }
    Ok(out)
}

#[cfg(test)]
mod population_file_tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn rows_headers_and_errors() {
        let p = Path::new("pop.csv");
        let v = parse_population("x0,y0,x1,y1\n1,2,3,4\n\n# comment\n5 6 7 8\n", p, 4).unwrap();
        assert_eq!(v, vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        let e = parse_population("1,2,3,4\n1,2,3\n", p, 4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pop.csv:2") && e.contains("3 values"), "{e}");
        let e = parse_population("1,2,3,4\n1,2,x,4\n", p, 4)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pop.csv:2"), "{e}");
        let e = parse_population("1,2,NaN,4\n", p, 4).unwrap_err().to_string();
        assert!(e.contains("pop.csv:1"), "{e}");
        let e = parse_population("1,2,1e300,4\n", p, 4).unwrap_err().to_string();
        assert!(e.contains("pop.csv:1"), "{e}");
        assert!(matches!(
            parse_population("# nothing\n", p, 4),
            Err(Error::Input { .. })
        ));
    }
}
