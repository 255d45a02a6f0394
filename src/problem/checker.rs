//! The emulation of an outside checker: the closest-point search of the shared checker
//! `shared/tools/verify.py`, step for step, and the projection check built on it.
//!
//! This is deliberately *not* the library's closest-point search ([`crate::closest`]): its
//! job is to behave like a simple downstream tool, so that a report's offsets are ones such a
//! tool can reproduce. It samples every patch at the 7 × 7 local parameters `k / 6`, takes the
//! four nearest samples of all and runs at most 25 Gauss-Newton steps clamped to each one's
//! patch, with `verify.py`'s arithmetic (de Casteljau as `a + (b - a) t`). A grid whose
//! overhangs or folds trap that search reports offsets such a tool cannot reproduce; the
//! projection check says so, and the adaptive surface search accepts only layouts whose
//! offsets this search confirms.
//!
//! Beside it, the other check such a tool would run on a fitted grid: [`fold_check`], how far
//! the surface normal turns between neighbouring samples (an exact evaluation through
//! [`PatchGrid::partials`], not an emulation).

use crate::bezier::casteljau_with;
use crate::chain::samples;
use crate::chain::{PatchGrid, MAX_DEGREE};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::OnceLock;

/// The coarse search passes when its rms and max are within this factor of the exact ones.
pub const AGREEMENT: f64 = 1.001;

/// What a coarse sampled search finds on a fitted grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectionCheck {
    /// Root mean square of the coarse distances.
    pub rms: f64,
    /// Largest coarse distance.
    pub max: f64,
    /// Whether both are within [`AGREEMENT`] of the exact closest-point rms and max.
    pub agrees: bool,
}

/// The distances the checker's sampled search ([`sampled_offsets`]) finds from `points` to
/// `grid` (upper bounds of the true ones), compared with the exact `rms` and `max`.
#[must_use]
pub fn projection_check(grid: &PatchGrid<DVec3>, points: &[DVec3], rms: f64, max: f64) -> ProjectionCheck {
    let d = sampled_offsets(grid, points);
    let n = d.len().max(1) as f64;
    let coarse_rms = (d.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
    let coarse_max = d.iter().copied().fold(0.0, f64::max);
    let slack = |exact: f64| exact * AGREEMENT + 1e-15;
    ProjectionCheck {
        rms: coarse_rms,
        max: coarse_max,
        agrees: coarse_rms <= slack(rms) && coarse_max <= slack(max),
    }
}

/// De Casteljau's algorithm with `verify.py`'s arithmetic (`a + (b - a) t`, in order).
fn casteljau(ctrl: &mut [DVec3], t: f64) -> DVec3 {
    casteljau_with(ctrl, t, |a, b, t| a + (b - a) * t, |_| {})
}

/// One patch's control points (rows along u) and its evaluation with `verify.py`'s arithmetic.
struct CheckPatch {
    du: usize,
    dv: usize,
    ctrl: Vec<DVec3>,
}

/// Room for one row or column of a patch's control points (and their differences).
type Row = [DVec3; MAX_DEGREE + 1];

impl CheckPatch {
    fn eval(&self, u: f64, v: f64) -> DVec3 {
        let mut rows: Row = [DVec3::ZERO; MAX_DEGREE + 1];
        for (p, r) in rows.iter_mut().zip(self.ctrl.chunks(self.dv + 1)) {
            let mut c: Row = [DVec3::ZERO; MAX_DEGREE + 1];
            c[..r.len()].copy_from_slice(r);
            *p = casteljau(&mut c[..r.len()], v);
        }
        casteljau(&mut rows[..=self.du], u)
    }

    /// The point and its partials, on the stack (the same arithmetic as before, when each
    /// step allocated its rows: 14 allocations a Gauss-Newton step).
    fn partials(&self, u: f64, v: f64) -> (DVec3, DVec3, DVec3) {
        let (du, dv) = (self.du as f64, self.dv as f64);
        let mut rows: Row = [DVec3::ZERO; MAX_DEGREE + 1];
        let mut drows: Row = [DVec3::ZERO; MAX_DEGREE + 1];
        for (k, r) in self.ctrl.chunks(self.dv + 1).enumerate() {
            let mut c: Row = [DVec3::ZERO; MAX_DEGREE + 1];
            c[..r.len()].copy_from_slice(r);
            rows[k] = casteljau(&mut c[..r.len()], v);
            let mut d: Row = [DVec3::ZERO; MAX_DEGREE + 1];
            for (x, w) in d.iter_mut().zip(r.windows(2)) {
                *x = (w[1] - w[0]) * dv;
            }
            drows[k] = casteljau(&mut d[..r.len() - 1], v);
        }
        let n = self.du + 1;
        let mut dr: Row = [DVec3::ZERO; MAX_DEGREE + 1];
        for (x, w) in dr.iter_mut().zip(rows[..n].windows(2)) {
            *x = (w[1] - w[0]) * du;
        }
        let p = casteljau(&mut rows[..n], u);
        let pu = casteljau(&mut dr[..n - 1], u);
        let pv = casteljau(&mut drows[..n], u);
        (p, pu, pv)
    }
}

/// The four best `(distance², sample index)` of a scan, in order: the least distances, ties
/// in sampling order, as Python's stable sort keeps them (in whatever order they are offered).
struct Four {
    c: [(f64, usize); 4],
    kept: usize,
}

impl Default for Four {
    fn default() -> Self {
        Four {
            c: [(f64::INFINITY, usize::MAX); 4],
            kept: 0,
        }
    }
}

impl Four {
    fn offer(&mut self, d: f64, i: usize) {
        let before = |c: (f64, usize)| d.total_cmp(&c.0).then(i.cmp(&c.1)).is_lt();
        if self.kept == 4 && !before(self.c[3]) {
            return;
        }
        let mut at = self.kept.min(3);
        while at > 0 && before(self.c[at - 1]) {
            self.c[at] = self.c[at - 1];
            at -= 1;
        }
        self.c[at] = (d, i);
        self.kept = (self.kept + 1).min(4);
    }

    /// The fourth best distance², once four are kept.
    fn bound(&self) -> Option<f64> {
        (self.kept == 4).then_some(self.c[3].0)
    }
}

/// The samples sorted along the axis of their largest extent, for the nearest-sample scan: a
/// sample farther along that axis than the fourth best distance cannot be among the four, so
/// the scan runs outwards from the point and stops there (the same four as a scan of all).
struct Slab {
    axis: usize,
    key: Vec<f64>,
    pos: Vec<DVec3>,
    index: Vec<usize>,
}

impl Slab {
    fn new(samples: &[DVec3]) -> Self {
        let axis = longest_axis(samples);
        let mut index: Vec<usize> = (0..samples.len()).collect();
        index.sort_by(|&a, &b| samples[a][axis].total_cmp(&samples[b][axis]).then(a.cmp(&b)));
        Slab {
            axis,
            key: index.iter().map(|&i| samples[i][axis]).collect(),
            pos: index.iter().map(|&i| samples[i]).collect(),
            index,
        }
    }

    /// The four nearest samples to `q` (`dist2`'s arithmetic, ties by sample index).
    fn four(&self, q: DVec3) -> Four {
        let k = q[self.axis];
        let n = self.key.len();
        let (mut lo, mut hi) = {
            let m = self.key.partition_point(|&s| s < k);
            (m, m)
        };
        let mut four = Four::default();
        loop {
            // The nearer side along the axis next; its squared gap bounds every distance
            // left (a sum of non-negative squares never rounds below one of them).
            let gap = |j: usize| {
                let t = self.key[j] - k;
                t * t
            };
            let low = (lo > 0).then(|| gap(lo - 1));
            let high = (hi < n).then(|| gap(hi));
            let (take_low, g) = match (low, high) {
                (Some(a), Some(b)) => (a <= b, a.min(b)),
                (Some(a), None) => (true, a),
                (None, Some(b)) => (false, b),
                (None, None) => break,
            };
            if four.bound().is_some_and(|d4| g > d4) {
                break;
            }
            let j = if take_low {
                lo -= 1;
                lo
            } else {
                hi += 1;
                hi - 1
            };
            four.offer(dist2(self.pos[j], q), self.index[j]);
        }
        four
    }
}

/// Samples in a leaf of [`Tree`] at most.
const LEAF: usize = 12;

/// A k-d tree of the samples for the nearest-sample scan: the same four as [`Slab`] (and a
/// scan of all), from fewer distances. A child is skipped only when the squared gap from
/// the point to its splitting plane exceeds the fourth best distance²: every sample behind
/// the plane is at least that far along its axis (the rounded differences keep their order),
/// and a sum of non-negative squares never rounds below one of them, so nothing skipped
/// could be among the four, whatever order the others are offered in.
struct Tree {
    nodes: Vec<Node>,
    pos: Vec<DVec3>,
    index: Vec<usize>,
}

enum Node {
    Leaf(usize, usize),
    Split {
        axis: usize,
        at: f64,
        left: usize,
        right: usize,
    },
}

impl Tree {
    /// The tree of `samples`, `None` when one of them is not finite (the slab scan then).
    fn new(samples: &[DVec3]) -> Option<Self> {
        if !samples.iter().all(|s| s.is_finite()) {
            return None;
        }
        let mut tree = Tree {
            nodes: Vec::new(),
            pos: samples.to_vec(),
            index: (0..samples.len()).collect(),
        };
        tree.build(0, samples.len());
        Some(tree)
    }

    fn build(&mut self, lo: usize, hi: usize) -> usize {
        let me = self.nodes.len();
        self.nodes.push(Node::Leaf(lo, hi));
        if hi - lo <= LEAF {
            return me;
        }
        let axis = longest_axis(&self.pos[lo..hi]);
        let mid = lo + (hi - lo) / 2;
        let mut both: Vec<(DVec3, usize)> = (lo..hi).map(|k| (self.pos[k], self.index[k])).collect();
        both.select_nth_unstable_by(mid - lo, |p, q| {
            p.0[axis].total_cmp(&q.0[axis]).then(p.1.cmp(&q.1))
        });
        for (k, (p, i)) in (lo..hi).zip(both) {
            self.pos[k] = p;
            self.index[k] = i;
        }
        let at = self.pos[mid][axis];
        let left = self.build(lo, mid);
        let right = self.build(mid, hi);
        self.nodes[me] = Node::Split {
            axis,
            at,
            left,
            right,
        };
        me
    }

    /// The four nearest samples to `q` (`dist2`'s arithmetic, ties by sample index).
    fn four(&self, q: DVec3) -> Four {
        let mut four = Four::default();
        self.visit(0, q, &mut four);
        four
    }

    fn visit(&self, node: usize, q: DVec3, four: &mut Four) {
        match self.nodes[node] {
            Node::Leaf(lo, hi) => {
                for k in lo..hi {
                    four.offer(dist2(self.pos[k], q), self.index[k]);
                }
            }
            Node::Split {
                axis,
                at,
                left,
                right,
            } => {
                // Left of the plane every sample is at most `at` along the axis, right of it
                // at least.
                let (near, far) = if q[axis] < at {
                    (left, right)
                } else {
                    (right, left)
                };
                self.visit(near, q, four);
                let t = at - q[axis];
                if four.bound().is_some_and(|d4| t * t > d4) {
                    return;
                }
                self.visit(far, q, four);
            }
        }
    }
}

fn dist2(a: DVec3, b: DVec3) -> f64 {
    let d = a - b;
    d.x * d.x + d.y * d.y + d.z * d.z
}

/// The closest-point search of the shared checker `shared/tools/verify.py`, step for step:
/// every patch sampled at the 7 x 7 local parameters `k / 6`, the four best samples of all
/// (ties kept in sampling order, as Python's stable sort keeps them)
/// refined by at most 25 clamped Gauss-Newton steps in their patch. Returns every point's
/// distance: the distance to a point of the surface, so never below the true closest-point
/// distance. [`projection_check`] compares it with a fit's exact offsets;
/// [`crate::adaptive::adapt_surface`] accepts a layout only when it meets the tolerance too,
/// so that the checker confirms what the report claims.
#[must_use]
pub fn sampled_offsets(grid: &PatchGrid<DVec3>, points: &[DVec3]) -> Vec<f64> {
    let search = Sampled::new(grid);
    points
        .par_iter()
        .map(|&q| search.offset(q, None).sqrt())
        .collect()
}

/// Whether every point's offset by the checker's search ([`sampled_offsets`]) is within its
/// tolerance, `tol(p)` for point `p` (a NaN offset passes, as the max of [`sampled_offsets`] by
/// `f64::max` skips it): the same answer as comparing each offset with its tolerance, for less
/// work. A point's offset is the least over its four seeds, so once one seed's refinement ends
/// within `tol` the others cannot take the point out of it and are not refined; the scan stops at
/// the first point beyond it.
#[must_use]
pub fn sampled_within(
    grid: &PatchGrid<DVec3>,
    points: &[DVec3],
    tol: &(dyn Fn(usize) -> f64 + Sync),
) -> bool {
    let search = Sampled::new(grid);
    points.par_iter().enumerate().all(|(p, &q)| {
        let tol = tol(p);
        !(search.offset(q, Some(tol)).sqrt() > tol)
    })
}

/// The checker's search prepared on one grid: its patches, their samples and the k-d tree
/// of those (`None` where a sample is not finite), with the slab scan built on first need
/// (no tree, or a point that is not finite).
struct Sampled {
    patches: Vec<CheckPatch>,
    samples: Vec<(usize, f64, f64, DVec3)>,
    tree: Option<Tree>,
    slab: OnceLock<Slab>,
}

impl Sampled {
    fn new(grid: &PatchGrid<DVec3>) -> Self {
        let l = grid.layout();
        let (du, dv) = (l.u.degree(), l.v.degree());
        let (pu, pv) = l.patches();
        let patches: Vec<CheckPatch> = (0..pu)
            .flat_map(|i| (0..pv).map(move |j| (i, j)))
            .map(|(i, j)| {
                let p = grid.patch(i, j);
                let ctrl = (0..=du)
                    .flat_map(|a| (0..=dv).map(move |b| (a, b)))
                    .map(|(a, b)| p.at(a, b))
                    .collect();
                CheckPatch { du, dv, ctrl }
            })
            .collect();
        let samples: Vec<(usize, f64, f64, DVec3)> = patches
            .iter()
            .enumerate()
            .flat_map(|(k, p)| {
                (0..=6).flat_map(move |a| {
                    (0..=6).map(move |b| {
                        let (u, v) = (a as f64 / 6.0, b as f64 / 6.0);
                        (k, u, v, p.eval(u, v))
                    })
                })
            })
            .collect();
        let tree = Tree::new(&samples.iter().map(|s| s.3).collect::<Vec<_>>());
        Sampled {
            patches,
            samples,
            tree,
            slab: OnceLock::new(),
        }
    }

    /// The squared offset of `q`: the nearest of its four seeds' refinements. With `within`,
    /// it stops refining seeds once the offset so far is at most that (the result is then
    /// only known to be within it).
    fn offset(&self, q: DVec3, within: Option<f64>) -> f64 {
        let four = match &self.tree {
            Some(t) if q.is_finite() => t.four(q),
            _ => self
                .slab
                .get_or_init(|| Slab::new(&self.samples.iter().map(|s| s.3).collect::<Vec<_>>()))
                .four(q),
        };
        let (kept, four) = (four.kept, four.c);
        let mut best = four[0].0;
        let done = |best: f64| within.is_some_and(|tol| best.sqrt() <= tol);
        for &(_, i) in &four[..kept] {
            if done(best) {
                break;
            }
            let (k, u0, v0, _) = self.samples[i];
            let p = &self.patches[k];
            let (mut u, mut v) = (u0, v0);
            for _ in 0..25 {
                let (s, su, sv) = p.partials(u, v);
                let r = s - q;
                let (a11, a12, a22) = (su.dot(su), su.dot(sv), sv.dot(sv));
                let (b1, b2) = (-r.dot(su), -r.dot(sv));
                let det = a11 * a22 - a12 * a12;
                if det.abs() < 1e-300 {
                    break;
                }
                let du_ = (b1 * a22 - b2 * a12) / det;
                let dv_ = (a11 * b2 - a12 * b1) / det;
                let (un, vn) = ((u + du_).clamp(0.0, 1.0), (v + dv_).clamp(0.0, 1.0));
                if (un - u).abs() + (vn - v).abs() < 1e-14 {
                    break;
                }
                u = un;
                v = vn;
            }
            best = best.min(dist2(p.eval(u, v), q));
        }
        best
    }
}

/// The fold check of a patch grid: how far the unit normal turns between neighbouring
/// samples of a dense sample, in degrees.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FoldCheck {
    /// Samples a patch in each direction (the global sample is uniform within each patch).
    pub per_patch: usize,
    /// The largest turn of the normal between two neighbouring samples (along u or along v),
    /// degrees.
    pub max_turn_deg: f64,
    /// Where: the global `(u, v)` of the first sample of that pair.
    pub at: [f64; 2],
    /// True when it is at most 90°: the surface neither folds back nor overhangs between
    /// samples.
    pub passes: bool,
}

/// The fold check of `grid` on `per_patch` × `per_patch` samples a patch (borders shared):
/// the normal `S_u × S_v` at every sample, and the largest angle between the normals of
/// neighbouring samples along u and along v. Samples where the normal vanishes (a collapsed
/// edge such as a blade tip: `|S_u × S_v|` below `1e-10` of the grid's largest) have no
/// direction and are skipped.
#[must_use]
pub fn fold_check(grid: &PatchGrid<DVec3>, per_patch: usize) -> FoldCheck {
    let l = grid.layout();
    let per = per_patch.max(1);
    let (us, vs) = (samples(l.u.breaks(), per), samples(l.v.breaks(), per));
    let normals: Vec<Vec<DVec3>> = us
        .par_chunks(32)
        .flat_map_iter(|rows| grid.partials_on(rows, &vs))
        .map(|row| row.iter().map(|(pu, pv)| pu.cross(*pv)).collect())
        .collect();
    let big = normals.iter().flatten().fold(0.0_f64, |m, n| m.max(n.length()));
    let units: Vec<Vec<Option<DVec3>>> = normals
        .iter()
        .map(|row| {
            row.iter()
                .map(|&n| (n.length() > 1e-10 * big).then(|| n.normalize()))
                .collect()
        })
        .collect();
    // The largest turn is the least cosine: one arc cosine, for it.
    let mut worst = (1.0_f64, [0.0, 0.0]);
    for i in 0..us.len() {
        for j in 0..vs.len() {
            let Some(a) = units[i][j] else { continue };
            for (ni, nj) in [(i + 1, j), (i, j + 1)] {
                if ni >= us.len() || nj >= vs.len() {
                    continue;
                }
                if let Some(b) = units[ni][nj] {
                    let cos = a.dot(b).clamp(-1.0, 1.0);
                    if cos < worst.0 {
                        worst = (cos, [us[i], vs[j]]);
                    }
                }
            }
        }
    }
    let worst = (worst.0.acos().to_degrees(), worst.1);
    FoldCheck {
        per_patch: per,
        max_turn_deg: worst.0,
        at: worst.1,
        passes: worst.0 <= 90.0,
    }
}

/// The axis (0, 1, 2) along which `points` extend the most; the first of equals.
fn longest_axis(points: &[DVec3]) -> usize {
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let ext = hi - lo;
    if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::{ChainLayout, Continuity, GridLayout};

    /// A 2 × 2 bicubic C1 grid over the unit square at `z = bump·x·y` (a plane when 0).
    fn grid(bump: f64) -> PatchGrid<DVec3> {
        let u = ChainLayout::uniform(3, 2, Continuity::C1).unwrap();
        let v = ChainLayout::uniform(3, 2, Continuity::C1).unwrap();
        let layout = GridLayout::new(u, v);
        let (mu, mv) = layout.design_shape();
        let design = (0..mu)
            .flat_map(|i| {
                (0..mv).map(move |j| {
                    let (x, y) = (i as f64 / (mu - 1) as f64, j as f64 / (mv - 1) as f64);
                    DVec3::new(x, y, bump * x * y)
                })
            })
            .collect();
        PatchGrid::new(layout, design).unwrap()
    }

    #[test]
    fn sampled_within_answers_as_the_max_of_the_sampled_offsets() {
        let g = grid(0.8);
        let pts: Vec<DVec3> = (0..300)
            .map(|i| {
                let t = i as f64;
                DVec3::new(
                    0.5 + 0.6 * (t * 0.37).sin(),
                    0.5 + 0.6 * (t * 0.23).cos(),
                    0.3 * (t * 0.71).sin(),
                )
            })
            .collect();
        let d = sampled_offsets(&g, &pts);
        let max = d.iter().copied().fold(0.0, f64::max);
        let mut sorted = d.clone();
        sorted.sort_by(f64::total_cmp);
        for tol in [
            0.0,
            sorted[0],
            sorted[150],
            sorted[298],
            max,
            max * (1.0 + 1e-12),
            2.0 * max,
        ] {
            assert_eq!(
                sampled_within(&g, &pts, &|_| tol),
                max <= tol,
                "tol {tol}, max {max}"
            );
        }
        assert!(sampled_within(&g, &[], &|_| 0.0));
        // Each point against its own tolerance: the farthest point alone held looser.
        let far = d.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0;
        let each = |p: usize| if p == far { max } else { sorted[298] };
        assert!(sampled_within(&g, &pts, &each));
        assert!(!sampled_within(&g, &pts, &|p| if p == far {
            0.5 * max
        } else {
            max
        }));
    }

    /// Samples on a coarse lattice (many exact ties, repeated samples as on shared patch
    /// edges) stretched along z.
    fn lattice() -> Vec<DVec3> {
        (0..600)
            .map(|i| {
                let k = i % 450;
                DVec3::new((k % 5) as f64 * 0.5, ((k / 5) % 3) as f64, (k / 15) as f64 * 2.0)
            })
            .collect()
    }

    /// The `j`-th query point: among, between and beyond the lattice's samples.
    fn query(j: usize) -> DVec3 {
        let t = j as f64;
        DVec3::new((t * 0.37).sin() * 2.0, (t * 0.11).cos() * 2.0, t * 0.35 - 5.0)
    }

    /// The four nearest of `samples` to `q` by a scan of all: Python's stable sort by
    /// distance, ties in sampling order.
    fn four_by_scan(samples: &[DVec3], q: DVec3) -> Vec<(f64, usize)> {
        let mut all: Vec<(f64, usize)> = samples
            .iter()
            .enumerate()
            .map(|(i, s)| (dist2(*s, q), i))
            .collect();
        all.sort_by(|a, b| a.0.total_cmp(&b.0));
        all.truncate(4);
        all
    }

    #[test]
    fn the_tree_finds_the_four_a_scan_of_all_finds() {
        // The lattice and a jittered cloud.
        let cloud: Vec<DVec3> = (0..2000)
            .map(|i| {
                let t = i as f64;
                DVec3::new((t * 0.731).sin() * 3.0, (t * 0.193).cos(), t * 0.01)
            })
            .collect();
        for samples in [lattice(), cloud] {
            let tree = Tree::new(&samples).unwrap();
            for j in 0..300 {
                let q = query(j);
                let four = tree.four(q);
                assert_eq!(four.kept, 4);
                assert_eq!(four.c.to_vec(), four_by_scan(&samples, q), "point {j}");
            }
        }
        assert!(Tree::new(&[DVec3::new(f64::NAN, 0.0, 0.0)]).is_none());
    }

    #[test]
    fn the_slab_scan_finds_the_four_a_scan_of_all_finds() {
        let samples = lattice();
        let slab = Slab::new(&samples);
        assert_eq!(slab.axis, 2);
        for j in 0..200 {
            let q = query(j);
            let four = slab.four(q);
            assert_eq!(four.kept, 4);
            assert_eq!(four.c.to_vec(), four_by_scan(&samples, q), "point {j}");
        }
    }

    #[test]
    fn a_plane_is_measured_exactly_by_the_coarse_search() {
        // Points at height 0.01 above a plane: every distance is 0.01.
        let g = grid(0.0);
        let points: Vec<DVec3> = (0..50)
            .map(|k| {
                let (a, b) = ((k % 7) as f64 / 7.0 + 0.03, (k / 7) as f64 / 8.0 + 0.02);
                g.eval(a, b) + DVec3::Z * 0.01
            })
            .collect();
        let check = projection_check(&g, &points, 0.01, 0.01);
        assert!(check.agrees, "{check:?}");
        assert!(
            (check.rms - 0.01).abs() < 1e-12 && (check.max - 0.01).abs() < 1e-12,
            "{check:?}"
        );
    }

    #[test]
    fn distances_smaller_than_the_coarse_search_finds_do_not_agree() {
        // Claimed offsets of zero for points 0.01 off the surface: the check must refuse them,
        // since the coarse search can only find distances at least the true ones.
        let g = grid(0.3);
        let points: Vec<DVec3> = (0..20)
            .map(|k| g.eval(k as f64 / 20.0, 0.5) + DVec3::Z * 0.01)
            .collect();
        let check = projection_check(&g, &points, 0.0, 0.0);
        assert!(!check.agrees, "{check:?}");
        assert!(check.max > 0.005, "{check:?}");
    }
}
