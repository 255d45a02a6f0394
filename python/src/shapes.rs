//! Chains and surfaces, and the fits and adaptive searches that make them.

use crate::convert::*;
use bezchain::adaptive::{adapt_curve, AdaptOptions, ChordRule, Mode, SpanBreaks, SurfaceAdaptOptions};
use bezchain::chain::{Continuity, CurveChain, PatchGrid};
use bezchain::export::{AdaptReport, CurveReport, InputInfo, Schema, SurfaceAdaptReport};
use bezchain::fit::segments::{check_segments, SegmentsRefused};
use bezchain::fit::{fit_curve, parse_report, FitOptions, Method, Saved};
use bezchain::geometry::read_cloud;
use bezchain::problem::Metric;
use glam::{DVec2, DVec3};
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::path::Path;

/// A chain of Bezier curves (a fit, an adapted encoding or a saved curve report).
#[pyclass(module = "bezchain._bezchain", frozen)]
pub(crate) struct Chain {
    pub(crate) chain: CurveChain<DVec2>,
    pub(crate) sum_sq: f64,
    pub(crate) max_offset: f64,
    pub(crate) json: Option<String>,
    pub(crate) met: bool,
    pub(crate) message: Option<String>,
}

impl Chain {
    pub(crate) fn of_report(rep: &CurveReport, json: String) -> PyResult<Chain> {
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
pub(crate) struct Surface {
    pub(crate) grid: PatchGrid<DVec3>,
    pub(crate) sum_sq: f64,
    pub(crate) max_offset: f64,
    pub(crate) json: String,
    pub(crate) met: bool,
    pub(crate) message: Option<String>,
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

/// Fit a chain of `segments` Bezier curves of `degree` to the `(N, 2)` contour `points`, as
/// `bezchain fit --degree D --segments S` does (same defaults: C1 joins, least squares, the
/// closest-point metric).
#[pyfunction]
#[pyo3(signature = (points, degree=3, segments=5, continuity="c1", method="lsq", metric="closest"))]
pub(crate) fn fit(
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
    let call = format!("bezchain.fit(points, degree={degree}, segments={segments}, continuity='{continuity}', method='{}', metric='{}')", opts.method, opts.metric);
    Chain::of_report(&rep, json_text(Schema::Curve, call, &rep)?)
}

/// The chain with the fewest stored scalars whose offsets from the `(N, 2)` contour `points`
/// meet `tol` (model units; with `relative`, a fraction of the contour's extent), as
/// `bezchain adapt --tol T` searches it. When the tolerance is not met the closest chain found
/// is returned with `met` False and a `message` (the CLI then fails after writing its report).
#[pyfunction]
#[pyo3(signature = (points, tol, norm="max", degrees=None, mode="auto", max_scalars=None, search_points=80, relative=false))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn adapt(
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
        norm: word(norm)?,
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
        json: Some(json_text(
            Schema::Curve,
            format!("bezchain.adapt(points, tol={tol}, norm='{norm}', relative={relative})"),
            &rep,
        )?),
        met: r.met,
        message: r.message.clone(),
    })
}

/// The patch grid with the fewest stored scalars whose offsets from a sectioned cloud meet
/// `tol`, as `bezchain adapt-surface CLOUD --tol T` searches it. `cloud`: an `(M, 5)` array
/// `x, y, z, section, index` (as [`blade`] returns) or a sectioned cloud CSV file.
#[pyfunction]
#[pyo3(signature = (cloud, tol, norm="max", degrees_u=None, degrees_v=None, span_rule=true, chord_rule="auto", max_scalars=None, relative=false, span_breaks="auto"))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn adapt_surface(
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
    span_breaks: &str,
) -> PyResult<Surface> {
    check_tol(tol, max_scalars, "a patch grid")?;
    let span_breaks: SpanBreaks = word(span_breaks)?;
    let chord_rule: ChordRule = word(chord_rule)?;
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
        norm: word(norm)?,
        degrees_u: degrees("--degrees-u", degrees_u, [3, 6])?,
        degrees_v: degrees("--degrees-v", degrees_v, [2, 3])?,
        span_rule,
        chord_rule,
        max_scalars,
        span_breaks,
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
        json: json_text(
            Schema::Surface,
            format!("bezchain.adapt_surface(cloud, tol={tol}, norm='{norm}', relative={relative})"),
            &rep,
        )?,
        met: r.met,
        message: r.message.clone(),
    })
}
