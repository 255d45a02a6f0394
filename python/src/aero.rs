//! Aerodynamics: the panel method, the viscous analysis and the optimiser.

use crate::convert::*;
use crate::shapes::Chain;
use bezchain::aero::viscous::polar::check_alphas;
use bezchain::aero::{
    analyse_input, check_polar, objectives, AeroReport, Analysis, Constraints, ExtraConstraints, Method as AeroMethod,
    Optimisation, OptimiseOptions, Paneling, Setup, Viscous, ViscousOptions, ViscousPoint, DEFAULT_NODES,
};
use bezchain::chain::CurveChain;
use bezchain::eval::Backend;
use bezchain::export::{Schema, Stamp};
use bezchain::Error;
use glam::DVec2;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::Path;

/// The panel solution of `shape` (an `(N, 2)` array, a Chain or a file), as `bezchain aero`
/// makes it; the reader's warnings go to Python's `warnings`.
fn analysis_of(py: Python<'_>, shape: &Bound<'_, PyAny>, paneling: &Paneling) -> PyResult<Analysis> {
    if let Ok(c) = shape.cast::<Chain>() {
        let chain = c.get().chain.clone();
        return py.detach(|| Analysis::of_chain(&chain, paneling)).map_err(py_err);
    }
    if shape.is_instance_of::<pyo3::types::PyString>() || shape.hasattr("__fspath__")? {
        let path = path_of(shape)?;
        let mut warnings = Vec::new();
        let r = py.detach(|| {
            analyse_input(&path, paneling, &mut |p: &Path, w: &str| {
                warnings.push(format!("{}: {w}", p.display()));
            })
        });
        warn_each(py, &warnings)?;
        return r.map(|(a, _, _)| a).map_err(py_err);
    }
    let pts = curve_points(py, shape)?;
    py.detach(|| Analysis::of_points(&pts, paneling)).map_err(py_err)
}

/// The panel method on an aerofoil, as `bezchain aero` runs it: `shape` an `(N, 2)` array of
/// coordinates (a spline through them), a Chain, or a file (aerofoil coordinates or a curve
/// report).
///
/// Without `re`: the inviscid solution. Returns a dict of `alpha`, `cl`, `cm` (one each per
/// angle), `cp` (angles × nodes), `nodes` (node positions), `chord`, `leading_edge`,
/// `trailing_edge_point`, `te_gap`, `trailing_edge`.
///
/// With `re` (a Reynolds number, 1e4 to 1e8): the viscous analysis (`bezchain aero --re`),
/// `ncrit` the e^N amplification for free transition, `xtr_top`/`xtr_bottom` forced
/// transition (chord fractions; 1: free). Returns a dict of `alpha`, `cl`, `cd`, `cdp`, `cm`,
/// `xtr_top`, `xtr_bottom` (NaN where the point did not converge), `converged`, `separated`
/// (booleans), `iterations`, and `re`, `ncrit`, `nodes`, `chord`. The GIL is released while it
/// runs.
#[pyfunction]
#[pyo3(
    signature = (shape, alpha=vec![0.0, 4.0, 8.0], re=None, ncrit=9.0, xtr_top=1.0, xtr_bottom=1.0, panels=DEFAULT_NODES, te_ratio=0.15),
    text_signature = "(shape, alpha=(0.0, 4.0, 8.0), re=None, ncrit=9.0, xtr_top=1.0, xtr_bottom=1.0, panels=160, te_ratio=0.15)"
)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn aero<'py>(
    py: Python<'py>,
    shape: &Bound<'py, PyAny>,
    alpha: Vec<f64>,
    re: Option<f64>,
    ncrit: f64,
    xtr_top: f64,
    xtr_bottom: f64,
    panels: usize,
    te_ratio: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let paneling = Paneling {
        nodes: panels,
        te_ratio,
    };
    check_polar(&alpha, &paneling).map_err(py_err)?;
    if let Some(re) = re {
        let opts = ViscousOptions {
            re,
            ncrit,
            xtr_top,
            xtr_bottom,
            ..ViscousOptions::default()
        };
        opts.check()
            .map_err(|e| py_err_in(e, "re/ncrit/xtr_top/xtr_bottom"))?;
        check_alphas(&alpha).map_err(|e| py_err_in(e, "alpha"))?;
        let analysis = analysis_of(py, shape, &paneling)?;
        let nodes = analysis.solution.nodes().to_vec();
        let polar = py
            .detach(|| -> bezchain::Result<Vec<ViscousPoint>> {
                let body = Viscous::new(&nodes)?;
                Ok(body.polar(&alpha, &opts))
            })
            .map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("alpha", column(py, &polar, |p| p.alpha))?;
        let value = |v: Option<f64>| v.unwrap_or(f64::NAN);
        d.set_item("cl", column(py, &polar, |p| value(p.cl)))?;
        d.set_item("cd", column(py, &polar, |p| value(p.cd)))?;
        d.set_item("cdp", column(py, &polar, |p| value(p.cdp)))?;
        d.set_item("cm", column(py, &polar, |p| value(p.cm)))?;
        d.set_item("xtr_top", column(py, &polar, |p| value(p.xtr_top)))?;
        d.set_item("xtr_bottom", column(py, &polar, |p| value(p.xtr_bottom)))?;
        d.set_item("converged", column(py, &polar, |p| p.converged))?;
        d.set_item("separated", column(py, &polar, |p| p.separated.unwrap_or(false)))?;
        d.set_item("iterations", column(py, &polar, |p| p.iterations as u64))?;
        d.set_item("re", re)?;
        d.set_item("ncrit", ncrit)?;
        d.set_item("nodes", points2(py, &nodes)?)?;
        d.set_item("chord", analysis.solution.chord().length)?;
        return Ok(d);
    }
    let analysis = analysis_of(py, shape, &paneling)?;
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
    d.set_item("cl", column(py, &rep.polar, |c| c.cl))?;
    d.set_item("cm", column(py, &rep.polar, |c| c.cm))?;
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
    text_signature = "(start, objective, alpha=4.0, method='cmaes', population=None, generations=None, seed=1, tol=0.0001, margin=0.1, spread=0.01, stall=0, panels=160, min_thickness=None, cm_min=None, backend='auto', re=None, ncrit=9.0, cl=None, min_thickness_at=(), cl_min=None, min_te_angle=None, min_area=None)"
)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn optimise<'py>(
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
    let call = format!(
        "bezchain.optimise({:?}, {spec:?}, alpha={alpha}, method='{method}', seed={seed})",
        setup.start.display().to_string()
    );
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
            report: serde_json::to_string_pretty(
                &Stamp::new(Schema::Optimise, vec!["python".into(), call]).on(&outcome.report),
            )
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
    warn_each(py, &o.warnings)?;
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
        h.set_item(*name, column(py, &o.history, |r| r[k]))?;
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
pub(crate) fn objectives_list(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let names: Vec<String> = bezchain::aero::OBJECTIVES
        .iter()
        .map(|o| match o.argument() {
            Some(a) => format!("{}:{a}", o.name()),
            None => o.name().to_string(),
        })
        .collect();
    PyList::new(py, names)
}
