//! CPU mirror of `shaders/dense_grid.wgsl`: a patch grid sampled on a regular grid of global
//! parameters, with unit normals.

use super::eval_patch::NB;
use super::{fma, Lanes};
use crate::eval::kernel::{Config, Vertex};

/// `basis` of `dense_grid.wgsl`: the degree-n Bernstein values and first derivatives at t.
#[inline(always)]
fn basis(n: usize, t: f32) -> ([f32; NB], [f32; NB]) {
    let mut lvl = [0.0f32; NB];
    let mut low1 = [0.0f32; NB];
    lvl[0] = 1.0;
    let s = 1.0 - t;
    for j in 1..n + 1 {
        if j == n {
            low1 = lvl;
        }
        let mut saved = 0.0f32;
        for k in 0..j {
            let tmp = lvl[k];
            lvl[k] = fma(s, tmp, saved);
            saved = t * tmp;
        }
        lvl[j] = saved;
    }
    let mut d1 = [0.0f32; NB];
    let nf = n as f32;
    // low1[i - 1], zero before the start.
    let mut l1 = 0.0f32;
    for i in 0..n + 1 {
        d1[i] = nf * (l1 - low1[i]);
        l1 = low1[i];
    }
    (lvl, d1)
}

/// `locate`: the segment holding global g (breaks from `breaks[first]`, `count` segments) and
/// the local parameter in it.
#[inline(always)]
fn locate(breaks: &[f32], first: usize, count: usize, g: f32) -> (usize, f32) {
    let mut m = 0;
    for i in 1..count {
        if g >= breaks[first + i] {
            m = i;
        }
    }
    let b0 = breaks[first + m];
    (m, ((g - b0) / (breaks[first + m + 1] - b0)).clamp(0.0, 1.0))
}

/// `main` of `dense_grid.wgsl` for sample `(iu, iv)` of the individual in lane `lane` of the
/// block whose nets are in `net` (`net[r * 3 + c][lane]`, as written by the expand mirror).
#[inline(always)]
pub(crate) fn dense_grid(
    config: &Config,
    breaks: &[f32],
    net: &[Lanes],
    lane: usize,
    iu: usize,
    iv: usize,
) -> Vertex {
    const DIM: usize = 3;
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let (pu, pv) = (config.patches_u as usize, config.patches_v as usize);
    let (iu_max, iv_max) = (config.grid_u - 1, config.grid_v - 1);
    let (i, a_t) = locate(breaks, 0, pu, iu as f32 / iu_max as f32);
    let (j, b_t) = locate(breaks, pu + 1, pv, iv as f32 / iv_max as f32);
    let (bu, bu1) = basis(du, a_t);
    let (bv, bv1) = basis(dv, b_t);
    let mut s = [0.0f32; DIM];
    let mut su = [0.0f32; DIM];
    let mut sv = [0.0f32; DIM];
    for a in 0..du + 1 {
        let mut r0 = [0.0f32; DIM];
        let mut r1 = [0.0f32; DIM];
        for b in 0..dv + 1 {
            let r = (i * du + a) * config.net_cols as usize + j * dv + b;
            for c in 0..DIM {
                let p = net[r * DIM + c][lane];
                r0[c] = fma(bv[b], p, r0[c]);
                r1[c] = fma(bv1[b], p, r1[c]);
            }
        }
        for c in 0..DIM {
            s[c] = fma(bu[a], r0[c], s[c]);
            su[c] = fma(bu1[a], r0[c], su[c]);
            sv[c] = fma(bu[a], r1[c], sv[c]);
        }
    }
    let n = [
        su[1] * sv[2] - su[2] * sv[1],
        su[2] * sv[0] - su[0] * sv[2],
        su[0] * sv[1] - su[1] * sv[0],
    ];
    let len2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    let inv = if len2 > 0.0 { 1.0 / len2.sqrt() } else { 0.0 };
    Vertex {
        px: s[0],
        py: s[1],
        pz: s[2],
        nx: n[0] * inv,
        ny: n[1] * inv,
        nz: n[2] * inv,
    }
}
