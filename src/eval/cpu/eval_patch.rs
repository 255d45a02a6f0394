//! CPU mirror of `shaders/eval_patch.wgsl`: squared offsets of one group of target points for
//! one block of `LANES` individuals.
//!
//! Each lane of a [`Lanes`] array is one shader invocation; every step below is the shader's,
//! in the same order and with the same fused multiply-adds (`M::madd` for `fma`), applied to
//! all lanes at once. The shader's private `cp` (the held patch, per invocation) is the
//! `cp[(a * NV + b) * DIM + c][lane]` scratch array here.

use super::{Lanes, Madd, LANES};
use crate::eval::kernel::{Config, Partial, Target, MAX_DEGREE, NONE};

/// Basis arrays hold up to this many values (degree `MAX_DEGREE`).
pub(crate) const NB: usize = MAX_DEGREE + 1;
/// The shader's `SINGULAR`.
const SINGULAR: f32 = 1e-6;

/// `eval_patch.wgsl` `main` for point group `group` and the block whose expanded nets are in
/// `net` (`net[r * DIM + c][lane]`); writes the block's partials for that group.
#[inline(always)]
pub(crate) fn eval_patch<M: Madd, const DIM: usize>(
    config: &Config,
    targets: &[Target],
    breaks: &[f32],
    net: &[Lanes],
    group: usize,
    cp: &mut [Lanes],
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
                offset_sq_fixed::<M, DIM>(config, t, cp, &mut sum, &mut worst);
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
                let e2 = foot_point_sq::<M, DIM>(config, breaks, net, t, cp, &mut held);
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
fn load_patch(config: &Config, net: &[Lanes], patch: u32, cp: &mut [Lanes], held: &mut [u32; LANES]) {
    *held = [patch; LANES];
    let (du, dv, dim) = (
        config.degree_u as usize,
        config.degree_v as usize,
        config.dim as usize,
    );
    for a in 0..=du {
        for b in 0..=dv {
            let r = net_index(config, patch, a, b);
            let k = a * (dv + 1) + b;
            cp[k * dim..(k + 1) * dim].copy_from_slice(&net[r * dim..(r + 1) * dim]);
        }
    }
}

/// `load_patch` for one lane (Newton steps crossing borders, where lanes part ways).
#[inline(always)]
fn load_patch_lane(config: &Config, net: &[Lanes], patch: u32, lane: usize, cp: &mut [Lanes]) {
    let (du, dv, dim) = (
        config.degree_u as usize,
        config.degree_v as usize,
        config.dim as usize,
    );
    for a in 0..=du {
        for b in 0..=dv {
            let r = net_index(config, patch, a, b);
            let k = a * (dv + 1) + b;
            for c in 0..dim {
                cp[k * dim + c][lane] = net[r * dim + c][lane];
            }
        }
    }
}

/// `bernstein`: the degree-n Bernstein polynomials at t.
#[inline(always)]
pub(crate) fn bernstein<M: Madd>(n: usize, t: f32) -> [f32; NB] {
    let mut out = [0.0f32; NB];
    out[0] = 1.0;
    let s = 1.0 - t;
    for j in 1..=n {
        let mut saved = 0.0f32;
        for k in 0..j {
            let tmp = out[k];
            out[k] = M::madd(s, tmp, saved);
            saved = t * tmp;
        }
        out[j] = saved;
    }
    out
}

/// `offset_sq` with uniform parameters, for every lane; adds into `sum` and `worst` as the
/// shader's point loop does.
#[inline(always)]
fn offset_sq_fixed<M: Madd, const DIM: usize>(
    config: &Config,
    t: &Target,
    cp: &[Lanes],
    sum: &mut Lanes,
    worst: &mut Lanes,
) {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let bu = bernstein::<M>(du, t.u);
    let bv = bernstein::<M>(dv, t.v);
    // The shader's weights bu[a] * bv[b] in its (a, b) order, computed once for all lanes.
    let mut w = [0.0f32; NB * NB];
    for a in 0..=du {
        for b in 0..=dv {
            w[a * (dv + 1) + b] = bu[a] * bv[b];
        }
    }
    let ncp = (du + 1) * (dv + 1);
    let mut s = [[0.0f32; LANES]; DIM];
    for (&wk, p) in w[..ncp].iter().zip(cp.chunks_exact(DIM)) {
        for c in 0..DIM {
            for l in 0..LANES {
                s[c][l] = M::madd(wk, p[c][l], s[c][l]);
            }
        }
    }
    let q = [t.x, t.y, t.z];
    for l in 0..LANES {
        let mut e2 = 0.0f32;
        for c in 0..DIM {
            let d = s[c][l] - q[c];
            e2 = M::madd(d, d, e2);
        }
        sum[l] += e2;
        worst[l] = worst[l].max(e2);
    }
}

/// `offset_sq` with per-lane parameters.
#[inline(always)]
fn offset_sq_lanes<M: Madd, const DIM: usize>(
    config: &Config,
    u: &Lanes,
    v: &Lanes,
    q: [f32; 3],
    cp: &[Lanes],
) -> Lanes {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let mut e2 = [0.0f32; LANES];
    for l in 0..LANES {
        let bu = bernstein::<M>(du, u[l]);
        let bv = bernstein::<M>(dv, v[l]);
        let mut s = [0.0f32; DIM];
        for a in 0..=du {
            for b in 0..=dv {
                let w = bu[a] * bv[b];
                let k = a * (dv + 1) + b;
                for c in 0..DIM {
                    s[c] = M::madd(w, cp[k * DIM + c][l], s[c]);
                }
            }
        }
        for c in 0..DIM {
            let d = s[c] - q[c];
            e2[l] = M::madd(d, d, e2[l]);
        }
    }
    e2
}

/// `Basis`: Bernstein values with first and second derivatives, per lane.
pub(crate) struct LaneBasis {
    /// Values.
    pub b: [Lanes; NB],
    /// First derivatives.
    pub d1: [Lanes; NB],
    /// Second derivatives.
    pub d2: [Lanes; NB],
}

/// `basis`: the degree-n basis at per-lane t with its derivatives.
#[inline(always)]
pub(crate) fn basis_lanes<M: Madd>(n: usize, t: &Lanes) -> LaneBasis {
    let mut lvl = [[0.0f32; LANES]; NB];
    let mut low1 = [[0.0f32; LANES]; NB];
    let mut low2 = [[0.0f32; LANES]; NB];
    lvl[0] = [1.0; LANES];
    let s = t.map(|x| 1.0 - x);
    for j in 1..=n {
        if j + 1 == n {
            low2 = lvl;
        }
        if j == n {
            low1 = lvl;
        }
        let mut saved = [0.0f32; LANES];
        for k in 0..j {
            for l in 0..LANES {
                let tmp = lvl[k][l];
                lvl[k][l] = M::madd(s[l], tmp, saved[l]);
                saved[l] = t[l] * tmp;
            }
        }
        lvl[j] = saved;
    }
    let mut out = LaneBasis {
        b: lvl,
        d1: [[0.0; LANES]; NB],
        d2: [[0.0; LANES]; NB],
    };
    let nf = n as f32;
    let nn = nf * (nf - 1.0);
    // low1[i - 1], low2[i - 2] and low2[i - 1], zero before the start.
    let mut l1 = [0.0f32; LANES];
    let mut l2a = [0.0f32; LANES];
    let mut l2b = [0.0f32; LANES];
    for i in 0..=n {
        for l in 0..LANES {
            out.d1[i][l] = nf * (l1[l] - low1[i][l]);
            out.d2[i][l] = nn * ((l2a[l] - 2.0 * l2b[l]) + low2[i][l]);
            l1[l] = low1[i][l];
            l2a[l] = l2b[l];
            l2b[l] = low2[i][l];
        }
    }
    out
}

/// `Jet`: a point with its first and second partials, per coordinate and lane.
struct LaneJet<const DIM: usize> {
    s: [Lanes; DIM],
    su: [Lanes; DIM],
    sv: [Lanes; DIM],
    suu: [Lanes; DIM],
    suv: [Lanes; DIM],
    svv: [Lanes; DIM],
}

/// `jet`: the held patch and its partials at per-lane local (u, v).
#[inline(always)]
fn jet_lanes<M: Madd, const DIM: usize>(config: &Config, u: &Lanes, v: &Lanes, cp: &[Lanes]) -> LaneJet<DIM> {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let bu = basis_lanes::<M>(du, u);
    let bv = basis_lanes::<M>(dv, v);
    let zero = [[0.0f32; LANES]; DIM];
    let mut out = LaneJet {
        s: zero,
        su: zero,
        sv: zero,
        suu: zero,
        suv: zero,
        svv: zero,
    };
    for a in 0..=du {
        let (mut r0, mut r1, mut r2) = (zero, zero, zero);
        for b in 0..=dv {
            let k = a * (dv + 1) + b;
            for c in 0..DIM {
                let p = &cp[k * DIM + c];
                for l in 0..LANES {
                    r0[c][l] = M::madd(bv.b[b][l], p[l], r0[c][l]);
                    r1[c][l] = M::madd(bv.d1[b][l], p[l], r1[c][l]);
                    r2[c][l] = M::madd(bv.d2[b][l], p[l], r2[c][l]);
                }
            }
        }
        for c in 0..DIM {
            for l in 0..LANES {
                out.s[c][l] = M::madd(bu.b[a][l], r0[c][l], out.s[c][l]);
                out.su[c][l] = M::madd(bu.d1[a][l], r0[c][l], out.su[c][l]);
                out.suu[c][l] = M::madd(bu.d2[a][l], r0[c][l], out.suu[c][l]);
                out.sv[c][l] = M::madd(bu.b[a][l], r1[c][l], out.sv[c][l]);
                out.suv[c][l] = M::madd(bu.d1[a][l], r1[c][l], out.suv[c][l]);
                out.svv[c][l] = M::madd(bu.b[a][l], r2[c][l], out.svv[c][l]);
            }
        }
    }
    out
}

/// `relocate`: move local t of segment k (chain breaks from `breaks[first]`, `count`
/// segments) to the segment holding it, clamped to `[0, 1]`.
#[inline(always)]
fn relocate<M: Madd>(breaks: &[f32], first: usize, count: usize, k: usize, t: f32) -> (usize, f32) {
    let t0 = breaks[first + k];
    let g = M::madd(t, breaks[first + k + 1] - t0, t0).clamp(0.0, 1.0);
    let mut m = 0;
    for i in 1..count {
        if g >= breaks[first + i] {
            m = i;
        }
    }
    let b0 = breaks[first + m];
    (m, ((g - b0) / (breaks[first + m + 1] - b0)).clamp(0.0, 1.0))
}

/// `dot_n`: the dot product over DIM coordinates.
#[inline(always)]
fn dot_n<M: Madd, const DIM: usize>(x: &[f32; DIM], y: &[f32; DIM]) -> f32 {
    let mut acc = 0.0f32;
    for c in 0..DIM {
        acc = M::madd(x[c], y[c], acc);
    }
    acc
}

/// `foot_point_sq` for every lane: `config.newton` (at least 1) Newton steps from the
/// target's start parameters on the held patch.
#[inline(always)]
fn foot_point_sq<M: Madd, const DIM: usize>(
    config: &Config,
    breaks: &[f32],
    net: &[Lanes],
    t: &Target,
    cp: &mut [Lanes],
    held: &mut [u32; LANES],
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
        let e = jet_lanes::<M, DIM>(config, &u, &v, cp);
        for l in 0..LANES {
            let pick = |x: &[Lanes; DIM]| -> [f32; DIM] { std::array::from_fn(|c| x[c][l]) };
            let (s, su, sv) = (pick(&e.s), pick(&e.su), pick(&e.sv));
            let (suu, suv, svv) = (pick(&e.suu), pick(&e.suv), pick(&e.svv));
            let r: [f32; DIM] = std::array::from_fn(|c| s[c] - q[c]);
            best[l] = best[l].min(dot_n::<M, DIM>(&r, &r));
            let gu = dot_n::<M, DIM>(&r, &su);
            let gv = dot_n::<M, DIM>(&r, &sv);
            let guu = dot_n::<M, DIM>(&su, &su);
            let guv = dot_n::<M, DIM>(&su, &sv);
            let gvv = dot_n::<M, DIM>(&sv, &sv);
            let huu = guu + dot_n::<M, DIM>(&r, &suu);
            let huv = guv + dot_n::<M, DIM>(&r, &suv);
            let hvv = gvv + dot_n::<M, DIM>(&r, &svv);
            let mut step_u = 0.0f32;
            let mut step_v = 0.0f32;
            let det = huu * hvv - huv * huv;
            let gdet = guu * gvv - guv * guv;
            if huu > 0.0 && det > SINGULAR * huu * hvv {
                step_u = (huv * gv - hvv * gu) / det;
                step_v = (huv * gu - huu * gv) / det;
            } else if guu > 0.0 && gdet > SINGULAR * guu * gvv {
                step_u = (guv * gv - gvv * gu) / gdet;
                step_v = (guv * gu - guu * gv) / gdet;
            } else {
                let cu = if huu > 0.0 { huu } else { guu };
                let cv = if hvv > 0.0 { hvv } else { gvv };
                if cu > 0.0 {
                    step_u = -gu / cu;
                }
                if cv > 0.0 {
                    step_v = -gv / cv;
                }
            }
            u[l] += step_u;
            v[l] += step_v;
            if config.cross == 0 {
                u[l] = u[l].clamp(0.0, 1.0);
                v[l] = v[l].clamp(0.0, 1.0);
            } else {
                if u[l] < 0.0 || u[l] > 1.0 {
                    let (m, t) = relocate::<M>(breaks, 0, pu_count, i[l] as usize, u[l]);
                    i[l] = m as u32;
                    u[l] = t;
                }
                if v[l] < 0.0 || v[l] > 1.0 {
                    let (m, t) = relocate::<M>(breaks, pu_count + 1, pv_count, j[l] as usize, v[l]);
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
    let e2 = offset_sq_lanes::<M, DIM>(config, &u, &v, q, cp);
    for l in 0..LANES {
        best[l] = best[l].min(e2[l]);
        if config.cross != 0 && held[l] != t.patch_id {
            held[l] = t.patch_id;
            load_patch_lane(config, net, t.patch_id, l, cp);
        }
    }
    best
}
