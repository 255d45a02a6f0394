//! The Bernstein basis (paper eq. 1) and its derivative (eq. 2).

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

/// Fill `out[0..=n]` with the degree-`n` Bernstein polynomials `B_{i,n}(u)`.
///
/// Computed by the triangular recurrence (de Casteljau on the basis), which is stable on
/// `[0, 1]` and costs `n (n + 1) / 2` multiply-adds.
pub fn bernstein(n: usize, u: f64, out: &mut [f64]) {
    debug_assert!(out.len() > n, "bernstein: output slice too short for degree {n}");
    let v = 1.0 - u;
    out[0] = 1.0;
    for j in 1..=n {
        let mut saved = 0.0;
        for k in 0..j {
            let tmp = out[k];
            out[k] = saved + v * tmp;
            saved = u * tmp;
        }
        out[j] = saved;
    }
}

/// Fill `out[0..=n]` with `d/du B_{i,n}(u) = n (B_{i-1,n-1}(u) - B_{i,n-1}(u))` (eq. 2).
pub fn bernstein_deriv(n: usize, u: f64, out: &mut [f64]) {
    debug_assert!(
        out.len() > n,
        "bernstein_deriv: output slice too short for degree {n}"
    );
    if n == 0 {
        out[0] = 0.0;
        return;
    }
    let mut low = [0.0; 32];
    debug_assert!(n <= 32, "bernstein_deriv: degree {n} above 32");
    bernstein(n - 1, u, &mut low);
    let nf = n as f64;
    for i in 0..=n {
        let a = if i > 0 { low[i - 1] } else { 0.0 };
        let b = if i < n { low[i] } else { 0.0 };
        out[i] = nf * (a - b);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
