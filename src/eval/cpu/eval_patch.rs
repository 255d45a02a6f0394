//! CPU mirror of `shaders/eval_patch.wgsl`: squared offsets of one group of target points for
//! one block of `LANES` individuals.
//!
//! Each lane of a [`Lanes`] array is one shader invocation; every step below is the shader's,
//! in the same order and with the same multiply-adds (`A::fma`, see [`Arith`]), applied to all
//! lanes at once. Where a loop order differs from the shader's (coordinates outermost), every
//! sum still adds its terms in the shader's order, so with [`Unfused`](super::Unfused)
//! arithmetic each lane's result is the shader's on lavapipe to the bit. The shader's private
//! `cp[(a * NV + b) * DIM + c]` (the held patch, per invocation) is `cp[a * NV + b][c][lane]`
//! here: one [`Point`] per control point, so that every coordinate index is a constant below
//! 3 and the hot loops carry no bounds checks.
//!
//! The SIMD paths run the fixed-parameter loop in [`super::fixed`] instead (the same sums,
//! fused) and the Newton steps here, fused.

use super::{Arith, Lanes, Point, LANES};
use crate::eval::basis::{basis_lanes, bernstein_lanes, BasisWork, LaneBasis};
use crate::eval::kernel::{Config, Partial, RefJet, Target, NONE};

/// The shader's `SINGULAR`.
const SINGULAR: f32 = 1e-6;
/// The shader's `SAME_FOOT`.
const SAME_FOOT: f32 = 1e-3;

/// The points `first..last` of the group `group` of `config`.
#[inline(always)]
pub(crate) fn group_range(config: &Config, group: usize) -> (usize, usize) {
    let first = group * config.group_points as usize;
    (
        first,
        (first + config.group_points as usize).min(config.n_points as usize),
    )
}

/// The end of the run of targets on `targets[p]`'s patch, before `last`.
#[inline(always)]
pub(crate) fn run_end(targets: &[Target], p: usize, last: usize) -> usize {
    let run = targets[p].patch_id;
    let mut end = p + 1;
    while end < last && targets[end].patch_id == run {
        end += 1;
    }
    end
}

/// Net row and column of control point `(a, b)` of patch `patch`: `r` in the shader.
#[inline(always)]
pub(crate) fn net_index(config: &Config, patch: u32, a: usize, b: usize) -> usize {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let i = (patch / config.patches_v) as usize;
    let j = patch as usize - i * config.patches_v as usize;
    (i * du + a) * config.net_cols as usize + j * dv + b
}

/// Write the block's sums and maxima as its partials.
#[inline(always)]
pub(crate) fn store(sum: &Lanes, worst: &Lanes, partials: &mut [Partial; LANES]) {
    for (p, (s, w)) in partials.iter_mut().zip(sum.iter().zip(worst)) {
        *p = Partial {
            sum_sq: *s,
            max_sq: *w,
        };
    }
}

/// The block's inputs the kernels read: the shader's bindings (the net is the block's).
pub(crate) struct Bindings<'a> {
    pub config: &'a Config,
    pub targets: &'a [Target],
    pub breaks: &'a [f32],
    pub net: &'a [Lanes],
    pub weights: &'a [f32],
    pub jets: &'a [RefJet],
}

/// The control points of patch `patch`: `(slot in the patch, row of the net)` for each, in
/// the shader's `load_patch` order.
#[inline(always)]
fn patch_rows(config: &Config, patch: u32) -> impl Iterator<Item = (usize, usize)> + '_ {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    (0..du + 1)
        .flat_map(move |a| (0..dv + 1).map(move |b| (a * (dv + 1) + b, net_index(config, patch, a, b))))
}

/// `load_patch` for every lane at once (the start of a run, where all lanes agree).
#[inline(always)]
fn load_patch(config: &Config, net: &[Lanes], patch: u32, cp: &mut [Point], held: &mut [u32; LANES]) {
    *held = [patch; LANES];
    let dim = config.dim as usize;
    for (slot, r) in patch_rows(config, patch) {
        cp[slot][..dim].copy_from_slice(&net[r * dim..(r + 1) * dim]);
    }
}

/// `load_patch` for one lane (Newton steps crossing borders, where lanes part ways).
#[inline(always)]
fn load_patch_lane(config: &Config, net: &[Lanes], patch: u32, lane: usize, cp: &mut [Point]) {
    let dim = config.dim as usize;
    for (slot, r) in patch_rows(config, patch) {
        for c in 0..dim {
            cp[slot][c][lane] = net[r * dim + c][lane];
        }
    }
}

/// Per-lane sums and maxima of squared offsets.
struct Totals {
    sum: Lanes,
    worst: Lanes,
}

impl Totals {
    /// Add one point's squared offsets, lane by lane.
    #[inline(always)]
    fn add(&mut self, e2: &Lanes) {
        for l in 0..LANES {
            self.sum[l] += e2[l];
            self.worst[l] = self.worst[l].max(e2[l]);
        }
    }
}

/// The shader's walk over point group `group`: run by run of points on one patch, that patch
/// loaded into `cp` for every lane, then `score(p, end, cp, held, totals)` adds the run's
/// points `p..end` in order; the totals become the block's partials. Callers mark `score`
/// `#[inline(always)]` (see `fixed`).
#[inline(always)]
fn over_runs(
    b: &Bindings<'_>,
    group: usize,
    cp: &mut [Point],
    partials: &mut [Partial; LANES],
    mut score: impl FnMut(usize, usize, &mut [Point], &mut [u32; LANES], &mut Totals),
) {
    let (first, last) = group_range(b.config, group);
    let mut totals = Totals {
        sum: [0.0; LANES],
        worst: [0.0; LANES],
    };
    let mut held = [NONE; LANES];
    let mut p = first;
    while p < last {
        let end = run_end(b.targets, p, last);
        load_patch(b.config, b.net, b.targets[p].patch_id, cp, &mut held);
        score(p, end, cp, &mut held, &mut totals);
        p = end;
    }
    store(&totals.sum, &totals.worst, partials);
}

/// `main` with `newton == 0` for point group `group`: `offset_sq_fixed` over every point,
/// all lanes at once.
#[inline(always)]
pub(crate) fn fixed<A: Arith, const DIM: usize>(
    b: &Bindings<'_>,
    group: usize,
    cp: &mut [Point],
    partials: &mut [Partial; LANES],
) {
    let config = b.config;
    let ncp = (config.degree_u as usize + 1) * (config.degree_v as usize + 1);
    // The closures are inlined too: a closure compiled on its own would not take the
    // caller's target features, and `A::fma` would become a call into libm's `fmaf`.
    over_runs(
        b,
        group,
        cp,
        partials,
        #[inline(always)]
        |p, end, cp, _, totals| {
            for (t, w) in b.targets[p..end]
                .iter()
                .zip(b.weights[p * ncp..end * ncp].chunks_exact(ncp))
            {
                let r0 = [t.rx, t.ry, t.rz];
                // Coordinates one after the other: one accumulator in registers; each still adds
                // its terms in the shader's order.
                let mut s = [[0.0f32; LANES]; DIM];
                for (c, sc) in s.iter_mut().enumerate() {
                    let mut acc = [r0[c]; LANES];
                    for (&wk, q) in w.iter().zip(&cp[..ncp]) {
                        for l in 0..LANES {
                            acc[l] = A::fma(wk, q[c][l], acc[l]);
                        }
                    }
                    *sc = acc;
                }
                let mut e2 = [0.0f32; LANES];
                for (l, e) in e2.iter_mut().enumerate() {
                    for sc in &s {
                        *e = A::fma(sc[l], sc[l], *e);
                    }
                }
                totals.add(&e2);
            }
        },
    );
}

/// `main` with `newton >= 1` for point group `group`: `foot_point_sq` over every point.
#[inline(always)]
pub(crate) fn newton<A: Arith, const DIM: usize>(
    b: &Bindings<'_>,
    group: usize,
    cp: &mut [Point],
    work: &mut NewtonWork,
    partials: &mut [Partial; LANES],
) {
    over_runs(
        b,
        group,
        cp,
        partials,
        #[inline(always)]
        |p, end, cp, held, totals| {
            for q in p..end {
                totals.add(&foot_point_sq::<A, DIM>(b, q, cp, held, work));
            }
        },
    );
}

/// `offset_sq`: the squared length of `base` plus the held patch at per-lane (u, v).
#[inline(always)]
fn offset_sq<A: Arith, const DIM: usize>(
    config: &Config,
    u: &Lanes,
    v: &Lanes,
    base: &Point,
    cp: &[Point],
) -> Lanes {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let bu = bernstein_lanes::<A>(du, u);
    let bv = bernstein_lanes::<A>(dv, v);
    let mut s = *base;
    for a in 0..du + 1 {
        for b in 0..dv + 1 {
            let p = &cp[a * (dv + 1) + b];
            for l in 0..LANES {
                let w = bu[a][l] * bv[b][l];
                for c in 0..DIM {
                    s[c][l] = A::fma(w, p[c][l], s[c][l]);
                }
            }
        }
    }
    let mut e2 = [0.0f32; LANES];
    for c in 0..DIM {
        for l in 0..LANES {
            e2[l] = A::fma(s[c][l], s[c][l], e2[l]);
        }
    }
    e2
}

/// `Jet`: a point with its first and second partials, per coordinate (the first DIM used)
/// and lane.
#[derive(Clone, Debug)]
struct LaneJet {
    s: Point,
    su: Point,
    sv: Point,
    suu: Point,
    suv: Point,
    svv: Point,
}

/// The Newton path's function-scope arrays (the basis work, the two bases and the jet), kept
/// per task.
#[derive(Clone, Debug)]
pub(crate) struct NewtonWork {
    basis: BasisWork,
    bu: LaneBasis,
    bv: LaneBasis,
    jet: LaneJet,
}

impl Default for NewtonWork {
    fn default() -> Self {
        let zero = [[0.0; LANES]; 3];
        NewtonWork {
            basis: BasisWork::default(),
            bu: LaneBasis::default(),
            bv: LaneBasis::default(),
            jet: LaneJet {
                s: zero,
                su: zero,
                sv: zero,
                suu: zero,
                suv: zero,
                svv: zero,
            },
        }
    }
}

/// `jet`: the held patch and its partials at per-lane local (u, v), into `work.jet`.
#[inline(always)]
fn jet<A: Arith, const DIM: usize>(
    config: &Config,
    u: &Lanes,
    v: &Lanes,
    cp: &[Point],
    work: &mut NewtonWork,
) {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let NewtonWork {
        basis,
        bu,
        bv,
        jet: out,
    } = work;
    basis_lanes::<A>(du, u, basis, bu);
    basis_lanes::<A>(dv, v, basis, bv);
    // The shader's loops with the coordinate loop outermost: every sum still runs over b, then
    // over a, in the shader's order, and the six sums of a coordinate stay in registers.
    for c in 0..DIM {
        let mut acc = [[0.0f32; LANES]; 6];
        for a in 0..du + 1 {
            let mut r0 = [0.0f32; LANES];
            let mut r1 = [0.0f32; LANES];
            let mut r2 = [0.0f32; LANES];
            for b in 0..dv + 1 {
                let p = &cp[a * (dv + 1) + b][c];
                for l in 0..LANES {
                    r0[l] = A::fma(bv.b[b][l], p[l], r0[l]);
                    r1[l] = A::fma(bv.d1[b][l], p[l], r1[l]);
                    r2[l] = A::fma(bv.d2[b][l], p[l], r2[l]);
                }
            }
            for l in 0..LANES {
                acc[0][l] = A::fma(bu.b[a][l], r0[l], acc[0][l]);
                acc[1][l] = A::fma(bu.d1[a][l], r0[l], acc[1][l]);
                acc[2][l] = A::fma(bu.d2[a][l], r0[l], acc[2][l]);
                acc[3][l] = A::fma(bu.b[a][l], r1[l], acc[3][l]);
                acc[4][l] = A::fma(bu.d1[a][l], r1[l], acc[4][l]);
                acc[5][l] = A::fma(bu.b[a][l], r2[l], acc[5][l]);
            }
        }
        out.s[c] = acc[0];
        out.su[c] = acc[1];
        out.suu[c] = acc[2];
        out.sv[c] = acc[3];
        out.suv[c] = acc[4];
        out.svv[c] = acc[5];
    }
}

/// `Taylor`: the reference's Taylor polynomial at per-lane displacement `(du, dv)`.
struct LaneTaylor {
    val: Point,
    du: Point,
    dv: Point,
}

/// `taylor` for every lane.
#[inline(always)]
fn taylor<A: Arith, const DIM: usize>(rj: &RefJet, t: &Target, du: &Lanes, dv: &Lanes) -> LaneTaylor {
    let r0 = [t.rx, t.ry, t.rz];
    let zero = [[0.0f32; LANES]; 3];
    let mut out = LaneTaylor {
        val: zero,
        du: zero,
        dv: zero,
    };
    for c in 0..DIM {
        for l in 0..LANES {
            let tu = A::fma(rj.suu[c], du[l], A::fma(rj.suv[c], dv[l], rj.su[c]));
            let tv = A::fma(rj.suv[c], du[l], A::fma(rj.svv[c], dv[l], rj.sv[c]));
            out.val[c][l] = A::fma(
                0.5 * du[l],
                tu + rj.su[c],
                A::fma(0.5 * dv[l], tv + rj.sv[c], r0[c]),
            );
            out.du[c][l] = tu;
            out.dv[c][l] = tv;
        }
    }
    out
}

/// `locate`: the segment of a chain (breaks from `breaks[first]`, `count` segments) holding
/// global g, and the local parameter in it.
#[inline(always)]
fn locate(breaks: &[f32], first: usize, count: usize, g: f32) -> (usize, f32) {
    let mut m = 0;
    for i in 1..count {
        if g >= breaks[first + i] {
            m = i;
        }
    }
    let b0 = breaks[first + m];
    (m, clamp((g - b0) / (breaks[first + m + 1] - b0), 0.0, 1.0))
}

/// WGSL's `clamp(x, lo, hi)`: `min(max(x, lo), hi)`.
#[inline(always)]
fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    x.max(lo).min(hi)
}

/// `dot_n` for every lane.
#[inline(always)]
fn dot<A: Arith, const DIM: usize>(x: &Point, y: &Point) -> Lanes {
    let mut acc = [0.0f32; LANES];
    for c in 0..DIM {
        for l in 0..LANES {
            acc[l] = A::fma(x[c][l], y[c][l], acc[l]);
        }
    }
    acc
}

/// The Newton step of `foot_point_sq` from the gradient `(gu, gv)`, the Gauss-Newton matrix
/// `g..` and the Hessian `h..`: the shader's three branches, with the 2x2 solve written once
/// over the chosen matrix (the same operations as each branch, so the same result).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn newton_step(gu: f32, gv: f32, guu: f32, guv: f32, gvv: f32, huu: f32, huv: f32, hvv: f32) -> (f32, f32) {
    let det = huu * hvv - huv * huv;
    let gdet = guu * gvv - guv * guv;
    let full = huu > 0.0 && det > SINGULAR * huu * hvv;
    let gauss = guu > 0.0 && gdet > SINGULAR * guu * gvv;
    let (d, a, b, c) = if full {
        (det, huu, huv, hvv)
    } else {
        (gdet, guu, guv, gvv)
    };
    let pair = ((b * gv - c * gu) / d, (b * gu - a * gv) / d);
    let cu = if huu > 0.0 { huu } else { guu };
    let cv = if hvv > 0.0 { hvv } else { gvv };
    let single = (
        if cu > 0.0 { -gu / cu } else { 0.0 },
        if cv > 0.0 { -gv / cv } else { 0.0 },
    );
    if full || gauss {
        pair
    } else {
        single
    }
}

/// `Frame`: the frame of a target's foot-point search.
struct Frame {
    i0: usize,
    j0: usize,
    fv: usize,
    h0u: f32,
    h0v: f32,
    lo_u: f32,
    hi_u: f32,
    lo_v: f32,
    hi_v: f32,
}

/// `frame_of`.
#[inline(always)]
fn frame_of(config: &Config, breaks: &[f32], t: &Target) -> Frame {
    let pv = config.patches_v;
    let i0 = (t.patch_id / pv) as usize;
    let j0 = (t.patch_id - i0 as u32 * pv) as usize;
    let fv = config.patches_u as usize + 1;
    let (mut h0u, mut h0v) = (1.0f32, 1.0f32);
    let (mut lo_u, mut hi_u, mut lo_v, mut hi_v) = (-t.u, 1.0 - t.u, -t.v, 1.0 - t.v);
    if config.cross != 0 {
        h0u = breaks[i0 + 1] - breaks[i0];
        h0v = breaks[fv + j0 + 1] - breaks[fv + j0];
        lo_u = -(t.u + breaks[i0] / h0u);
        hi_u = (1.0 - breaks[i0]) / h0u - t.u;
        lo_v = -(t.v + breaks[fv + j0] / h0v);
        hi_v = (1.0 - breaks[fv + j0]) / h0v - t.v;
    }
    Frame {
        i0,
        j0,
        fv,
        h0u,
        h0v,
        lo_u: lo_u.max(-t.reach_u),
        hi_u: hi_u.min(t.reach_u),
        lo_v: lo_v.max(-t.reach_v),
        hi_v: hi_v.min(t.reach_v),
    }
}

/// `Seed` for every lane: where a descent starts.
struct Seed {
    du: Lanes,
    dv: Lanes,
    u: Lanes,
    v: Lanes,
    ku: Lanes,
    kv: Lanes,
}

impl Seed {
    /// The start parameters, on the start patch.
    fn start(t: &Target) -> Self {
        Seed {
            du: [0.0; LANES],
            dv: [0.0; LANES],
            u: [t.u; LANES],
            v: [t.v; LANES],
            ku: [1.0; LANES],
            kv: [1.0; LANES],
        }
    }
}

/// One target's foot-point search over every lane: the bindings, the target `p`, the held
/// control points and the Newton step's work arrays.
struct Search<'s, 'b> {
    bind: &'s Bindings<'b>,
    p: usize,
    cp: &'s mut [Point],
    held: &'s mut [u32; LANES],
    work: &'s mut NewtonWork,
}

/// `Cand`: a candidate start of one lane.
#[derive(Clone, Copy)]
struct Cand {
    e2: f32,
    du: f32,
    dv: f32,
    u: f32,
    v: f32,
    ku: f32,
    kv: f32,
    patch: u32,
}

/// `Pick`: one lane's two best local minima so far and its last candidate.
#[derive(Clone, Copy)]
struct Pick {
    first: Cand,
    second: Cand,
    last: Cand,
    down: bool,
}

impl Pick {
    /// `offer`.
    #[inline(always)]
    fn offer(&mut self, c: Cand) {
        if c.e2 < self.first.e2 {
            self.second = self.first;
            self.first = c;
        } else if c.e2 < self.second.e2 {
            self.second = c;
        }
    }

    /// `step_pick`.
    #[inline(always)]
    fn step(&mut self, c: Cand, fresh: bool) {
        if self.down && (fresh || self.last.e2 <= c.e2) {
            self.offer(self.last);
        }
        self.down = fresh || c.e2 < self.last.e2;
        self.last = c;
    }
}

/// `seed` for every lane: the candidates are the same for all lanes (loaded for all at
/// once), the minima per lane.
#[inline(always)]
#[allow(clippy::manual_range_contains)] // the shader's test
fn seed<A: Arith, const DIM: usize>(s: &mut Search<'_, '_>, f: &Frame) -> [Pick; LANES] {
    let (bind, p, cp, held) = (s.bind, s.p, &mut *s.cp, &mut *s.held);
    let (config, breaks, net) = (bind.config, bind.breaks, bind.net);
    let (t, rj) = (&bind.targets[p], &bind.jets[p]);
    let none = Cand {
        e2: 3.0e38,
        du: 0.0,
        dv: 0.0,
        u: t.u,
        v: t.v,
        ku: 1.0,
        kv: 1.0,
        patch: t.patch_id,
    };
    let mut pick = [Pick {
        first: none,
        second: none,
        last: none,
        down: false,
    }; LANES];
    let ring = if config.cross != 0 {
        config.seed_ring as usize
    } else {
        0
    };
    let (pu, pv) = (config.patches_u as usize, config.patches_v as usize);
    let (i_lo, i_hi) = (f.i0 - f.i0.min(ring), (f.i0 + ring).min(pu - 1));
    let (j_lo, j_hi) = (f.j0 - f.j0.min(ring), (f.j0 + ring).min(pv - 1));
    let n = config.seeds as f32;
    let curve = config.degree_v == 0;
    let nv = if curve { 1 } else { config.seeds + 1 };
    let mut first = true;
    for i in i_lo..=i_hi {
        let hu = breaks[i + 1] - breaks[i];
        for j in j_lo..=j_hi {
            let hv = breaks[f.fv + j + 1] - breaks[f.fv + j];
            let here = (i * pv + j) as u32;
            load_patch(config, net, here, cp, held);
            for a in 0..=config.seeds {
                let uc = a as f32 / n;
                let (mut du, mut ku) = (uc - t.u, 1.0f32);
                if i != f.i0 {
                    du = (A::fma(uc, hu, breaks[i]) - breaks[f.i0]) / f.h0u - t.u;
                    ku = f.h0u / hu;
                }
                for b in 0..nv {
                    let (mut vc, mut dv, mut kv) = (t.v, 0.0f32, 1.0f32);
                    if !curve {
                        vc = b as f32 / n;
                        dv = vc - t.v;
                        if j != f.j0 {
                            dv = (A::fma(vc, hv, breaks[f.fv + j]) - breaks[f.fv + f.j0]) / f.h0v - t.v;
                            kv = f.h0v / hv;
                        }
                    }
                    let inside = du >= f.lo_u && du <= f.hi_u && dv >= f.lo_v && dv <= f.hi_v;
                    if !inside {
                        continue;
                    }
                    let base = taylor::<A, DIM>(rj, t, &[du; LANES], &[dv; LANES]).val;
                    let e2 = offset_sq::<A, DIM>(config, &[uc; LANES], &[vc; LANES], &base, cp);
                    let fresh = first || (!curve && b == 0);
                    for l in 0..LANES {
                        let c = Cand {
                            e2: e2[l],
                            du,
                            dv,
                            u: uc,
                            v: vc,
                            ku,
                            kv,
                            patch: here,
                        };
                        pick[l].step(c, fresh);
                    }
                    first = false;
                }
            }
        }
    }
    for pl in &mut pick {
        if pl.down {
            pl.offer(pl.last);
        }
    }
    pick
}

/// `descend_from` for every lane: each lane's candidate held first.
#[inline(always)]
fn descend_from<A: Arith, const DIM: usize>(
    s: &mut Search<'_, '_>,
    f: &Frame,
    cands: [Cand; LANES],
) -> [Lanes; 3] {
    let mut start = Seed::start(&s.bind.targets[s.p]);
    for (l, c) in cands.iter().enumerate() {
        if s.held[l] != c.patch {
            s.held[l] = c.patch;
            load_patch_lane(s.bind.config, s.bind.net, c.patch, l, s.cp);
        }
        start.du[l] = c.du;
        start.dv[l] = c.dv;
        start.u[l] = c.u;
        start.v[l] = c.v;
        start.ku[l] = c.ku;
        start.kv[l] = c.kv;
    }
    descend::<A, DIM>(s, f, start)
}

/// `descend` for every lane: the least squared offset met in `config.newton` (at least 1)
/// Newton steps from `s`.
#[inline(always)]
#[allow(clippy::manual_range_contains)] // the shader's test, which lets NaN through
fn descend<A: Arith, const DIM: usize>(search: &mut Search<'_, '_>, f: &Frame, s: Seed) -> [Lanes; 3] {
    let (bind, p) = (search.bind, search.p);
    let (cp, held, work) = (&mut *search.cp, &mut *search.held, &mut *search.work);
    let (config, breaks, net) = (bind.config, bind.breaks, bind.net);
    let (t, rj) = (&bind.targets[p], &bind.jets[p]);
    let pv = config.patches_v;
    let (pu_count, pv_count) = (config.patches_u as usize, config.patches_v as usize);
    let cross = config.cross != 0;
    let Seed {
        mut du,
        mut dv,
        mut u,
        mut v,
        mut ku,
        mut kv,
    } = s;
    let mut best = [3.0e38f32; LANES];
    let mut it = 0;
    loop {
        jet::<A, DIM>(config, &u, &v, cp, work);
        let tp = taylor::<A, DIM>(rj, t, &du, &dv);
        let e = &work.jet;
        let zero = [[0.0f32; LANES]; 3];
        let (mut r, mut su, mut sv, mut suu, mut suv, mut svv) = (zero, zero, zero, zero, zero, zero);
        for c in 0..DIM {
            for l in 0..LANES {
                r[c][l] = tp.val[c][l] + e.s[c][l];
                su[c][l] = A::fma(ku[l], e.su[c][l], tp.du[c][l]);
                sv[c][l] = A::fma(kv[l], e.sv[c][l], tp.dv[c][l]);
                suu[c][l] = A::fma(ku[l] * ku[l], e.suu[c][l], rj.suu[c]);
                suv[c][l] = A::fma(ku[l] * kv[l], e.suv[c][l], rj.suv[c]);
                svv[c][l] = A::fma(kv[l] * kv[l], e.svv[c][l], rj.svv[c]);
            }
        }
        let rr = dot::<A, DIM>(&r, &r);
        let gu = dot::<A, DIM>(&r, &su);
        let gv = dot::<A, DIM>(&r, &sv);
        let guu = dot::<A, DIM>(&su, &su);
        let guv = dot::<A, DIM>(&su, &sv);
        let gvv = dot::<A, DIM>(&sv, &sv);
        let ruu = dot::<A, DIM>(&r, &suu);
        let ruv = dot::<A, DIM>(&r, &suv);
        let rvv = dot::<A, DIM>(&r, &svv);
        for l in 0..LANES {
            best[l] = best[l].min(rr[l]);
            let (huu, huv, hvv) = (guu[l] + ruu[l], guv[l] + ruv[l], gvv[l] + rvv[l]);
            let (step_u, step_v) = newton_step(gu[l], gv[l], guu[l], guv[l], gvv[l], huu, huv, hvv);
            du[l] = clamp(du[l] + step_u, f.lo_u, f.hi_u);
            dv[l] = clamp(dv[l] + step_v, f.lo_v, f.hi_v);
        }
        if !cross {
            for l in 0..LANES {
                u[l] = clamp(t.u + du[l], 0.0, 1.0);
                v[l] = clamp(t.v + dv[l], 0.0, 1.0);
            }
        } else {
            for l in 0..LANES {
                let (wu, wv) = (t.u + du[l], t.v + dv[l]);
                let (mut i, mut j) = (f.i0, f.j0);
                u[l] = wu;
                v[l] = wv;
                ku[l] = 1.0;
                kv[l] = 1.0;
                if wu < 0.0 || wu > 1.0 {
                    let g = clamp(A::fma(wu, f.h0u, breaks[f.i0]), 0.0, 1.0);
                    (i, u[l]) = locate(breaks, 0, pu_count, g);
                    ku[l] = f.h0u / (breaks[i + 1] - breaks[i]);
                }
                if wv < 0.0 || wv > 1.0 {
                    let g = clamp(A::fma(wv, f.h0v, breaks[f.fv + f.j0]), 0.0, 1.0);
                    (j, v[l]) = locate(breaks, f.fv, pv_count, g);
                    kv[l] = f.h0v / (breaks[f.fv + j + 1] - breaks[f.fv + j]);
                }
                let moved = i as u32 * pv + j as u32;
                if moved != held[l] {
                    held[l] = moved;
                    load_patch_lane(config, net, moved, l, cp);
                }
            }
        }
        it += 1;
        if it >= config.newton {
            break;
        }
    }
    let base = taylor::<A, DIM>(rj, t, &du, &dv).val;
    let e2 = offset_sq::<A, DIM>(config, &u, &v, &base, cp);
    for l in 0..LANES {
        best[l] = best[l].min(e2[l]);
    }
    [best, du, dv]
}

/// `foot_point_sq` for every lane: a descent from target `p`'s start parameters and, with
/// `config.seeds`, from each lane's two candidate starts; the start patch held after.
#[inline(always)]
fn foot_point_sq<A: Arith, const DIM: usize>(
    bind: &Bindings<'_>,
    p: usize,
    cp: &mut [Point],
    held: &mut [u32; LANES],
    work: &mut NewtonWork,
) -> Lanes {
    let (config, net) = (bind.config, bind.net);
    let t = &bind.targets[p];
    let f = frame_of(config, bind.breaks, t);
    let mut s = Search {
        bind,
        p,
        cp,
        held,
        work,
    };
    let start = descend::<A, DIM>(&mut s, &f, Seed::start(t));
    let mut e2 = start[0];
    if config.seeds != 0 {
        let pick = seed::<A, DIM>(&mut s, &f);
        let a = descend_from::<A, DIM>(&mut s, &f, pick.map(|p| p.first));
        let b = descend_from::<A, DIM>(&mut s, &f, pick.map(|p| p.second));
        for l in 0..LANES {
            let o = if b[0][l] < a[0][l] { &b } else { &a };
            let apart = (o[1][l] - start[1][l]).abs() + (o[2][l] - start[2][l]).abs() > SAME_FOOT;
            if apart && o[0][l] < e2[l] {
                e2[l] = o[0][l];
            }
        }
    }
    if config.cross != 0 {
        for l in 0..LANES {
            if s.held[l] != t.patch_id {
                s.held[l] = t.patch_id;
                load_patch_lane(config, net, t.patch_id, l, s.cp);
            }
        }
    }
    e2
}
