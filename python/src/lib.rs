//! `bezchain._bezchain`: the Python module, a thin layer over the library functions the CLI's
//! subcommands call (so that its numbers are the CLI's); arrays in and out through numpy,
//! library errors mapped to `ValueError` (bad input), `OSError` (files) or `RuntimeError`, and
//! every long computation run with the GIL released.

use bezchain::adaptive::{adapt_curve, AdaptOptions, ChordRule, Mode, Norm, SurfaceAdaptOptions};
use bezchain::aero::{
    check_polar, objectives, AeroReport, Analysis, Constraints, ExtraConstraints, Method as AeroMethod, Optimisation,
    OptimiseOptions, Paneling, Setup, DEFAULT_NODES,
};
use bezchain::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
use bezchain::eval::Backend;
use bezchain::export::{AdaptReport, CurveReport, InputInfo, SurfaceAdaptReport};
use bezchain::fit::population::{
    self, eval_curve_population, eval_grid_population, BatchOptions, F32Overflow,
};
use bezchain::fit::segments::{check_segments, SegmentsRefused};
use bezchain::fit::{fit_curve, parse_report, FitOptions, Method, Saved};
use bezchain::geometry::{
    check_scale, parse_cloud, parse_curve, read_cloud, read_curve, Blade, Grid, Loaded2, LoftOptions, Naca,
    NacaOptions, Precision, Spacing, MAX_NACA_POINTS,
};
use bezchain::problem::Metric;
use bezchain::Error;
use glam::{DVec2, DVec3};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyNotImplementedError, PyOSError, PyRuntimeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::ffi::CString;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A library error as the Python exception it stands for: `OSError` for files that cannot be
/// read, `ValueError` for bad input or arguments, `RuntimeError` for the rest; the message is
/// the CLI's.
fn py_err(e: Error) -> PyErr {
    match &e {
        Error::Io { .. } => PyOSError::new_err(e.to_string()),
        _ if e.is_user_error() => PyValueError::new_err(e.to_string()),
        _ => PyRuntimeError::new_err(e.to_string()),
    }
}

/// Hand reader warnings to Python's `warnings` (prefixed with the input, as the CLI prints).
fn warn_all(py: Python<'_>, what: &str, warnings: &[String]) -> PyResult<()> {
    for w in warnings {
        let text = CString::new(format!("{what}: {w}")).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)?;
    }
    Ok(())
}

/// `obj` as a C-contiguous float64 array of `ndim` dimensions (numpy's `ascontiguousarray`).
fn as_f64<'py>(obj: &Bound<'py, PyAny>, ndim: usize, what: &str) -> PyResult<Bound<'py, PyAny>> {
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
fn rows(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<f64>, usize)> {
    let arr = as_f64(obj, 2, what)?;
    let arr = arr.cast::<PyArray2<f64>>().map_err(PyErr::from)?;
    let cols = arr.shape()[1];
    let data = arr.readonly().as_slice().map_err(PyErr::from)?.to_vec();
    Ok((data, cols))
}

/// A 2D array of `n` rows as CSV text under `header`, every value written in shortest
/// round-trip form: the data exactly as a file would hold them, for the file readers.
fn csv(header: &str, data: &[f64], cols: usize, int_from: usize) -> String {
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
fn curve_points(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Vec<DVec2>> {
    Ok(curve_loaded(py, obj)?.points)
}

/// [`curve_points`] with what the reader says of them (their extent, their name).
fn curve_loaded(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<Loaded2> {
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
fn cloud_points(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<(Vec<DVec3>, Option<Grid>)> {
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
fn path_of(obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    obj.extract::<PathBuf>()
}

fn array2<'py>(py: Python<'py>, data: Vec<f64>, cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = data.len() / cols.max(1);
    let a = Array2::from_shape_vec((n, cols), data).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py))
}

fn points2<'py>(py: Python<'py>, pts: &[DVec2]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    array2(py, pts.iter().flat_map(|p| [p.x, p.y]).collect(), 2)
}

fn points3<'py>(py: Python<'py>, pts: &[DVec3]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    array2(py, pts.iter().flat_map(|p| [p.x, p.y, p.z]).collect(), 3)
}

/// The report JSON as the CLI writes it (`--json`).
fn json_text<T: serde::Serialize>(value: &T) -> PyResult<String> {
    let mut text = serde_json::to_string_pretty(value).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    text.push('\n');
    Ok(text)
}

/// `LO-HI` or one degree, the value of `flag` (the CLI's `--degrees` syntax; a pair of
/// integers or one integer is taken too), `default` without one.
fn degrees(flag: &str, obj: Option<&Bound<'_, PyAny>>, default: [usize; 2]) -> PyResult<[usize; 2]> {
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

fn word<T: std::str::FromStr<Err = Error>>(text: &str) -> PyResult<T> {
    text.parse().map_err(py_err)
}

/// The tolerances of `adapt` and `adapt_surface`, checked as the CLI checks `--tol`.
fn check_tol(tol: f64, max_scalars: Option<usize>, what: &str) -> PyResult<()> {
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

/// The norm a tolerance bounds, `max` or `rms`.
fn norm(text: &str) -> PyResult<Norm> {
    match text.to_ascii_lowercase().as_str() {
        "max" => Ok(Norm::Max),
        "rms" => Ok(Norm::Rms),
        _ => Err(PyValueError::new_err(format!(
            "norm '{text}': expected max or rms"
        ))),
    }
}

// ---------------------------------------------------------------------------------------------
// Chains and surfaces.

/// A chain of Bezier curves (a fit, an adapted encoding or a saved curve report).
#[pyclass(module = "bezchain._bezchain", frozen)]
struct Chain {
    chain: CurveChain<DVec2>,
    sum_sq: f64,
    max_offset: f64,
    json: Option<String>,
    met: bool,
    message: Option<String>,
}

impl Chain {
    fn of_report(rep: &CurveReport, json: String) -> PyResult<Chain> {
        Ok(Chain {
            chain: rep.chain().map_err(py_err)?,
            sum_sq: rep.offset.sum_sq,
            max_offset: rep.offset.max,
            json: Some(json),
            met: true,
            message: None,
        })
    }
}

/// Evaluate `f` at a parameter or an array of them: `(dim,)` for a number, `(..., dim)` for
/// an array; every parameter must lie in [0, 1].
fn eval_at<'py>(
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

fn as_f64_any<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    obj.py()
        .import("numpy")?
        .call_method1("asarray", (obj, "float64"))
}

#[pymethods]
impl Chain {
    /// The point at parameter `t` in [0, 1] (shape `(2,)`), or at every parameter of an array
    /// (shape `t.shape + (2,)`).
    fn evaluate<'py>(&self, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        eval_at(t, 2, |t| {
            let p = self.chain.eval(t);
            vec![p.x, p.y]
        })
    }

    /// The design points, the optimisation variables (shape `(n, 2)`).
    #[getter]
    fn design_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        points2(py, self.chain.design())
    }

    /// The expanded Bezier control points (shape `(segments * degree + 1, 2)`).
    #[getter]
    fn control_points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        points2(py, self.chain.ctrl())
    }

    /// Degree of every segment.
    #[getter]
    fn degree(&self) -> usize {
        self.chain.layout().degree()
    }

    /// Number of segments.
    #[getter]
    fn segments(&self) -> usize {
        self.chain.layout().segments()
    }

    /// Continuity at the joins, `C0`, `C1` or `C2`.
    #[getter]
    fn continuity(&self) -> String {
        self.chain.layout().continuity().to_string()
    }

    /// The breaks `0 = t0 < ... < ts = 1`.
    #[getter]
    fn breaks<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.chain.layout().breaks().to_vec().into_pyarray(py)
    }

    /// Sum of squared offsets of the data (model units squared), as the report's `offset`.
    #[getter]
    fn sum_sq(&self) -> f64 {
        self.sum_sq
    }

    /// Largest offset of a data point (model units), as the report's `offset`.
    #[getter]
    fn max_offset(&self) -> f64 {
        self.max_offset
    }

    /// False when an adaptive search did not meet its tolerance (then `message` says why).
    #[getter]
    fn met(&self) -> bool {
        self.met
    }

    /// Why an adaptive search did not meet its tolerance, else None.
    #[getter]
    fn message(&self) -> Option<String> {
        self.message.clone()
    }

    /// The JSON report, as `bezchain fit --json` / `adapt --json` write it (a chain from
    /// `with_design` has none: ValueError).
    fn to_json(&self) -> PyResult<String> {
        self.json.clone().ok_or_else(|| {
            PyValueError::new_err("a chain made by with_design has no report (no data to measure)")
        })
    }

    /// The chain of the same layout with other design points (shape `(n, 2)`, or the `2n`
    /// values `x0, y0, x1, y1, ...` of a population row); its offsets are unknown (NaN).
    fn with_design(&self, design: &Bound<'_, PyAny>) -> PyResult<Chain> {
        let arr = as_f64_any(design)?;
        let flat: Vec<f64> = arr.call_method0("ravel")?.extract()?;
        let n = self.chain.layout().design_count();
        if flat.len() != 2 * n {
            return Err(PyValueError::new_err(format!(
                "design: {} values, but the layout has {n} design points ({} values)",
                flat.len(),
                2 * n
            )));
        }
        if flat.iter().any(|v| !v.is_finite()) {
            return Err(PyValueError::new_err("design: the design points must be finite"));
        }
        let design = flat.chunks(2).map(|p| DVec2::new(p[0], p[1])).collect();
        let chain = CurveChain::new(self.chain.layout().clone(), design).map_err(py_err)?;
        Ok(Chain {
            chain,
            sum_sq: f64::NAN,
            max_offset: f64::NAN,
            json: None,
            met: true,
            message: None,
        })
    }

    /// A chain from a curve report's JSON text (the CLI's report reader).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Chain> {
        match parse_report(text, Path::new("<json>")).map_err(py_err)? {
            Saved::Curve(rep, _) => Chain::of_report(&rep, text.to_string()),
            Saved::Surface(..) => Err(PyValueError::new_err(
                "<json>: a surface report; Chain.from_json needs a curve report",
            )),
        }
    }

    fn __repr__(&self) -> String {
        let l = self.chain.layout();
        format!(
            "Chain(degree={}, segments={}, continuity={}, design_points={}, max_offset={:.3e})",
            l.degree(),
            l.segments(),
            l.continuity(),
            l.design_count(),
            self.max_offset
        )
    }
}

/// A grid of tensor-product Bezier patches (an adapted surface).
#[pyclass(module = "bezchain._bezchain", frozen)]
struct Surface {
    grid: PatchGrid<DVec3>,
    sum_sq: f64,
    max_offset: f64,
    json: String,
    met: bool,
    message: Option<String>,
}

#[pymethods]
impl Surface {
    /// The point at parameters `(u, v)` in [0, 1]² (shape `(3,)`), or at every pair of two
    /// arrays of one shape (shape `u.shape + (3,)`).
    fn evaluate<'py>(&self, u: &Bound<'py, PyAny>, v: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let py = u.py();
        let np = py.import("numpy")?;
        let pair = np.call_method1("broadcast_arrays", (as_f64_any(u)?, as_f64_any(v)?))?;
        let uu = pair.get_item(0)?;
        let vv: Vec<f64> = pair.get_item(1)?.call_method0("ravel")?.extract()?;
        if let Some(t) = vv.iter().find(|t| !(0.0..=1.0).contains(*t)) {
            return Err(PyValueError::new_err(format!("parameter {t} is outside [0, 1]")));
        }
        let k = std::cell::Cell::new(0usize);
        eval_at(&uu, 3, |u| {
            let p = self.grid.eval(u, vv[k.get()]);
            k.set(k.get() + 1);
            vec![p.x, p.y, p.z]
        })
    }

    /// The design net, rows along u (shape `(nu, nv, 3)`).
    #[getter]
    fn design_net<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let (nu, nv) = self.grid.layout().design_shape();
        let data: Vec<f64> = self.grid.design().iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let a =
            Array3::from_shape_vec((nu, nv, 3), data).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }

    /// `[du, dv]`.
    #[getter]
    fn degree(&self) -> [usize; 2] {
        let l = self.grid.layout();
        [l.u.degree(), l.v.degree()]
    }

    /// `[pu, pv]`.
    #[getter]
    fn patches(&self) -> [usize; 2] {
        let l = self.grid.layout();
        [l.u.segments(), l.v.segments()]
    }

    /// Sum of squared offsets of the cloud (model units squared).
    #[getter]
    fn sum_sq(&self) -> f64 {
        self.sum_sq
    }

    /// Largest offset of a cloud point (model units).
    #[getter]
    fn max_offset(&self) -> f64 {
        self.max_offset
    }

    /// False when the search did not meet its tolerance (then `message` says why).
    #[getter]
    fn met(&self) -> bool {
        self.met
    }

    /// Why the search did not meet its tolerance, else None.
    #[getter]
    fn message(&self) -> Option<String> {
        self.message.clone()
    }

    /// The JSON report, as `bezchain adapt-surface --json` writes it.
    fn to_json(&self) -> String {
        self.json.clone()
    }

    fn __repr__(&self) -> String {
        let l = self.grid.layout();
        format!(
            "Surface(degree=[{}, {}], patches=[{}, {}], max_offset={:.3e})",
            l.u.degree(),
            l.v.degree(),
            l.u.segments(),
            l.v.segments(),
            self.max_offset
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Files and generators.

/// Read an aerofoil or contour file (Selig or Lednicer `.dat`, CSV or XYZ rows) as `bezchain`
/// reads it: an `(N, 2)` array; the reader's repairs become warnings.
#[pyfunction]
fn read_aerofoil<'py>(py: Python<'py>, path: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let path = path_of(path)?;
    let loaded = py.detach(|| read_curve(&path)).map_err(py_err)?;
    warn_all(py, &path.display().to_string(), &loaded.warnings)?;
    points2(py, &loaded.points)
}

/// A NACA 4- or 5-digit aerofoil, upper trailing edge → leading edge → lower trailing edge,
/// as `bezchain naca CODE --points N` writes it: an `(N, 2)` array.
#[pyfunction]
#[pyo3(signature = (code, points=161, spacing="cosine", closed_te=false))]
fn naca<'py>(
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
fn blade<'py>(
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

/// `e` with `context` before it, as the CLI's one-line message.
fn py_err_in(e: Error, context: &str) -> PyErr {
    let msg = format!("{context}: {e}");
    match &e {
        Error::Io { .. } => PyOSError::new_err(msg),
        _ if e.is_user_error() => PyValueError::new_err(msg),
        _ => PyRuntimeError::new_err(msg),
    }
}

// ---------------------------------------------------------------------------------------------
// Fitting and the adaptive searches.

/// Fit a chain of `segments` Bezier curves of `degree` to the `(N, 2)` contour `points`, as
/// `bezchain fit --degree D --segments S` does (same defaults: C1 joins, least squares, the
/// closest-point metric).
#[pyfunction]
#[pyo3(signature = (points, degree=3, segments=5, continuity="c1", method="lsq", metric="closest"))]
fn fit(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    degree: usize,
    segments: usize,
    continuity: &str,
    method: &str,
    metric: &str,
) -> PyResult<Chain> {
    let continuity: Continuity = word(continuity)?;
    let method = Method::parse_among(method, Method::CURVE).map_err(py_err)?;
    let metric: Metric = word(metric)?;
    let pts = curve_points(py, points)?;
    let layout = check_segments(degree, segments, continuity, pts.len()).map_err(|r| match r {
        SegmentsRefused::Layout(e) => PyValueError::new_err(format!("--degree {degree} --segments {segments}: {e}")),
        SegmentsRefused::TooMany { design, most } => {
            let hint = match most {
                0 => "use a lower --degree or more data points".to_string(),
                s => format!("use at most --segments {s} at degree {degree}"),
            };
            PyValueError::new_err(format!(
                "--segments {segments}: {design}, more than the {} data points of points can determine; {hint}",
                pts.len()
            ))
        }
    })?;
    let opts = FitOptions {
        method,
        metric,
        ..FitOptions::default()
    };
    let n = pts.len();
    let fit = py
        .detach(|| fit_curve(&pts, layout, &opts))
        .map_err(|e| py_err_in(e, &format!("points: fitting {n} points")))?;
    let rep = CurveReport::from_fit(
        &fit,
        InputInfo {
            path: "points".into(),
            points: n,
        },
    );
    Chain::of_report(&rep, json_text(&rep)?)
}

/// The chain with the fewest stored scalars whose offsets from the `(N, 2)` contour `points`
/// meet `tol` (model units; with `relative`, a fraction of the contour's extent), as
/// `bezchain adapt --tol T` searches it. When the tolerance is not met the closest chain found
/// is returned with `met` False and a `message` (the CLI then fails after writing its report).
#[pyfunction]
#[pyo3(signature = (points, tol, norm="max", degrees=None, mode="auto", max_scalars=None, search_points=80, relative=false))]
#[allow(clippy::too_many_arguments)]
fn adapt(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    tol: f64,
    norm: &str,
    degrees: Option<&Bound<'_, PyAny>>,
    mode: &str,
    max_scalars: Option<usize>,
    search_points: usize,
    relative: bool,
) -> PyResult<Chain> {
    check_tol(tol, max_scalars, "a chain")?;
    let [min_degree, max_degree] = self::degrees("--degrees", degrees, [2, 7])?;
    let mode: Mode = word(mode)?;
    let loaded = curve_loaded(py, points)?;
    let scale = if relative { loaded.extent() } else { 1.0 };
    let pts = loaded.points;
    let opts = AdaptOptions {
        tol: tol * scale,
        norm: self::norm(norm)?,
        min_degree,
        max_degree,
        mode,
        max_scalars,
        search_points,
        ..AdaptOptions::default()
    };
    let r = py
        .detach(|| adapt_curve(&pts, &opts))
        .map_err(|e| py_err_in(e, &format!("points: adapting to {:.3e}", opts.tol)))?;
    let rep = AdaptReport::new(
        &r,
        &opts,
        InputInfo {
            path: "points".into(),
            points: pts.len(),
        },
    );
    Ok(Chain {
        chain: r.chain.clone(),
        sum_sq: r.offset.sum_sq,
        max_offset: r.offset.max,
        json: Some(json_text(&rep)?),
        met: r.met,
        message: r.message.clone(),
    })
}

/// The patch grid with the fewest stored scalars whose offsets from a sectioned cloud meet
/// `tol`, as `bezchain adapt-surface CLOUD --tol T` searches it. `cloud`: an `(M, 5)` array
/// `x, y, z, section, index` (as [`blade`] returns) or a sectioned cloud CSV file.
#[pyfunction]
#[pyo3(signature = (cloud, tol, norm="max", degrees_u=None, degrees_v=None, span_rule=true, chord_rule="auto", max_scalars=None, relative=false))]
#[allow(clippy::too_many_arguments)]
fn adapt_surface(
    py: Python<'_>,
    cloud: &Bound<'_, PyAny>,
    tol: f64,
    norm: &str,
    degrees_u: Option<&Bound<'_, PyAny>>,
    degrees_v: Option<&Bound<'_, PyAny>>,
    span_rule: bool,
    chord_rule: &str,
    max_scalars: Option<usize>,
    relative: bool,
) -> PyResult<Surface> {
    check_tol(tol, max_scalars, "a patch grid")?;
    let chord_rule = match chord_rule.to_ascii_lowercase().as_str() {
        "auto" => ChordRule::Auto,
        "on" => ChordRule::On,
        "off" => ChordRule::Off,
        _ => {
            return Err(PyValueError::new_err(format!(
                "chord_rule '{chord_rule}': expected auto, on or off"
            )))
        }
    };
    let (name, points, grid) = match path_of(cloud) {
        Ok(path) if !cloud.is_instance_of::<numpy::PyUntypedArray>() => {
            let loaded = py.detach(|| read_cloud(&path)).map_err(py_err)?;
            let name = path.display().to_string();
            warn_all(py, &name, &loaded.warnings)?;
            (name, loaded.points, loaded.grid)
        }
        _ => {
            let (p, g) = cloud_points(py, cloud)?;
            ("cloud".to_string(), p, g)
        }
    };
    let Some(grid) = grid else {
        return Err(PyValueError::new_err(format!(
            "{name}: adapt-surface needs a sectioned cloud (CSV with complete section,index columns) or a \
             blade definition"
        )));
    };
    let scale = if relative {
        grid.largest_chord(&points)
    } else {
        1.0
    };
    if !(tol * scale > 0.0 && (tol * scale).is_finite()) {
        return Err(PyValueError::new_err(format!(
            "--tol {tol}: the tolerance must be positive"
        )));
    }
    let opts = SurfaceAdaptOptions {
        tol: tol * scale,
        norm: self::norm(norm)?,
        degrees_u: degrees("--degrees-u", degrees_u, [3, 6])?,
        degrees_v: degrees("--degrees-v", degrees_v, [2, 3])?,
        span_rule,
        chord_rule,
        max_scalars,
        ..SurfaceAdaptOptions::default()
    };
    let r = py
        .detach(|| bezchain::adaptive::adapt_surface(&points, grid, &opts))
        .map_err(|e| py_err_in(e, &format!("{name}: adapting to {:.3e}", opts.tol)))?;
    let rep = SurfaceAdaptReport::new(
        &r,
        &opts,
        InputInfo {
            path: name,
            points: points.len(),
        },
    );
    Ok(Surface {
        grid: r.grid.clone(),
        sum_sq: r.offset.sum_sq,
        max_offset: r.offset.max,
        json: json_text(&rep)?,
        met: r.met,
        message: r.message.clone(),
    })
}

// ---------------------------------------------------------------------------------------------
// Population evaluation.

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
struct Evaluator {
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

// ---------------------------------------------------------------------------------------------
// Aerodynamics.

/// The inviscid panel method (XFOIL's) on an aerofoil, as `bezchain aero` runs it: `shape` an
/// `(N, 2)` array of coordinates (a spline through them), a Chain, or a file (aerofoil
/// coordinates or a curve report). Returns a dict of `alpha`, `cl`, `cm` (one each per angle),
/// `cp` (angles × nodes), `nodes` (node positions), `chord`, `te_gap`, `trailing_edge`.
/// `re` (a Reynolds number, for the viscous solver) is not available yet.
#[pyfunction]
#[pyo3(
    signature = (shape, alpha=vec![0.0, 4.0, 8.0], re=None, ncrit=9.0, panels=DEFAULT_NODES, te_ratio=0.15),
    text_signature = "(shape, alpha=(0.0, 4.0, 8.0), re=None, ncrit=9.0, panels=160, te_ratio=0.15)"
)]
fn aero<'py>(
    py: Python<'py>,
    shape: &Bound<'py, PyAny>,
    alpha: Vec<f64>,
    re: Option<f64>,
    ncrit: f64,
    panels: usize,
    te_ratio: f64,
) -> PyResult<Bound<'py, PyDict>> {
    if re.is_some() {
        return Err(PyNotImplementedError::new_err(format!(
            "aero(re=...): the viscous analysis (Reynolds number, ncrit {ncrit}) is not in the Python module yet; \
             call aero with re=None for the inviscid panel method"
        )));
    }
    let paneling = Paneling {
        nodes: panels,
        te_ratio,
    };
    check_polar(&alpha, &paneling).map_err(py_err)?;
    let analysis = if let Ok(c) = shape.cast::<Chain>() {
        let chain = c.get().chain.clone();
        py.detach(|| Analysis::of_chain(&chain, &paneling))
    } else if shape.is_instance_of::<pyo3::types::PyString>() || shape.hasattr("__fspath__")? {
        let path = path_of(shape)?;
        let mut warnings = Vec::new();
        let r = py.detach(|| {
            bezchain::aero::analyse_input(&path, &paneling, &mut |p: &Path, w: &str| {
                warnings.push(format!("{}: {w}", p.display()));
            })
        });
        for w in &warnings {
            let text = CString::new(w.as_str()).unwrap_or_default();
            PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)?;
        }
        r.map(|(a, _, _)| a)
    } else {
        let pts = curve_points(py, shape)?;
        py.detach(|| Analysis::of_points(&pts, &paneling))
    }
    .map_err(py_err)?;
    let rep = AeroReport::new(
        &analysis,
        &paneling,
        &alpha,
        bezchain::aero::AeroInput {
            path: String::new(),
            kind: String::new(),
            points: 0,
        },
    );
    let d = PyDict::new(py);
    d.set_item("alpha", alpha.clone().into_pyarray(py))?;
    d.set_item(
        "cl",
        rep.polar
            .iter()
            .map(|c| c.cl)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "cm",
        rep.polar
            .iter()
            .map(|c| c.cm)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    let nodes = rep.nodes;
    let cp: Vec<f64> = rep.pressure.iter().flat_map(|p| p.cp.iter().copied()).collect();
    d.set_item("cp", array2(py, cp, nodes)?)?;
    d.set_item(
        "nodes",
        array2(py, rep.node_points.iter().flat_map(|p| *p).collect(), 2)?,
    )?;
    d.set_item("chord", rep.chord.length)?;
    d.set_item("leading_edge", rep.chord.le.to_vec().into_pyarray(py))?;
    d.set_item("trailing_edge_point", rep.chord.te.to_vec().into_pyarray(py))?;
    d.set_item("te_gap", rep.te_gap)?;
    d.set_item("trailing_edge", rep.trailing_edge.clone())?;
    Ok(d)
}

/// What an optimisation run leaves, made with the GIL released.
struct Optimised {
    design: Vec<f64>,
    chain: CurveChain<DVec2>,
    report: String,
    sum_sq: f64,
    max: f64,
    selig: Vec<DVec2>,
    history: Vec<[f64; 5]>,
    eval: [f64; 4],
    stop: String,
    generations: u64,
    evaluations: u64,
    backend: String,
    warnings: Vec<String>,
}

/// Optimise an aerofoil as `bezchain optimise START --objective OBJ` does: `start` an aerofoil
/// file (adapted to `tol` first) or an adapt report; `objective` `max-ld`, `min-cd`,
/// `multipoint:FILE` (viscous: `re`, `ncrit`, `cl` as the CLI's `--re`, `--ncrit`, `--cl`),
/// `inverse:TARGET` or `max-cl` (with a constraint); `min_thickness_at` a list of `(x, t)`
/// pairs; the other options as the CLI's (same defaults). Returns a dict: `chain`
/// (the result, a Chain whose `to_json()` is the CLI's report), `design_points` (its design
/// points), `design` (the optimised variables, the encoding's free numbers), `history` (per generation: `generation`, `best`, `mean`, `evaluations`,
/// `seconds` arrays), `cl`, `cm`, `thickness`, `objective` (f64, at `alpha`), `selig` (the
/// result at 241 panel nodes, as `--dat` writes it), `stop`, `generations`, `evaluations`,
/// `backend`. The GIL is released while it runs.
#[pyfunction]
#[pyo3(
    signature = (start, objective, alpha=4.0, method="cmaes", population=None, generations=None, seed=1, tol=1e-4, margin=0.1, spread=0.01, stall=0, panels=DEFAULT_NODES, min_thickness=None, cm_min=None, backend="auto", re=None, ncrit=9.0, cl=None, min_thickness_at=Vec::new(), cl_min=None, min_te_angle=None, min_area=None),
    text_signature = "(start, objective, alpha=4.0, method='cmaes', population=None, generations=None, seed=1, tol=0.0001, margin=0.1, spread=0.01, stall=0, panels=160, min_thickness=None, cm_min=None, backend='auto', re=None, ncrit=9.0, cl=None, min_thickness_at=[], cl_min=None, min_te_angle=None, min_area=None)"
)]
#[allow(clippy::too_many_arguments)]
fn optimise<'py>(
    py: Python<'py>,
    start: &Bound<'py, PyAny>,
    objective: &str,
    alpha: f64,
    method: &str,
    population: Option<usize>,
    generations: Option<usize>,
    seed: u64,
    tol: f64,
    margin: f64,
    spread: f64,
    stall: usize,
    panels: usize,
    min_thickness: Option<f64>,
    cm_min: Option<f64>,
    backend: &str,
    re: Option<f64>,
    ncrit: f64,
    cl: Option<f64>,
    min_thickness_at: Vec<(f64, f64)>,
    cl_min: Option<f64>,
    min_te_angle: Option<f64>,
    min_area: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let method = AeroMethod::parse_among(method, AeroMethod::AERO).map_err(py_err)?;
    let backend: Backend = word(backend)?;
    let setup = Setup {
        start: path_of(start)?,
        spec: objective.to_string(),
        alpha,
        tol,
        margin,
        panels,
        constraints: Constraints {
            min_thickness,
            cm_min,
        },
        extra: ExtraConstraints {
            thickness_at: min_thickness_at,
            min_te_angle,
            min_area,
            cl_min,
        },
        re,
        ncrit,
        cl,
    };
    setup.check().map_err(py_err)?;
    let options = OptimiseOptions {
        population,
        generations,
        seed,
        backend,
        spread,
        stall_generations: stall,
        ..OptimiseOptions::default()
    };
    let spec = objective.to_string();
    let out: bezchain::Result<Optimised> = py.detach(|| {
        let mut warnings = Vec::new();
        let objective = objectives::parse(&spec)?;
        let study = setup.prepare(objective, &mut |p: &Path, w: &str| {
            warnings.push(format!("{}: {w}", p.display()));
        })?;
        let mut run = Optimisation::new(&study.problem, method, &options)?;
        let stop = run.run(|_| Ok(()))?;
        let outcome = study.outcome(run.finish(stop)?, &options)?;
        let r = &outcome.result;
        let chain = study.problem.space.chain(&r.design)?;
        Ok(Optimised {
            design: r.design.clone(),
            report: serde_json::to_string_pretty(&outcome.report)
                .map(|mut t| {
                    t.push('\n');
                    t
                })
                .map_err(|e| Error::Output(e.to_string()))?,
            sum_sq: outcome.report.curve.offset.sum_sq,
            max: outcome.report.curve.offset.max,
            chain,
            selig: outcome.selig.clone(),
            history: r
                .history
                .iter()
                .map(|h| {
                    [
                        h.generation as f64,
                        h.best,
                        h.mean,
                        h.evaluations as f64,
                        h.seconds,
                    ]
                })
                .collect(),
            eval: [r.eval.cl, r.eval.cm, r.eval.thickness, r.eval.objective],
            stop: format!("{:?}", r.stop),
            generations: r.generations,
            evaluations: r.evaluations,
            backend: r.backend.to_string(),
            warnings,
        })
    });
    let o = out.map_err(py_err)?;
    for w in &o.warnings {
        let text = CString::new(w.as_str()).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &text, 1)?;
    }
    let d = PyDict::new(py);
    let chain = Chain {
        chain: o.chain,
        sum_sq: o.sum_sq,
        max_offset: o.max,
        json: Some(o.report),
        met: true,
        message: None,
    };
    d.set_item("design_points", points2(py, chain.chain.design())?)?;
    d.set_item("chain", Py::new(py, chain)?)?;
    d.set_item("design", o.design.into_pyarray(py))?;
    let h = PyDict::new(py);
    for (k, name) in ["generation", "best", "mean", "evaluations", "seconds"]
        .iter()
        .enumerate()
    {
        h.set_item(
            *name,
            o.history
                .iter()
                .map(|r| r[k])
                .collect::<Vec<_>>()
                .into_pyarray(py),
        )?;
    }
    d.set_item("history", h)?;
    for (k, name) in ["cl", "cm", "thickness", "objective"].iter().enumerate() {
        d.set_item(*name, o.eval[k])?;
    }
    d.set_item("selig", points2(py, &o.selig)?)?;
    d.set_item("stop", o.stop)?;
    d.set_item("generations", o.generations)?;
    d.set_item("evaluations", o.evaluations)?;
    d.set_item("backend", o.backend)?;
    Ok(d)
}

/// The names of the objectives `optimise` takes (`max-ld`, `min-cd`, `multipoint:FILE`,
/// `inverse:TARGET`, `max-cl`).
#[pyfunction]
fn objectives_list(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let names: Vec<String> = bezchain::aero::OBJECTIVES
        .iter()
        .map(|o| match o.argument() {
            Some(a) => format!("{}:{a}", o.name()),
            None => o.name().to_string(),
        })
        .collect();
    PyList::new(py, names)
}

/// bezchain: chained Bezier curves and patches as compact shape-optimisation variables.
#[pymodule]
fn _bezchain(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Chain>()?;
    m.add_class::<Surface>()?;
    m.add_class::<Evaluator>()?;
    m.add_function(wrap_pyfunction!(read_aerofoil, m)?)?;
    m.add_function(wrap_pyfunction!(naca, m)?)?;
    m.add_function(wrap_pyfunction!(blade, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(adapt, m)?)?;
    m.add_function(wrap_pyfunction!(adapt_surface, m)?)?;
    m.add_function(wrap_pyfunction!(aero, m)?)?;
    m.add_function(wrap_pyfunction!(optimise, m)?)?;
    m.add_function(wrap_pyfunction!(objectives_list, m)?)?;
    Ok(())
}
