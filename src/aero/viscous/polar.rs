//! Viscous polars: [`Viscous`] (one body's factored panel system), a point from a cold start or
//! from a neighbour's solution, a polar by continuation along α, and populations with rayon.

use super::closures::Fluid;
use super::coupling::Body;
use super::equations::State;
use super::newton::{Factored, System};
use crate::error::{Error, Result};
use glam::DVec2;
use rayon::prelude::*;
use std::sync::Arc;

/// The operating point and solver settings of a viscous analysis.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ViscousOptions {
    /// Chord Reynolds number (default 1e6; accepted from 1e4 to 1e8).
    pub re: f64,
    /// Critical amplification factor of the e^N method (default 9; in (0, 20]).
    pub ncrit: f64,
    /// Forced transition on the upper surface, chord fraction (default 1: free).
    pub xtr_top: f64,
    /// Forced transition on the lower surface, chord fraction (default 1: free).
    pub xtr_bottom: f64,
    /// Newton iterations per point (default 80).
    pub max_iter: usize,
}

impl Default for ViscousOptions {
    fn default() -> Self {
        ViscousOptions {
            re: 1e6,
            ncrit: 9.0,
            xtr_top: 1.0,
            xtr_bottom: 1.0,
            max_iter: 80,
        }
    }
}

/// The largest angle of attack (degrees, either sign) a viscous point accepts.
pub const MAX_ALPHA: f64 = 30.0;

/// Refuse angles of attack outside ±[`MAX_ALPHA`] (or not finite) before a polar is run.
pub fn check_alphas(alphas: &[f64]) -> Result<()> {
    match alphas.iter().find(|a| !(a.abs() <= MAX_ALPHA)) {
        Some(a) => Err(Error::invalid(format!(
            "the viscous analysis takes angles between -{MAX_ALPHA} and {MAX_ALPHA} degrees, not {a}"
        ))),
        None => Ok(()),
    }
}

impl ViscousOptions {
    /// Refuse settings outside the ranges the closures are meant for.
    pub fn check(&self) -> Result<()> {
        if !(self.re >= 1e4 && self.re <= 1e8) {
            return Err(Error::invalid(format!(
                "the Reynolds number must be between 1e4 and 1e8, not {}",
                self.re
            )));
        }
        if !(self.ncrit > 0.0 && self.ncrit <= 20.0) {
            return Err(Error::invalid(format!(
                "Ncrit must be in (0, 20], not {}",
                self.ncrit
            )));
        }
        for (name, v) in [("top", self.xtr_top), ("bottom", self.xtr_bottom)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(Error::invalid(format!(
                    "forced transition ({name}) must be a chord fraction in [0, 1], not {v}"
                )));
            }
        }
        if self.max_iter == 0 {
            return Err(Error::invalid("at least one Newton iteration is needed"));
        }
        Ok(())
    }

    fn fluid(&self) -> Fluid {
        Fluid {
            re: self.re,
            ncrit: self.ncrit,
        }
    }
}

/// One point of a viscous polar. The coefficients are `None` when Newton did not converge.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ViscousPoint {
    /// Angle of attack, degrees.
    pub alpha: f64,
    /// Lift coefficient.
    pub cl: Option<f64>,
    /// Drag coefficient from the wake's momentum deficit (Squire–Young).
    pub cd: Option<f64>,
    /// Pressure drag, `CD − CDf`.
    pub cdp: Option<f64>,
    /// Moment about the quarter chord.
    pub cm: Option<f64>,
    /// Upper-surface transition, chord fraction (1: laminar to the trailing edge).
    pub xtr_top: Option<f64>,
    /// Lower-surface transition, chord fraction.
    pub xtr_bottom: Option<f64>,
    /// Turbulent separation (negative skin friction) on the body.
    pub separated: Option<bool>,
    /// Whether Newton converged.
    pub converged: bool,
    /// Newton iterations taken.
    pub iterations: usize,
    /// Why the point has no numbers (`None` when it converged): the last try's reason.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
}

/// A solved point's boundary layer, to start a neighbour from (same body or same node count).
#[derive(Clone, Debug)]
pub struct Warm {
    /// The angle it was solved at, degrees.
    alpha: f64,
    u: Vec<State>,
    turb: Vec<bool>,
    /// The solve's last factored Jacobian: a chord step's matrix for the first step of a
    /// solve started here.
    jacobian: Option<Arc<Factored>>,
}

impl Warm {
    /// The pressure coefficient `1 - (uₑ/V∞)²` at the first `nodes` stations, the body's panel
    /// nodes in their order (the solution's edge velocities, as its CL integrates them).
    #[must_use]
    pub fn cp(&self, nodes: usize) -> Vec<f64> {
        self.u.iter().take(nodes).map(|u| 1.0 - u[3] * u[3]).collect()
    }
}

/// One body's viscous analysis: its panel system factored once for every angle.
pub struct Viscous {
    body: Body,
}

impl Viscous {
    /// Factor the panel system of `nodes` (counterclockwise from the upper trailing edge).
    pub fn new(nodes: &[DVec2]) -> Result<Viscous> {
        if nodes.len() < crate::aero::panel::MIN_NODES || nodes.iter().any(|p| !p.is_finite()) {
            return Err(Error::invalid("the viscous analysis needs finite panel nodes"));
        }
        crate::aero::panel::check_simple(nodes)?;
        Ok(Viscous {
            body: Body::new(nodes)?,
        })
    }

    /// One point at `alpha` degrees, from `warm` when given (else a marched boundary layer);
    /// the solution for the next point when it converged.
    pub fn point(
        &self,
        alpha: f64,
        opts: &ViscousOptions,
        warm: Option<&Warm>,
    ) -> (ViscousPoint, Option<Warm>) {
        self.point_with(alpha, opts, warm, true)
    }

    /// [`Viscous::point`], with exact partials where they are known or (`exact: false`)
    /// forward differences throughout.
    fn point_with(
        &self,
        alpha: f64,
        opts: &ViscousOptions,
        warm: Option<&Warm>,
        exact: bool,
    ) -> (ViscousPoint, Option<Warm>) {
        let failed = |iterations, why: String| ViscousPoint {
            alpha,
            cl: None,
            cd: None,
            cdp: None,
            cm: None,
            xtr_top: None,
            xtr_bottom: None,
            separated: None,
            converged: false,
            iterations,
            failure: Some(why),
        };
        if !(alpha.abs() <= MAX_ALPHA) {
            return (
                failed(0, format!("the angle is outside ±{MAX_ALPHA} degrees")),
                None,
            );
        }
        let xtr = [opts.xtr_top, opts.xtr_bottom];
        let w = warm.map(|w| (w.u.as_slice(), w.turb.as_slice()));
        let mut sys = match System::new(&self.body, alpha, opts.fluid(), xtr, w) {
            Ok(sys) => sys,
            Err(e) => return (failed(0, e.to_string()), None),
        };
        sys.exact = exact;
        sys.jacobian = warm.and_then(|w| w.jacobian.clone());
        // The start kept for a second try (its wake and coupling are not built again).
        let start = sys.clone();
        let mut out = sys.solve(opts.max_iter);
        if !out.converged() {
            // Again from the same start, the transition points held while far off.
            sys = start;
            out = sys.solve_held(opts.max_iter);
            if !out.converged() {
                return (failed(out.iterations, out.stop.to_string()), None);
            }
        }
        let f = sys.forces(alpha);
        let ok = [f.cl, f.cm, f.cd, f.cdf].iter().all(|v| v.is_finite()) && f.cd > 0.0;
        if !ok {
            let why = "the converged solution's coefficients are not finite or its drag not positive";
            return (failed(out.iterations, why.into()), None);
        }
        let point = ViscousPoint {
            alpha,
            cl: Some(f.cl),
            cd: Some(f.cd),
            cdp: Some(f.cd - f.cdf),
            cm: Some(f.cm),
            xtr_top: Some(f.xtr[0]),
            xtr_bottom: Some(f.xtr[1]),
            separated: Some(f.separated),
            converged: true,
            iterations: out.iterations,
            failure: None,
        };
        let warm = Warm {
            alpha,
            u: sys.u.clone(),
            turb: sys.turb.clone(),
            jacobian: sys.jacobian.take(),
        };
        (point, Some(warm))
    }

    /// A point from `warm`; when that fails, through the angle halfway from `warm`'s (twice
    /// over), then from a cold start; all of it with exact partials, then again with forward
    /// differences.
    fn point_retry(
        &self,
        alpha: f64,
        opts: &ViscousOptions,
        warm: Option<&Warm>,
    ) -> (ViscousPoint, Option<Warm>) {
        // The tries with exact partials or (`exact: false`) forward differences throughout.
        let tries = |exact: bool| {
            let (p, w) = self.point_with(alpha, opts, warm, exact);
            let Some(start) = warm else { return (p, w) };
            if p.converged {
                return (p, w);
            }
            for parts in [2, 4] {
                let mut cur = start.clone();
                let mut done = true;
                for k in 1..parts {
                    let a = start.alpha + (alpha - start.alpha) * f64::from(k) / f64::from(parts);
                    match self.point_with(a, opts, Some(&cur), exact) {
                        (_, Some(next)) => cur = next,
                        _ => {
                            done = false;
                            break;
                        }
                    }
                }
                if done {
                    let (q, w2) = self.point_with(alpha, opts, Some(&cur), exact);
                    if q.converged {
                        return (q, w2);
                    }
                }
            }
            rescued_or(p, self.point_with(alpha, opts, None, exact))
        };
        let (p, w) = tries(true);
        if p.converged || warm.is_none() {
            return (p, w);
        }
        // The same tries again with forward-difference partials: a different path to the same
        // solution, which finds some points near the stall that the exact Newton loses (S1223
        // at 7°; 5 more of the benchmark's 352 points on 32 shapes, at no loss of points/s).
        rescued_or(p, tries(false))
    }

    /// The polar at `alphas` (degrees, any order; returned in the same order): continuation
    /// outwards from the angle nearest zero, each point started from its converged neighbour;
    /// then each point that failed without a converged neighbour's start (a first point that
    /// failed from cold, and the cold starts after it) again from a neighbour that converged,
    /// onwards from there.
    pub fn polar(&self, alphas: &[f64], opts: &ViscousOptions) -> Vec<ViscousPoint> {
        self.polar_solved(alphas, opts, None)
            .into_iter()
            .map(|p| p.0)
            .collect()
    }

    /// [`Viscous::polar`], every point's boundary layer kept; with `near` (one entry an
    /// angle: a nearby body's solutions there, the same number of nodes), each point is first
    /// started from `near`'s solution at its angle, and only where that fails reached by
    /// continuation.
    fn polar_solved(
        &self,
        alphas: &[f64],
        opts: &ViscousOptions,
        near: Option<&[Option<Warm>]>,
    ) -> Vec<(ViscousPoint, Option<Warm>)> {
        let mut order: Vec<usize> = (0..alphas.len()).collect();
        order.sort_by(|&a, &b| alphas[a].total_cmp(&alphas[b]));
        let Some(start) =
            (0..order.len()).min_by(|&a, &b| alphas[order[a]].abs().total_cmp(&alphas[order[b]].abs()))
        else {
            return Vec::new();
        };
        let m = order.len();
        // Per sorted position: the point, its solution, and the position its start came from.
        type Slot = (ViscousPoint, Option<Warm>, Option<usize>);
        let from_near = |pos: usize| {
            let k = order[pos];
            let w = near.and_then(|n| n.get(k)).and_then(Option::as_ref)?;
            let solved = self.point(alphas[k], opts, Some(w));
            solved.0.converged.then_some(solved)
        };
        let (first, warm0) = from_near(start).unwrap_or_else(|| self.point(alphas[order[start]], opts, None));
        let sweep = |idx: Vec<usize>| -> Vec<(usize, Slot)> {
            let mut warm = warm0.clone().map(|w| (start, w));
            let mut out = Vec::new();
            for pos in idx {
                let from = warm.as_ref().map(|w| w.0);
                let (p, w) = from_near(pos).unwrap_or_else(|| {
                    self.point_retry(alphas[order[pos]], opts, warm.as_ref().map(|w| &w.1))
                });
                if let Some(w) = &w {
                    warm = Some((pos, w.clone()));
                }
                out.push((pos, (p, w, from)));
            }
            out
        };
        let (a, b) = rayon::join(
            || sweep((start + 1..m).collect()),
            || sweep((0..start).rev().collect()),
        );
        let mut slots: Vec<Option<Slot>> = vec![None; m];
        slots[start] = Some((first, warm0, None));
        for (pos, slot) in a.into_iter().chain(b) {
            slots[pos] = Some(slot);
        }
        let mut slots: Vec<Slot> = slots.into_iter().flatten().collect();
        // Second chances, upwards then downwards, from a converged neighbour not tried yet.
        let mut retry = |pos: usize, nb: usize| {
            if slots[pos].0.converged || slots[pos].2 == Some(nb) {
                return;
            }
            let Some(w) = slots[nb].1.clone() else { return };
            let (p, w2) = self.point_retry(alphas[order[pos]], opts, Some(&w));
            slots[pos].2 = Some(nb);
            if p.converged {
                (slots[pos].0, slots[pos].1) = (p, w2);
            }
        };
        for pos in 1..m {
            retry(pos, pos - 1);
        }
        for pos in (0..m.saturating_sub(1)).rev() {
            retry(pos, pos + 1);
        }
        let mut points: Vec<Option<(ViscousPoint, Option<Warm>)>> = vec![None; alphas.len()];
        for (pos, slot) in slots.into_iter().enumerate() {
            points[order[pos]] = Some((slot.0, slot.1));
        }
        points.into_iter().flatten().collect()
    }
}

/// Polars of many bodies at the same angles, in parallel over the bodies.
pub fn polars(bodies: &[Viscous], alphas: &[f64], opts: &ViscousOptions) -> Vec<Vec<ViscousPoint>> {
    bodies.par_iter().map(|b| b.polar(alphas, opts)).collect()
}

/// Polars of a population of nearby shapes at the same angles: first `centre`'s (the
/// population's centre, or a parent) by continuation, then every body's, each point started
/// from the centre's solution at its angle (a body with another number of nodes, or a point
/// whose start fails, falls back to continuation, as [`Viscous::polar`]); in parallel over
/// the bodies. The centre's polar, and the bodies'.
pub fn polars_around(
    centre: &Viscous,
    bodies: &[Viscous],
    alphas: &[f64],
    opts: &ViscousOptions,
) -> (Vec<ViscousPoint>, Vec<Vec<ViscousPoint>>) {
    let solved = centre.polar_solved(alphas, opts, None);
    let near: Vec<Option<Warm>> = solved.iter().map(|p| p.1.clone()).collect();
    let polars = bodies
        .par_iter()
        .map(|b| {
            let same = b.body.nodes.len() == centre.body.nodes.len();
            b.polar_solved(alphas, opts, same.then_some(near.as_slice()))
                .into_iter()
                .map(|p| p.0)
                .collect()
        })
        .collect();
    (solved.into_iter().map(|p| p.0).collect(), polars)
}

/// A retry's result where it converged, else the first try's point with no warm start.
fn rescued_or(first: ViscousPoint, retry: (ViscousPoint, Option<Warm>)) -> (ViscousPoint, Option<Warm>) {
    if retry.0.converged {
        retry
    } else {
        (first, None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aero::Paneling;
    use std::path::Path;

    fn shipped(file: &str) -> Viscous {
        Viscous::new(&crate::aero::viscous::shipped_nodes(file)).unwrap()
    }

    /// NACA 4413 at Re 1e6: a cold start converges to a plausible point.
    #[test]
    fn naca4413_cold_start_converges() {
        let v = shipped("data/naca4413.dat");
        let (p, _) = v.point(2.0, &ViscousOptions::default(), None);
        eprintln!("{p:?}");
        assert!(p.converged, "{p:?}");
        let cd = p.cd.unwrap();
        assert!(cd > 0.004 && cd < 0.01, "{p:?}");
    }

    /// FX 77-W-270 (trailing-edge gap 0.042 chord) at Re 1e6: the polar from 0° to 4°
    /// converges at every angle. Pinned to XFOIL 6.99 (PANE, VISC 1e6, ASEQ from −2°): CD
    /// 0.01301, 0.01406, 0.01455 at 0°, 2°, 4°, CL 0.4902, 0.7488, 1.0057. CD within 3 %, CL
    /// within 0.005 (bezchain: 0.4895, 0.7480, 1.0048; CD within 0.03 %; CL was 0.024
    /// low while the wake cells' stream function cut across the edge's lower node).
    #[test]
    fn a_blunt_trailing_edge_polar_converges() {
        let v = shipped("data/airfoils/regressions/fx77w270.dat");
        let polar = v.polar(&[0.0, 2.0, 4.0], &ViscousOptions::default());
        let xfoil = [(0.4902, 0.01301), (0.7488, 0.01406), (1.0057, 0.01455)];
        for (p, (cl, cd)) in polar.iter().zip(xfoil) {
            assert!(p.converged && p.failure.is_none(), "{p:?}");
            let (pcl, pcd) = (p.cl.unwrap(), p.cd.unwrap());
            assert!(
                (pcd / cd - 1.0).abs() < 0.03,
                "CD {pcd} against XFOIL's {cd}: {p:?}"
            );
            assert!((pcl - cl).abs() < 0.005, "CL {pcl} against XFOIL's {cl}: {p:?}");
        }
    }

    /// A population around a centre: every body's points started from the centre's at the
    /// same angle are the points its own polar finds by continuation.
    #[test]
    fn a_population_around_its_centre_has_the_polars_of_its_bodies() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/airfoils/naca4412.dat");
        let base = crate::geometry::read_curve(&path).unwrap().points;
        // Thinner, thicker, and more cambered by up to 0.2 % of the chord.
        let shapes: Vec<Vec<DVec2>> = [(0.998, 0.0), (1.002, 0.0), (1.0, 0.002)]
            .iter()
            .map(|&(f, c)| {
                let bump = |x: f64| c * (std::f64::consts::PI * x).sin();
                base.iter()
                    .map(|p| DVec2::new(p.x, f * p.y + bump(p.x)))
                    .collect()
            })
            .collect();
        let paneling = Paneling::default();
        let body = |p: &[DVec2]| {
            Viscous::new(
                crate::aero::Analysis::of_points(p, &paneling)
                    .unwrap()
                    .solution
                    .nodes(),
            )
            .unwrap()
        };
        let centre = shipped("data/airfoils/naca4412.dat");
        let bodies: Vec<Viscous> = shapes.iter().map(|p| body(p)).collect();
        let alphas = [-1.0, 2.0, 5.0];
        let o = ViscousOptions::default();
        let (c, around) = polars_around(&centre, &bodies, &alphas, &o);
        assert!(c.iter().all(|p| p.converged));
        for (b, pa) in bodies.iter().zip(&around) {
            for (p, q) in pa.iter().zip(b.polar(&alphas, &o)) {
                assert!(p.converged && q.converged, "{p:?} {q:?}");
                let (dcl, dcd) = (p.cl.unwrap() - q.cl.unwrap(), p.cd.unwrap() / q.cd.unwrap() - 1.0);
                assert!(dcl.abs() < 1e-4 && dcd.abs() < 1e-3, "{p:?} {q:?}");
            }
        }
    }

    /// A point that cannot be solved says why.
    #[test]
    fn a_failed_point_gives_its_reason() {
        let v = shipped("data/naca4413.dat");
        let o = ViscousOptions {
            max_iter: 1,
            ..ViscousOptions::default()
        };
        let (p, _) = v.point(2.0, &o, None);
        assert!(!p.converged, "{p:?}");
        let why = p.failure.unwrap_or_default();
        assert!(why.contains("iteration limit"), "{why}");
        let (p, _) = v.point(45.0, &ViscousOptions::default(), None);
        assert!(p.failure.unwrap_or_default().contains("outside"));
    }

    /// A figure eight is refused, the panel nodes that cross named.
    #[test]
    fn a_contour_that_crosses_itself_is_refused() {
        let nodes: Vec<DVec2> = (0..=40)
            .map(|k| {
                let t = std::f64::consts::TAU * f64::from(k) / 40.0;
                DVec2::new(0.5 + 0.5 * t.cos(), 0.1 * (2.0 * t).sin())
            })
            .collect();
        let Err(e) = Viscous::new(&nodes) else {
            panic!("a figure eight was analysed");
        };
        assert!(
            e.is_user_error() && e.to_string().contains("crosses itself"),
            "{e}"
        );
        let v = shipped("data/naca4413.dat");
        assert!(crate::aero::panel::crossing(&v.body.nodes).is_none());
    }

    #[test]
    fn bad_options_are_refused() {
        let o = ViscousOptions {
            re: 10.0,
            ..ViscousOptions::default()
        };
        assert!(o.check().is_err());
        let o = ViscousOptions {
            ncrit: 0.0,
            ..ViscousOptions::default()
        };
        assert!(o.check().is_err());
        let o = ViscousOptions {
            xtr_top: 1.5,
            ..ViscousOptions::default()
        };
        assert!(o.check().is_err());
        assert!(ViscousOptions::default().check().is_ok());
    }
}
