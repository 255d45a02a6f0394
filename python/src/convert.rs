//! Conversions between Python objects and the library's types, and errors as Python exceptions.

use bezchain::export::{Schema, Stamp};
use bezchain::geometry::{parse_cloud, parse_curve, Grid, Loaded2};
use bezchain::Error;
use glam::{DVec2, DVec3};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use std::ffi::CString;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A library error as the Python exception it stands for: `OSError` for files that cannot be
/// read, `ValueError` for bad input or arguments, `RuntimeError` for the rest; the message is
/// the CLI's.
pub(crate) fn py_err(e: Error) -> PyErr {
    match &e {
        Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ if e.is_user_error() => PyValueError::new_err(e.to_string()),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// Hand reader warnings to Python's `warnings` (prefixed with the input, as the CLI prints).
pub(crate) fn warn_all(py: Python<'_>, what: &str, warnings: &[String]) -> PyResult<()> {
    let prefixed: Vec<String> = warnings.iter().map(|w| format!("{what}: {w}")).collect();
    warn_each(py, &prefixed)
}

/// `obj` as a C-contiguous float64 array of `ndim` dimensions (numpy's `ascontiguousarray`).
pub(crate) fn as_f64<'py>(obj: &Bound<'py, PyAny>, ndim: usize, what: &str) -> PyResult<Bound<'py, PyAny>> {
    let np = obj.py().import("numpy")?;
    let arr = np.call_method1("ascontiguousarray", (obj, "float64"))?;
    let got: usize = arr.getattr("ndim")?.extract()?;
    if got != ndim {
        return Err(PyValueError::new_err(format!(
            "{what}: expected a {ndim}-dimensional array, got {got} dimensions"
        )));
    }
    Ok(arr)
}

/// The rows of a 2D float array and its column count.
pub(crate) fn rows(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<f64>, usize)> {
    let arr = as_f64(obj, 2, what)?;
    let arr = arr.cast::<PyArray2<f64>>().map_err(PyErr::from)?;
    let cols = arr.shape()[1];
    let data = arr.readonly().as_slice().map_err(PyErr::from)?.to_vec();
    Ok((data, cols))
}

/// A 2D array of `n` rows as CSV text under `header`, every value written in shortest
/// round-trip form: the data exactly as a file would hold them, for the file readers.
pub(crate) fn csv(header: &str, data: &[f64], cols: usize, int_from: usize) -> String {
    let mut text = String::with_capacity(data.len() * 24);
    text.push_str(header);
    text.push('\n');
    for row in data.chunks(cols.max(1)) {
        for (i, v) in row.iter().enumerate() {
            if i > 0 {
                text.push(',');
            }
            if i >= int_from && v.fract() == 0.0 && v.abs() < 1e15 {
                let _ = write!(text, "{}", *v as i64);
            } else {
                let _ = write!(text, "{v}");
            }
        }
        text.push('\n');
    }
    text
}

/// A contour given as an `(N, 2)` array, read by the same reader as a file of its points
/// (its checks, its repairs as warnings; `points` names it in messages).
pub(crate) fn curve_points(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Vec<DVec2>> {
    Ok(curve_loaded(py, obj)?.points)
}

/// [`curve_points`] with what the reader says of them (their extent, their name).
pub(crate) fn curve_loaded(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Loaded2> {
    let (data, cols) = rows(obj, "points")?;
    if cols != 2 {
        return Err(PyValueError::new_err(format!(
            "points: expected an (N, 2) array of x, y, got {cols} columns"
        )));
    }
    let loaded = parse_curve(&csv("x,y", &data, 2, 2), Path::new("points")).map_err(py_err)?;
    warn_all(py, "points", &loaded.warnings)?;
    Ok(loaded)
}

/// A sectioned cloud given as an `(M, 5)` array `x, y, z, section, index` (as [`blade`]
/// returns), read by the cloud reader; an `(M, 3)` array has no sections.
pub(crate) fn cloud_points(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<(Vec<DVec3>, Option<Grid>)> {
    let (data, cols) = rows(obj, "cloud")?;
    let header = match cols {
        3 => "x,y,z",
        5 => "x,y,z,section,index",
        c => {
            return Err(PyValueError::new_err(format!(
            "cloud: expected an (M, 3) array of x, y, z or an (M, 5) array of x, y, z, section, index, got \
                 {c} columns"
        )))
        }
    };
    let loaded = parse_cloud(&csv(header, &data, cols, 3), Path::new("cloud")).map_err(py_err)?;
    warn_all(py, "cloud", &loaded.warnings)?;
    Ok((loaded.points, loaded.grid))
}

/// A path argument (`str` or `os.PathLike`).
pub(crate) fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
}

pub(crate) fn array2<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = data.len() / cols.max(1);
    let a = Array2::from_shape_vec((n, cols), data).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py))
}

pub(crate) fn points2<'py>(py: Python<'py>, pts: &[DVec2]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    array2(py, pts.iter().flat_map(|p| [p.x, p.y]).collect(), 2)
}

pub(crate) fn points3<'py>(py: Python<'py>, pts: &[DVec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    array2(py, pts.iter().flat_map(|p| [p.x, p.y, p.z]).collect(), 3)
}

/// The report JSON as the CLI writes it (`--json`), stamped as `schema` with the Python call
/// that made it as its command (`["python", "bezchain.fit(degree=3, segments=5)"]`).
pub(crate) fn json_text<T: serde::Serialize>(schema: Schema, call: String, value: &T) -> PyResult<String> {
    let stamp = Stamp::new(schema, vec!["python".to_string(), call]);
    let mut text =
        serde_json::to_string_pretty(&stamp.on(value)).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    text.push('\n');
    Ok(text)
}

/// `LO-HI` or one degree, the value of `flag` (the CLI's `--degrees` syntax; a pair of
/// integers or one integer is taken too), `default` without one.
pub(crate) fn degrees(
    flag: &str,
    obj: Option<&Bound<'_, PyAny>>,
    default: [usize; 2],
) -> PyResult<[usize; 2]> {
    let Some(obj) = obj else { return Ok(default) };
    if let Ok((a, b)) = obj.extract::<(usize, usize)>() {
        return Ok([a, b]);
    }
    if let Ok(d) = obj.extract::<usize>() {
        return Ok([d, d]);
    }
    let text: String = obj.extract()?;
    let bad = || PyValueError::new_err(format!("{flag} '{text}': expected LO-HI or one degree, e.g. 2-7"));
    let degree = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
    match text.split_once('-') {
        Some((a, b)) => Ok([degree(a)?, degree(b)?]),
        None => degree(&text).map(|d| [d, d]),
    }
}

pub(crate) fn word<T: std::str::FromStr<Err = Error>>(text: &str) -> PyResult<T> {
    text.parse().map_err(py_err)
}

/// The tolerances of `adapt` and `adapt_surface`, checked as the CLI checks `--tol`.
pub(crate) fn check_tol(tol: f64, max_scalars: Option<usize>, what: &str) -> PyResult<()> {
    if max_scalars == Some(0) {
        return Err(PyValueError::new_err(format!(
            "--max-scalars 0: {what} stores at least a few scalars; give a positive count"
        )));
    }
    if !(tol.is_finite() && tol > 0.0) {
        return Err(PyValueError::new_err(format!(
            "--tol {tol}: the tolerance must be a positive number"
        )));
    }
    Ok(())
}

/// Evaluate `f` at a parameter or an array of them: `(dim,)` for a number, `(..., dim)` for
/// an array; every parameter must lie in [0, 1].
pub(crate) fn eval_at<'py>(
    obj: &Bound<'py, PyAny>,
    dim: usize,
    f: impl Fn(f64) -> Vec<f64>,
) -> PyResult<Bound<'py, PyAny>> {
    let py = obj.py();
    let arr = as_f64_any(obj)?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let flat: Vec<f64> = arr.call_method0("ravel")?.extract()?;
    if let Some(t) = flat.iter().find(|t| !(0.0..=1.0).contains(*t)) {
        return Err(PyValueError::new_err(format!("parameter {t} is outside [0, 1]")));
    }
    let out: Vec<f64> = flat.iter().flat_map(|&t| f(t)).collect();
    let mut shape = shape;
    shape.push(dim);
    Array1::from_vec(out)
        .into_pyarray(py)
        .call_method1("reshape", (shape,))
}

pub(crate) fn as_f64_any<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    obj.py()
        .import("numpy")?
        .call_method1("asarray", (obj, "float64"))
}

/// `e` with `context` before it, as the CLI's one-line message.
pub(crate) fn py_err_in(e: Error, context: &str) -> PyErr {
    let msg = format!("{context}: {e}");
    match &e {
        Error::Io { .. } => PyOSError::new_err(msg),
        _ if e.is_user_error() => PyValueError::new_err(msg),
        _ => PyRuntimeError::new_err(msg),
    }
}

/// Hand warnings already prefixed with their input to Python's `warnings`.
pub(crate) fn warn_each(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    for w in warnings {
        let text = CString::new(w.as_str()).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)?;
    }
    Ok(())
}

/// One field of every row as a numpy array.
pub(crate) fn column<'py, R, T: numpy::Element>(
    py: Python<'py>,
    rows: &[R],
    field: impl Fn(&R) -> T,
) -> Bound<'py, PyArray1<T>> {
    rows.iter().map(field).collect::<Vec<T>>().into_pyarray(py)
}
