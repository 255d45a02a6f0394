//! The JSON reports of fitted curves and surfaces (`docs/ARCHITECTURE.md` §5.4, §5.5), written
//! by `fit`, `fit-surface`, `adapt`, `adapt-surface` and `optimise`, and the one reader of saved
//! reports ([`read_reports`], [`read_report`], [`Report::read`]) that `eval`, `sample`, `aero`,
//! `optimise` and `export` read them back with: each report's shape and, for an adapt report,
//! the encoding its `adapt` block stores.

use super::curve::CurveFit;
use super::surface::SurfaceFit;
use crate::adaptive::{Encoding, SurfaceEncoding};
use crate::bezier::Vector;
use crate::chain::{ChainLayout, Continuity, CurveChain, GridLayout, PatchGrid};
use crate::error::{Error, Result};
use crate::eval::{Backend, BackendInfo};
use crate::geometry::{from_json_value, parse_json, read_bytes, read_text};
use crate::optim::Method;
use crate::problem::OffsetStats;
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Offsets between the data and the fitted shape.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OffsetReport {
    /// `closest` (true closest-point distances) or `corresponding` (fixed parameters).
    pub metric: String,
    /// `Σ e_j²`.
    pub sum_sq: f64,
    /// `Σ e_j`.
    pub sum: f64,
    /// `sqrt(sum_sq / n)`.
    pub rms: f64,
    /// `max e_j`.
    pub max: f64,
    /// The data point with the largest offset.
    pub max_at: Vec<f64>,
}

/// One stage of a fit (an optimiser run).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitInfo {
    /// Method name as given on the command line (`lsq`, `bfgs`, `ga`, ...).
    pub method: String,
    /// Iterations (or generations) taken.
    pub iterations: u64,
    /// Objective evaluations (for population methods: individuals evaluated).
    pub evaluations: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// `cpu`, or the GPU adapter that ran the population evaluations.
    pub backend: String,
    /// Stages of a hybrid method (`ga+lsq`: the GA, then the least-squares polish).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub stages: Vec<FitInfo>,
    /// Population evaluations per second (individual × point), for population methods.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evals_per_second: Option<f64>,
    /// The cap that cut the method short (`"evaluation cap"`, `"iteration cap"`); absent when
    /// it stopped on its own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<String>,
}

impl<P: Vector> From<&OffsetStats<P>> for OffsetReport {
    /// The report's block of the library's offset statistics.
    fn from(s: &OffsetStats<P>) -> Self {
        OffsetReport {
            metric: s.metric.to_string(),
            sum_sq: s.sum_sq,
            sum: s.sum,
            rms: s.rms,
            max: s.max,
            max_at: (0..P::DIM).map(|c| s.max_at.coord(c)).collect(),
        }
    }
}

/// The name a report gives a backend: `cpu`, or the GPU adapter.
#[must_use]
pub fn backend_label(info: &BackendInfo) -> String {
    match info.backend {
        Backend::Gpu => info.adapter.clone(),
        _ => "cpu".to_string(),
    }
}

impl FitInfo {
    /// The `fit` block of an adaptive search on the CPU: `iterations` (steps or families),
    /// `evaluations` (candidate fits) and the seconds it took.
    #[must_use]
    pub fn of_search(iterations: u64, evaluations: u64, seconds: f64) -> Self {
        FitInfo {
            method: "adapt".into(),
            iterations,
            evaluations,
            seconds,
            backend: "cpu".into(),
            stages: vec![],
            evals_per_second: None,
            stopped: None,
        }
    }

    /// The `fit` block of a curve fit: the method's effort, and for the evolutionary methods
    /// the backend, the evaluator's throughput and the stages (of a hybrid).
    #[must_use]
    pub fn of_curve(fit: &CurveFit<DVec2>) -> Self {
        let mut info = FitInfo {
            method: fit.method.name().to_string(),
            iterations: fit.report.iterations as u64,
            evaluations: fit.report.evaluations as u64,
            seconds: fit.report.seconds,
            backend: "cpu".to_string(),
            stages: Vec::new(),
            evals_per_second: None,
            stopped: fit.stopped().map(String::from),
        };
        if let Some(evo) = &fit.evolution {
            info.backend = backend_label(&evo.run.backend);
            info.evals_per_second = Some(evo.run.evals_per_second);
            if evo.stages.len() > 1 {
                info.stages = evo
                    .stages
                    .iter()
                    .enumerate()
                    .map(|(k, s)| FitInfo {
                        method: s.method.clone(),
                        iterations: s.report.iterations as u64,
                        evaluations: s.report.evaluations as u64,
                        seconds: s.report.seconds,
                        backend: if k == 0 {
                            info.backend.clone()
                        } else {
                            "cpu".to_string()
                        },
                        stages: Vec::new(),
                        evals_per_second: (k == 0).then_some(evo.run.evals_per_second),
                        // A generation limit is the evolutionary stage's own end, not a cap.
                        stopped: if k == 0 {
                            None
                        } else {
                            s.report.cap().map(String::from)
                        },
                    })
                    .collect();
            }
        }
        info
    }

    /// The `fit` block of a surface fit by `method`: every stage, the evolutionary one (the
    /// first, when there is one) with the backend and the evaluator's throughput.
    #[must_use]
    pub fn of_surface(fit: &SurfaceFit, method: Method) -> Self {
        let evo_backend = fit.evolution.as_ref().map(|e| backend_label(&e.run.backend));
        let rate = fit.evolution.as_ref().map(|e| e.run.evals_per_second);
        let stages = fit
            .stages
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let evolutionary = k == 0 && evo_backend.is_some();
                FitInfo {
                    method: s.name.to_string(),
                    iterations: s.report.iterations as u64,
                    evaluations: s.report.evaluations as u64,
                    seconds: s.report.seconds,
                    backend: if evolutionary {
                        evo_backend.clone().unwrap_or_default()
                    } else {
                        "cpu".into()
                    },
                    stages: Vec::new(),
                    evals_per_second: if evolutionary { rate } else { None },
                    stopped: if evolutionary {
                        None
                    } else {
                        s.report.cap().map(String::from)
                    },
                }
            })
            .collect();
        FitInfo {
            method: method.name().into(),
            iterations: fit.report.iterations as u64,
            evaluations: fit.report.evaluations as u64,
            seconds: fit.report.seconds,
            backend: evo_backend.unwrap_or_else(|| "cpu".into()),
            stages,
            evals_per_second: rate,
            stopped: fit.stopped().map(String::from),
        }
    }
}

/// Where the data came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InputInfo {
    /// The input file as given.
    pub path: String,
    /// Number of data points used.
    pub points: usize,
}

/// The report of a curve fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurveReport {
    /// Always `curve`.
    pub kind: String,
    /// Always 2.
    pub dimension: usize,
    /// Degree of every segment.
    pub degree: usize,
    /// Number of segments.
    pub segments: usize,
    /// `C0`, `C1` or `C2`.
    pub continuity: Continuity,
    /// Breaks `0 = t0 < ... < ts = 1`.
    pub breaks: Vec<f64>,
    /// The optimisation variables.
    pub design_points: Vec<[f64; 2]>,
    /// Expanded Bezier control points; segment k uses `[k*d ..= (k+1)*d]`.
    pub control_points: Vec<[f64; 2]>,
    /// Offsets, re-measured in f64.
    pub offset: OffsetReport,
    /// How the fit ran.
    pub fit: FitInfo,
    /// The data.
    pub input: InputInfo,
}

/// The report of a surface fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SurfaceReport {
    /// Always `surface`.
    pub kind: String,
    /// Always 3.
    pub dimension: usize,
    /// `[du, dv]`.
    pub degree: [usize; 2],
    /// `[pu, pv]`.
    pub patches: [usize; 2],
    /// Continuity along u and along v.
    pub continuity: [Continuity; 2],
    /// Breaks along u.
    pub breaks_u: Vec<f64>,
    /// Breaks along v.
    pub breaks_v: Vec<f64>,
    /// The design net, rows along u.
    pub design_net: Vec<Vec<[f64; 3]>>,
    /// The expanded control net, rows along u.
    pub control_net: Vec<Vec<[f64; 3]>>,
    /// The largest relative jump of the first derivative across any patch border, in either
    /// direction, measured on the control net ([`PatchGrid::continuity_error`]; rounding
    /// for C1 and C2 grids, 0 for a single patch).
    #[serde(default)]
    pub continuity_error: f64,
    /// Offsets, re-measured in f64.
    pub offset: OffsetReport,
    /// How the fit ran.
    pub fit: FitInfo,
    /// The data.
    pub input: InputInfo,
}

/// Either kind of report, as read back from a file.
#[derive(Clone, Debug, PartialEq)]
pub enum Report {
    /// A curve report.
    Curve(CurveReport),
    /// A surface report.
    Surface(SurfaceReport),
}

impl CurveReport {
    /// The report of `chain` with the given offsets, fit information and input.
    #[must_use]
    pub fn new(chain: &CurveChain<DVec2>, offset: OffsetReport, fit: FitInfo, input: InputInfo) -> Self {
        let l = chain.layout();
        CurveReport {
            kind: "curve".into(),
            dimension: 2,
            degree: l.degree(),
            segments: l.segments(),
            continuity: l.continuity(),
            breaks: l.breaks().to_vec(),
            design_points: chain.design().iter().map(|p| p.to_array()).collect(),
            control_points: chain.ctrl().iter().map(|p| p.to_array()).collect(),
            offset,
            fit,
            input,
        }
    }

    /// The report of a finished curve fit of the data described by `input`.
    #[must_use]
    pub fn from_fit(fit: &CurveFit<DVec2>, input: InputInfo) -> Self {
        CurveReport::new(
            &fit.chain,
            OffsetReport::from(&fit.offset),
            FitInfo::of_curve(fit),
            input,
        )
    }

    /// The chain layout the report describes.
    pub fn layout(&self) -> Result<ChainLayout> {
        let l = ChainLayout::with_breaks(self.degree, self.breaks.clone(), self.continuity)?;
        if l.segments() != self.segments {
            return Err(Error::invalid(format!(
                "report: {} segments but {} breaks",
                self.segments,
                self.breaks.len()
            )));
        }
        Ok(l)
    }

    /// The chain rebuilt from the design points (checked against the stored control points).
    pub fn chain(&self) -> Result<CurveChain<DVec2>> {
        let design = self.design_points.iter().map(|&p| DVec2::from_array(p)).collect();
        let chain = CurveChain::new(self.layout()?, design)?;
        check_expanded(
            chain.ctrl().iter().map(|p| p.to_array().to_vec()),
            self.control_points.iter().map(|p| p.to_vec()),
        )?;
        Ok(chain)
    }
}

impl SurfaceReport {
    /// The report of `grid` with the given offsets, fit information and input.
    #[must_use]
    pub fn new(grid: &PatchGrid<DVec3>, offset: OffsetReport, fit: FitInfo, input: InputInfo) -> Self {
        let l = grid.layout();
        let nest = |pts: &[DVec3], cols: usize| -> Vec<Vec<[f64; 3]>> {
            pts.chunks(cols)
                .map(|r| r.iter().map(|p| p.to_array()).collect())
                .collect()
        };
        SurfaceReport {
            kind: "surface".into(),
            dimension: 3,
            degree: [l.u.degree(), l.v.degree()],
            patches: [l.u.segments(), l.v.segments()],
            continuity: [l.u.continuity(), l.v.continuity()],
            breaks_u: l.u.breaks().to_vec(),
            breaks_v: l.v.breaks().to_vec(),
            design_net: nest(grid.design(), l.design_shape().1),
            control_net: nest(grid.net(), l.net_shape().1),
            continuity_error: grid.continuity_error(),
            offset,
            fit,
            input,
        }
    }

    /// The report of a finished surface fit by `method` of the cloud described by `input`.
    #[must_use]
    pub fn from_fit(fit: &SurfaceFit, method: Method, input: InputInfo) -> Self {
        SurfaceReport::new(
            &fit.grid,
            OffsetReport::from(&fit.stats),
            FitInfo::of_surface(fit, method),
            input,
        )
    }

    /// The grid layout the report describes.
    pub fn layout(&self) -> Result<GridLayout> {
        let u = ChainLayout::with_breaks(self.degree[0], self.breaks_u.clone(), self.continuity[0])?;
        let v = ChainLayout::with_breaks(self.degree[1], self.breaks_v.clone(), self.continuity[1])?;
        if [u.segments(), v.segments()] != self.patches {
            return Err(Error::invalid("report: patches do not match the breaks"));
        }
        Ok(GridLayout::new(u, v))
    }

    /// The grid rebuilt from the design net (checked against the stored control net).
    pub fn grid(&self) -> Result<PatchGrid<DVec3>> {
        let layout = self.layout()?;
        let (nu, nv) = layout.design_shape();
        if self.design_net.len() != nu || self.design_net.iter().any(|r| r.len() != nv) {
            return Err(Error::invalid(format!("report: design_net is not {nu} x {nv}")));
        }
        let design = self
            .design_net
            .iter()
            .flatten()
            .map(|&p| DVec3::from_array(p))
            .collect();
        let grid = PatchGrid::new(layout, design)?;
        check_expanded(
            grid.net().iter().map(|p| p.to_array().to_vec()),
            self.control_net
                .iter()
                .flatten()
                .map(|p| p.to_vec())
                .collect::<Vec<_>>()
                .into_iter(),
        )?;
        Ok(grid)
    }
}

/// Stored control points must be the expansion of the stored design points (to rounding).
fn check_expanded(
    ours: impl ExactSizeIterator<Item = Vec<f64>>,
    stored: impl ExactSizeIterator<Item = Vec<f64>>,
) -> Result<()> {
    if ours.len() != stored.len() {
        return Err(Error::invalid(format!(
            "report: {} control points stored, the layout expands to {}",
            stored.len(),
            ours.len()
        )));
    }
    for (i, (a, b)) in ours.zip(stored).enumerate() {
        let scale = a.iter().chain(&b).fold(1.0_f64, |m, x| m.max(x.abs()));
        if a.iter().zip(&b).any(|(x, y)| (x - y).abs() > 1e-9 * scale) {
            return Err(Error::invalid(format!(
                "report: control point {i} is not generated from the design points by the layout"
            )));
        }
    }
    Ok(())
}

impl Report {
    /// Read the one report (either kind) of a JSON file ([`read_report`], the encoding of an
    /// adapt report left out).
    pub fn read(path: &Path) -> Result<Report> {
        Ok(match read_report(path)? {
            Saved::Curve(r, _) => Report::Curve(r),
            Saved::Surface(r, _) => Report::Surface(r),
        })
    }
}

/// One report of a saved file: its shape's report and, for an adapt report, the encoding its
/// `adapt` block stores (`docs/ARCHITECTURE.md` §5.6, §5.7).
#[derive(Clone, Debug, PartialEq)]
pub enum Saved {
    /// A curve report (of `fit`, `adapt` or `optimise`).
    Curve(CurveReport, Option<Encoding>),
    /// A surface report (of `fit-surface` or `adapt-surface`).
    Surface(SurfaceReport, Option<SurfaceEncoding>),
}

/// Whether `path` holds a JSON report rather than coordinates: its first character, after
/// white space, is `{`.
pub fn is_report(path: &Path) -> Result<bool> {
    let bytes = read_bytes(path)?;
    Ok(bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{'))
}

/// The one report of a JSON file. A field that does not parse is named with its line.
pub fn read_report(path: &Path) -> Result<Saved> {
    parse_report(&read_text(path)?, path)
}

/// The one report of a JSON `text` ([`read_report`] on text already read; `path` names it in
/// errors, e.g. `<string>` for a report handed over in memory).
pub fn parse_report(text: &str, path: &Path) -> Result<Saved> {
    let value: serde_json::Value = parse_json(text, path, "not JSON")?;
    Saved::of_text(value, text, path)
}

/// Every report of a JSON file: one report, or a sweep's (`{"kind": "sweep", "reports": […]}`,
/// or a bare array of reports as written before reports were stamped; an empty one gives
/// none). A field of a single report that does not parse is named with its line; one in a
/// sweep, with the report's index from the second on (`report 2: `).
pub fn read_reports(path: &Path) -> Result<Vec<Saved>> {
    let text = read_text(path)?;
    let value = parse_json(&text, path, "not JSON")?;
    let value = match value {
        serde_json::Value::Object(mut sweep) if kind_of_map(&sweep) == "sweep" => {
            match sweep.remove("reports") {
                Some(reports @ serde_json::Value::Array(_)) => reports,
                _ => {
                    return Err(Error::Input {
                        path: path.into(),
                        message: "a sweep report needs \"reports\", an array of reports".into(),
                    })
                }
            }
        }
        other => other,
    };
    match value {
        serde_json::Value::Array(items) => items
            .into_iter()
            .enumerate()
            .map(|(k, item)| Saved::of_value(item, path, k))
            .collect(),
        one => Ok(vec![Saved::of_text(one, &text, path)?]),
    }
}

/// The error for a JSON value that is no bezchain report; `at` says which of an array.
fn not_a_report(path: &Path, at: &str) -> Error {
    Error::Input {
        path: path.into(),
        message: format!("{at}not a bezchain report (\"kind\" must be \"curve\" or \"surface\")"),
    }
}

/// The `kind` of a report's JSON object (empty without one).
fn kind_of_map(map: &serde_json::Map<String, serde_json::Value>) -> &str {
    map.get("kind").and_then(|k| k.as_str()).unwrap_or_default()
}

/// The `kind` of a report's JSON value (empty without one).
fn kind_of(value: &serde_json::Value) -> String {
    value
        .get("kind")
        .and_then(|k| k.as_str())
        .unwrap_or_default()
        .to_string()
}

impl Saved {
    /// The report of a file's single JSON `value`, parsed from its `text` (so that an error
    /// names the line).
    fn of_text(value: serde_json::Value, text: &str, path: &Path) -> Result<Saved> {
        let kind = kind_of(&value);
        let what = format!("not a bezchain {kind} report");
        match kind.as_str() {
            "curve" => Ok(Saved::Curve(
                parse_json(text, path, &what)?,
                encoding(&value, path, "", &kind)?,
            )),
            "surface" => Ok(Saved::Surface(
                parse_json(text, path, &what)?,
                encoding(&value, path, "", &kind)?,
            )),
            _ => Err(not_a_report(path, "")),
        }
    }

    /// The report `item`, the `k`-th of an array in `path`.
    fn of_value(item: serde_json::Value, path: &Path, k: usize) -> Result<Saved> {
        let at = if k == 0 {
            String::new()
        } else {
            format!("report {k}: ")
        };
        let kind = kind_of(&item);
        let bad = |e: String| Error::Input {
            path: path.into(),
            message: format!("{at}not a bezchain {kind} report: {e}"),
        };
        match kind.as_str() {
            "curve" => {
                let enc = encoding(&item, path, &at, &kind)?;
                Ok(Saved::Curve(from_json_value(item, "").map_err(bad)?, enc))
            }
            "surface" => {
                let enc = encoding(&item, path, &at, &kind)?;
                Ok(Saved::Surface(from_json_value(item, "").map_err(bad)?, enc))
            }
            _ => Err(not_a_report(path, &at)),
        }
    }
}

/// The encoding of a report's `adapt` block, if it has one (`at` and `kind` for the message).
fn encoding<E: serde::de::DeserializeOwned>(
    value: &serde_json::Value,
    path: &Path,
    at: &str,
    kind: &str,
) -> Result<Option<E>> {
    let Some(enc) = value
        .get("adapt")
        .map(|a| a.get("encoding").cloned().unwrap_or_default())
    else {
        return Ok(None);
    };
    from_json_value(enc, "adapt.encoding.")
        .map(Some)
        .map_err(|e| Error::Input {
            path: path.into(),
            message: format!("{at}not a bezchain {kind} report: {e}"),
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn offset() -> OffsetReport {
        OffsetReport {
            metric: "closest".into(),
            sum_sq: 1e-8,
            sum: 1e-4,
            rms: 1e-5,
            max: 3e-5,
            max_at: vec![0.5, 0.1],
        }
    }

    fn fit() -> FitInfo {
        FitInfo {
            method: "lsq".into(),
            iterations: 3,
            evaluations: 4,
            seconds: 0.001,
            backend: "cpu".into(),
            stages: vec![],
            evals_per_second: None,
            stopped: None,
        }
    }

    fn input(path: &str, points: usize) -> InputInfo {
        InputInfo {
            path: path.into(),
            points,
        }
    }

    #[test]
    fn curve_report_round_trips_with_the_design_keys() {
        let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
        let design: Vec<DVec2> = (0..12)
            .map(|i| DVec2::new(i as f64 / 11.0, (i as f64).sin() * 0.1))
            .collect();
        let chain = CurveChain::new(layout, design).unwrap();
        let rep = CurveReport::new(&chain, offset(), fit(), input("data/naca4413.dat", 82));
        let text = serde_json::to_string_pretty(&rep).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        for key in [
            "kind",
            "dimension",
            "degree",
            "segments",
            "continuity",
            "breaks",
            "design_points",
            "control_points",
            "offset",
            "fit",
            "input",
        ] {
            assert!(v.get(key).is_some(), "missing key {key}");
        }
        assert_eq!(v["continuity"], "C1");
        assert_eq!(v["control_points"].as_array().unwrap().len(), 16);
        for key in ["metric", "sum_sq", "sum", "rms", "max", "max_at"] {
            assert!(v["offset"].get(key).is_some(), "missing offset.{key}");
        }
        for key in ["method", "iterations", "evaluations", "seconds", "backend"] {
            assert!(v["fit"].get(key).is_some(), "missing fit.{key}");
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.json");
        std::fs::write(&path, &text).unwrap();
        match Report::read(&path).unwrap() {
            Report::Curve(back) => {
                assert_eq!(back, rep);
                assert_eq!(back.chain().unwrap().ctrl(), chain.ctrl());
            }
            Report::Surface(_) => panic!("read a curve report as a surface"),
        }
    }

    #[test]
    fn surface_report_round_trips() {
        let g = GridLayout::uniform((3, 3), (4, 2), Continuity::C1).unwrap();
        let design: Vec<DVec3> = (0..60)
            .map(|i| DVec3::new((i / 6) as f64, (i % 6) as f64, (i as f64).cos()))
            .collect();
        let grid = PatchGrid::new(g, design).unwrap();
        let rep = SurfaceReport::new(&grid, offset(), fit(), input("cloud.csv", 984));
        assert_eq!((rep.design_net.len(), rep.design_net[0].len()), (10, 6));
        assert_eq!((rep.control_net.len(), rep.control_net[0].len()), (13, 7));
        let v = serde_json::to_value(&rep).unwrap();
        assert_eq!(v["degree"], serde_json::json!([3, 3]));
        assert_eq!(v["patches"], serde_json::json!([4, 2]));
        let back: SurfaceReport = serde_json::from_value(v).unwrap();
        assert_eq!(back.grid().unwrap().net(), grid.net());
    }

    #[test]
    fn tampered_and_foreign_reports_are_refused() {
        let layout = ChainLayout::uniform(2, 2, Continuity::C1).unwrap();
        let chain = CurveChain::new(layout, vec![DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ONE]).unwrap();
        let mut rep = CurveReport::new(
            &chain,
            offset(),
            fit(),
            InputInfo {
                path: "x".into(),
                points: 4,
            },
        );
        rep.control_points[2][0] += 0.5;
        assert!(rep.chain().is_err());
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.json");
        std::fs::write(&path, "{\"kind\": \"curve\", \"degree\": 3}").unwrap();
        let e = Report::read(&path).unwrap_err();
        assert!(
            matches!(e, Error::Parse { line: 1, .. }) && e.to_string().contains("missing field"),
            "{e}"
        );
        // A value of the wrong type names its field.
        std::fs::write(&path, "{\"kind\": \"curve\",\n \"degree\": [3]}").unwrap();
        let e = Report::read(&path).unwrap_err().to_string();
        assert!(e.contains("bad.json:2") && e.contains("field 'degree'"), "{e}");
        std::fs::write(&path, "{ not json").unwrap();
        assert!(matches!(Report::read(&path), Err(Error::Parse { line: 1, .. })));
        std::fs::write(&path, "[1, 2]").unwrap();
        assert!(Report::read(&path).is_err());
    }

    /// An array of reports reads each, an adapt report with its encoding; a report of an
    /// array that does not parse is named by its index from the second on, and a file that
    /// should hold one report refuses an array.
    #[test]
    fn arrays_and_adapt_encodings_read_back() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/naca4413.dat");
        let pts = crate::geometry::read_curve(&data).unwrap().points;
        let opts = crate::adaptive::AdaptOptions {
            tol: 1e-2,
            ..crate::adaptive::AdaptOptions::default()
        };
        let adapted = crate::adaptive::adapt_curve(&pts, &opts).unwrap();
        let layout = ChainLayout::uniform(2, 2, Continuity::C1).unwrap();
        let chain = CurveChain::new(layout, vec![DVec2::ZERO, DVec2::X, DVec2::Y, DVec2::ONE]).unwrap();
        let fitted = CurveReport::new(
            &chain,
            offset(),
            fit(),
            InputInfo {
                path: "y".into(),
                points: 4,
            },
        );
        let plain = serde_json::to_value(&fitted).unwrap();
        // An adapt report is a curve report with an `adapt` block holding the encoding.
        let mut adapt = serde_json::to_value(CurveReport::new(
            &adapted.chain,
            offset(),
            fit(),
            InputInfo {
                path: "x".into(),
                points: pts.len(),
            },
        ))
        .unwrap();
        adapt["adapt"] = serde_json::json!({ "encoding": adapted.encoding });
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.json");
        std::fs::write(&path, serde_json::to_string(&vec![&adapt, &plain]).unwrap()).unwrap();
        let saved = read_reports(&path).unwrap();
        assert!(matches!(&saved[0], Saved::Curve(_, Some(e)) if *e == adapted.encoding));
        assert_eq!(saved[1], Saved::Curve(fitted, None));
        let e = read_report(&path).unwrap_err().to_string();
        assert!(
            e.ends_with("not a bezchain report (\"kind\" must be \"curve\" or \"surface\")"),
            "{e}"
        );
        let mut broken = plain.clone();
        broken["degree"] = serde_json::json!("three");
        std::fs::write(&path, serde_json::to_string(&vec![&plain, &broken]).unwrap()).unwrap();
        let e = read_reports(&path).unwrap_err().to_string();
        assert!(
            e.contains("report 1: not a bezchain curve report: field 'degree'"),
            "{e}"
        );
        std::fs::write(&path, "[]").unwrap();
        assert!(read_reports(&path).unwrap().is_empty());
    }
}
