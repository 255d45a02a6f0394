//! The f32 mirror of `shaders/basis.wgsl`: the Bernstein basis with its first and second
//! derivatives, for one parameter ([`bernstein`], [`basis`]) or one per lane
//! ([`bernstein_lanes`], [`basis_lanes`]), in the shaders' arithmetic ([`Arith`]: the
//! multiply-add as lavapipe computes it, or fused). The data preparation of [`super::kernel`]
//! and the CPU mirrors of [`super::cpu`] both compute with it.

use crate::chain::MAX_DEGREE;

/// Basis arrays hold up to this many values (degree [`MAX_DEGREE`]).
pub(crate) const NB: usize = MAX_DEGREE + 1;

/// Individuals per block: one lane each (one AVX-512 register, two AVX2 registers).
pub(crate) const LANES: usize = 16;
/// One value per lane of a block.
pub(crate) type Lanes = [f32; LANES];
/// How the kernels compute the shaders' `fma(a, b, c)`.
pub(crate) trait Arith {
    /// `a * b + c`.
    fn fma(a: f32, b: f32, c: f32) -> f32;
}

/// `a * b + c` rounded twice, as lavapipe computes `fma`.
pub(crate) struct Unfused;

impl Arith for Unfused {
    #[inline(always)]
    fn fma(a: f32, b: f32, c: f32) -> f32 {
        a * b + c
    }
}

/// `a * b + c` rounded once. Only inside functions compiled with the `fma` feature (elsewhere
/// `mul_add` is a library call).
pub(crate) struct Fused;

impl Arith for Fused {
    #[inline(always)]
    fn fma(a: f32, b: f32, c: f32) -> f32 {
        a.mul_add(b, c)
    }
}

/// `bernstein`: the degree-n Bernstein polynomials at t.
#[inline(always)]
pub(crate) fn bernstein<A: Arith>(n: usize, t: f32) -> [f32; NB] {
    let mut out = [0.0f32; NB];
    out[0] = 1.0;
    let s = 1.0 - t;
    for j in 1..n + 1 {
        raise::<A>(&mut out, j, t, s);
    }
    out
}

/// One step of the Bernstein recurrence: the degree `j - 1` values in `level[..j]` become the
/// degree `j` values in `level[..=j]` (`s = 1 - t`).
#[inline(always)]
fn raise<A: Arith>(level: &mut [f32; NB], j: usize, t: f32, s: f32) {
    let mut saved = 0.0f32;
    for k in 0..j {
        let tmp = level[k];
        level[k] = A::fma(s, tmp, saved);
        saved = t * tmp;
    }
    level[j] = saved;
}

/// `Basis`: Bernstein values with first and second derivatives at one parameter (`T = f32`)
/// or at one parameter per lane (`T = Lanes`, [`LaneBasis`]).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Basis<T = f32> {
    /// Values.
    pub b: [T; NB],
    /// First derivatives.
    pub d1: [T; NB],
    /// Second derivatives.
    pub d2: [T; NB],
}

/// `basis`: the degree-n basis at t with its derivatives.
#[inline(always)]
pub(crate) fn basis<A: Arith>(n: usize, t: f32) -> Basis {
    let mut lvl = [0.0f32; NB];
    let mut low1 = [0.0f32; NB];
    let mut low2 = [0.0f32; NB];
    lvl[0] = 1.0;
    let s = 1.0 - t;
    for j in 1..n + 1 {
        if j + 1 == n {
            low2 = lvl;
        }
        if j == n {
            low1 = lvl;
        }
        raise::<A>(&mut lvl, j, t, s);
    }
    let mut out = Basis {
        b: lvl,
        d1: [0.0; NB],
        d2: [0.0; NB],
    };
    let nf = n as f32;
    let nn = nf * (nf - 1.0);
    // low1[i - 1], low2[i - 2] and low2[i - 1], zero before the start.
    let (mut l1, mut l2a, mut l2b) = (0.0f32, 0.0f32, 0.0f32);
    for i in 0..n + 1 {
        out.d1[i] = nf * (l1 - low1[i]);
        out.d2[i] = nn * ((l2a - 2.0 * l2b) + low2[i]);
        l1 = low1[i];
        l2a = l2b;
        l2b = low2[i];
    }
    out
}

/// `bernstein` with per-lane t.
#[inline(always)]
pub(crate) fn bernstein_lanes<A: Arith>(n: usize, t: &Lanes) -> [Lanes; NB] {
    let mut out = [[0.0f32; LANES]; NB];
    out[0] = [1.0; LANES];
    let s = t.map(|x| 1.0 - x);
    for j in 1..n + 1 {
        raise_lanes::<A>(&mut out, j, t, &s);
    }
    out
}

/// One step of the Bernstein recurrence per lane: the degree `j - 1` values in `level[..j]`
/// become the degree `j` values in `level[..=j]` (`s = 1 - t`).
#[inline(always)]
fn raise_lanes<A: Arith>(level: &mut [Lanes; NB], j: usize, t: &Lanes, s: &Lanes) {
    let mut saved = [0.0f32; LANES];
    for k in 0..j {
        for l in 0..LANES {
            let tmp = level[k][l];
            level[k][l] = A::fma(s[l], tmp, saved[l]);
            saved[l] = t[l] * tmp;
        }
    }
    level[j] = saved;
}

/// `Basis` per lane.
pub(crate) type LaneBasis = Basis<Lanes>;

/// The function-scope arrays of `basis` (`lvl`, `low1`, `low2`), kept by the caller so that
/// a call neither clears nor copies them whole: only the entries `0..=n` a degree-n basis
/// uses are written, and read after being written.
#[derive(Clone, Debug, Default)]
pub(crate) struct BasisWork {
    lvl: [Lanes; NB],
    low1: [Lanes; NB],
    low2: [Lanes; NB],
}

/// `basis` with per-lane t, into `out[..=n]`.
#[inline(always)]
pub(crate) fn basis_lanes<A: Arith>(n: usize, t: &Lanes, work: &mut BasisWork, out: &mut LaneBasis) {
    let BasisWork { lvl, low1, low2 } = work;
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
        raise_lanes::<A>(lvl, j, t, &s);
    }
    out.b[..=n].copy_from_slice(&lvl[..=n]);
    let nf = n as f32;
    let nn = nf * (nf - 1.0);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bezier::{bernstein as bernstein_f64, bernstein_deriv};

    #[test]
    fn the_basis_matches_the_f64_one() {
        for n in 0..=7 {
            for &t in &[0.0f32, 0.2, 0.5, 0.93, 1.0] {
                let got = basis::<Unfused>(n, t);
                let lanes = bernstein_lanes::<Unfused>(n, &[t; LANES]);
                assert_eq!(bernstein::<Unfused>(n, t), got.b);
                let mut b = [0.0; 16];
                let mut d = [0.0; 16];
                bernstein_f64(n, f64::from(t), &mut b);
                bernstein_deriv(n, f64::from(t), &mut d);
                for i in 0..=n {
                    assert!((f64::from(got.b[i]) - b[i]).abs() < 1e-6, "n {n} t {t} b{i}");
                    assert!((f64::from(got.d1[i]) - d[i]).abs() < 1e-4, "n {n} t {t} d{i}");
                    assert_eq!(lanes[i][3], got.b[i]);
                }
                let sum2: f32 = got.d2[..=n].iter().sum();
                assert!(
                    sum2.abs() < 1e-3,
                    "second derivatives of a partition of unity sum to 0"
                );
            }
        }
    }

    /// The mirror, with either rounding of `fma` and one parameter or one per lane, against
    /// the f64 evaluator: each value within `n + 1` f32 roundings of it, each derivative of
    /// order `k` within `(2n)^k` times that (its differences scale the values' errors).
    #[test]
    fn the_mirror_is_the_f64_evaluator_to_f32_rounding() {
        use super::Fused;
        use crate::bezier::bernstein_jet;
        let eps = f64::from(f32::EPSILON);
        let ts: Vec<f32> = (0..=LANES * 4)
            .map(|i| i as f32 / (LANES * 4) as f32)
            .chain([1e-7, 0.1, 1.0 / 3.0, 0.62, 1.0 - 1e-7])
            .collect();
        let (mut work, mut out) = (BasisWork::default(), LaneBasis::default());
        for n in 0..NB {
            let tol = |k: usize| (n + 1) as f64 * eps * (2.0 * n as f64).max(1.0).powi(k as i32);
            let check = |t: f32, got: [&[f32]; 3], what: &str| {
                let want = bernstein_jet::<NB, 3>(n, f64::from(t));
                for k in 0..3 {
                    for i in 0..=n {
                        let err = (f64::from(got[k][i]) - want[k][i]).abs();
                        assert!(
                            err <= tol(k),
                            "{what} n={n} t={t} order {k} i={i}: {} vs {}",
                            got[k][i],
                            want[k][i]
                        );
                    }
                }
            };
            for &t in &ts {
                let u = basis::<Unfused>(n, t);
                check(t, [&u.b, &u.d1, &u.d2], "unfused");
                let f = basis::<Fused>(n, t);
                check(t, [&f.b, &f.d1, &f.d2], "fused");
            }
            for chunk in ts.chunks(LANES) {
                let mut t = [0.5f32; LANES];
                t[..chunk.len()].copy_from_slice(chunk);
                basis_lanes::<Unfused>(n, &t, &mut work, &mut out);
                for (l, &tl) in t.iter().enumerate() {
                    let lane = |a: &[Lanes; NB]| a.map(|x| x[l]);
                    check(tl, [&lane(&out.b), &lane(&out.d1), &lane(&out.d2)], "lanes");
                }
            }
        }
    }
}
