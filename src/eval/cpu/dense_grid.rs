//! CPU mirror of `shaders/dense_grid.wgsl`: a patch grid sampled on a tensor grid of
//! parameters, with the cross product of its tangents.

use super::{Arith, Lanes};
use crate::eval::basis::basis;
use crate::eval::kernel::{Config, Sample, Vertex};

/// `main` of `dense_grid.wgsl` for sample `(iu, iv)` of the design in lane `lane` of the
/// block whose nets are in `net` (`net[r * 3 + c][lane]`, as written by the expand mirror).
#[inline(always)]
pub(crate) fn dense_grid<A: Arith>(
    config: &Config,
    samples: &[Sample],
    net: &[Lanes],
    lane: usize,
    iu: usize,
    iv: usize,
) -> Vertex {
    const DIM: usize = 3;
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let lu = samples[iu];
    let lv = samples[config.grid_u as usize + iv];
    let bu = basis::<A>(du, lu.t);
    let bv = basis::<A>(dv, lv.t);
    let (i, j) = (lu.index as usize, lv.index as usize);
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
                r0[c] = A::fma(bv.b[b], p, r0[c]);
                r1[c] = A::fma(bv.d1[b], p, r1[c]);
            }
        }
        for c in 0..DIM {
            s[c] = A::fma(bu.b[a], r0[c], s[c]);
            su[c] = A::fma(bu.d1[a], r0[c], su[c]);
            sv[c] = A::fma(bu.b[a], r1[c], sv[c]);
        }
    }
    let tu = su[0] * su[0] + su[1] * su[1] + su[2] * su[2];
    let tv = sv[0] * sv[0] + sv[1] * sv[1] + sv[2] * sv[2];
    Vertex {
        px: s[0],
        py: s[1],
        pz: s[2],
        nx: su[1] * sv[2] - su[2] * sv[1],
        ny: su[2] * sv[0] - su[0] * sv[2],
        nz: su[0] * sv[1] - su[1] * sv[0],
        tangent_sq: tu.max(tv),
        _pad: 0.0,
    }
}
