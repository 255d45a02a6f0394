//! Population evaluation: `bezchain eval` as an object.

use crate::convert::*;
use crate::shapes::{Chain, Surface};
use bezchain::chain::{ChainLayout, GridLayout};
use bezchain::eval::Backend;
use bezchain::fit::population::{
    self, eval_curve_population, eval_grid_population, BatchOptions, F32Overflow,
};
use bezchain::geometry::{check_scale, Precision};
use glam::{DVec2, DVec3};
use numpy::PyArray2;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// The layout and data an [`Evaluator`] measures populations against (one per evaluator,
/// never in a collection: the variants' sizes do not matter).
#[allow(clippy::large_enum_variant)]
enum EvalShape {
    Curve(ChainLayout, Vec<DVec2>),
    Grid(GridLayout, Vec<DVec3>),
}

/// The fitness of populations of designs of one layout against fixed data: `bezchain eval`
/// as an object (the first individual of each population is the reference the others' foot
/// points start from, as there).
#[pyclass(module = "bezchain._bezchain", frozen)]
pub(crate) struct Evaluator {
    shape: EvalShape,
    options: BatchOptions,
    info: std::sync::Mutex<String>,
}

#[pymethods]
impl Evaluator {
    /// `chain`: a Chain (or Surface) whose layout the designs use; `points`: the data, an
    /// `(N, 2)` array for a chain, an `(M, 3)` or `(M, 5)` cloud for a surface; `backend`:
    /// `auto`, `gpu` or `cpu` (as `--backend`); `newton` and `seeds` as `bezchain eval`'s.
    #[new]
    #[pyo3(signature = (chain, points, backend="auto", newton=8, seeds=None))]
    fn new(
        py: Python<'_>,
        chain: &Bound<'_, PyAny>,
        points: &Bound<'_, PyAny>,
        backend: &str,
        newton: u32,
        seeds: Option<u32>,
    ) -> PyResult<Evaluator> {
        let backend: Backend = word(backend)?;
        let shape = if let Ok(c) = chain.cast::<Chain>() {
            let pts = curve_points(py, points)?;
            EvalShape::Curve(c.get().chain.layout().clone(), pts)
        } else if let Ok(s) = chain.cast::<Surface>() {
            let (pts, _) = cloud_points(py, points)?;
            EvalShape::Grid(s.get().grid.layout().clone(), pts)
        } else {
            return Err(PyValueError::new_err("chain: expected a Chain or a Surface"));
        };
        let check = match &shape {
            EvalShape::Curve(_, p) => check_scale(p, Precision::F32),
            EvalShape::Grid(_, p) => check_scale(p, Precision::F32),
        };
        if let Err((at, message)) = check {
            let at = at.map_or(String::new(), |k| format!(" (point {})", k + 1));
            return Err(PyValueError::new_err(format!("points{at}: {message}")));
        }
        Ok(Evaluator {
            shape,
            options: BatchOptions {
                backend,
                newton,
                seeds,
                ..BatchOptions::default()
            },
            info: std::sync::Mutex::new(String::new()),
        })
    }

    /// Design variables per individual: `2 ×` design points (x, y each) for a chain, `3 ×`
    /// design-net points (row-major) for a surface.
    #[getter]
    fn n_vars(&self) -> usize {
        match &self.shape {
            EvalShape::Curve(l, _) => 2 * l.design_count(),
            EvalShape::Grid(l, _) => {
                let (nu, nv) = l.design_shape();
                3 * nu * nv
            }
        }
    }

    /// The backend and adapter of the last evaluation (`bezchain eval`'s last line).
    #[getter]
    fn info(&self) -> String {
        self.info.lock().map(|s| s.clone()).unwrap_or_default()
    }

    /// The fitness of every row of `population` (shape `(P, n_vars)`, float64): a `(P, 2)`
    /// array of `(sum_sq, max)`, the numbers `bezchain eval` prints for that population. The
    /// GIL is released while it runs.
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        population: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (pop, cols) = rows(population, "population")?;
        let n_vars = self.n_vars();
        if cols != n_vars {
            return Err(PyValueError::new_err(format!(
                "population: {cols} columns, but the layout has {n_vars} design variables"
            )));
        }
        let overflow = match &self.shape {
            EvalShape::Curve(_, p) => population::check_f32(p, &pop, n_vars),
            EvalShape::Grid(_, p) => population::check_f32(p, &pop, n_vars),
        };
        if let Err(o) = overflow {
            return Err(PyValueError::new_err(match o {
                F32Overflow::Data(at, message) => {
                    let at = at.map_or(String::new(), |k| format!(" (point {})", k + 1));
                    format!("points{at}: {message}")
                }
                F32Overflow::Individual(k, i, message) => {
                    format!(
                        "population: individual {} (its row {}), variable {}: {message}",
                        k + 1,
                        k + 1,
                        i + 1
                    )
                }
            }));
        }
        let result = py
            .detach(|| match &self.shape {
                EvalShape::Curve(l, p) => eval_curve_population(l, p, &pop, &self.options),
                EvalShape::Grid(l, p) => eval_grid_population(l, p, &pop, &self.options),
            })
            .map_err(py_err)?;
        if let Some(k) = result
            .fitness
            .iter()
            .position(|f| !(f.sum_sq.is_finite() && f.max.is_finite()))
        {
            return Err(PyRuntimeError::new_err(format!(
                "population: individual {}: the evaluator's fitness is not finite (sum_sq {}, max {})",
                k + 1,
                result.fitness[k].sum_sq,
                result.fitness[k].max
            )));
        }
        if let Ok(mut info) = self.info.lock() {
            *info = result.info.to_string();
        }
        array2(
            py,
            result
                .fitness
                .iter()
                .flat_map(|f| [f64::from(f.sum_sq), f64::from(f.max)])
                .collect(),
            2,
        )
    }
}
