//! The CPU mirror of `shaders/aero.wgsl`: the panel method for a population, blocks of
//! `LANES` individuals at a time (rayon over blocks), every individual's working set
//! interleaved by lane as the shader interleaves it by invocation.
//!
//! The node map, the assembly, the elimination and the back substitution run over all lanes
//! at once (the same control flow for every individual, so the loops vectorise); the chord, the
//! trailing edge, the coefficients, the geometry checks and the score run lane by lane, as each
//! invocation runs them. The f32 arithmetic is the shader's, operation for operation, including
//! its own `ln` and `atan2` (so that the two paths do not depend on two vendors' libraries).

#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::kernel::{AeroConfig, AeroEvaluator, AeroKernel, AeroResult};
use crate::error::Result;
use crate::eval::Simd;
use crate::eval::{Backend, BackendInfo};
use rayon::prelude::*;

/// Individuals per block: one lane each (a block's working set, about 0.85 MB at 160 nodes,
/// stays in a core's L2).
pub(crate) const LANES: usize = 8;
type Lanes = [f32; LANES];

const QOPI: f32 = 0.079_577_47;
const HOPI: f32 = 0.159_154_94;
const PI: f32 = std::f32::consts::PI;
const SHARP_GAP: f32 = 1e-4;
const BISECTOR_OFFSET: f32 = 0.1;
const FOLD_TOLERANCE: f32 = 1e-3;
/// Surfaces that swap by less than this (per chord) do not cross: f32 cannot tell a closed
/// trailing edge, whose upper and lower nodes meet, from one crossed by rounding (an H200
/// put a closed NACA 4415 edge 1e-11 on the wrong side where lavapipe put it on neither).
const CROSS_TOLERANCE: f32 = 1e-6;
const TINY: f32 = 1e-20;

const OBJECTIVE_MAX_CL: u32 = 1;
const OBJECTIVE_INVERSE: u32 = 2;
const CONSTRAIN_THICKNESS: u32 = 1;
const CONSTRAIN_CM: u32 = 2;

const FLAG_NON_FINITE: u32 = 1;
const FLAG_FOLD: u32 = 2;
const FLAG_CROSSING: u32 = 4;
const FLAG_SINGULAR: u32 = 8;
const FLAG_THIN: u32 = 16;
const FLAG_CM: u32 = 32;
const FLAGS_GEOMETRY: u32 = 15;

const PENALTY_GEOMETRY: f32 = 1e6;
const PENALTY_CONSTRAINT: f32 = 1e3;
const MAX_VIOLATION: f32 = 1e5;

type V2 = [f32; 2];

#[inline(always)]
fn sub(a: V2, b: V2) -> V2 {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline(always)]
fn add(a: V2, b: V2) -> V2 {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline(always)]
fn scale(a: V2, s: f32) -> V2 {
    [a[0] * s, a[1] * s]
}

#[inline(always)]
fn dot(a: V2, b: V2) -> f32 {
    a[0] * b[0] + a[1] * b[1]
}

#[inline(always)]
fn length(a: V2) -> f32 {
    (a[0] * a[0] + a[1] * a[1]).sqrt()
}

#[inline(always)]
fn finite(x: f32) -> bool {
    (x.to_bits() & 0x7f80_0000) != 0x7f80_0000
}

/// The shader's `ln`: `x = m 2^e`, `m ∈ [√½, √2)`, `ln m = 2 atanh s`; 0 for `x ≤ 0`.
// The shader's literals, so that both round them to the same f32.
#[allow(clippy::approx_constant)]
#[inline(always)]
pub(crate) fn ln(x: f32) -> f32 {
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > 1.414_213_6;
    m = if big { 0.5 * m } else { m };
    e = if big { e + 1 } else { e };
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    let p = s * (2.0 + z * (0.666_666_7 + z * (0.4 + z * (0.285_714_3 + z * 0.222_222_2))));
    let r = p + e as f32 * 0.693_147_2;
    if x > 0.0 {
        r
    } else {
        0.0
    }
}

/// The shader's `atan2r`: `atan2(y, x)` in `(−π, π]`, 0 at `(0, 0)`.
// The shader's literals, so that both round them to the same f32.
#[allow(clippy::approx_constant, clippy::excessive_precision)]
#[inline(always)]
pub(crate) fn atan2r(y: f32, x: f32) -> f32 {
    let ax = x.abs();
    let ay = y.abs();
    let swap = ay > ax;
    let num = if swap { ax } else { ay };
    let den = if swap { ay } else { ax };
    let t = if den == 0.0 { 0.0 } else { num / den };
    let high = t > 0.414_213_57;
    let u = if high { (t - 1.0) / (t + 1.0) } else { t };
    let z = u * u;
    let poly = (((0.080_537_444 * z - 0.138_776_85) * z + 0.199_777_1) * z - 0.333_329_5) * z * u + u;
    let mut a = if high { poly + 0.785_398_16 } else { poly };
    a = if swap { 1.570_796_3 - a } else { a };
    a = if x < 0.0 { PI - a } else { a };
    if y < 0.0 {
        -a
    } else {
        a
    }
}

/// The shader's `FAR2`: panels farther than 5 lengths take the series.
const FAR2: f32 = 25.0;

/// A panel `a → b` seen from `f`: its length, unit direction, and `f`'s coordinates along and
/// across it measured from its midpoint (`c`, `y`, `rho = c² + y²`), which the far-field
/// series take.
struct Far {
    s: V2,
    len: f32,
    len2: f32,
    c: f32,
    y: f32,
    c2: f32,
    y2: f32,
    rho: f32,
}

#[inline(always)]
fn unit_along(a: V2, b: V2) -> (f32, f32, V2) {
    let d = sub(b, a);
    let len2 = d[0] * d[0] + d[1] * d[1];
    let len = len2.sqrt();
    (len, len2, [d[0] / len, d[1] / len])
}

#[inline(always)]
fn far_frame(f: V2, a: V2, b: V2) -> Far {
    let (len, len2, s) = unit_along(a, b);
    let m = scale(add(a, b), 0.5);
    let rm = sub(f, m);
    let c = s[0] * rm[0] + s[1] * rm[1];
    let y = s[0] * rm[1] - s[1] * rm[0];
    let (c2, y2) = (c * c, y * y);
    Far {
        s,
        len,
        len2,
        c,
        y,
        c2,
        y2,
        rho: c2 + y2,
    }
}

/// The closed forms' shared terms for `f` and panel `a → b` with unit direction `s`: the
/// coordinates of `f` along (`x1`, `x2` from each end) and across (`yy`) the panel, the squared
/// distances and their logs, the angle the panel subtends (`sub_`) and the source stream
/// function `psis`.
struct Near {
    x1: f32,
    x2: f32,
    yy: f32,
    rs1: f32,
    rs2: f32,
    g1: f32,
    g2: f32,
    sub_: f32,
    psis: f32,
}

#[inline(always)]
fn near_frame(f: V2, a: V2, b: V2, s: V2) -> Near {
    let r1 = sub(f, a);
    let r2 = sub(f, b);
    let x1 = s[0] * r1[0] + s[1] * r1[1];
    let x2 = s[0] * r2[0] + s[1] * r2[1];
    let yy = s[0] * r1[1] - s[1] * r1[0];
    let rs1 = r1[0] * r1[0] + r1[1] * r1[1];
    let rs2 = r2[0] * r2[0] + r2[1] * r2[1];
    let g1 = ln(rs1);
    let g2 = ln(rs2);
    let sub_ = atan2r(r1[0] * r2[1] - r1[1] * r2[0], r1[0] * r2[0] + r1[1] * r2[1]);
    let psis = 0.5 * x1 * g1 - 0.5 * x2 * g2 + x2 - x1 + yy * sub_;
    Near {
        x1,
        x2,
        yy,
        rs1,
        rs2,
        g1,
        g2,
        sub_,
        psis,
    }
}

impl Near {
    /// The shader's `theta` terms: the angles from each end, 0 at the end itself.
    #[inline(always)]
    fn thetas(&self) -> (f32, f32) {
        let t1 = if self.rs1 > 0.0 {
            atan2r(self.x1, self.yy)
        } else {
            0.0
        };
        let t2 = if self.rs2 > 0.0 {
            atan2r(self.x2, self.yy)
        } else {
            0.0
        };
        (t1, t2)
    }

    /// The linear-vortex stream function.
    #[inline(always)]
    fn psid(&self) -> f32 {
        let Near {
            x1,
            x2,
            rs1,
            rs2,
            g1,
            g2,
            psis,
            ..
        } = *self;
        ((x1 + x2) * psis + 0.5 * (rs2 * g2 - rs1 * g1 + x1 * x1 - x2 * x2)) / (x1 - x2)
    }
}

impl Far {
    /// The source stream function's far-field series.
    #[inline(always)]
    fn psis(&self) -> f32 {
        let (len, len2, c2, y2, rho) = (self.len, self.len2, self.c2, self.y2, self.rho);
        let g = ln(rho);
        let g2 = 2.0 * (y2 - c2) / (rho * rho);
        let g4 = -12.0 * (c2 * c2 - 6.0 * c2 * y2 + y2 * y2) / (rho * rho * rho * rho);
        0.5 * len * g + len * len2 / 48.0 * g2 + len * len2 * len2 / 3840.0 * g4
    }

    /// Whether the series serve: `f` farther than `FAR2` panel lengths (squared).
    #[inline(always)]
    fn far(&self) -> bool {
        self.rho > FAR2 * self.len2
    }
}

/// The shader's `vortex_terms` in the far field (its Taylor series), and whether the panel is
/// far: `((psis, psid), far)`. Branch-free, so the lanes run it side by side.
#[inline(always)]
fn vortex_far(f: V2, a: V2, b: V2) -> ([f32; 2], bool) {
    let far = far_frame(f, a, b);
    let (len2, c, c2, y2, rho) = (far.len2, far.c, far.c2, far.y2, far.rho);
    let g1 = 2.0 * c / rho;
    let g3 = 4.0 * c * (c2 - 3.0 * y2) / (rho * rho * rho);
    let psid = -len2 / 12.0 * g1 - len2 * len2 / 480.0 * g3;
    ([far.psis(), psid], far.far())
}

/// The shader's `vortex_terms` in the near field (the closed forms).
#[inline(always)]
fn vortex_near(f: V2, a: V2, b: V2) -> [f32; 2] {
    let (_, _, s) = unit_along(a, b);
    let near = near_frame(f, a, b, s);
    [near.psis, near.psid()]
}

/// The shader's `source_terms`: `(psis, psig)`.
#[inline(always)]
fn source_terms(f: V2, a: V2, b: V2) -> [f32; 2] {
    let far = far_frame(f, a, b);
    if far.far() {
        let (len, len2, c, y, rho) = (far.len, far.len2, far.c, far.y, far.rho);
        let t = atan2r(c, y);
        let t2 = -2.0 * c * y / (rho * rho);
        return [far.psis(), -(len * t + len * len2 / 24.0 * t2)];
    }
    let near = near_frame(f, a, b, far.s);
    let (t1, t2) = near.thetas();
    let (x1, x2, yy) = (near.x1, near.x2, near.yy);
    [near.psis, 0.5 * yy * (near.g1 - near.g2) + x2 * t2 - x1 * t1]
}

/// The shader's `panel_derivs`.
#[inline(always)]
fn panel_derivs(f: V2, a: V2, b: V2, n: V2) -> [f32; 3] {
    let (_, _, s) = unit_along(a, b);
    let near = near_frame(f, a, b, s);
    let psid = near.psid();
    let (t1, t2) = near.thetas();
    let Near {
        x1,
        x2,
        yy,
        g1,
        g2,
        sub_,
        psis,
        ..
    } = near;
    let dx = x1 - x2;
    let xn = s[0] * n[0] + s[1] * n[1];
    let yn = s[0] * n[1] - s[1] * n[0];
    let psx1 = 0.5 * g1;
    let psx2 = -0.5 * g2;
    let pdx1 = ((x1 + x2) * psx1 + psis - x1 * g1 - psid) / dx;
    let pdx2 = ((x1 + x2) * psx2 + psis + x2 * g2 + psid) / dx;
    let pdyy = ((x1 + x2) * sub_ - yy * (g1 - g2)) / dx;
    [
        (psx1 + psx2) * xn + sub_ * yn,
        (pdx1 + pdx2) * xn + pdyy * yn,
        (t2 - t1) * xn + 0.5 * (g1 - g2) * yn,
    ]
}

/// The shader's `end_tangent`.
#[inline(always)]
fn end_tangent(p0: V2, p1: V2, p2: V2) -> V2 {
    let h1 = length(sub(p1, p0));
    let h2 = length(sub(p2, p1));
    let d = sub(
        scale(sub(p1, p0), (h1 + h2) / (h1 * h2)),
        scale(sub(p2, p0), h1 / (h2 * (h1 + h2))),
    );
    let l = length(d);
    if l > 0.0 {
        [-d[0] / l, -d[1] / l]
    } else {
        [0.0, 0.0]
    }
}

/// The shader's `failed`.
fn failed(flags: u32, violation: f32) -> AeroResult {
    let violation = violation.min(MAX_VIOLATION);
    AeroResult {
        flags,
        violation,
        score: PENALTY_GEOMETRY + violation,
        ..AeroResult::default()
    }
}

/// Where the elements of one individual's working set sit.
#[derive(Clone, Copy)]
struct Layout {
    n: usize,
}

impl Layout {
    #[inline(always)]
    fn mat(self, i: usize, j: usize) -> usize {
        2 * self.n + i * (self.n + 1) + j
    }
    #[inline(always)]
    fn rhs(self, r: usize, i: usize) -> usize {
        2 * self.n + (self.n + 1) * (self.n + 1) + r * (self.n + 1) + i
    }
}

/// Elimination steps fused into one pass over the trailing rows.
const BLOCK: usize = 4;

/// Elimination step `k` (the shader's loop body) on every row below it.
#[inline(always)]
fn eliminate_step(work: &mut [Lanes], lay: Layout, k: usize) {
    let n = lay.n;
    let piv = work[lay.mat(k, k)];
    let inv: Lanes = std::array::from_fn(|l| 1.0 / piv[l]);
    let b0 = work[lay.rhs(0, k)];
    let b1 = work[lay.rhs(1, k)];
    let (head, tail) = work.split_at_mut(lay.mat(k + 1, 0));
    let pivot_row = &head[lay.mat(k, k + 1)..=lay.mat(k, n)];
    for i in k + 1..=n {
        let base = lay.mat(i, 0) - lay.mat(k + 1, 0);
        let lf: Lanes = std::array::from_fn(|l| tail[base + k][l] * inv[l]);
        for (t, p) in tail[base + k + 1..=base + n].iter_mut().zip(pivot_row) {
            for l in 0..LANES {
                t[l] -= lf[l] * p[l];
            }
        }
        let r0 = lay.rhs(0, i) - lay.mat(k + 1, 0);
        let r1 = lay.rhs(1, i) - lay.mat(k + 1, 0);
        for l in 0..LANES {
            tail[r0][l] -= lf[l] * b0[l];
            tail[r1][l] -= lf[l] * b1[l];
        }
    }
}

/// Elimination steps `k0 .. k0 + BLOCK`: the block's own rows step by step, then every row
/// below with its multipliers found one after another (each from the entry the earlier steps
/// left) and the four updates of each entry applied in order, `((a − l₀p₀) − l₁p₁) − …`,
/// exactly the shader's arithmetic.
#[inline(always)]
fn eliminate_block(work: &mut [Lanes], lay: Layout, k0: usize) {
    let n = lay.n;
    // The block's rows first: row k0 + r takes steps k0 .. k0 + r.
    for r in 1..BLOCK {
        for s in 0..r {
            let k = k0 + s;
            let i = k0 + r;
            let inv: Lanes = std::array::from_fn(|l| 1.0 / work[lay.mat(k, k)][l]);
            let lf: Lanes = std::array::from_fn(|l| work[lay.mat(i, k)][l] * inv[l]);
            for j in k + 1..=n {
                let p = work[lay.mat(k, j)];
                let t = &mut work[lay.mat(i, j)];
                for l in 0..LANES {
                    t[l] -= lf[l] * p[l];
                }
            }
            for c in 0..2 {
                let b = work[lay.rhs(c, k)];
                let t = &mut work[lay.rhs(c, i)];
                for l in 0..LANES {
                    t[l] -= lf[l] * b[l];
                }
            }
        }
    }
    let inv: [Lanes; BLOCK] =
        std::array::from_fn(|s| std::array::from_fn(|l| 1.0 / work[lay.mat(k0 + s, k0 + s)][l]));
    let rb: [[Lanes; BLOCK]; 2] = std::array::from_fn(|c| std::array::from_fn(|s| work[lay.rhs(c, k0 + s)]));
    let (head, tail) = work.split_at_mut(lay.mat(k0 + BLOCK, 0));
    // The pivot rows from column k0 on.
    let rows: [&[Lanes]; BLOCK] = std::array::from_fn(|s| &head[lay.mat(k0 + s, k0)..=lay.mat(k0 + s, n)]);
    let origin = lay.mat(k0 + BLOCK, 0);
    for i in k0 + BLOCK..=n {
        let row = &mut tail[lay.mat(i, k0) - origin..=lay.mat(i, n) - origin];
        // Multipliers one after another, on the block's own columns.
        let mut lf = [[0.0f32; LANES]; BLOCK];
        for s in 0..BLOCK {
            for l in 0..LANES {
                lf[s][l] = row[s][l] * inv[s][l];
            }
            for c in s + 1..BLOCK {
                for l in 0..LANES {
                    row[c][l] -= lf[s][l] * rows[s][c][l];
                }
            }
        }
        for j in BLOCK..row.len() {
            let mut t = row[j];
            for s in 0..BLOCK {
                let p = rows[s][j];
                for l in 0..LANES {
                    t[l] -= lf[s][l] * p[l];
                }
            }
            row[j] = t;
        }
        for c in 0..2 {
            let at = lay.rhs(c, i) - origin;
            let mut t = tail[at];
            for s in 0..BLOCK {
                for l in 0..LANES {
                    t[l] -= lf[s][l] * rb[c][s][l];
                }
            }
            tail[at] = t;
        }
    }
}

/// Per-lane quantities of the prologue: chord, trailing edge, the bisector control point.
#[derive(Clone, Copy, Default)]
struct Edge {
    kle: usize,
    /// The leading edge lies after node `kle` (which is then on the upper surface).
    le_after: bool,
    le: V2,
    te: V2,
    chord: f32,
    sharp: bool,
    closed: bool,
    scs: f32,
    sds: f32,
    /// Bisector control point and the normal its velocity is taken along.
    fb: V2,
    nb: V2,
}

#[inline(always)]
fn node(work: &[Lanes], k: usize, l: usize) -> V2 {
    [work[2 * k][l], work[2 * k + 1][l]]
}

/// The chord and the trailing edge of lane `l` (the shader's prologue), or the failure.
fn edge(work: &[Lanes], n: usize, l: usize) -> std::result::Result<Edge, AeroResult> {
    for k in 0..n - 1 {
        let d = sub(node(work, k + 1, l), node(work, k, l));
        if d[0] == 0.0 && d[1] == 0.0 {
            return Err(failed(FLAG_SINGULAR, MAX_VIOLATION));
        }
    }
    let te = scale(add(node(work, 0, l), node(work, n - 1, l)), 0.5);
    let mut kle = 1;
    let mut far = -1.0f32;
    for k in 1..n - 1 {
        let r = sub(node(work, k, l), te);
        let d2 = r[0] * r[0] + r[1] * r[1];
        if d2 > far {
            far = d2;
            kle = k;
        }
    }
    let pa = node(work, kle - 1, l);
    let pb = node(work, kle, l);
    let pc = node(work, kle + 1, l);
    let h0 = length(sub(pb, pa));
    let h1 = length(sub(pc, pb));
    let d0 = length(sub(pa, te));
    let d1 = length(sub(pb, te));
    let d2 = length(sub(pc, te));
    let denom = h0 * h1 * (h0 + h1);
    let curv = 2.0 * (h0 * (d2 - d1) - h1 * (d1 - d0)) / denom;
    let slope = (h0 * h0 * (d2 - d1) + h1 * h1 * (d1 - d0)) / denom;
    let sv = if curv < 0.0 {
        (-slope / curv).max(-h0).min(h1)
    } else {
        0.0
    };
    let la = sv * (sv - h1) / (h0 * (h0 + h1));
    let lb = (sv + h0) * (h1 - sv) / (h0 * h1);
    let lc = sv * (sv + h0) / (h1 * (h0 + h1));
    let le = add(add(scale(pa, la), scale(pb, lb)), scale(pc, lc));
    let chord = length(sub(te, le));
    if !(chord > TINY) || !finite(chord) {
        return Err(failed(FLAG_SINGULAR, MAX_VIOLATION));
    }
    let gap = sub(node(work, 0, l), node(work, n - 1, l));
    let aft_first = end_tangent(node(work, 0, l), node(work, 1, l), node(work, 2, l));
    let aft_last = end_tangent(node(work, n - 1, l), node(work, n - 2, l), node(work, n - 3, l));
    let mean = scale(add(aft_first, aft_last), 0.5);
    let dste = length(gap);
    let sharp = dste < SHARP_GAP * chord;
    let closed = dste == 0.0;
    let scs = if sharp {
        1.0
    } else {
        (mean[0] * gap[1] - mean[1] * gap[0]) / dste
    };
    let sds = if sharp {
        0.0
    } else {
        (mean[0] * gap[0] + mean[1] * gap[1]) / dste
    };
    let ml = length(mean);
    let bis = if ml > 0.0 {
        [mean[0] / ml, mean[1] / ml]
    } else {
        [1.0, 0.0]
    };
    let ds = length(sub(node(work, 0, l), node(work, 1, l)))
        .min(length(sub(node(work, n - 1, l), node(work, n - 2, l))));
    let fb = sub(
        scale(add(node(work, 0, l), node(work, n - 1, l)), 0.5),
        scale(bis, BISECTOR_OFFSET * ds),
    );
    Ok(Edge {
        kle,
        le_after: sv > 0.0,
        le,
        te,
        chord,
        sharp,
        closed,
        scs,
        sds,
        fb,
        nb: [-bis[1], bis[0]],
    })
}

/// One block's task: the kernel and its configuration, the population, and which block of
/// [`LANES`] individuals.
struct Block<'a> {
    kernel: &'a AeroKernel,
    config: &'a AeroConfig,
    population: &'a [f32],
    index: usize,
}

/// The kernel on one block: `out` holds its results (up to [`LANES`]), `work` the block's
/// working set (`kernel.work_words()` elements).
#[inline(always)]
fn aero_block(task: &Block<'_>, work: &mut [Lanes], out: &mut [AeroResult]) {
    let Block {
        kernel,
        config,
        population,
        index: block,
    } = *task;
    let n = config.n_nodes as usize;
    let nv = config.n_vars as usize;
    let lay = Layout { n };
    let rows = (config.population as usize)
        .saturating_sub(block * LANES)
        .min(LANES);
    let row = |l: usize| &population[(block * LANES + l) * nv..(block * LANES + l + 1) * nv];

    // Nodes: base + map · design.
    let mut bad = [false; LANES];
    for e in 0..2 * n {
        let mut v = [kernel.node_base[e]; LANES];
        for i in 0..nv {
            let m = kernel.node_map[e * nv + i];
            for l in 0..rows {
                v[l] += m * row(l)[i];
            }
        }
        for l in 0..LANES {
            bad[l] = bad[l] || !finite(v[l]);
        }
        work[e] = v;
    }
    let mut fate: [Option<AeroResult>; LANES] = [None; LANES];
    let mut edges = [Edge::default(); LANES];
    for l in 0..LANES {
        if l >= rows {
            fate[l] = Some(AeroResult::default());
        } else if bad[l] {
            fate[l] = Some(failed(FLAG_NON_FINITE, MAX_VIOLATION));
        } else {
            match edge(work, n, l) {
                Ok(e) => edges[l] = e,
                Err(f) => fate[l] = Some(f),
            }
        }
    }
    if fate.iter().all(Option::is_some) {
        for (o, f) in out.iter_mut().zip(fate) {
            *o = f.unwrap_or_default();
        }
        return;
    }
    // Lanes that failed (or hold no individual) compute on a copy of a live lane's nodes, so
    // that no NaN enters the shared loops; their results are discarded.
    let live = fate.iter().position(Option::is_none).unwrap_or(0);
    for l in 0..LANES {
        if fate[l].is_some() {
            for e in 0..2 * n {
                work[e][l] = work[e][live];
            }
            edges[l] = edges[live];
        }
    }

    // Assembly: Ψ at every node.
    for i in 0..n {
        let f: [V2; LANES] = std::array::from_fn(|l| node(work, i, l));
        let (fx, fy) = (work[2 * i], work[2 * i + 1]);
        let mut carry = [0.0f32; LANES];
        for j in 0..n - 1 {
            // The series for every lane side by side (the nodes' x and y arrive as lanes), the
            // closed forms where a panel is near.
            let (ax, ay, bx, by) = (work[2 * j], work[2 * j + 1], work[2 * j + 2], work[2 * j + 3]);
            let mut psis = [0.0f32; LANES];
            let mut psid = [0.0f32; LANES];
            let mut near = [0u32; LANES];
            for l in 0..LANES {
                let (t, far) = vortex_far([fx[l], fy[l]], [ax[l], ay[l]], [bx[l], by[l]]);
                psis[l] = t[0];
                psid[l] = t[1];
                near[l] = u32::from(!far);
            }
            if near.iter().any(|&x| x != 0) {
                for l in 0..LANES {
                    if near[l] != 0 {
                        [psis[l], psid[l]] = vortex_near(f[l], [ax[l], ay[l]], [bx[l], by[l]]);
                    }
                }
            }
            let mut entry = [0.0f32; LANES];
            for l in 0..LANES {
                entry[l] = carry[l] + QOPI * (psis[l] - psid[l]);
                carry[l] = QOPI * (psis[l] + psid[l]);
            }
            work[lay.mat(i, j)] = entry;
        }
        work[lay.mat(i, n - 1)] = carry;
        for l in 0..LANES {
            if !edges[l].closed {
                let t = source_terms(f[l], node(work, n - 1, l), node(work, 0, l));
                let w = HOPI * (0.5 * edges[l].scs * t[1] - 0.5 * edges[l].sds * t[0]);
                work[lay.mat(i, 0)][l] = work[lay.mat(i, 0)][l] + w;
                work[lay.mat(i, n - 1)][l] = work[lay.mat(i, n - 1)][l] - w;
            }
        }
        work[lay.mat(i, n)] = [-1.0; LANES];
        work[lay.rhs(0, i)] = std::array::from_fn(|l| -f[l][1]);
        work[lay.rhs(1, i)] = std::array::from_fn(|l| f[l][0]);
    }
    if edges.iter().any(|e| e.sharp) {
        // Zero velocity along the bisector just inside the trailing edge replaces the last row.
        let mut carry = [0.0f32; LANES];
        for j in 0..n - 1 {
            for l in 0..LANES {
                let t = panel_derivs(edges[l].fb, node(work, j, l), node(work, j + 1, l), edges[l].nb);
                if edges[l].sharp {
                    work[lay.mat(n - 1, j)][l] = carry[l] + QOPI * (t[0] - t[1]);
                }
                carry[l] = QOPI * (t[0] + t[1]);
            }
        }
        for l in 0..LANES {
            let e = edges[l];
            if !e.sharp {
                continue;
            }
            work[lay.mat(n - 1, n - 1)][l] = carry[l];
            if !e.closed {
                let t = panel_derivs(e.fb, node(work, n - 1, l), node(work, 0, l), e.nb);
                let w = HOPI * (0.5 * e.scs * t[2] - 0.5 * e.sds * t[0]);
                work[lay.mat(n - 1, 0)][l] = work[lay.mat(n - 1, 0)][l] + w;
                work[lay.mat(n - 1, n - 1)][l] = work[lay.mat(n - 1, n - 1)][l] - w;
            }
            work[lay.mat(n - 1, n)][l] = 0.0;
            let nb = e.nb;
            // bis = (nb.y, −nb.x).
            work[lay.rhs(0, n - 1)][l] = -nb[1];
            work[lay.rhs(1, n - 1)][l] = nb[0];
        }
    }
    // Kutta: γ_first + γ_last = 0.
    for j in 0..=n {
        work[lay.mat(n, j)] = [0.0; LANES];
    }
    work[lay.mat(n, 0)] = [1.0; LANES];
    work[lay.mat(n, n - 1)] = [1.0; LANES];
    work[lay.rhs(0, n)] = [0.0; LANES];
    work[lay.rhs(1, n)] = [0.0; LANES];

    // Elimination of the first N − 1 columns (the shader's phase 2), four steps per pass over
    // the trailing rows: each row takes its four updates in the shader's order, so the values
    // are the shader's, with a quarter of its memory traffic.
    let mut k = 0;
    while k + BLOCK < n {
        eliminate_block(work, lay, k);
        k += BLOCK;
    }
    while k < n - 1 {
        eliminate_step(work, lay, k);
        k += 1;
    }
    // The last 2 × 2 block (γ_last, Ψ₀), then back substitution (phase 3).
    let p = work[lay.mat(n - 1, n - 1)];
    let q = work[lay.mat(n - 1, n)];
    let r = work[lay.mat(n, n - 1)];
    let s = work[lay.mat(n, n)];
    let det: Lanes = std::array::from_fn(|l| p[l] * s[l] - q[l] * r[l]);
    for c in 0..2 {
        let u = work[lay.rhs(c, n - 1)];
        let v = work[lay.rhs(c, n)];
        work[lay.rhs(c, n - 1)] = std::array::from_fn(|l| (u[l] * s[l] - q[l] * v[l]) / det[l]);
        work[lay.rhs(c, n)] = std::array::from_fn(|l| (p[l] * v[l] - r[l] * u[l]) / det[l]);
    }
    for c in 0..2 {
        for k in (0..n - 1).rev() {
            let mut acc = work[lay.rhs(c, k)];
            for j in k + 1..=n {
                let (m, x) = (work[lay.mat(k, j)], work[lay.rhs(c, j)]);
                for l in 0..LANES {
                    acc[l] -= m[l] * x[l];
                }
            }
            let d = work[lay.mat(k, k)];
            work[lay.rhs(c, k)] = std::array::from_fn(|l| acc[l] / d[l]);
        }
    }

    for (l, o) in out.iter_mut().enumerate().take(rows) {
        *o = match fate[l] {
            Some(f) => f,
            None => finish_lane(kernel, config, work, lay, &edges[l], l),
        };
    }
}

/// The pivot check, coefficients, geometry checks, objective and score of lane `l` (the
/// shader's phase 4).
fn finish_lane(
    kernel: &AeroKernel,
    config: &AeroConfig,
    work: &[Lanes],
    lay: Layout,
    e: &Edge,
    l: usize,
) -> AeroResult {
    let n = lay.n;
    let mut singular = false;
    for k in 0..n - 1 {
        singular = singular || !(work[lay.mat(k, k)][l].abs() > TINY);
    }
    let det = work[lay.mat(n - 1, n - 1)][l] * work[lay.mat(n, n)][l]
        - work[lay.mat(n - 1, n)][l] * work[lay.mat(n, n - 1)][l];
    singular = singular || !(det.abs() > TINY);
    if singular {
        return failed(FLAG_SINGULAR, MAX_VIOLATION);
    }
    let nd = |k: usize| node(work, k, l);
    let gamma = |c: usize, k: usize| work[lay.rhs(c, k)][l];
    let ca = config.cos_alpha;
    let sa = config.sin_alpha;
    let (le, te, chord, kle) = (e.le, e.te, e.chord, e.kle);
    let quarter = add(le, scale(sub(te, le), 0.25));
    let mut cl = 0.0f32;
    let mut cm = 0.0f32;
    let gi = ca * gamma(0, 0) + sa * gamma(1, 0);
    let mut cpi = 1.0 - gi * gi;
    for i in 0..n {
        let j = if i + 1 == n { 0 } else { i + 1 };
        let gj = ca * gamma(0, j) + sa * gamma(1, j);
        let cpj = 1.0 - gj * gj;
        let d = sub(nd(j), nd(i));
        let mid = sub(scale(add(nd(j), nd(i)), 0.5), quarter);
        let dx = d[0] * ca + d[1] * sa;
        let dy = d[1] * ca - d[0] * sa;
        let ax = mid[0] * ca + mid[1] * sa;
        let ay = mid[1] * ca - mid[0] * sa;
        let ag = 0.5 * (cpi + cpj);
        let dg = cpj - cpi;
        cl += dx * ag;
        cm -= dx * (ag * ax + dg * dx / 12.0) + dy * (ag * ay + dg * dy / 12.0);
        cpi = cpj;
    }
    cl /= chord;
    cm /= chord * chord;

    let cdir = scale(sub(te, le), 1.0 / chord);
    let xof = |p: V2| dot(sub(p, le), cdir) / chord;
    let yof = |p: V2| {
        let q = sub(p, le);
        (cdir[0] * q[1] - cdir[1] * q[0]) / chord
    };
    let mut flags = 0u32;
    let mut violation = 0.0f32;
    for k in 0..kle {
        let back = xof(nd(k + 1)) - xof(nd(k));
        if back > FOLD_TOLERANCE {
            flags |= FLAG_FOLD;
            violation = violation.max(back);
        }
    }
    for k in kle..n - 1 {
        let back = xof(nd(k)) - xof(nd(k + 1));
        if back > FOLD_TOLERANCE {
            flags |= FLAG_FOLD;
            violation = violation.max(back);
        }
    }
    let mut thick = 0.0f32;
    let mut m = kle;
    for k in (0..kle).rev() {
        let xu = xof(nd(k));
        let yu = yof(nd(k));
        while m + 2 < n && xof(nd(m + 1)) < xu {
            m += 1;
        }
        let (xl0, xl1) = (xof(nd(m)), xof(nd(m + 1)));
        let (yl0, yl1) = (yof(nd(m)), yof(nd(m + 1)));
        if xu >= xl0 && xu <= xl1 && xl1 > xl0 {
            let yl = yl0 + (xu - xl0) / (xl1 - xl0) * (yl1 - yl0);
            let t = yu - yl;
            thick = thick.max(t);
            if t < -CROSS_TOLERANCE {
                flags |= FLAG_CROSSING;
                violation = violation.max(-t);
            }
        }
    }
    let te_cross = yof(nd(n - 1)) - yof(nd(0));
    if te_cross > CROSS_TOLERANCE {
        flags |= FLAG_CROSSING;
        violation = violation.max(te_cross);
    }
    if !finite(cl) || !finite(cm) {
        flags |= FLAG_NON_FINITE;
        violation = MAX_VIOLATION;
    }
    if flags & FLAGS_GEOMETRY != 0 {
        return failed(flags, violation);
    }

    let mut objective = 0.0f32;
    if config.objective == OBJECTIVE_MAX_CL {
        objective = -cl;
    } else if config.objective == OBJECTIVE_INVERSE {
        let ns = config.target_samples as usize;
        let mut sum = 0.0f32;
        let mut wsum = 0.0f32;
        for k in 0..n {
            let prev = if k == 0 { 0 } else { k - 1 };
            let next = if k + 1 == n { n - 1 } else { k + 1 };
            let w = 0.5 * (length(sub(nd(k), nd(prev))) + length(sub(nd(next), nd(k))));
            let xk = xof(nd(k)).max(0.0);
            let xi = xk.sqrt().min(1.0) * (ns - 1) as f32;
            let lo = (xi as usize).min(ns - 2);
            let fr = xi - lo as f32;
            let upper = k < kle || (k == kle && e.le_after);
            let side = if upper { 0 } else { ns };
            let t = &kernel.target;
            let ct = t[side + lo] + fr * (t[side + lo + 1] - t[side + lo]);
            let g = ca * gamma(0, k) + sa * gamma(1, k);
            let dc = (1.0 - g * g) - ct;
            sum += w * dc * dc;
            wsum += w;
        }
        objective = sum / wsum;
    }
    let mut score = objective;
    let mut cviol = 0.0f32;
    if config.constraints & CONSTRAIN_THICKNESS != 0 && thick < config.min_thickness {
        flags |= FLAG_THIN;
        cviol += config.min_thickness - thick;
    }
    if config.constraints & CONSTRAIN_CM != 0 && cm < config.cm_min {
        flags |= FLAG_CM;
        cviol += config.cm_min - cm;
    }
    if cviol > 0.0 {
        score = PENALTY_CONSTRAINT + cviol;
    }
    AeroResult {
        cl,
        cm,
        thickness: thick,
        objective,
        score,
        flags,
        violation: cviol,
        _pad0: 0,
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn aero_avx2(task: &Block<'_>, work: &mut [Lanes], out: &mut [AeroResult]) {
    aero_block(task, work, out);
}

/// Run one block on the kernels `simd` names.
fn run_block(simd: Simd, task: &Block<'_>, work: &mut [Lanes], out: &mut [AeroResult]) {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `Simd::Avx2` and `Simd::Avx512` are only produced by `Simd::detect` after it
        // has seen AVX2 and FMA on this CPU, which is all this function requires (the panel
        // kernel has no AVX-512 form of its own; it runs its AVX2 form there).
        Simd::Avx2 | Simd::Avx512 => unsafe { aero_avx2(task, work, out) },
        _ => aero_block(task, work, out),
    }
}

/// The panel method for populations on the CPU: rayon over blocks of `LANES` individuals.
#[derive(Clone, Debug)]
pub struct CpuAero {
    kernel: AeroKernel,
    simd: Simd,
    info: BackendInfo,
}

impl CpuAero {
    /// An evaluator of `kernel` on the best kernels this CPU runs.
    #[must_use]
    pub fn new(kernel: AeroKernel) -> Self {
        Self::with_simd(kernel, Simd::detect())
    }

    /// The same, on the portable kernels (for the tests that compare them).
    #[cfg(test)]
    #[must_use]
    pub fn new_portable(kernel: AeroKernel) -> Self {
        Self::with_simd(kernel, Simd::Portable)
    }

    fn with_simd(kernel: AeroKernel, simd: Simd) -> Self {
        let info = BackendInfo {
            backend: Backend::Cpu,
            adapter: format!(
                "CPU: {} rayon threads, {} kernels, {LANES} individuals per block",
                rayon::current_num_threads(),
                // The panel kernel has an AVX2 form only; AVX-512 machines run it.
                match simd {
                    Simd::Portable => "portable",
                    _ => "AVX2",
                }
            ),
            fallback: None,
        };
        CpuAero { kernel, simd, info }
    }

    /// Record why Auto took the CPU.
    #[must_use]
    pub(crate) fn with_fallback(mut self, why: String) -> Self {
        self.info.fallback = Some(why);
        self
    }
}

impl AeroEvaluator for CpuAero {
    fn evaluate(&mut self, population: &[f32], out: &mut [AeroResult]) -> Result<()> {
        let rows = self.kernel.rows(population, out.len())?;
        if rows == 0 {
            return Ok(());
        }
        let config = AeroConfig {
            population: rows as u32,
            stride: LANES as u32,
            ..self.kernel.config
        };
        let words = self.kernel.work_words();
        let (kernel, simd) = (&self.kernel, self.simd);
        out.par_chunks_mut(LANES).enumerate().for_each_init(
            || vec![[0.0f32; LANES]; words],
            |work, (index, chunk)| {
                let task = Block {
                    kernel,
                    config: &config,
                    population,
                    index,
                };
                run_block(simd, &task, work, chunk)
            },
        );
        Ok(())
    }

    fn info(&self) -> &BackendInfo {
        &self.info
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_and_atan2_match_the_library_to_f32_rounding() {
        for k in 1..2000 {
            let x = 1e-12f32 * 1.021f32.powi(k * 2);
            let want = (x as f64).ln();
            assert!(
                (f64::from(ln(x)) - want).abs() <= 2e-7 * want.abs().max(1.0),
                "ln {x}"
            );
        }
        assert_eq!(ln(0.0), 0.0);
        for i in -40..=40 {
            for j in -40..=40 {
                let (y, x) = (i as f32 * 0.37, j as f32 * 0.29);
                let want = if i == 0 && j == 0 {
                    0.0
                } else {
                    (y as f64).atan2(x as f64)
                };
                let got = f64::from(atan2r(y, x));
                assert!((got - want).abs() < 4e-7, "atan2({y}, {x}) = {got}, not {want}");
            }
        }
    }
}
