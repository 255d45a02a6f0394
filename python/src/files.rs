//! Files and generators: aerofoil files, NACA sections, blade definitions.

use crate::convert::*;
use bezchain::geometry::{
    check_scale, read_curve, Blade, LoftOptions, Naca, NacaOptions, Precision, Spacing, MAX_NACA_POINTS,
};
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Read an aerofoil or contour file (Selig or Lednicer `.dat`, CSV or XYZ rows) as `bezchain`
/// reads it: an `(N, 2)` array; the reader's repairs become warnings.
#[pyfunction]
pub(crate) fn read_aerofoil<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let path = path_of(path)?;
    let loaded = py.detach(|| read_curve(&path)).map_err(py_err)?;
    warn_all(py, &path.display().to_string(), &loaded.warnings)?;
    points2(py, &loaded.points)
}

/// A NACA 4- or 5-digit aerofoil, upper trailing edge → leading edge → lower trailing edge,
/// as `bezchain naca CODE --points N` writes it: an `(N, 2)` array.
#[pyfunction]
#[pyo3(signature = (code, points=161, spacing="cosine", closed_te=false))]
pub(crate) fn naca<'py>(
    py: Python<'py>,
    code: &str,
    points: usize,
    spacing: &str,
    closed_te: bool,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    if points > MAX_NACA_POINTS {
        return Err(PyValueError::new_err(format!(
            "--points {points} is more than the largest allowed, {MAX_NACA_POINTS}; a few hundred points resolve \
             any section"
        )));
    }
    let spacing = match spacing.to_ascii_lowercase().as_str() {
        "cosine" => Spacing::Cosine,
        "uniform" => Spacing::Uniform,
        _ => {
            return Err(PyValueError::new_err(format!(
                "spacing '{spacing}': expected cosine or uniform"
            )))
        }
    };
    let naca = Naca::parse(code).map_err(py_err)?;
    let pts = naca
        .contour(&NacaOptions {
            points,
            spacing,
            closed_te,
        })
        .map_err(py_err)?;
    points2(py, &pts)
}

/// Loft a blade definition (bezchain JSON, windIO YAML, AeroDyn 15) into the cloud
/// `bezchain blade` writes: an `(M, 5)` array `x, y, z, section, index` (`(M, 3)` when the
/// cloud has no sections).
#[pyfunction]
#[pyo3(signature = (path, points_per_section=None, sections=None))]
pub(crate) fn blade<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
    points_per_section: Option<usize>,
    sections: Option<usize>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let path = path_of(path)?;
    let b = py.detach(|| Blade::from_file(&path)).map_err(py_err)?;
    warn_all(py, &path.display().to_string(), &b.warnings)?;
    let opts = LoftOptions {
        points_per_section,
        sections,
        ..LoftOptions::default()
    };
    let cloud = py
        .detach(|| b.loft(&opts))
        .map_err(|e| py_err_in(e, &format!("{}: lofting", path.display())))?;
    if let Err((at, message)) = check_scale(&cloud.points, Precision::F64) {
        let at = at.map_or(String::new(), |k| format!(" (point {})", k + 1));
        return Err(PyValueError::new_err(format!(
            "{}: the lofted cloud{at}: {message}",
            path.display()
        )));
    }
    match cloud.grid {
        Some(g) => {
            let per = g.per_section.max(1);
            let data = cloud
                .points
                .iter()
                .enumerate()
                .flat_map(|(k, p)| [p.x, p.y, p.z, (k / per) as f64, (k % per) as f64])
                .collect();
            array2(py, data, 5)
        }
        None => points3(py, &cloud.points),
    }
}
