//! The crate's one f64 evaluator of Bezier curves and patches: the Bernstein basis (paper
//! eq. 1) with its derivatives (eq. 2), de Casteljau's algorithm, the Horner-like scheme for
//! one curve's point and derivatives, and the Bernstein-weighted sums of control points
//! (eqs. 1 and 3) that turn a basis into points and partials.
//!
//! The `bezier` types, the chain layouts (their basis and segment jets), the shapes, the
//! patch grids, the population evaluator's reference design, the checker's emulation and the
//! CAD export all evaluate through these functions; the only other evaluator is the f32 CPU
//! mirror of the shaders (`eval/cpu/basis.rs`), tested against this one. Nothing here
//! allocates: buffers are arrays sized by const generics (a caller with a constant degree gets
//! every loop unrolled) or slices the caller owns.

use super::point::Vector;

/// Binomial coefficient `n choose k` as f64 (exact for the degrees used here).
#[must_use]
pub fn binomial(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    let k = k.min(n - k);
    let mut c = 1.0;
    for i in 0..k {
        c = c * (n - i) as f64 / (i + 1) as f64;
    }
    c
}

/// The highest degree of the Horner-like scheme's table of binomials ([`curve_jet`]).
const TABLE_DEGREE: usize = 32;

/// `C(n, i)` for `n <= TABLE_DEGREE`, exact in f64 (Pascal's triangle adds integers).
const BINOMIAL: [[f64; TABLE_DEGREE + 1]; TABLE_DEGREE + 1] = binomials();

const fn binomials() -> [[f64; TABLE_DEGREE + 1]; TABLE_DEGREE + 1] {
    let mut t = [[0.0; TABLE_DEGREE + 1]; TABLE_DEGREE + 1];
    let mut n = 0;
    while n <= TABLE_DEGREE {
        t[n][0] = 1.0;
        let mut i = 1;
        while i <= n {
            t[n][i] = t[n - 1][i - 1] + if i < n { t[n - 1][i] } else { 0.0 };
            i += 1;
        }
        n += 1;
    }
    t
}

/// `(-1)^(k-j) C(k, j)`: the weights of the `k`-th difference in [`bernstein_jet`].
const SIGNED: [[f64; 4]; 4] = [
    [1.0, 0.0, 0.0, 0.0],
    [-1.0, 1.0, 0.0, 0.0],
    [1.0, -2.0, 1.0, 0.0],
    [-1.0, 3.0, -3.0, 1.0],
];

/// One step of the triangular recurrence (de Casteljau on the basis): the degree `j - 1`
/// values in `rows[from][..j]` become the degree `j` values in `rows[to][..=j]` (`v = 1 - u`;
/// `from` and `to` may be the same row).
#[inline(always)]
fn raise<const W: usize>(rows: &mut [[f64; W]], from: usize, to: usize, j: usize, u: f64, v: f64) {
    let mut saved = 0.0;
    for k in 0..j {
        let tmp = rows[from][k];
        rows[to][k] = saved + v * tmp;
        saved = u * tmp;
    }
    rows[to][j] = saved;
}

/// Fill `out[0..=n]` with the degree-`n` Bernstein polynomials `B_{i,n}(u)`, for degrees up
/// to 32.
///
/// Computed by the triangular recurrence (de Casteljau on the basis), which is stable on
/// `[0, 1]` and costs `n (n + 1) / 2` multiply-adds.
pub fn bernstein(n: usize, u: f64, out: &mut [f64]) {
    debug_assert!(out.len() > n, "bernstein: output slice too short for degree {n}");
    debug_assert!(n <= 32, "bernstein: degree {n} above 32");
    let [b] = bernstein_levels::<33, 1>(n, u);
    out[..=n].copy_from_slice(&b[..=n]);
}

/// The Bernstein polynomials of degrees `n`, `n - 1`, ..., `n - L + 1` at `u`, all from one
/// recurrence: level `k` holds `B_{i,n-k}(u)` in its first `n - k + 1` entries and zeros
/// after them (a level of negative degree is all zeros). `W > n`.
///
/// Degree `j` is computed into level `(n - j) mod L`, so that the last `L` degrees land in
/// their own levels and nothing is copied (a copy of values just stored one by one stalls on
/// store forwarding, in the hottest loop of a surface fit).
#[inline(always)]
#[must_use]
pub fn bernstein_levels<const W: usize, const L: usize>(n: usize, u: f64) -> [[f64; W]; L] {
    debug_assert!(n < W, "bernstein_levels: degree {n} does not fit {W} entries");
    let v = 1.0 - u;
    let mut levels = [[0.0; W]; L];
    levels[n % L][0] = 1.0;
    for j in 1..=n {
        raise(&mut levels, (n - j + 1) % L, (n - j) % L, j, u, v);
    }
    levels
}

/// The degree-`n` Bernstein polynomials at `u` and their derivatives: `out[k][i]` is
/// `d^k B_{i,n}(u) / du^k` for `k < K` (`K` at most 4), zero past `i = n` and for `k > n`.
///
/// By eq. 2 applied `k` times, `d^k B_{i,n} = n!/(n-k)! Σ_j (-1)^(k-j) C(k, j) B_{i-j,n-k}`,
/// the differences taken from the highest `j` down, over the lower degrees of the same
/// recurrence. `W > n`.
#[inline(always)]
#[must_use]
pub fn bernstein_jet<const W: usize, const K: usize>(n: usize, u: f64) -> [[f64; W]; K] {
    const { assert!(K >= 1 && K <= 4, "bernstein_jet: orders 0 to 3") };
    let levels = bernstein_levels::<W, K>(n, u);
    let mut out = [[0.0; W]; K];
    out[0] = levels[0];
    for k in 1..K.min(n + 1) {
        let low = &levels[k];
        let factor = (0..k).fold(1.0, |f, j| f * (n - j) as f64);
        for i in 0..=n {
            let at = |back: usize| if i >= back { low[i - back] } else { 0.0 };
            let mut s = at(k);
            for j in (0..k).rev() {
                s += SIGNED[k][j] * at(j);
            }
            out[k][i] = factor * s;
        }
    }
    out
}

/// Fill `out[0..=n]` with `d/du B_{i,n}(u) = n (B_{i-1,n-1}(u) - B_{i,n-1}(u))` (eq. 2), for
/// degrees up to 32.
pub fn bernstein_deriv(n: usize, u: f64, out: &mut [f64]) {
    debug_assert!(
        out.len() > n,
        "bernstein_deriv: output slice too short for degree {n}"
    );
    debug_assert!(n <= 32, "bernstein_deriv: degree {n} above 32");
    let jet = bernstein_jet::<33, 2>(n, u);
    out[..=n].copy_from_slice(&jet[1][..=n]);
}

/// The point `Σ_i w_i p_i` of `points` with `weights` (as many as there are points, or
/// more), summed in order from zero: a Bezier curve in Bernstein form (eq. 1) when the
/// weights are its basis, a chain when they are its B-spline basis.
#[inline(always)]
#[must_use]
pub fn combine<P: Vector>(points: &[P], weights: &[f64]) -> P {
    points
        .iter()
        .zip(weights)
        .fold(P::ZERO, |acc, (&p, &w)| acc + p * w)
}

/// The tensor-product patch of the `nu × nv` control points `net[i * stride + j]` with the
/// bases `wu` along u and `wv` along v (each: values, then derivatives, `order + 1` of them
/// at least, `W >= nu, nv` entries): `out[a][b] = ∂^(a+b) P / ∂u^a ∂v^b` for
/// `a + b <= order`, zero otherwise (eq. 3). Each row is combined along v, then the rows along
/// u (eq. 4's curve of curves), every sum in order from zero.
#[inline(always)]
#[must_use]
pub fn tensor_jet<P: Vector, const W: usize, const K: usize>(
    net: &[P],
    stride: usize,
    (nu, nv): (usize, usize),
    wu: [&[f64; W]; K],
    wv: [&[f64; W]; K],
    order: usize,
) -> [[P; K]; K] {
    debug_assert!(order < K, "tensor_jet: order {order} needs {} bases", order + 1);
    debug_assert!(
        nu <= W && nv <= W,
        "tensor_jet: {nu} x {nv} points for bases of {W}"
    );
    let mut out = [[P::ZERO; K]; K];
    for i in 0..nu {
        let row = &net[i * stride..i * stride + nv];
        let mut sums = [P::ZERO; K];
        for (j, &x) in row.iter().enumerate() {
            for b in 0..K {
                if b <= order {
                    sums[b] += x * wv[b][j];
                }
            }
        }
        for a in 0..K {
            for b in 0..K - a {
                if a + b <= order {
                    out[a][b] += sums[b] * wu[a][i];
                }
            }
        }
    }
    out
}

/// De Casteljau's algorithm on `pts` (overwritten) at `u`, each step `a.lerp_to(b, u)`:
/// the point of the Bezier curve with control points `pts`.
#[inline]
#[must_use]
pub fn casteljau<P: Vector>(pts: &mut [P], u: f64) -> P {
    casteljau_with(pts, u, P::lerp_to, |_| {})
}

/// De Casteljau's algorithm with the interpolation `lerp(a, b, u)` of the caller's choice:
/// after step `r` (1 to `n`) of `n + 1` points, `pts[..=n - r]` hold the triangle's level `r`,
/// which `level` sees; returns the point, `pts[0]` after the last step.
#[inline]
pub fn casteljau_with<P: Copy>(
    pts: &mut [P],
    u: f64,
    lerp: impl Fn(P, P, f64) -> P,
    mut level: impl FnMut(&[P]),
) -> P {
    let n = pts.len();
    for r in 1..n {
        for i in 0..n - r {
            pts[i] = lerp(pts[i], pts[i + 1], u);
        }
        level(&pts[..n - r]);
    }
    pts[0]
}

/// The degree-`D` Bezier curve with the `D + 1` control points `ctrl` at `u`: the point and
/// its first and second derivatives times `scale` and `scale²` (a chain's segment of length
/// `1 / scale` gives them with respect to the chain's parameter), those above `order` zero.
/// By the Horner-like scheme on the control points and their differences (the hodographs').
#[inline(always)]
#[must_use]
pub fn curve_jet<P: Vector, const D: usize>(ctrl: &[P], u: f64, order: usize, scale: f64) -> [P; 3] {
    debug_assert_eq!(
        ctrl.len(),
        D + 1,
        "curve_jet: {} points for degree {D}",
        ctrl.len()
    );
    // A slice of constant length: the table row and every loop bound below are constants.
    let (d, c, h) = (D, &ctrl[..=D], scale);
    let v = 1.0 - u;
    let mut out = [P::ZERO; 3];
    out[0] = horner(c, u, v);
    if order >= 1 && d >= 1 {
        let mut c1 = [P::ZERO; D];
        for i in 0..d {
            c1[i] = c[i + 1] - c[i];
        }
        let df = d as f64;
        out[1] = horner(&c1[..d], u, v) * (df * h);
        if order >= 2 && d >= 2 {
            for i in 0..d - 1 {
                c1[i] = c1[i + 1] - c1[i];
            }
            out[2] = horner(&c1[..d - 1], u, v) * (df * (df - 1.0) * h * h);
        }
    }
    out
}

/// The Bezier curve with control points `c` at `u` (`v = 1 - u`), by the Horner-like scheme
/// for Bernstein sums.
#[inline]
fn horner<P: Vector>(c: &[P], u: f64, v: f64) -> P {
    let row = &BINOMIAL[c.len() - 1];
    let mut acc = c[0];
    let mut pow = 1.0;
    for i in 1..c.len() {
        pow *= u;
        acc = acc * v + c[i] * (row[i] * pow);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    #[test]
    fn binomials_match_pascal() {
        assert_eq!(binomial(5, 2), 10.0);
        assert_eq!(binomial(6, 3), 20.0);
        assert_eq!(binomial(3, 4), 0.0);
        for n in 1..12 {
            for k in 1..n {
                assert_eq!(binomial(n, k), binomial(n - 1, k - 1) + binomial(n - 1, k));
            }
        }
    }

    #[test]
    fn partition_of_unity_and_closed_form() {
        let mut b = [0.0; 8];
        for n in 0..7 {
            for i in 0..=20 {
                let u = i as f64 / 20.0;
                bernstein(n, u, &mut b);
                let sum: f64 = b[..=n].iter().sum();
                assert!((sum - 1.0).abs() < 1e-14);
                for (k, bk) in b[..=n].iter().enumerate() {
                    let exact = binomial(n, k) * u.powi(k as i32) * (1.0 - u).powi((n - k) as i32);
                    assert!((bk - exact).abs() < 1e-14, "n={n} k={k} u={u}");
                }
            }
        }
    }

    #[test]
    fn derivative_matches_finite_differences() {
        let (mut d, mut bp, mut bm) = ([0.0; 8], [0.0; 8], [0.0; 8]);
        let h = 1e-6;
        for n in 1..7 {
            for i in 1..20 {
                let u = i as f64 / 20.0;
                bernstein_deriv(n, u, &mut d);
                bernstein(n, u + h, &mut bp);
                bernstein(n, u - h, &mut bm);
                for k in 0..=n {
                    let fd = (bp[k] - bm[k]) / (2.0 * h);
                    assert!((d[k] - fd).abs() < 1e-7, "n={n} k={k}: {} vs {fd}", d[k]);
                }
                let sum: f64 = d[..=n].iter().sum();
                assert!(
                    sum.abs() < 1e-12,
                    "derivatives of a partition of unity sum to zero"
                );
            }
        }
    }

    /// `d^k/du^k` of `C(n, i) u^i (1 - u)^(n - i)` by Leibniz's rule, in closed form.
    fn exact_deriv(n: usize, i: usize, k: usize, u: f64) -> f64 {
        let falling = |m: usize, p: usize| (0..p).fold(1.0, |f, j| f * (m as f64 - j as f64));
        let pow = |x: f64, e: isize| if e < 0 { 0.0 } else { x.powi(e as i32) };
        (0..=k)
            .map(|m| {
                let a = falling(i, m) * pow(u, i as isize - m as isize);
                let sign = if (k - m).is_multiple_of(2) { 1.0 } else { -1.0 };
                let b = sign * falling(n - i, k - m) * pow(1.0 - u, (n - i) as isize - (k - m) as isize);
                binomial(k, m) * a * b
            })
            .sum::<f64>()
            * binomial(n, i)
    }

    #[test]
    fn the_jet_is_the_closed_form_to_rounding() {
        for n in 0..=7 {
            for s in 0..=16 {
                let u = s as f64 / 16.0;
                let jet = bernstein_jet::<8, 4>(n, u);
                for (k, row) in jet.iter().enumerate() {
                    let scale = 1.0 + (2.0 * n as f64).powi(k as i32);
                    for (i, &got) in row.iter().enumerate() {
                        let want = if i <= n { exact_deriv(n, i, k, u) } else { 0.0 };
                        assert!(
                            (got - want).abs() <= 1e-14 * scale,
                            "n={n} k={k} i={i} u={u}: {got} vs {want}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn levels_values_and_derivatives_come_from_one_recurrence() {
        for n in 0..=9 {
            for s in 0..=12 {
                let u = s as f64 / 12.0 - 0.1;
                let levels = bernstein_levels::<12, 3>(n, u);
                for (k, level) in levels.iter().enumerate() {
                    let mut b = [0.0; 12];
                    if k <= n {
                        bernstein(n - k, u, &mut b);
                    }
                    assert_eq!(level, &b, "n={n} level {k} at {u}, bit for bit");
                }
                let jet = bernstein_jet::<12, 2>(n, u);
                let mut d = [0.0; 12];
                bernstein_deriv(n, u, &mut d);
                assert_eq!(jet[0], levels[0]);
                assert_eq!(jet[1][..=n], d[..=n]);
            }
        }
    }

    fn ctrl(n: usize) -> Vec<DVec2> {
        (0..=n)
            .map(|i| DVec2::new(i as f64 / n.max(1) as f64, (2.3 * i as f64).sin()))
            .collect()
    }

    /// `curve_jet` for a degree known only at run time.
    fn jet_of(c: &[DVec2], u: f64, scale: f64) -> [DVec2; 3] {
        match c.len() - 1 {
            1 => curve_jet::<DVec2, 1>(c, u, 2, scale),
            2 => curve_jet::<DVec2, 2>(c, u, 2, scale),
            3 => curve_jet::<DVec2, 3>(c, u, 2, scale),
            4 => curve_jet::<DVec2, 4>(c, u, 2, scale),
            5 => curve_jet::<DVec2, 5>(c, u, 2, scale),
            6 => curve_jet::<DVec2, 6>(c, u, 2, scale),
            _ => curve_jet::<DVec2, 7>(c, u, 2, scale),
        }
    }

    #[test]
    fn casteljau_horner_and_the_basis_give_one_curve() {
        for n in 1..=7 {
            let c = ctrl(n);
            for s in 0..=20 {
                let u = s as f64 / 20.0;
                let mut pts = c.clone();
                let p = casteljau(&mut pts, u);
                let b = bernstein_jet::<8, 3>(n, u);
                let jet = jet_of(&c, u, 2.5);
                assert!((p - combine(&c, &b[0])).length() < 1e-15, "n={n} u={u}");
                assert!((jet[0] - p).length() < 1e-15, "n={n} u={u}");
                assert!((jet[1] - combine(&c, &b[1]) * 2.5).length() < 1e-12);
                assert!((jet[2] - combine(&c, &b[2]) * 6.25).length() < 1e-10);
            }
            // The triangle's levels end in the point; its edges are the split's control points.
            let mut pts = c.clone();
            let mut firsts = Vec::new();
            let p = casteljau_with(&mut pts, 0.3, DVec2::lerp_to, |l: &[DVec2]| firsts.push(l[0]));
            assert_eq!(firsts.len(), n);
            assert_eq!(firsts[n - 1], p);
        }
    }

    #[test]
    fn the_tensor_jet_is_the_sum_of_basis_products() {
        let (du, dv, stride) = (3, 2, 5);
        let net: Vec<DVec3> = (0..(du + 1) * stride)
            .map(|k| DVec3::new(k as f64, (k * k % 7) as f64, (0.4 * k as f64).cos()))
            .collect();
        for (u, v) in [(0.0, 0.0), (0.3, 0.8), (1.0, 0.45), (0.61, 1.0)] {
            let bu = bernstein_jet::<4, 4>(du, u);
            let bv = bernstein_jet::<4, 4>(dv, v);
            let jet =
                tensor_jet::<DVec3, 4, 4>(&net, stride, (du + 1, dv + 1), bu.each_ref(), bv.each_ref(), 3);
            for a in 0..4 {
                for b in 0..4 {
                    let mut want = DVec3::ZERO;
                    if a + b <= 3 {
                        for i in 0..=du {
                            for j in 0..=dv {
                                want += net[i * stride + j] * (bu[a][i] * bv[b][j]);
                            }
                        }
                    }
                    assert!((jet[a][b] - want).length() < 1e-12, "({a}, {b}) at ({u}, {v})");
                }
            }
        }
    }
}
