//! Helpers of the surface tests: an offset measure of a patch grid that works from a control
//! net alone, independently of the library's foot-point code.

#![allow(dead_code)]

use glam::DVec3;

/// de Casteljau on one row of control points.
fn casteljau(ctrl: &[DVec3], t: f64) -> DVec3 {
    let mut p = ctrl.to_vec();
    for r in 1..p.len() {
        for i in 0..p.len() - r {
            p[i] = p[i].lerp(p[i + 1], t);
        }
    }
    p[0]
}

/// A Bezier patch from its `(du + 1) x (dv + 1)` control points, rows along u.
struct Patch {
    rows: Vec<Vec<DVec3>>,
}

impl Patch {
    fn eval(&self, u: f64, v: f64) -> DVec3 {
        let col: Vec<DVec3> = self.rows.iter().map(|r| casteljau(r, v)).collect();
        casteljau(&col, u)
    }
}

/// The patches of a control net (`net[r][c]`, rows along u) of degrees `du x dv`.
fn patches(net: &[Vec<DVec3>], du: usize, dv: usize) -> Vec<Patch> {
    let (pu, pv) = ((net.len() - 1) / du, (net[0].len() - 1) / dv);
    assert_eq!(pu * du + 1, net.len(), "net rows");
    assert_eq!(pv * dv + 1, net[0].len(), "net columns");
    let mut out = Vec::new();
    for i in 0..pu {
        for j in 0..pv {
            out.push(Patch {
                rows: (i * du..=(i + 1) * du)
                    .map(|r| net[r][j * dv..=(j + 1) * dv].to_vec())
                    .collect(),
            });
        }
    }
    out
}

/// Squared distance from `q` to one patch: Gauss-Newton from each start `(d2, u, v)`, with
/// partial derivatives by central differences, steps clamped to the patch and halved until
/// the distance does not grow.
fn patch_distance(p: &Patch, q: DVec3, starts: &[(f64, f64, f64)]) -> f64 {
    let d2 = |u: f64, v: f64| (p.eval(u, v) - q).length_squared();
    let mut best = f64::INFINITY;
    for &(_, u0, v0) in starts {
        let (mut u, mut v, mut f) = (u0, v0, d2(u0, v0));
        for _ in 0..60 {
            let e = 1e-6;
            let (ua, ub) = ((u - e).max(0.0), (u + e).min(1.0));
            let (va, vb) = ((v - e).max(0.0), (v + e).min(1.0));
            let su = (p.eval(ub, v) - p.eval(ua, v)) / (ub - ua);
            let sv = (p.eval(u, vb) - p.eval(u, va)) / (vb - va);
            let r = p.eval(u, v) - q;
            let (a, b, c) = (su.dot(su), su.dot(sv), sv.dot(sv));
            let (g1, g2) = (su.dot(r), sv.dot(r));
            let det = a * c - b * b;
            if det.abs() <= 1e-300 || det.is_nan() {
                break;
            }
            let (mut du, mut dv) = (-(c * g1 - b * g2) / det, -(a * g2 - b * g1) / det);
            let mut moved = false;
            for _ in 0..40 {
                let (un, vn) = ((u + du).clamp(0.0, 1.0), (v + dv).clamp(0.0, 1.0));
                let fn_ = d2(un, vn);
                if fn_ < f {
                    moved = (un - u).abs() + (vn - v).abs() > 1e-15;
                    (u, v, f) = (un, vn, fn_);
                    break;
                }
                du *= 0.5;
                dv *= 0.5;
            }
            if !moved {
                break;
            }
        }
        // Gauss-Newton stalls on the patch's edges (a clamped step need not descend): finish
        // with a pattern search along the axes and diagonals.
        let mut h = 1e-2;
        while h > 1e-14 {
            let mut moved = false;
            for (du, dv) in [
                (h, 0.0),
                (-h, 0.0),
                (0.0, h),
                (0.0, -h),
                (h, h),
                (-h, -h),
                (h, -h),
                (-h, h),
            ] {
                let (un, vn) = ((u + du).clamp(0.0, 1.0), (v + dv).clamp(0.0, 1.0));
                let fn_ = d2(un, vn);
                if fn_ < f {
                    (u, v, f) = (un, vn, fn_);
                    moved = true;
                }
            }
            if !moved {
                h *= 0.5;
            }
        }
        best = best.min(f);
    }
    best
}

/// A patch grid known only by its control net, sampled once: every patch on a grid whose
/// steps are at most 0.4% of the net's diameter along the control polygon (at least 8 per
/// side). A distance is found by Gauss-Newton (then a pattern search) from every sample that
/// is a local minimum of its patch's samples and could hold the closest point. Slow and simple
/// on purpose, and independent of the library's evaluation and foot-point code.
pub struct IndependentGrid {
    patches: Vec<Patch>,
    /// Per patch: samples along u and v, their parameters, positions and longest step.
    samples: Vec<PatchSamples>,
}

/// Samples along u and v, their parameters, positions and longest step.
type PatchSamples = (usize, usize, Vec<(f64, f64)>, Vec<DVec3>, f64);

impl IndependentGrid {
    /// The grid of control net `net` (rows along u) of degrees `du x dv`.
    pub fn new(net: &[Vec<DVec3>], du: usize, dv: usize) -> IndependentGrid {
        let patches = patches(net, du, dv);
        let all: Vec<DVec3> = net.iter().flatten().copied().collect();
        let (lo, hi) = all
            .iter()
            .fold((DVec3::MAX, DVec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let step = 0.004 * (hi - lo).length();
        let samples = patches
            .iter()
            .map(|p| {
                let poly = |pts: Vec<DVec3>| pts.windows(2).map(|w| (w[1] - w[0]).length()).sum::<f64>();
                let along_v = p.rows.iter().map(|r| poly(r.clone())).fold(0.0, f64::max);
                let along_u = (0..p.rows[0].len())
                    .map(|c| poly(p.rows.iter().map(|r| r[c]).collect()))
                    .fold(0.0, f64::max);
                let count = |len: f64| ((len / step).ceil() as usize).clamp(8, 400);
                let (nu, nv) = (count(along_u), count(along_v));
                let grid: Vec<(f64, f64)> = (0..=nu)
                    .flat_map(|a| (0..=nv).map(move |b| (a as f64 / nu as f64, b as f64 / nv as f64)))
                    .collect();
                let pts: Vec<DVec3> = grid.iter().map(|&(u, v)| p.eval(u, v)).collect();
                let mut h: f64 = 0.0;
                for a in 0..=nu {
                    for b in 0..=nv {
                        let k = a * (nv + 1) + b;
                        if a < nu {
                            h = h.max((pts[k + nv + 1] - pts[k]).length());
                        }
                        if b < nv {
                            h = h.max((pts[k + 1] - pts[k]).length());
                        }
                    }
                }
                (nu, nv, grid, pts, h)
            })
            .collect();
        IndependentGrid { patches, samples }
    }

    /// The distance from `q` to the grid.
    pub fn distance(&self, q: DVec3) -> f64 {
        let d2: Vec<Vec<f64>> = self
            .samples
            .iter()
            .map(|s| s.3.iter().map(|x| (*x - q).length_squared()).collect())
            .collect();
        let best_sample = d2.iter().flatten().fold(f64::INFINITY, |m, &d| m.min(d));
        let mut best = best_sample;
        for ((p, d), (nu, nv, grid, _, h)) in self.patches.iter().zip(&d2).zip(&self.samples) {
            let (nu, nv) = (*nu, *nv);
            let mut starts = Vec::new();
            for a in 0..=nu {
                for b in 0..=nv {
                    let k = a * (nv + 1) + b;
                    // No point of the patch is nearer than its nearest sample less a step.
                    if d[k].sqrt() - h > best_sample.sqrt() {
                        continue;
                    }
                    let lower = (a.saturating_sub(1)..=(a + 1).min(nu))
                        .flat_map(|x| (b.saturating_sub(1)..=(b + 1).min(nv)).map(move |y| x * (nv + 1) + y))
                        .any(|m| d[m] < d[k]);
                    if !lower {
                        starts.push((d[k], grid[k].0, grid[k].1));
                    }
                }
            }
            if !starts.is_empty() {
                best = best.min(patch_distance(p, q, &starts));
            }
        }
        best.sqrt()
    }
}
