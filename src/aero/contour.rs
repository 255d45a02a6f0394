//! Contours the panel method runs on, and where its nodes go on them.
//!
//! A [`Contour`] is a closed-ish curve over a parameter `t ∈ [0, 1]` that starts and ends at
//! the trailing edge: a fitted or regenerated [`CurveChain`], a [`SplineContour`] through raw
//! aerofoil coordinates, or an exact shape in tests. [`panel_params`] places `N` nodes on it
//! as XFOIL's `PANE` does: panel lengths `Δs` such that `Δs (1 + C κ̂)` is the same on every
//! panel, with `κ̂` the curvature smoothed over a length of about one leading-edge radius and
//! normalised by its maximum, the trailing edge given an artificial curvature of 0.15 of the
//! leading edge's, and the two end panels shortened as XFOIL shortens them. The result is a
//! list of parameters: the population evaluator computes them once, on the start shape, and
//! then places every individual's nodes at those same parameters (a fixed, linear map).

use crate::chain::CurveChain;
use crate::error::{Error, Result};
pub use crate::geometry::SplineContour;
use glam::DVec2;

/// A curve from the trailing edge round the leading edge back to the trailing edge.
pub trait Contour {
    /// The point at parameter `t ∈ [0, 1]`.
    fn point(&self, t: f64) -> DVec2;
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
}

/// Panel nodes of XFOIL's default paneling: 160 nodes.
pub const DEFAULT_NODES: usize = 160;
/// XFOIL's curvature attraction `6 CVPAR` (CVPAR = 1) times √2, since XFOIL weighs each panel
/// by the root-sum-square of its end curvatures.
const ATTRACTION: f64 = 6.0 * std::f64::consts::SQRT_2;

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
/// The two end panels relative to their neighbours: XFOIL shortens the first of its five
/// times finer working panels to 1/3 of the next (`RDSTE` = 0.667), so the end panel is
/// (1/3 + 4) / 5 of the regular length.
const END_PANEL: f64 = (1.0 / 3.0 + 4.0) / 5.0;
/// Samples of the contour before refinement.
const SAMPLES: usize = 2048;
/// Sample intervals turning by more than this (radians) are halved, up to [`REFINE_ROUNDS`] times.
const MAX_TURN: f64 = 0.01;
const REFINE_ROUNDS: usize = 12;

/// The contour sampled finely: parameters, points, cumulative arclength.
struct Samples {
    t: Vec<f64>,
    p: Vec<DVec2>,
    s: Vec<f64>,
}

impl Samples {
    fn new(contour: &dyn Contour) -> Samples {
        let mut t: Vec<f64> = (0..=SAMPLES).map(|k| k as f64 / SAMPLES as f64).collect();
        let mut p: Vec<DVec2> = t.iter().map(|&u| contour.point(u)).collect();
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
                    np.push(contour.point(m));
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
        Samples { t, p, s }
    }

    /// The unsigned curvature at every sample (turning angle over the mean adjacent length).
    fn curvature(&self) -> Vec<f64> {
        let n = self.p.len();
        let mut k = vec![0.0; n];
        for i in 1..n - 1 {
            let (a, b) = (self.p[i] - self.p[i - 1], self.p[i + 1] - self.p[i]);
            let len = 0.5 * (a.length() + b.length());
            if len > 0.0 {
                k[i] = a.perp_dot(b).atan2(a.dot(b)).abs() / len;
            }
        }
        k[0] = k[1];
        k[n - 1] = k[n - 2];
        k
    }
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
    let mut sm = Samples::new(contour);
    if sm.p.iter().any(|p| !p.is_finite()) {
        return Err(Error::invalid("the contour is not finite"));
    }
    let te = 0.5 * (sm.p[0] + sm.p[sm.p.len() - 1]);
    let t_le = leading_edge_param(contour);
    let le = contour.point(t_le);
    let chord = (le - te).length();
    let total = sm.s[sm.s.len() - 1];
    if !(chord > 0.0) || !(total > 0.0) {
        return Err(Error::invalid("the contour has no extent"));
    }
    let gap = (sm.p[0] - sm.p[sm.p.len() - 1]).length();
    if gap > 0.5 * chord {
        return Err(Error::invalid(format!(
            "the contour's ends are {gap:.3e} apart, half its chord ({chord:.3e}) or more: an aerofoil \
             contour must start and end at the trailing edge"
        )));
    }
    // The leading edge becomes a sample of its own.
    let k_le = sm.t.partition_point(|&t| t < t_le).clamp(1, sm.t.len() - 1);
    if (sm.t[k_le] - t_le).abs() > 0.0 && (sm.t[k_le - 1] - t_le).abs() > 0.0 {
        sm.t.insert(k_le, t_le);
        sm.p.insert(k_le, le);
        sm.s = std::iter::once(0.0)
            .chain(sm.p.windows(2).scan(0.0, |acc, w| {
                *acc += (w[1] - w[0]).length();
                Some(*acc)
            }))
            .collect();
    }
    let k_le = sm.t.partition_point(|&t| t < t_le).min(sm.t.len() - 1);
    let sbref = 0.5 * sm.s[sm.s.len() - 1];
    let raw: Vec<f64> = sm.curvature().iter().map(|k| k * sbref).collect();
    let cvle = raw[k_le];
    // The mean curvature over ±(one leading-edge radius) around the leading edge.
    let reach = sbref / cvle.max(20.0);
    let s_le = sm.s[k_le];
    let near: Vec<f64> = (0..sm.s.len())
        .filter(|&i| (sm.s[i] - s_le).abs() <= reach)
        .map(|i| raw[i])
        .collect();
    let cvavg = near.iter().sum::<f64>() / near.len().max(1) as f64;
    let smooth = (1.0 / cvavg.max(20.0)).max(0.25 / (n / 2) as f64) * sbref;
    let w = smoothed(&sm.s, &raw, k_le, cvle, cvavg * paneling.te_ratio, smooth);
    let wmax = w.iter().copied().fold(0.0, f64::max);
    if !(wmax > 0.0) {
        return Err(Error::invalid("the contour has no curvature (a straight line)"));
    }
    // Cumulative weighted length F(s) = ∫ (1 + C κ̂) ds, trapezoidal.
    let mut f = vec![0.0; sm.s.len()];
    for i in 1..f.len() {
        let rho = |k: usize| 1.0 + ATTRACTION * w[k] / wmax;
        f[i] = f[i - 1] + 0.5 * (rho(i - 1) + rho(i)) * (sm.s[i] - sm.s[i - 1]);
    }
    let ftotal = f[f.len() - 1];
    let step = ftotal / ((n - 3) as f64 + 2.0 * END_PANEL);
    let mut params = Vec::with_capacity(n);
    params.push(sm.t[0]);
    for k in 1..n - 1 {
        let target = step * (END_PANEL + (k - 1) as f64);
        let i = f.partition_point(|&v| v < target).clamp(1, f.len() - 1);
        let u = (target - f[i - 1]) / (f[i] - f[i - 1]);
        params.push(sm.t[i - 1] + u * (sm.t[i] - sm.t[i - 1]));
    }
    params.push(sm.t[sm.t.len() - 1]);
    if crate::geometry::twice_signed_area(&sm.p) < 0.0 {
        params.reverse();
    }
    Ok(params)
}

/// The curvature smoothed by `(1 − L² d²/ds²) w = raw` with `L = smooth`, held at `te` at
/// both ends and at `cvle` at the leading-edge sample `k_le` (XFOIL's smoothing).
fn smoothed(s: &[f64], raw: &[f64], k_le: usize, cvle: f64, te: f64, smooth: f64) -> Vec<f64> {
    let n = s.len();
    let l2 = smooth * smooth;
    let (mut a, mut b, mut c, mut d) = (vec![0.0; n], vec![1.0; n], vec![0.0; n], raw.to_vec());
    d[0] = te;
    d[n - 1] = te;
    for i in 1..n - 1 {
        if i == k_le {
            d[i] = cvle;
            continue;
        }
        let (hm, hp) = (s[i] - s[i - 1], s[i + 1] - s[i]);
        let ho = 0.5 * (s[i + 1] - s[i - 1]);
        if hm <= 0.0 || hp <= 0.0 {
            continue;
        }
        a[i] = -l2 / (hm * ho);
        b[i] = l2 * (1.0 / hm + 1.0 / hp) / ho + 1.0;
        c[i] = -l2 / (hp * ho);
    }
    crate::geometry::tridiagonal(&a, &b, &c, &d)
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
