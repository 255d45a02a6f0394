//! CAD export: every chain as one B-spline curve and every patch grid as one B-spline surface,
//! written as STEP AP214 ([`super::step`]) or IGES 5.3 ([`super::iges`]).
//!
//! A chain of degree `d` whose joins have continuity `Ck` is exactly the B-spline of degree `d`
//! over the clamped knot vector whose interior knots are the breaks, each of multiplicity
//! `d - k`, with the design points as control points (the layout's own knot vector,
//! [`ChainLayout::knots`], `docs/ARCHITECTURE.md` §2.2); an adapted chain's
//! encoding gives each join its own `k`. Nothing is approximated: the exported curve or
//! surface is the fitted one, to the rounding of its coefficients (printed in shortest
//! round-trip form).

use super::{AdaptReport, SurfaceAdaptReport};
use crate::adaptive::{Encoding, SurfaceEncoding};
use crate::bezier::tensor_jet;
use crate::chain::{ChainLayout, CurveChain, PatchGrid};
use crate::error::{Error, Result};
use crate::export::{CurveReport, SurfaceReport};
use crate::geometry::from_json_value;
use crate::keyword::keywords;
use glam::{DVec2, DVec3};
use std::path::Path;

/// A non-rational B-spline curve over a clamped knot vector.
#[derive(Clone, Debug, PartialEq)]
pub struct BsplineCurve {
    /// Polynomial degree.
    pub degree: usize,
    /// The full knot vector (`degree + 1` equal knots at each end), non-decreasing.
    pub knots: Vec<f64>,
    /// Control points, `knots.len() - degree - 1` of them.
    pub ctrl: Vec<DVec3>,
}

/// A non-rational tensor-product B-spline surface over clamped knot vectors.
#[derive(Clone, Debug, PartialEq)]
pub struct BsplineSurface {
    /// Degrees `[du, dv]`.
    pub degree: [usize; 2],
    /// Knot vector along u.
    pub knots_u: Vec<f64>,
    /// Knot vector along v.
    pub knots_v: Vec<f64>,
    /// Number of control points along u and along v.
    pub count: [usize; 2],
    /// Control points, row-major: point `(i, j)` (i along u) at `i * count[1] + j`.
    pub ctrl: Vec<DVec3>,
}

/// One exported entity.
#[derive(Clone, Debug, PartialEq)]
pub enum CadShape {
    /// A curve (a chain; 2D chains lie in z = 0).
    Curve(BsplineCurve),
    /// A surface (a patch grid).
    Surface(BsplineSurface),
}

/// The length unit written into the files (the coordinates themselves are never scaled).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CadUnit {
    /// Metres (default).
    #[default]
    Metre,
    /// Millimetres (what OpenCASCADE writes unless told otherwise).
    Millimetre,
}

keywords!(CadUnit, "CAD unit", { Metre => "m", Millimetre => "mm" });

/// The knots that differ and how often each occurs (STEP's form).
#[must_use]
pub fn distinct_knots(knots: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut values: Vec<f64> = Vec::new();
    let mut mults: Vec<usize> = Vec::new();
    for &k in knots {
        if values.last() == Some(&k) {
            if let Some(m) = mults.last_mut() {
                *m += 1;
            }
        } else {
            values.push(k);
            mults.push(1);
        }
    }
    (values, mults)
}

/// The chain whose B-spline form has `degree` and `knots`: its layout (the knots' distinct
/// values mapped from `[lo, hi]` to the breaks in `[0, 1]`, an interior knot of multiplicity
/// `m` a join of continuity order `degree - m`) with `lo` and `hi`. `None` where the knots are
/// not a chain's (clamped ends of multiplicity `degree + 1`, degree 1 to
/// [`MAX_DEGREE`](crate::chain::MAX_DEGREE), interior multiplicities 1 to `degree`).
///
/// The exported B-splines are evaluated as these chains, through their Bezier extraction and
/// the one Bernstein evaluator ([`ChainLayout::basis`]): exactly the curves and surfaces the
/// reports hold.
fn chain_layout(degree: usize, knots: &[f64]) -> Option<(ChainLayout, f64, f64)> {
    let (values, mults) = distinct_knots(knots);
    let (&lo, &hi) = (values.first()?, values.last()?);
    let clamped = |m: &usize| *m == degree + 1;
    if values.len() < 2 || !mults.first().is_some_and(clamped) || !mults.last().is_some_and(clamped) {
        return None;
    }
    let breaks = values.iter().map(|k| (k - lo) / (hi - lo)).collect();
    let orders = mults[1..mults.len() - 1]
        .iter()
        .map(|&m| degree.checked_sub(m))
        .collect::<Option<Vec<_>>>()?;
    let layout = ChainLayout::with_orders(degree, breaks, orders).ok()?;
    Some((layout, lo, hi))
}

/// The layout's parameter of `t` in `[lo, hi]`.
fn to_unit(t: f64, lo: f64, hi: f64) -> f64 {
    (t - lo) / (hi - lo)
}

impl BsplineCurve {
    /// The B-spline form of a chain (exact).
    #[must_use]
    pub fn from_chain(chain: &CurveChain<DVec2>) -> Self {
        let knots = chain.layout().knots().to_vec();
        let ctrl: Vec<DVec3> = chain.design().iter().map(|p| p.extend(0.0)).collect();
        debug_assert_eq!(
            ctrl.len(),
            knots.len() - chain.layout().degree() - 1,
            "one design point per basis function"
        );
        BsplineCurve {
            degree: chain.layout().degree(),
            knots,
            ctrl,
        }
    }

    /// The B-spline an adapted curve's encoding stores (each join its own continuity).
    pub fn from_encoding(enc: &Encoding) -> Result<Self> {
        let layout = enc.layout()?;
        Ok(BsplineCurve {
            degree: layout.degree(),
            knots: layout.knots().to_vec(),
            ctrl: enc.coeffs()?.iter().map(|p| p.extend(0.0)).collect(),
        })
    }

    /// The point at parameter `t` (clamped to the knot range), evaluated as the chain the
    /// B-spline is; NaN where the knots are not a chain's (clamped, degree 1 to 7, interior
    /// multiplicities 1 to the degree).
    #[must_use]
    pub fn eval(&self, t: f64) -> DVec3 {
        let Some((layout, lo, hi)) = chain_layout(self.degree, &self.knots) else {
            debug_assert!(false, "BsplineCurve::eval: the knots are not a chain's");
            return DVec3::NAN;
        };
        layout.eval(&self.ctrl, to_unit(t, lo, hi))
    }
}

impl BsplineSurface {
    /// The B-spline form of a patch grid (exact).
    #[must_use]
    pub fn from_grid(grid: &PatchGrid<DVec3>) -> Self {
        let l = grid.layout();
        let (nu, nv) = l.design_shape();
        BsplineSurface {
            degree: [l.u.degree(), l.v.degree()],
            knots_u: l.u.knots().to_vec(),
            knots_v: l.v.knots().to_vec(),
            count: [nu, nv],
            ctrl: grid.design().to_vec(),
        }
    }

    /// The B-spline surface an adapted grid's encoding stores.
    pub fn from_encoding(enc: &SurfaceEncoding) -> Result<Self> {
        let (lu, lv) = enc.layouts()?;
        Ok(BsplineSurface {
            degree: [lu.degree(), lv.degree()],
            knots_u: lu.knots().to_vec(),
            knots_v: lv.knots().to_vec(),
            count: [lu.design_count(), lv.design_count()],
            ctrl: enc.design()?,
        })
    }

    /// The control point `(i, j)`.
    #[must_use]
    pub fn at(&self, i: usize, j: usize) -> DVec3 {
        self.ctrl[i * self.count[1] + j]
    }

    /// The point at `(u, v)` (clamped to the knot ranges), evaluated as the patch grid the
    /// B-spline surface is; NaN where either knot vector is not a chain's.
    #[must_use]
    pub fn eval(&self, u: f64, v: f64) -> DVec3 {
        let along = |d: usize, knots: &[f64], t: f64| {
            chain_layout(d, knots).map(|(l, lo, hi)| (l.basis(to_unit(t, lo, hi), 0), d + 1))
        };
        let (Some((bu, nu)), Some((bv, nv))) = (
            along(self.degree[0], &self.knots_u, u),
            along(self.degree[1], &self.knots_v, v),
        ) else {
            debug_assert!(false, "BsplineSurface::eval: the knots are not a grid's");
            return DVec3::NAN;
        };
        let net = &self.ctrl[bu.first * self.count[1] + bv.first..];
        tensor_jet(net, self.count[1], (nu, nv), [&bu.value], [&bv.value], 0)[0][0]
    }

    /// The boundary curve at `u = knots_u` start (`side` 0) or end (1), running along v.
    #[must_use]
    pub fn u_boundary(&self, side: usize) -> BsplineCurve {
        let i = if side == 0 { 0 } else { self.count[0] - 1 };
        BsplineCurve {
            degree: self.degree[1],
            knots: self.knots_v.clone(),
            ctrl: (0..self.count[1]).map(|j| self.at(i, j)).collect(),
        }
    }

    /// The boundary curve at the start (`side` 0) or end (1) of v, running along u.
    #[must_use]
    pub fn v_boundary(&self, side: usize) -> BsplineCurve {
        let j = if side == 0 { 0 } else { self.count[1] - 1 };
        BsplineCurve {
            degree: self.degree[0],
            knots: self.knots_u.clone(),
            ctrl: (0..self.count[0]).map(|i| self.at(i, j)).collect(),
        }
    }
}

/// The Bezier control points a curve's B-spline expands to must be the stored ones (a
/// tampered or inconsistent report is refused).
fn check_bezier(ours: &[DVec2], stored: &[[f64; 2]], what: &str) -> Result<()> {
    if ours.len() != stored.len() {
        return Err(Error::invalid(format!(
            "report: {} control points stored, the {what} expands to {}",
            stored.len(),
            ours.len()
        )));
    }
    for (i, (a, b)) in ours.iter().zip(stored).enumerate() {
        let b = DVec2::from_array(*b);
        if (*a - b).abs().max_element() > 1e-9 * (1.0 + b.abs().max_element()) {
            return Err(Error::invalid(format!(
                "report: control point {i} is not generated by the {what}"
            )));
        }
    }
    Ok(())
}

impl CadShape {
    /// The curve of a fit report (checked against its stored control points).
    pub fn from_curve_report(r: &CurveReport) -> Result<Self> {
        Ok(CadShape::Curve(BsplineCurve::from_chain(&r.chain()?)))
    }

    /// The curve of an adapt report: its encoding's B-spline, each join with its own
    /// multiplicity (checked against the stored control points).
    pub fn from_adapt_report(r: &AdaptReport) -> Result<Self> {
        Self::from_encoded_curve(&r.curve, &r.adapt.outcome.encoding)
    }

    /// The curve `enc` stores, checked against the report `r` it came with.
    fn from_encoded_curve(r: &CurveReport, enc: &Encoding) -> Result<Self> {
        check_bezier(&enc.control_points()?, &r.control_points, "encoding")?;
        Ok(CadShape::Curve(BsplineCurve::from_encoding(enc)?))
    }

    /// The surface of a fit report (checked against its stored control net).
    pub fn from_surface_report(r: &SurfaceReport) -> Result<Self> {
        Ok(CadShape::Surface(BsplineSurface::from_grid(&r.grid()?)))
    }

    /// The surface of an adapted-surface report: its encoding's B-spline (checked against the
    /// stored control net).
    pub fn from_surface_adapt_report(r: &SurfaceAdaptReport) -> Result<Self> {
        Self::from_encoded_surface(&r.surface, &r.adapt.outcome.encoding)
    }

    /// The surface `enc` stores, checked against the report `r` it came with.
    fn from_encoded_surface(r: &SurfaceReport, enc: &SurfaceEncoding) -> Result<Self> {
        let grid = enc.grid()?;
        let stored: Vec<DVec3> = r
            .control_net
            .iter()
            .flatten()
            .map(|p| DVec3::from_array(*p))
            .collect();
        if stored.len() != grid.net().len()
            || grid
                .net()
                .iter()
                .zip(&stored)
                .any(|(a, b)| (*a - *b).abs().max_element() > 1e-9 * (1.0 + b.abs().max_element()))
        {
            return Err(Error::invalid(
                "report: the control net is not generated by the encoding",
            ));
        }
        Ok(CadShape::Surface(BsplineSurface::from_encoding(enc)?))
    }

    /// Every shape of a report file (`fit`, `adapt`, `fit-surface`, `adapt-surface`; one report
    /// or an array of them).
    pub fn read_reports(path: &Path) -> Result<Vec<CadShape>> {
        let text = crate::geometry::read_text(path)?;
        let value: serde_json::Value = crate::geometry::parse_json(&text, path, "not JSON")?;
        let items = match value {
            serde_json::Value::Array(items) => items,
            one => vec![one],
        };
        if items.is_empty() {
            return Err(Error::Input {
                path: path.into(),
                message: "an empty array: no report to export".into(),
            });
        }
        let mut out = Vec::with_capacity(items.len());
        for (k, item) in items.into_iter().enumerate() {
            let at = if out.is_empty() && k == 0 {
                String::new()
            } else {
                format!("report {k}: ")
            };
            let kind = item
                .get("kind")
                .and_then(|k| k.as_str())
                .unwrap_or_default()
                .to_string();
            let adapted = item.get("adapt").is_some();
            let bad = |e: String| Error::Input {
                path: path.into(),
                message: format!("{at}not a bezchain {kind} report: {e}"),
            };
            let invalid = |e: Error| Error::Input {
                path: path.into(),
                message: format!("{at}{e}"),
            };
            // An adapt report is read as its fit report plus the encoding (the rest of its
            // adapt block is not needed here).
            let encoding = item.get("adapt").and_then(|a| a.get("encoding")).cloned();
            let shape = match (kind.as_str(), adapted) {
                ("curve", false) => {
                    let r: CurveReport = from_json_value(item, "").map_err(bad)?;
                    CadShape::from_curve_report(&r).map_err(invalid)?
                }
                ("curve", true) => {
                    let enc: Encoding =
                        from_json_value(encoding.unwrap_or_default(), "adapt.encoding.").map_err(bad)?;
                    let r: CurveReport = from_json_value(item, "").map_err(bad)?;
                    CadShape::from_encoded_curve(&r, &enc).map_err(invalid)?
                }
                ("surface", false) => {
                    let r: SurfaceReport = from_json_value(item, "").map_err(bad)?;
                    CadShape::from_surface_report(&r).map_err(invalid)?
                }
                ("surface", true) => {
                    let enc: SurfaceEncoding =
                        from_json_value(encoding.unwrap_or_default(), "adapt.encoding.").map_err(bad)?;
                    let r: SurfaceReport = from_json_value(item, "").map_err(bad)?;
                    CadShape::from_encoded_surface(&r, &enc).map_err(invalid)?
                }
                _ => {
                    return Err(Error::Input {
                        path: path.into(),
                        message: format!(
                            "{at}not a bezchain report (\"kind\" must be \"curve\" or \"surface\")"
                        ),
                    })
                }
            };
            out.push(shape);
        }
        Ok(out)
    }
}

/// Write `shapes` as STEP and/or IGES files (each atomically). `name` names the product in
/// the files, `timestamp` is written as the files' date (`YYYY-MM-DDThh:mm:ss`).
pub fn write_cad(
    shapes: &[CadShape],
    step: Option<&Path>,
    iges: Option<&Path>,
    unit: CadUnit,
    name: &str,
    timestamp: &str,
) -> Result<()> {
    if shapes.is_empty() {
        return Err(Error::invalid("nothing to export"));
    }
    if let Some(p) = step {
        let text = super::step::step_text(shapes, unit, name, timestamp)?;
        crate::geometry::write_atomic(p, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    }
    if let Some(p) = iges {
        let text = super::iges::iges_text(shapes, unit, name, timestamp)?;
        crate::geometry::write_atomic(p, |w| std::io::Write::write_all(w, text.as_bytes()))?;
    }
    Ok(())
}

/// The current UTC time as `YYYY-MM-DDThh:mm:ss` (for the files' date).
#[must_use]
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, GridLayout};

    #[test]
    fn a_chain_and_its_bspline_are_the_same_curve() {
        for (degree, continuity) in [
            (3, Continuity::C1),
            (3, Continuity::C2),
            (2, Continuity::C0),
            (5, Continuity::C2),
        ] {
            let layout =
                ChainLayout::with_breaks(degree, vec![0.0, 0.2, 0.45, 0.7, 1.0], continuity).unwrap();
            let design: Vec<DVec2> = (0..layout.design_count())
                .map(|i| DVec2::new(i as f64 * 0.3, ((i * 7) % 5) as f64 * 0.1 - 0.2))
                .collect();
            let chain = CurveChain::new(layout, design).unwrap();
            let b = BsplineCurve::from_chain(&chain);
            let (values, mults) = distinct_knots(&b.knots);
            assert_eq!(values, vec![0.0, 0.2, 0.45, 0.7, 1.0]);
            let m = degree - continuity.order();
            assert_eq!(mults, vec![degree + 1, m, m, m, degree + 1]);
            for i in 0..=400 {
                let t = i as f64 / 400.0;
                let d = (b.eval(t).truncate() - chain.eval(t)).length();
                assert!(d < 1e-13, "degree {degree} {continuity} at {t}: {d}");
            }
        }
    }

    #[test]
    fn a_grid_and_its_bspline_surface_are_the_same_surface() {
        let g = GridLayout::new(
            ChainLayout::with_breaks(3, vec![0.0, 0.3, 0.5, 1.0], Continuity::C1).unwrap(),
            ChainLayout::with_breaks(2, vec![0.0, 0.6, 1.0], Continuity::C1).unwrap(),
        );
        let (nu, nv) = g.design_shape();
        let design: Vec<DVec3> = (0..nu * nv)
            .map(|k| DVec3::new((k / nv) as f64, (k % nv) as f64, ((k * 13) % 7) as f64 * 0.1))
            .collect();
        let grid = PatchGrid::new(g, design).unwrap();
        let s = BsplineSurface::from_grid(&grid);
        assert_eq!(s.count, [nu, nv]);
        for i in 0..=40 {
            for j in 0..=40 {
                let (u, v) = (i as f64 / 40.0, j as f64 / 40.0);
                assert!((s.eval(u, v) - grid.eval(u, v)).length() < 1e-13, "({u}, {v})");
            }
        }
        // Boundaries are the surface's edges.
        for i in 0..=20 {
            let t = i as f64 / 20.0;
            assert!((s.u_boundary(1).eval(t) - grid.eval(1.0, t)).length() < 1e-13);
            assert!((s.v_boundary(0).eval(t) - grid.eval(t, 0.0)).length() < 1e-13);
        }
    }

    #[test]
    fn units_and_dates() {
        assert_eq!("MM".parse::<CadUnit>().unwrap(), CadUnit::Millimetre);
        assert!("ft".parse::<CadUnit>().is_err());
        let now = utc_now();
        assert_eq!(now.len(), 19);
        assert!(now.starts_with("20") && &now[10..11] == "T", "{now}");
    }
}
