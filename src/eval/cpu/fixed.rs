//! The fixed-parameter offsets (`eval_patch.wgsl` with `newton == 0`, the GA fitness kernel
//! proper) with explicit SIMD: AVX-512 (16 lanes a register) and AVX2 + FMA (8 lanes).
//!
//! The same sums as the mirror in [`super::eval_patch::fixed`], term for term and in the same
//! order, with fused multiply-adds (one rounding each, where lavapipe rounds twice): per point
//! and coordinate `s = r0; s = fma(w_k, cp_k, s)` over the patch's control points, then
//! `e2 = s_0²; e2 = fma(s_c, s_c, e2)`, `sum += e2`, `worst = max(worst, e2)`.
//!
//! Blocking. A block's lanes are taken one register (a column of [`Vector::WIDTH`] lanes) at
//! a time; within a run of points on one patch, `G` points are evaluated together, so each
//! control point loaded into a register feeds `G` multiply-adds whose other operand, the
//! point's basis weight, is broadcast from memory once for the `DIM` coordinates. `G` is the
//! most points whose `G × DIM` accumulators, `G` weights and one control point fit in the
//! registers (AVX-512, 32: 7 points in space, 10 in the plane; AVX2, 16: 3 and 4), so nothing
//! spills: per control point the loop loads `G` weights and `DIM` values for `G × DIM` FMAs.

use super::eval_patch::{group_range, net_index, run_end, store};
use super::{Lanes, LANES};
use crate::eval::kernel::{Config, Partial, Target, NB};

/// One SIMD register of f32 lanes with the operations the fixed-parameter loop needs.
///
/// # Safety
///
/// Implementations call instructions of a CPU feature; callers must run on a CPU that has it.
pub(crate) unsafe trait Vector: Copy {
    /// Lanes per register.
    const WIDTH: usize;
    /// All lanes `x`.
    unsafe fn splat(x: f32) -> Self;
    /// `WIDTH` values from `p` (unaligned).
    unsafe fn load(p: *const f32) -> Self;
    /// Store to `p` (unaligned).
    unsafe fn store(self, p: *mut f32);
    /// `a * b + c`, rounded once.
    unsafe fn fma(a: Self, b: Self, c: Self) -> Self;
    /// `a * b`.
    unsafe fn mul(a: Self, b: Self) -> Self;
    /// `a + b`.
    unsafe fn add(a: Self, b: Self) -> Self;
    /// The larger of `a` and `b`; `b` where `a` is NaN (as `f32::max(b, a)`).
    unsafe fn max(a: Self, b: Self) -> Self;
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Vector;
    use std::arch::x86_64::*;

    /// `Vector` for one register type: its width, the features its methods need (all, and
    /// for `fma`), and the intrinsic behind each method.
    macro_rules! vector {
        ($ty:ty, $width:expr, $feat:literal, $fma_feat:literal,
         $splat:ident, $load:ident, $store:ident, $fma:ident, $mul:ident, $add:ident, $max:ident) => {
            unsafe impl Vector for $ty {
                const WIDTH: usize = $width;
                #[inline]
                #[target_feature(enable = $feat)]
                unsafe fn splat(x: f32) -> Self {
                    $splat(x)
                }
                #[inline]
                #[target_feature(enable = $feat)]
                unsafe fn load(p: *const f32) -> Self {
                    $load(p)
                }
                #[inline]
                #[target_feature(enable = $feat)]
                unsafe fn store(self, p: *mut f32) {
                    $store(p, self);
                }
                #[inline]
                #[target_feature(enable = $fma_feat)]
                unsafe fn fma(a: Self, b: Self, c: Self) -> Self {
                    $fma(a, b, c)
                }
                #[inline]
                #[target_feature(enable = $feat)]
                unsafe fn mul(a: Self, b: Self) -> Self {
                    $mul(a, b)
                }
                #[inline]
                #[target_feature(enable = $feat)]
                unsafe fn add(a: Self, b: Self) -> Self {
                    $add(a, b)
                }
                #[inline]
                #[target_feature(enable = $feat)]
                unsafe fn max(a: Self, b: Self) -> Self {
                    // vmaxps returns its second operand where either is NaN.
                    $max(a, b)
                }
            }
        };
    }

    // SAFETY: every method needs AVX-512F, which `Simd::Avx512` is only chosen with.
    vector!(
        __m512,
        16,
        "avx512f",
        "avx512f",
        _mm512_set1_ps,
        _mm512_loadu_ps,
        _mm512_storeu_ps,
        _mm512_fmadd_ps,
        _mm512_mul_ps,
        _mm512_add_ps,
        _mm512_max_ps
    );

    // SAFETY: every method needs AVX, and `fma` FMA too, which `Simd::Avx2` is only chosen with.
    vector!(
        __m256,
        8,
        "avx",
        "avx,fma",
        _mm256_set1_ps,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        _mm256_fmadd_ps,
        _mm256_mul_ps,
        _mm256_add_ps,
        _mm256_max_ps
    );
}

/// Most control points of a patch, times 3 coordinates: the held patch of one column.
const HELD: usize = NB * NB * 3;

/// The fixed-parameter partials of point group `group` for the block whose difference nets
/// are in `net`, `G` points at a time.
///
/// # Safety
///
/// The CPU must have `V`'s feature; `weights` holds `ncp` values for every target.
#[inline(always)]
pub(crate) unsafe fn fixed<V: Vector, const DIM: usize, const G: usize>(
    config: &Config,
    targets: &[Target],
    weights: &[f32],
    net: &[Lanes],
    group: usize,
    partials: &mut [Partial; LANES],
) {
    let (du, dv) = (config.degree_u as usize, config.degree_v as usize);
    let ncp = (du + 1) * (dv + 1);
    debug_assert!(ncp * DIM <= HELD && weights.len() >= targets.len() * ncp);
    let (first, last) = group_range(config, group);
    let w = weights.as_ptr();
    let mut cp = [V::splat(0.0); HELD];
    let mut sums = [0.0f32; LANES];
    let mut worsts = [0.0f32; LANES];
    for col in (0..LANES).step_by(V::WIDTH) {
        let mut sum = V::splat(0.0);
        let mut worst = V::splat(0.0);
        let mut p = first;
        while p < last {
            let end = run_end(targets, p, last);
            let patch = targets[p].patch_id;
            for a in 0..du + 1 {
                for b in 0..dv + 1 {
                    let r = net_index(config, patch, a, b);
                    for c in 0..DIM {
                        cp[(a * (dv + 1) + b) * DIM + c] = V::load(net[r * DIM + c].as_ptr().add(col));
                    }
                }
            }
            while p + G <= end {
                points::<V, DIM, G>(&targets[p..p + G], w.add(p * ncp), ncp, &cp, &mut sum, &mut worst);
                p += G;
            }
            while p < end {
                points::<V, DIM, 1>(&targets[p..p + 1], w.add(p * ncp), ncp, &cp, &mut sum, &mut worst);
                p += 1;
            }
        }
        sum.store(sums.as_mut_ptr().add(col));
        worst.store(worsts.as_mut_ptr().add(col));
    }
    store(&sums, &worsts, partials);
}

/// The offsets of the `G` points `targets` (weights from `w`, `ncp` a point) on the held
/// patch `cp`, added into `sum` and `worst` in order.
#[inline(always)]
unsafe fn points<V: Vector, const DIM: usize, const G: usize>(
    targets: &[Target],
    w: *const f32,
    ncp: usize,
    cp: &[V; HELD],
    sum: &mut V,
    worst: &mut V,
) {
    let mut acc = [[V::splat(0.0); DIM]; G];
    for (a, t) in acc.iter_mut().zip(targets) {
        let r0 = [t.rx, t.ry, t.rz];
        for c in 0..DIM {
            a[c] = V::splat(r0[c]);
        }
    }
    for k in 0..ncp {
        for c in 0..DIM {
            let x = *cp.get_unchecked(k * DIM + c);
            for (g, a) in acc.iter_mut().enumerate() {
                a[c] = V::fma(V::splat(*w.add(g * ncp + k)), x, a[c]);
            }
        }
    }
    for a in &acc {
        let mut e2 = V::mul(a[0], a[0]);
        for c in 1..DIM {
            e2 = V::fma(a[c], a[c], e2);
        }
        *sum = V::add(*sum, e2);
        *worst = V::max(e2, *worst);
    }
}
