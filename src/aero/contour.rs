//! Contours the panel method runs on, and where its nodes go on them.
//!
//! A [`Contour`] is a closed-ish curve over a parameter `t ∈ [0, 1]` that starts and ends at
//! the trailing edge: a fitted or regenerated [`CurveChain`], a [`SplineContour`] through raw
//! aerofoil coordinates, or an exact shape in tests. [`panel_params`] places `N` nodes on it
//! by XFOIL's `PANE` (its `PANGEN`), step for step:
//! - the curvature is measured at the contour's [`Sites`] (for raw coordinates the data
//!   points themselves, where XFOIL measures it; otherwise fine samples), the trailing edge
//!   given an artificial curvature of `CTERAT` = 0.15 of the mean leading-edge curvature;
//! - it is smoothed over about one leading-edge radius, held at its leading-edge value, and
//!   normalised by its maximum;
//! - `5 (N − 1) + 1` working nodes are placed by Newton's method so that every panel's length
//!   times `1 + 6 κ̂` (κ̂ the root-sum-square of its ends' curvatures) is the same, the two end
//!   panels 1/3 of their neighbours; every fifth is a node.
//!
//! On raw coordinates the nodes are XFOIL's to its printed precision (the tests pin it). The
//! result is a list of parameters: the population evaluator computes them once, on the start
//! shape, and then places every individual's nodes at those same parameters (a fixed, linear
//! map).

use crate::chain::CurveChain;
use crate::error::{Error, Result};
pub use crate::geometry::SplineContour;
use crate::geometry::{locate, tridiagonal, Spline1};
use glam::DVec2;

/// A curve from the trailing edge round the leading edge back to the trailing edge.
pub trait Contour {
    /// The point at parameter `t ∈ [0, 1]`.
    fn point(&self, t: f64) -> DVec2;

    /// Where the paneling measures curvature: by default the contour sampled finely.
    fn sites(&self) -> Sites<'_> {
        Sites::sampled(&|t| self.point(t))
    }
}

impl Contour for CurveChain<DVec2> {
    fn point(&self, t: f64) -> DVec2 {
        self.eval(t)
    }
}

impl<F: Fn(f64) -> DVec2> Contour for F {
    fn point(&self, t: f64) -> DVec2 {
        self(t)
    }
}

impl Contour for SplineContour {
    fn point(&self, t: f64) -> DVec2 {
        self.at(t)
    }

    /// XFOIL's: the data points, with the spline's exact curvature.
    fn sites(&self) -> Sites<'_> {
        let t = self.knots();
        Sites {
            p: t.iter().map(|&u| self.at(u)).collect(),
            s: t.iter().map(|u| u * self.length()).collect(),
            kappa: t.iter().map(|&u| self.curvature(u).abs()).collect(),
            t,
            exact: Some(Box::new(|u| self.curvature(u).abs())),
        }
    }
}

/// A contour sampled where the paneling measures its curvature: at every site the parameter
/// `t`, the point, an increasing arclength-like parameter `s` (the panels' lengths are
/// measured in it; XFOIL's spline parameter), the unsigned curvature with respect to `s`, and,
/// where the contour knows it, its exact curvature at any `t` (else the sites' interpolated).
pub struct Sites<'a> {
    t: Vec<f64>,
    p: Vec<DVec2>,
    s: Vec<f64>,
    kappa: Vec<f64>,
    exact: Option<Box<dyn Fn(f64) -> f64 + 'a>>,
}

/// Panel nodes of XFOIL's default paneling: 160 nodes.
pub const DEFAULT_NODES: usize = 160;
/// XFOIL's curvature attraction `6 CVPAR` (CVPAR = 1).
const ATTRACTION: f64 = 6.0;
/// XFOIL's `RDSTE`: each end panel of the working nodes relative to its neighbour is
/// `2 (RDSTE − 1) + 1`, a third.
const END_PANEL: f64 = 2.0 * (0.667 - 1.0) + 1.0;
/// Working nodes per panel (XFOIL's `IPFAC`).
const WORKING: usize = 5;
/// Newton steps of the node placement, and the largest node move (in `s`, relative to the
/// half-perimeter) that ends them: XFOIL's.
const NEWTON_STEPS: usize = 20;
const NEWTON_TOL: f64 = 1e-3;

/// How nodes are placed on a contour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Paneling {
    /// Number of nodes (panels + 1). Default 160, XFOIL's.
    pub nodes: usize,
    /// The trailing edge's artificial curvature relative to the mean curvature at the leading
    /// edge (XFOIL's `CTERAT`, "TE/LE panel density ratio"): larger values put shorter panels
    /// at the trailing edge. Default 0.15, XFOIL's.
    pub te_ratio: f64,
}

impl Default for Paneling {
    fn default() -> Self {
        Paneling {
            nodes: DEFAULT_NODES,
            te_ratio: 0.15,
        }
    }
}

impl Paneling {
    /// XFOIL's default paneling with `nodes` nodes.
    #[must_use]
    pub fn with_nodes(nodes: usize) -> Self {
        Paneling {
            nodes,
            ..Paneling::default()
        }
    }
}

/// Samples of a contour without sites of its own before refinement.
const SAMPLES: usize = 2048;
/// Sample intervals turning by more than this (radians) are halved, up to [`REFINE_ROUNDS`] times.
const MAX_TURN: f64 = 0.01;
const REFINE_ROUNDS: usize = 12;

impl<'a> Sites<'a> {
    /// The contour sampled finely (intervals that turn much are halved), `s` its polygon's
    /// length and the curvature the turning angle over the mean adjacent length, linear
    /// between samples.
    pub fn sampled(contour: &dyn Fn(f64) -> DVec2) -> Sites<'a> {
        let mut t: Vec<f64> = (0..=SAMPLES).map(|k| k as f64 / SAMPLES as f64).collect();
        let mut p: Vec<DVec2> = t.iter().map(|&u| contour(u)).collect();
        for _ in 0..REFINE_ROUNDS {
            let mut split = vec![false; t.len() - 1];
            for k in 1..t.len() - 1 {
                let (a, b) = (p[k] - p[k - 1], p[k + 1] - p[k]);
                if a.perp_dot(b).atan2(a.dot(b)).abs() > MAX_TURN {
                    split[k - 1] = true;
                    split[k] = true;
                }
            }
            if !split.iter().any(|&s| s) {
                break;
            }
            let (mut nt, mut np) = (vec![t[0]], vec![p[0]]);
            for k in 0..t.len() - 1 {
                if split[k] {
                    let m = 0.5 * (t[k] + t[k + 1]);
                    nt.push(m);
                    np.push(contour(m));
                }
                nt.push(t[k + 1]);
                np.push(p[k + 1]);
            }
            t = nt;
            p = np;
        }
        let mut s = vec![0.0];
        for w in p.windows(2) {
            s.push(s[s.len() - 1] + (w[1] - w[0]).length());
        }
        let n = p.len();
        let mut kappa = vec![0.0; n];
        for i in 1..n - 1 {
            let (a, b) = (p[i] - p[i - 1], p[i + 1] - p[i]);
            let len = 0.5 * (a.length() + b.length());
            if len > 0.0 {
                kappa[i] = a.perp_dot(b).atan2(a.dot(b)).abs() / len;
            }
        }
        kappa[0] = kappa[1];
        kappa[n - 1] = kappa[n - 2];
        Sites {
            t,
            p,
            s,
            kappa,
            exact: None,
        }
    }
}

impl Sites<'_> {
    /// The unsigned curvature at `t`: exact where the contour gives it, else linear between
    /// the sites.
    fn curvature(&self, t: f64) -> f64 {
        match &self.exact {
            Some(f) => f(t),
            None => interpolate(&self.t, &self.kappa, t),
        }
    }
}

/// The piecewise-linear interpolant of `(xs[i], ys[i])` at `x`, `xs` increasing (clamped at the
/// ends; a zero-length interval takes its first value).
fn interpolate(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let (k, u) = locate(xs, x);
    let u = if u.is_finite() { u.clamp(0.0, 1.0) } else { 0.0 };
    ys[k] + u * (ys[k + 1] - ys[k])
}

/// The parameter of the leading edge of `contour`: the point farthest from the trailing-edge
/// midpoint, by sampling and golden-section refinement.
#[must_use]
pub fn leading_edge_param(contour: &dyn Contour) -> f64 {
    let te = 0.5 * (contour.point(0.0) + contour.point(1.0));
    let far = |t: f64| (contour.point(t) - te).length();
    let k = (1..SAMPLES)
        .max_by(|&a, &b| far(a as f64 / SAMPLES as f64).total_cmp(&far(b as f64 / SAMPLES as f64)))
        .unwrap_or(SAMPLES / 2);
    let (mut a, mut b) = ((k - 1) as f64 / SAMPLES as f64, (k + 1) as f64 / SAMPLES as f64);
    let g = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..60 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if far(c) > far(d) {
            b = d;
        } else {
            a = c;
        }
    }
    0.5 * (a + b)
}

/// The parameters of the panel nodes on `contour` by XFOIL's paneling rule (see the module
/// documentation), ordered so that the nodes run counterclockwise: increasing from 0 to 1 for
/// a counterclockwise contour, decreasing from 1 to 0 for a clockwise one.
pub fn panel_params(contour: &dyn Contour, paneling: &Paneling) -> Result<Vec<f64>> {
    let n = paneling.nodes;
    Error::check_non_negative("the trailing-edge density ratio", paneling.te_ratio)?;
    if n < super::panel::MIN_NODES {
        return Err(Error::invalid(format!(
            "at least {} panel nodes are needed, not {n}",
            super::panel::MIN_NODES
        )));
    }
    let sites = contour.sites();
    if sites.p.iter().any(|p| !p.is_finite()) {
        return Err(Error::invalid("the contour is not finite"));
    }
    let (first, last) = (sites.p[0], sites.p[sites.p.len() - 1]);
    let te = 0.5 * (first + last);
    let t_le = leading_edge_param(contour);
    let chord = (contour.point(t_le) - te).length();
    let total = sites.s[sites.s.len() - 1];
    if !(chord > 0.0) || !(total > 0.0) {
        return Err(Error::invalid("the contour has no extent"));
    }
    let gap = (first - last).length();
    if gap > 0.5 * chord {
        return Err(Error::invalid(format!(
            "the contour's ends are {gap:.3e} apart, half its chord ({chord:.3e}) or more: an aerofoil \
             contour must start and end at the trailing edge"
        )));
    }
    let s_le = interpolate(&sites.t, &sites.s, t_le);
    let t_at = |s: f64| interpolate(&sites.s, &sites.t, s);
    let sbref = 0.5 * total;
    let cvle = sites.curvature(t_le) * sbref;
    // The mean curvature at seven points within one leading-edge radius of the leading edge.
    let cvavg = (-3..=3)
        .map(|k| sites.curvature(t_at(s_le + k as f64 / 3.0 * sbref / cvle.max(20.0))) * sbref)
        .sum::<f64>()
        / 7.0;
    let mut raw: Vec<f64> = sites.kappa.iter().map(|k| k * sbref).collect();
    let ends = raw.len() - 1;
    raw[0] = cvavg * paneling.te_ratio;
    raw[ends] = raw[0];
    let smooth = (1.0 / cvavg.max(20.0)).max(0.25 / (n / 2) as f64) * sbref;
    let mut w = smoothed(&sites.s, &raw, s_le, cvle, smooth);
    let wmax = w.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(wmax > 0.0) || !wmax.is_finite() {
        return Err(Error::invalid("the contour has no curvature (a straight line)"));
    }
    w.iter_mut().for_each(|v| *v /= wmax);
    let s_nodes = place_nodes(&Spline1::new(&sites.s, &w), total, n)?;
    let mut params: Vec<f64> = s_nodes.iter().map(|&s| t_at(s)).collect();
    let ends = params.len() - 1;
    params[0] = sites.t[0];
    params[ends] = sites.t[sites.t.len() - 1];
    if crate::geometry::twice_signed_area(&sites.p) < 0.0 {
        params.reverse();
    }
    Ok(params)
}

/// The curvature smoothed by `(1 − L² d²/ds²) w = raw` with `L = smooth`, the ends held at
/// their values and the leading edge (at `s_le`, between sites or on one) at `cvle`: XFOIL's
/// smoothing, discretised on the sites as XFOIL does.
fn smoothed(s: &[f64], raw: &[f64], s_le: f64, cvle: f64, smooth: f64) -> Vec<f64> {
    let n = s.len();
    let l2 = smooth * smooth;
    let (mut a, mut b, mut c, mut d) = (vec![0.0; n], vec![1.0; n], vec![0.0; n], raw.to_vec());
    let row = |hm: f64, hp: f64| {
        let ho = 0.5 * (hm + hp);
        (
            -l2 / (hm * ho),
            l2 * (1.0 / hm + 1.0 / hp) / ho + 1.0,
            -l2 / (hp * ho),
        )
    };
    for i in 1..n - 1 {
        let (hm, hp) = (s[i] - s[i - 1], s[i + 1] - s[i]);
        if hm > 0.0 && hp > 0.0 {
            (a[i], b[i], c[i]) = row(hm, hp);
        }
    }
    if let Some(i) = (1..n - 1).find(|&i| s[i] >= s_le) {
        if s[i] == s_le {
            (a[i], b[i], c[i], d[i]) = (0.0, 1.0, 0.0, cvle);
        } else if i >= 2 && i + 1 < n {
            // The leading edge between sites i − 1 and i: each side's equation sees it as its
            // neighbour, at its own distance.
            let (hm, hp) = (s[i - 1] - s[i - 2], s_le - s[i - 1]);
            (a[i - 1], b[i - 1], _) = row(hm, hp);
            c[i - 1] = 0.0;
            d[i - 1] += l2 * cvle / (hp * 0.5 * (hm + hp));
            let (hm, hp) = (s[i] - s_le, s[i + 1] - s[i]);
            (_, b[i], c[i]) = row(hm, hp);
            a[i] = 0.0;
            d[i] += l2 * cvle / (hm * 0.5 * (hm + hp));
        }
    }
    tridiagonal(&a, &b, &c, &d)
}

/// The node positions (in the sites' `s`, from 0 to `total`) by XFOIL's Newton iteration on
/// `5 (nodes − 1) + 1` working nodes: every panel's length times `1 + 6 √(κ̂₁² + κ̂₂²)` equal
/// to its neighbours', the end panels [`END_PANEL`] of theirs; every fifth working node.
fn place_nodes(w: &Spline1, total: f64, nodes: usize) -> Result<Vec<f64>> {
    let nn = WORKING * (nodes - 1) + 1;
    let avg = total / ((nn - 3) as f64 + 2.0 * END_PANEL);
    let mut sn: Vec<f64> = (0..nn)
        .map(|i| match i {
            0 => 0.0,
            i if i == nn - 1 => total,
            i => avg * ((i - 1) as f64 + END_PANEL),
        })
        .collect();
    let (mut a, mut b, mut c, mut r) = (vec![0.0; nn], vec![1.0; nn], vec![0.0; nn], vec![0.0; nn]);
    for _ in 0..NEWTON_STEPS {
        let cv: Vec<(f64, f64)> = sn.iter().map(|&s| w.at(s)).collect();
        // The root-sum-square of two ends' curvatures and its derivatives by each end's s.
        let mean = |(c1, d1): (f64, f64), (c2, d2): (f64, f64)| {
            let m = c1.hypot(c2);
            if m == 0.0 {
                (0.0, 0.0, 0.0)
            } else {
                (m, d1 * c1 / m, d2 * c2 / m)
            }
        };
        for i in 1..nn - 1 {
            let (cm, cm_1, cm_2) = mean(cv[i - 1], cv[i]);
            let (cp, cp_2, cp_3) = mean(cv[i], cv[i + 1]);
            let (dsm, dsp) = (sn[i] - sn[i - 1], sn[i] - sn[i + 1]);
            let (fm, fp) = (ATTRACTION * cm + 1.0, ATTRACTION * cp + 1.0);
            a[i] = -fm + ATTRACTION * dsm * cm_1;
            b[i] = fp + fm + ATTRACTION * (dsp * cp_2 + dsm * cm_2);
            c[i] = -fp + ATTRACTION * dsp * cp_3;
            r[i] = -(dsp * fp + dsm * fm);
        }
        (b[0], c[0], r[0]) = (1.0, 0.0, 0.0);
        (a[nn - 1], b[nn - 1], r[nn - 1]) = (0.0, 1.0, 0.0);
        // Next to each end: the end panel END_PANEL times its neighbour.
        r[1] = -((sn[1] - sn[0]) + END_PANEL * (sn[1] - sn[2]));
        (a[1], b[1], c[1]) = (-1.0, 1.0 + END_PANEL, -END_PANEL);
        let i = nn - 2;
        r[i] = -((sn[i] - sn[i + 1]) + END_PANEL * (sn[i] - sn[i - 1]));
        (a[i], b[i], c[i]) = (-END_PANEL, 1.0 + END_PANEL, -1.0);
        let step = tridiagonal(&a, &b, &c, &r);
        // Under-relax so that no working panel grows more than fourfold or shrinks below a fifth.
        let mut relax = 1.0f64;
        let mut largest = 0.0f64;
        for i in 0..nn - 1 {
            let (ds, dds) = (sn[i + 1] - sn[i], step[i + 1] - step[i]);
            let ratio = 1.0 + relax * dds / ds;
            if ratio > 4.0 {
                relax = 3.0 * ds / dds;
            }
            if ratio < 0.2 {
                relax = -0.8 * ds / dds;
            }
            largest = largest.max(step[i].abs());
        }
        for i in 1..nn - 1 {
            sn[i] += relax * step[i];
        }
        if largest < NEWTON_TOL * 0.5 * total {
            break;
        }
    }
    if sn.iter().any(|s| !s.is_finite()) || sn.windows(2).any(|p| p[1] <= p[0]) {
        return Err(Error::invalid(
            "the panel nodes could not be placed on the contour",
        ));
    }
    Ok(sn.iter().step_by(WORKING).copied().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_contour;

    #[test]
    fn nodes_cluster_at_the_leading_edge_as_xfoils_do() {
        let pts = test_contour("4413", 161);
        let sp = SplineContour::new(&pts).unwrap();
        let t = panel_params(&sp, &Paneling::default()).unwrap();
        assert_eq!(t.len(), DEFAULT_NODES);
        assert!(t.windows(2).all(|w| w[1] > w[0]));
        let nodes: Vec<DVec2> = t.iter().map(|&u| sp.point(u)).collect();
        let ds: Vec<f64> = nodes.windows(2).map(|w| (w[1] - w[0]).length()).collect();
        let (min, max) = ds
            .iter()
            .fold((f64::MAX, 0.0f64), |(a, b), &d| (a.min(d), b.max(d)));
        // XFOIL's PANE on NACA 4413 (82 points): 0.0019 at the leading edge, 0.0178 at most.
        assert!(min > 0.0012 && min < 0.0028, "smallest panel {min}");
        assert!(max > 0.015 && max < 0.021, "largest panel {max}");
        let le = nodes
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.x.total_cmp(&b.1.x))
            .unwrap()
            .0;
        assert!((75..=85).contains(&le), "leading edge at node {le}");
    }

    #[test]
    fn a_clockwise_contour_gets_reversed_parameters() {
        let pts = test_contour("0012", 82);
        let rev: Vec<DVec2> = pts.iter().rev().copied().collect();
        let t = panel_params(&SplineContour::new(&rev).unwrap(), &Paneling::with_nodes(40)).unwrap();
        assert!(t.windows(2).all(|w| w[1] < w[0]));
        assert!(panel_params(&SplineContour::new(&rev).unwrap(), &Paneling::with_nodes(4)).is_err());
        let open: Vec<DVec2> = (0..20).map(|i| DVec2::new(i as f64, (i as f64).sin())).collect();
        assert!(panel_params(&SplineContour::new(&open).unwrap(), &Paneling::with_nodes(40)).is_err());
    }
}
