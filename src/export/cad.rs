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
use crate::chain::{CurveChain, PatchGrid};
use crate::error::{Error, Result};
use crate::fit::report::{read_reports, CurveReport, Saved, SurfaceReport};
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

/// The B-spline basis functions of `degree` over `knots` that are non-zero at `t` (clamped to
/// the knot range): the index of the first and their values (Cox-de Boor).
fn basis(degree: usize, knots: &[f64], t: f64) -> (usize, Vec<f64>) {
    let n = knots.len() - degree - 1;
    let (lo, hi) = (knots[degree], knots[n]);
    let t = t.clamp(lo, hi);
    // The span: knots[span] <= t < knots[span + 1], the last non-empty span at the end.
    let span = if t >= hi {
        (degree..n)
            .rev()
            .find(|&s| knots[s] < knots[s + 1])
            .unwrap_or(degree)
    } else {
        knots.partition_point(|&k| k <= t) - 1
    };
    let mut values = vec![0.0; degree + 1];
    let mut left = vec![0.0; degree + 1];
    let mut right = vec![0.0; degree + 1];
    values[0] = 1.0;
    for j in 1..=degree {
        left[j] = t - knots[span + 1 - j];
        right[j] = knots[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = values[r] / (right[r + 1] + left[j - r]);
            values[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        values[j] = saved;
    }
    (span - degree, values)
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

    /// The point at parameter `t` (clamped to the knot range).
    #[must_use]
    pub fn eval(&self, t: f64) -> DVec3 {
        let (first, b) = basis(self.degree, &self.knots, t);
        b.iter().enumerate().map(|(a, w)| self.ctrl[first + a] * *w).sum()
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

    /// The point at `(u, v)` (clamped to the knot ranges).
    #[must_use]
    pub fn eval(&self, u: f64, v: f64) -> DVec3 {
        let (fu, bu) = basis(self.degree[0], &self.knots_u, u);
        let (fv, bv) = basis(self.degree[1], &self.knots_v, v);
        let mut p = DVec3::ZERO;
        for (a, wu) in bu.iter().enumerate() {
            for (b, wv) in bv.iter().enumerate() {
                p += self.at(fu + a, fv + b) * (wu * wv);
            }
        }
        p
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
    /// or an array of them, read by [`read_reports`]), each checked against the control points
    /// its report stores.
    pub fn read_reports(path: &Path) -> Result<Vec<CadShape>> {
        let saved = read_reports(path)?;
        if saved.is_empty() {
            return Err(Error::Input {
                path: path.into(),
                message: "an empty array: no report to export".into(),
            });
        }
        let mut out = Vec::with_capacity(saved.len());
        for (k, report) in saved.iter().enumerate() {
            let shape = match report {
                Saved::Curve(r, None) => CadShape::from_curve_report(r),
                Saved::Curve(r, Some(enc)) => CadShape::from_encoded_curve(r, enc),
                Saved::Surface(r, None) => CadShape::from_surface_report(r),
                Saved::Surface(r, Some(enc)) => CadShape::from_encoded_surface(r, enc),
            };
            let at = if k == 0 {
                String::new()
            } else {
                format!("report {k}: ")
            };
            out.push(shape.map_err(|e| Error::Input {
                path: path.into(),
                message: format!("{at}{e}"),
            })?);
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
