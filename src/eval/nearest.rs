//! Closest points in f64 on curve chains and patch grids: the start parameters of
//! [`batch`](super::batch) and the reference the f32 kernels are tested against.
//!
//! Each search samples every segment or patch, then refines the best sample of each by Newton
//! steps with a backtracking line search (so the distance never grows), clamped to the
//! domain, until the step is below `1e-13` in parameter.

use crate::bezier::BezierPatch;
use crate::chain::{CurveChain, PatchGrid};
use glam::{DVec2, DVec3};
use rayon::prelude::*;

/// Closest points of `points` on `chain`: `(t, squared distance)` per point, each searched
/// with `samples` samples per segment.
#[must_use]
pub fn curve_nearest(chain: &CurveChain<DVec2>, points: &[DVec2], samples: usize) -> Vec<(f64, f64)> {
    points.par_iter().map(|&q| chain.nearest(q, samples)).collect()
}

/// Closest points of `points` on `grid`: `((u, v), squared distance)` per point, with global
/// parameters, each searched with `samples × samples` samples per patch.
#[must_use]
pub fn grid_nearest(grid: &PatchGrid<DVec3>, points: &[DVec3], samples: usize) -> Vec<(DVec2, f64)> {
    let search = GridSearch::new(grid);
    points.par_iter().map(|&q| search.nearest(q, samples)).collect()
}

/// A patch grid with its patches extracted once.
struct GridSearch<'a> {
    grid: &'a PatchGrid<DVec3>,
    patches: Vec<BezierPatch<DVec3>>,
}

impl<'a> GridSearch<'a> {
    fn new(grid: &'a PatchGrid<DVec3>) -> Self {
        let (pu, pv) = grid.layout().patches();
        let patches = (0..pu)
            .flat_map(|i| (0..pv).map(move |j| (i, j)))
            .map(|(i, j)| grid.patch(i, j))
            .collect();
        GridSearch { grid, patches }
    }

    /// Point and global partials at global `(u, v)`, from the extracted patches.
    fn partials(&self, uv: DVec2) -> (DVec3, DVec3, DVec3) {
        let (lu, lv) = (&self.grid.layout().u, &self.grid.layout().v);
        let (i, a) = lu.locate(uv.x);
        let (j, b) = lv.locate(uv.y);
        let (p, pu, pv) = self.patches[i * lv.segments() + j].partials(a, b);
        (p, pu / lu.segment_length(i), pv / lv.segment_length(j))
    }

    fn dist_sq(&self, uv: DVec2, q: DVec3) -> f64 {
        (self.partials(uv).0 - q).length_squared()
    }

    fn nearest(&self, q: DVec3, samples: usize) -> (DVec2, f64) {
        let n = samples.max(1);
        let (lu, lv) = (&self.grid.layout().u, &self.grid.layout().v);
        let mut best = (DVec2::ZERO, f64::INFINITY);
        for i in 0..lu.segments() {
            for j in 0..lv.segments() {
                let patch = &self.patches[i * lv.segments() + j];
                let mut start = (DVec2::ZERO, f64::INFINITY);
                for a in 0..=n {
                    for b in 0..=n {
                        let (s, t) = (a as f64 / n as f64, b as f64 / n as f64);
                        let e = (patch.eval(s, t) - q).length_squared();
                        if e < start.1 {
                            start = (DVec2::new(lu.global(i, s), lv.global(j, t)), e);
                        }
                    }
                }
                let refined = self.refine(q, start);
                if refined.1 < best.1 {
                    best = refined;
                }
            }
        }
        best
    }

    /// Damped Newton on `|S(u, v) - q|²` in global parameters, clamped to `[0, 1]²`.
    fn refine(&self, q: DVec3, start: (DVec2, f64)) -> (DVec2, f64) {
        let (mut uv, mut e) = start;
        let h = 1e-6;
        for _ in 0..60 {
            let (p, su, sv) = self.partials(uv);
            let r = p - q;
            let g = DVec2::new(r.dot(su), r.dot(sv));
            // Second partials by central differences of the exact first partials: they only
            // steer the step, the fixed point (g = 0) is exact.
            let (_, su_p, sv_p) = self.partials((uv + DVec2::new(h, 0.0)).min(DVec2::ONE));
            let (_, su_m, sv_m) = self.partials((uv - DVec2::new(h, 0.0)).max(DVec2::ZERO));
            let (_, _, sv_vp) = self.partials((uv + DVec2::new(0.0, h)).min(DVec2::ONE));
            let (_, _, sv_vm) = self.partials((uv - DVec2::new(0.0, h)).max(DVec2::ZERO));
            let du = ((uv.x + h).min(1.0) - (uv.x - h).max(0.0)).max(f64::MIN_POSITIVE);
            let dv = ((uv.y + h).min(1.0) - (uv.y - h).max(0.0)).max(f64::MIN_POSITIVE);
            let suu = (su_p - su_m) / du;
            let suv = (sv_p - sv_m) / du;
            let svv = (sv_vp - sv_vm) / dv;
            let (mut huu, mut huv, mut hvv) = (
                su.dot(su) + r.dot(suu),
                su.dot(sv) + r.dot(suv),
                sv.dot(sv) + r.dot(svv),
            );
            if !(huu > 0.0 && huu * hvv - huv * huv > 1e-12 * huu * hvv) {
                (huu, huv, hvv) = (su.dot(su), su.dot(sv), sv.dot(sv));
            }
            let det = huu * hvv - huv * huv;
            let step = if det > 1e-300 && huu > 0.0 {
                DVec2::new(huv * g.y - hvv * g.x, huv * g.x - huu * g.y) / det
            } else {
                // Degenerate (a closed tip): gradient step scaled by the larger curvature.
                -g / huu.max(hvv).max(f64::MIN_POSITIVE)
            };
            let mut t = 1.0;
            let mut moved = false;
            for _ in 0..40 {
                let next = (uv + step * t).clamp(DVec2::ZERO, DVec2::ONE);
                let en = self.dist_sq(next, q);
                if en <= e {
                    moved = (next - uv).length() > 1e-13;
                    uv = next;
                    e = en;
                    break;
                }
                t *= 0.5;
            }
            if !moved {
                break;
            }
        }
        (uv, e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, GridLayout};

    fn grid() -> PatchGrid<DVec3> {
        let g = GridLayout::new(
            ChainLayout::uniform(3, 2, Continuity::C1).unwrap(),
            ChainLayout::with_breaks(3, vec![0.0, 0.4, 1.0], Continuity::C1).unwrap(),
        );
        let (nu, nv) = g.design_shape();
        let design = (0..nu * nv)
            .map(|k| {
                let (i, j) = (
                    (k / nv) as f64 / (nu - 1) as f64,
                    (k % nv) as f64 / (nv - 1) as f64,
                );
                DVec3::new(i, j, 0.3 * (3.0 * i).sin() * (2.0 * j).cos())
            })
            .collect();
        PatchGrid::new(g, design).unwrap()
    }

    #[test]
    fn grid_foot_points_are_stationary_and_global() {
        let grid = grid();
        let qs: Vec<DVec3> = (0..40)
            .map(|k| {
                let (u, v) = ((k % 7) as f64 / 6.0, (k / 7) as f64 / 5.0);
                grid.eval(u, v) + DVec3::new(0.01 * (k as f64).sin(), 0.02, 0.05 * (k as f64).cos())
            })
            .collect();
        let found = grid_nearest(&grid, &qs, 8);
        for (q, (uv, e)) in qs.iter().zip(&found) {
            assert!(((grid.eval(uv.x, uv.y) - *q).length_squared() - e).abs() < 1e-15);
            // No point of a fine scan is closer.
            for a in 0..=60 {
                for b in 0..=60 {
                    let s = grid.eval(a as f64 / 60.0, b as f64 / 60.0);
                    assert!((s - *q).length_squared() >= e - 1e-12);
                }
            }
            // Interior foot points are stationary: the residual is normal to the surface (to
            // a cosine of 1e-7, a parameter error far below what distances can see).
            if uv.x > 1e-6 && uv.x < 1.0 - 1e-6 && uv.y > 1e-6 && uv.y < 1.0 - 1e-6 {
                let (p, su, sv) = grid.partials(uv.x, uv.y);
                let r = p - *q;
                for s in [su, sv] {
                    assert!(
                        r.dot(s).abs() < 1e-7 * r.length() * s.length(),
                        "{uv}: {}",
                        r.dot(s)
                    );
                }
            }
        }
    }
}
