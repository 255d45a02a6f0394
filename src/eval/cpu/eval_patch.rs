//! CPU mirror of `shaders/eval_patch.wgsl`: squared offsets of one group of target points for
//! one block of `LANES` individuals.
//!
//! Each lane of a [`Lanes`] array is one shader invocation; every step below is the shader's,
//! in the same order and with the same multiply-adds ([`fma`]), applied to all lanes at once.
//! Where a loop order differs from the shader's (coordinates outermost), every sum still adds
//! its terms in the shader's order, so each lane's result is the shader's to the bit. The shader's private `cp[(a * NV + b) * DIM + c]` (the held patch, per
//! invocation) is `cp[a * NV + b][c][lane]` here: one [`Point`] per control point, so that
//! every coordinate index is a constant below 3 and the hot loops carry no bounds checks.

use super::{fma, Lanes, Point, LANES};
use crate::eval::kernel::{Config, Partial, Target, MAX_DEGREE, NONE};

/// Basis arrays hold up to this many values (degree `MAX_DEGREE`).
pub(crate) const NB: usize = MAX_DEGREE + 1;
/// The shader's `SINGULAR`.
const SINGULAR: f32 = 1e-6;

/// `eval_patch.wgsl` `main` for point group `group` and the block whose expanded nets are in
/// `net` (`net[r * DIM + c][lane]`); writes the block's partials for that group.
#[inline(always)]
#[allow(clippy::too_many_arguments)] // the shader's bindings and private arrays
pub(crate) fn eval_patch<const DIM: usize>(
    config: &Config,
    targets: &[Target],
    breaks: &[f32],
    net: &[Lanes],
    group: usize,
    cp: &mut [Point],
    work: &mut NewtonWork,
    partials: &mut [Partial; LANES],
) {
    let first = group * config.group_points as usize;
    let last = (first + config.group_points as usize).min(config.n_points as usize);
    let mut sum = [0.0f32; LANES];
    let mut worst = [0.0f32; LANES];
    // One outer iteration per run of points on one patch, as in the shader.
    let mut held = [NONE; LANES];
    let mut p = first;
    if config.newton == 0 {
        while p < last {
            let run = targets[p].patch_id;
            load_patch(config, net, run, cp, &mut held);
            while p < last {
                let t = &targets[p];
                if t.patch_id != run {
                    break;
                }
                offset_sq_fixed::<DIM>(config, t, cp, &mut sum, &mut worst);
                p += 1;
            }
        }
    } else {
        while p < last {
            let run = targets[p].patch_id;
            load_patch(config, net, run, cp, &mut held);
            while p < last {
                let t = &targets[p];
                if t.patch_id != run {
                    break;
                }
                let e2 = foot_point_sq::<DIM>(config, breaks, net, t, cp, &mut held, work);
                for l in 0..LANES {
                    sum[l] += e2[l];
                    worst[l] = worst[l].max(e2[l]);
                }
                p += 1;
            }
        }
    }
    for (p, (s, w)) in partials.iter_mut().zip(sum.iter().zip(&worst)) {
        *p = Partial {
            sum_sq: *s,
            max_sq: *w,
        };
    }
}

/// Net row and column of control point `(a, b)` of patch `patch`: `r` in the shader.
#[inline(always)]
fn net_index(config: &Config, patch: u32, a: usize, b: usize) -> usize {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let i = (patch / config.patches_v) as usize;
    let j = patch as usize - i * config.patches_v as usize;
    (i * du + a) * config.net_cols as usize + j * dv + b
}

/// `load_patch` for every lane at once (the start of a run, where all lanes agree).
#[inline(always)]
fn load_patch(config: &Config, net: &[Lanes], patch: u32, cp: &mut [Point], held: &mut [u32; LANES]) {
    *held = [patch; LANES];
    let (du, dv, dim) = (
        config.degree_u as usize,
        config.degree_v as usize,
        config.dim as usize,
    );
    for a in 0..du + 1 {
        for b in 0..dv + 1 {
            let r = net_index(config, patch, a, b);
            cp[a * (dv + 1) + b][..dim].copy_from_slice(&net[r * dim..(r + 1) * dim]);
        }
    }
}

/// `load_patch` for one lane (Newton steps crossing borders, where lanes part ways).
#[inline(always)]
fn load_patch_lane(config: &Config, net: &[Lanes], patch: u32, lane: usize, cp: &mut [Point]) {
    let (du, dv, dim) = (
        config.degree_u as usize,
        config.degree_v as usize,
        config.dim as usize,
    );
    for a in 0..du + 1 {
        for b in 0..dv + 1 {
            let r = net_index(config, patch, a, b);
            for c in 0..dim {
                cp[a * (dv + 1) + b][c][lane] = net[r * dim + c][lane];
            }
        }
    }
}

/// `bernstein`: the degree-n Bernstein polynomials at t.
#[inline(always)]
pub(crate) fn bernstein(n: usize, t: f32) -> [f32; NB] {
    let mut out = [0.0f32; NB];
    out[0] = 1.0;
    let s = 1.0 - t;
    for j in 1..n + 1 {
        let mut saved = 0.0f32;
        for k in 0..j {
            let tmp = out[k];
            out[k] = fma(s, tmp, saved);
            saved = t * tmp;
        }
        out[j] = saved;
    }
    out
}

/// `offset_sq` with uniform parameters, for every lane; adds into `sum` and `worst` as the
/// shader's point loop does.
#[inline(always)]
fn offset_sq_fixed<const DIM: usize>(
    config: &Config,
    t: &Target,
    cp: &[Point],
    sum: &mut Lanes,
    worst: &mut Lanes,
) {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let bu = bernstein(du, t.u);
    let bv = bernstein(dv, t.v);
    // The shader's weights bu[a] * bv[b] in its (a, b) order, computed once for all lanes.
    let mut w = [0.0f32; NB * NB];
    for a in 0..du + 1 {
        for b in 0..dv + 1 {
            w[a * (dv + 1) + b] = bu[a] * bv[b];
        }
    }
    let ncp = (du + 1) * (dv + 1);
    // Each coordinate accumulates over the control points in the shader's order; running the
    // coordinates one after the other keeps a single accumulator in registers.
    let mut s = [[0.0f32; LANES]; DIM];
    for (c, sc) in s.iter_mut().enumerate() {
        let mut acc = [0.0f32; LANES];
        for (&wk, p) in w[..ncp].iter().zip(&cp[..ncp]) {
            for l in 0..LANES {
                acc[l] = fma(wk, p[c][l], acc[l]);
            }
        }
        *sc = acc;
    }
    let q = [t.x, t.y, t.z];
    for l in 0..LANES {
        let mut e2 = 0.0f32;
        for c in 0..DIM {
            let d = s[c][l] - q[c];
            e2 = fma(d, d, e2);
        }
        sum[l] += e2;
        worst[l] = worst[l].max(e2);
    }
}

/// `bernstein` with per-lane t.
#[inline(always)]
fn bernstein_lanes(n: usize, t: &Lanes) -> [Lanes; NB] {
    let mut out = [[0.0f32; LANES]; NB];
    out[0] = [1.0; LANES];
    let s = t.map(|x| 1.0 - x);
    for j in 1..n + 1 {
        let mut saved = [0.0f32; LANES];
        for k in 0..j {
            for l in 0..LANES {
                let tmp = out[k][l];
                out[k][l] = fma(s[l], tmp, saved[l]);
                saved[l] = t[l] * tmp;
            }
        }
        out[j] = saved;
    }
    out
}

/// `offset_sq` with per-lane parameters.
#[inline(always)]
fn offset_sq_lanes<const DIM: usize>(
    config: &Config,
    u: &Lanes,
    v: &Lanes,
    q: [f32; 3],
    cp: &[Point],
) -> Lanes {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let bu = bernstein_lanes(du, u);
    let bv = bernstein_lanes(dv, v);
    let mut e2 = [0.0f32; LANES];
    for c in 0..DIM {
        let mut s = [0.0f32; LANES];
        for a in 0..du + 1 {
            for b in 0..dv + 1 {
                let p = &cp[a * (dv + 1) + b][c];
                for l in 0..LANES {
                    s[l] = fma(bu[a][l] * bv[b][l], p[l], s[l]);
                }
            }
        }
        for l in 0..LANES {
            let d = s[l] - q[c];
            e2[l] = fma(d, d, e2[l]);
        }
    }
    e2
}

/// `Basis`: Bernstein values with first and second derivatives, per lane.
#[derive(Clone, Debug)]
pub(crate) struct LaneBasis {
    /// Values.
    pub b: [Lanes; NB],
    /// First derivatives.
    pub d1: [Lanes; NB],
    /// Second derivatives.
    pub d2: [Lanes; NB],
}

/// The Newton path's function-scope arrays (the shader's `lvl`, `low1`, `low2`, the two bases
/// and the jet), kept per task so that a step neither clears nor copies them whole: only the
/// entries `0..=n` a degree-n basis uses are written, and read after being written.
#[derive(Clone, Debug)]
pub(crate) struct NewtonWork {
    lvl: [Lanes; NB],
    low1: [Lanes; NB],
    low2: [Lanes; NB],
    bu: LaneBasis,
    bv: LaneBasis,
    jet: LaneJet,
}

impl Default for NewtonWork {
    fn default() -> Self {
        let basis = LaneBasis {
            b: [[0.0; LANES]; NB],
            d1: [[0.0; LANES]; NB],
            d2: [[0.0; LANES]; NB],
        };
        let zero = [[0.0; LANES]; 3];
        NewtonWork {
            lvl: [[0.0; LANES]; NB],
            low1: [[0.0; LANES]; NB],
            low2: [[0.0; LANES]; NB],
            bu: basis.clone(),
            bv: basis,
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

/// `basis`: the degree-n basis at per-lane t with its derivatives, into `out[..=n]`.
#[inline(always)]
fn basis_lanes(
    n: usize,
    t: &Lanes,
    lvl: &mut [Lanes; NB],
    low1: &mut [Lanes; NB],
    low2: &mut [Lanes; NB],
    out: &mut LaneBasis,
) {
    // The shader's zero-initialised arrays, as far as a degree-n basis reads them.
    for x in [&mut *lvl, &mut *low1, &mut *low2] {
        for e in &mut x[..=n] {
            *e = [0.0; LANES];
        }
    }
    lvl[0] = [1.0; LANES];
    let s = t.map(|x| 1.0 - x);
    for j in 1..n + 1 {
        if j + 1 == n {
            low2[..=n].copy_from_slice(&lvl[..=n]);
        }
        if j == n {
            low1[..=n].copy_from_slice(&lvl[..=n]);
        }
        let mut saved = [0.0f32; LANES];
        for k in 0..j {
            for l in 0..LANES {
                let tmp = lvl[k][l];
                lvl[k][l] = fma(s[l], tmp, saved[l]);
                saved[l] = t[l] * tmp;
            }
        }
        lvl[j] = saved;
    }
    out.b[..=n].copy_from_slice(&lvl[..=n]);
    let nf = n as f32;
    let nn = nf * (nf - 1.0);
    // low1[i - 1], low2[i - 2] and low2[i - 1], zero before the start.
    let mut l1 = [0.0f32; LANES];
    let mut l2a = [0.0f32; LANES];
    let mut l2b = [0.0f32; LANES];
    for i in 0..n + 1 {
        for l in 0..LANES {
            out.d1[i][l] = nf * (l1[l] - low1[i][l]);
            out.d2[i][l] = nn * ((l2a[l] - 2.0 * l2b[l]) + low2[i][l]);
            l1[l] = low1[i][l];
            l2a[l] = l2b[l];
            l2b[l] = low2[i][l];
        }
    }
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

/// `jet`: the held patch and its partials at per-lane local (u, v), into `work.jet`.
#[inline(always)]
fn jet_lanes<const DIM: usize>(config: &Config, u: &Lanes, v: &Lanes, cp: &[Point], work: &mut NewtonWork) {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let NewtonWork {
        lvl,
        low1,
        low2,
        bu,
        bv,
        jet: out,
    } = work;
    basis_lanes(du, u, lvl, low1, low2, bu);
    basis_lanes(dv, v, lvl, low1, low2, bv);
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
                    r0[l] = fma(bv.b[b][l], p[l], r0[l]);
                    r1[l] = fma(bv.d1[b][l], p[l], r1[l]);
                    r2[l] = fma(bv.d2[b][l], p[l], r2[l]);
                }
            }
            for l in 0..LANES {
                acc[0][l] = fma(bu.b[a][l], r0[l], acc[0][l]);
                acc[1][l] = fma(bu.d1[a][l], r0[l], acc[1][l]);
                acc[2][l] = fma(bu.d2[a][l], r0[l], acc[2][l]);
                acc[3][l] = fma(bu.b[a][l], r1[l], acc[3][l]);
                acc[4][l] = fma(bu.d1[a][l], r1[l], acc[4][l]);
                acc[5][l] = fma(bu.b[a][l], r2[l], acc[5][l]);
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

/// `relocate`: move local t of segment k (chain breaks from `breaks[first]`, `count`
/// segments) to the segment holding it, clamped to `[0, 1]`.
#[inline(always)]
fn relocate(breaks: &[f32], first: usize, count: usize, k: usize, t: f32) -> (usize, f32) {
    let t0 = breaks[first + k];
    let g = fma(t, breaks[first + k + 1] - t0, t0).clamp(0.0, 1.0);
    let mut m = 0;
    for i in 1..count {
        if g >= breaks[first + i] {
            m = i;
        }
    }
    let b0 = breaks[first + m];
    (m, ((g - b0) / (breaks[first + m + 1] - b0)).clamp(0.0, 1.0))
}

/// `dot_n` for every lane.
#[inline(always)]
fn dot_lanes<const DIM: usize>(x: &Point, y: &Point) -> Lanes {
    let mut acc = [0.0f32; LANES];
    for c in 0..DIM {
        for l in 0..LANES {
            acc[l] = fma(x[c][l], y[c][l], acc[l]);
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

/// `foot_point_sq` for every lane: `config.newton` (at least 1) Newton steps from the
/// target's start parameters on the held patch.
#[inline(always)]
fn foot_point_sq<const DIM: usize>(
    config: &Config,
    breaks: &[f32],
    net: &[Lanes],
    t: &Target,
    cp: &mut [Point],
    held: &mut [u32; LANES],
    work: &mut NewtonWork,
) -> Lanes {
    let pv = config.patches_v;
    let (pu_count, pv_count) = (config.patches_u as usize, config.patches_v as usize);
    let i0 = t.patch_id / pv;
    let mut i = [i0; LANES];
    let mut j = [t.patch_id - i0 * pv; LANES];
    let mut u = [t.u; LANES];
    let mut v = [t.v; LANES];
    let mut best = [3.0e38f32; LANES];
    let q = [t.x, t.y, t.z];
    let mut it = 0;
    loop {
        jet_lanes::<DIM>(config, &u, &v, cp, work);
        let e = &work.jet;
        let mut r = [[0.0f32; LANES]; 3];
        for c in 0..DIM {
            for l in 0..LANES {
                r[c][l] = e.s[c][l] - q[c];
            }
        }
        let rr = dot_lanes::<DIM>(&r, &r);
        let gu = dot_lanes::<DIM>(&r, &e.su);
        let gv = dot_lanes::<DIM>(&r, &e.sv);
        let guu = dot_lanes::<DIM>(&e.su, &e.su);
        let guv = dot_lanes::<DIM>(&e.su, &e.sv);
        let gvv = dot_lanes::<DIM>(&e.sv, &e.sv);
        let ruu = dot_lanes::<DIM>(&r, &e.suu);
        let ruv = dot_lanes::<DIM>(&r, &e.suv);
        let rvv = dot_lanes::<DIM>(&r, &e.svv);
        for l in 0..LANES {
            best[l] = best[l].min(rr[l]);
            let (gu, gv, guu, guv, gvv) = (gu[l], gv[l], guu[l], guv[l], gvv[l]);
            let huu = guu + ruu[l];
            let huv = guv + ruv[l];
            let hvv = gvv + rvv[l];
            let (step_u, step_v) = newton_step(gu, gv, guu, guv, gvv, huu, huv, hvv);
            u[l] += step_u;
            v[l] += step_v;
        }
        if config.cross == 0 {
            for l in 0..LANES {
                u[l] = u[l].clamp(0.0, 1.0);
                v[l] = v[l].clamp(0.0, 1.0);
            }
        } else {
            for l in 0..LANES {
                if u[l] < 0.0 || u[l] > 1.0 {
                    let (m, t) = relocate(breaks, 0, pu_count, i[l] as usize, u[l]);
                    i[l] = m as u32;
                    u[l] = t;
                }
                if v[l] < 0.0 || v[l] > 1.0 {
                    let (m, t) = relocate(breaks, pu_count + 1, pv_count, j[l] as usize, v[l]);
                    j[l] = m as u32;
                    v[l] = t;
                }
                let moved = i[l] * pv + j[l];
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
    let e2 = offset_sq_lanes::<DIM>(config, &u, &v, q, cp);
    for l in 0..LANES {
        best[l] = best[l].min(e2[l]);
        if config.cross != 0 && held[l] != t.patch_id {
            held[l] = t.patch_id;
            load_patch_lane(config, net, t.patch_id, l, cp);
        }
    }
    best
}
