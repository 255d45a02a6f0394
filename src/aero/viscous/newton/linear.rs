//! The linear solve of one Newton step: block forward substitution through the boundary-layer
//! partials `B`, then the dense Schur complement in `uₑ`, with the whole Jacobian factored
//! densely as the fallback (the layout of the system: [`super`]).

use super::{Partials, System};
use nalgebra::{DMatrix, DVector};

impl System<'_> {
    /// Block forward substitution through `B`, then the dense Schur complement in `uₑ`.
    ///
    /// `X = B⁻¹ C` is kept row-major, each station's three rows only over the span of `uₑ`
    /// columns it can reach: the hull of its own `C` columns and the spans of the stations
    /// upstream of it (a surface station reaches its surface up to the stagnation point, the
    /// wake everything upstream), about a third of the dense block's entries.
    pub(super) fn schur(&self, jac: &[Partials], r: &[f64]) -> Option<Vec<[f64; 4]>> {
        let nt = self.u.len();
        // Row 3i+e of X at x[(3i+e)·nt + j]; z = B⁻¹ r.
        let mut x = vec![0.0; 3 * nt * nt];
        let mut z = vec![0.0; 3 * nt];
        let mut span = vec![(0usize, 0usize); nt];
        let mut done = vec![false; nt];
        // Units in dependency order: each surface's first two stations together.
        let mut units: Vec<([usize; 2], usize)> = Vec::with_capacity(nt);
        for s in 0..2 {
            let l = &self.surf[s];
            units.push(([l[0], l[1]], 2));
            units.extend(l[2..].iter().map(|&i| ([i, i], 1)));
        }
        units.extend(self.surf[2].iter().map(|&i| ([i, i], 1)));
        for &(stations, len) in &units {
            let unit = &stations[..len];
            // The unit's span: its C columns and its done dependencies' spans.
            let (mut lo, mut hi) = (nt, 0);
            for &i in unit {
                for &(j, ref p) in &jac[i] {
                    if p.iter().any(|row| row[3] != 0.0) {
                        (lo, hi) = (lo.min(j), hi.max(j + 1));
                    }
                    if !unit.contains(&j) && done[j] && span[j].0 < span[j].1 {
                        (lo, hi) = (lo.min(span[j].0), hi.max(span[j].1));
                    }
                }
            }
            let hi = hi.max(lo);
            // The unit's rows of [X z] before B's diagonal block is divided out: C and r less
            // the done stations' B entries times their solved rows.
            let mut a = [[0.0; 6]; 6];
            for &i in unit {
                for e in 0..3 {
                    z[3 * i + e] = r[3 * i + e];
                }
                for &(j, ref p) in &jac[i] {
                    for e in 0..3 {
                        x[(3 * i + e) * nt + j] += p[e][3];
                    }
                }
            }
            for (ui, &i) in unit.iter().enumerate() {
                for &(j, ref p) in &jac[i] {
                    if let Some(uj) = unit.iter().position(|&v| v == j) {
                        for e in 0..3 {
                            for q in 0..3 {
                                a[3 * ui + e][3 * uj + q] += p[e][q];
                            }
                        }
                    } else if done[j] {
                        let (jl, jh) = span[j];
                        for e in 0..3 {
                            for q in 0..3 {
                                let w = p[e][q];
                                if w == 0.0 {
                                    continue;
                                }
                                z[3 * i + e] -= w * z[3 * j + q];
                                if jl < jh {
                                    let (src, dst) = rows2(&mut x, nt, 3 * j + q, 3 * i + e);
                                    for (d, s) in dst[jl..jh].iter_mut().zip(&src[jl..jh]) {
                                        *d -= w * s;
                                    }
                                }
                            }
                        }
                    } else if p.iter().any(|row| row[..3].iter().any(|&w| w != 0.0)) {
                        // A station downstream in the order: B is not block-triangular here.
                        return None;
                    }
                    // Otherwise only its uₑ enters (the stagnation point): in C, not B.
                }
            }
            // B's diagonal block divided out by its LU factors, each column of [X z] taking the
            // operations (and so the round-off) of nalgebra's dense LU solve.
            let k = 3 * len;
            let lu = DMatrix::from_fn(k, k, |i, j| a[i][j]).lu();
            if !lu.is_invertible() {
                return None;
            }
            let (l, u) = (lu.l(), lu.u());
            let mut order = DVector::from_fn(k, |i, _| i as f64);
            lu.p().permute_rows(&mut order);
            let rows: Vec<usize> = (0..k).map(|ui| 3 * unit[ui / 3] + ui % 3).collect();
            let w = hi - lo + 1;
            let mut buf = vec![0.0; k * w];
            for (r, b) in buf.chunks_mut(w).enumerate() {
                let src = rows[order[r] as usize];
                b[0] = z[src];
                b[1..].copy_from_slice(&x[src * nt + lo..src * nt + hi]);
            }
            for i in 0..k {
                let (head, tail) = buf.split_at_mut((i + 1) * w);
                let bi = &head[i * w..];
                for (r, br) in tail.chunks_mut(w).enumerate() {
                    let f = l[(i + 1 + r, i)];
                    for (y, c) in br.iter_mut().zip(bi) {
                        *y -= c * f;
                    }
                }
            }
            for i in (0..k).rev() {
                let (head, tail) = buf.split_at_mut(i * w);
                let bi = &mut tail[..w];
                for v in bi.iter_mut() {
                    *v /= u[(i, i)];
                }
                for (r, br) in head.chunks_mut(w).enumerate() {
                    let f = u[(r, i)];
                    for (y, c) in br.iter_mut().zip(bi.iter()) {
                        *y -= c * f;
                    }
                }
            }
            for (r, b) in buf.chunks(w).enumerate() {
                let dst = rows[r];
                z[dst] = b[0];
                x[dst * nt + lo..dst * nt + hi].copy_from_slice(&b[1..]);
            }
            for &i in unit {
                span[i] = (lo, hi);
                done[i] = true;
            }
        }
        // S = I − D (diag δ* − diag uₑ X_δ*), rhs = −q − D (uₑ ∘ z_δ*).
        let mut m2 = DMatrix::<f64>::zeros(nt, nt);
        let mut uz = DVector::<f64>::zeros(nt);
        for i in 0..nt {
            let ue = self.u[i][3];
            let (lo, hi) = span[i];
            let xr = &x[(3 * i + 1) * nt..(3 * i + 2) * nt];
            for j in lo..hi {
                m2[(i, j)] = -ue * xr[j];
            }
            m2[(i, i)] += self.u[i][1];
            uz[i] = ue * z[3 * i + 1];
        }
        let mut s = &self.d * m2;
        s.neg_mut();
        for i in 0..nt {
            s[(i, i)] += 1.0;
        }
        let q = DVector::from_iterator(nt, (0..nt).map(|i| r[3 * nt + i]));
        let rhs = -q - &self.d * uz;
        let du = s.lu().solve(&rhs)?;
        let mut out = vec![[0.0; 4]; nt];
        for i in 0..nt {
            let (lo, hi) = span[i];
            for e in 0..3 {
                let xr = &x[(3 * i + e) * nt + lo..(3 * i + e) * nt + hi];
                let mut v = -z[3 * i + e];
                for (a, b) in xr.iter().zip(&du.as_slice()[lo..hi]) {
                    v -= a * b;
                }
                out[i][e] = v;
            }
            out[i][3] = du[i];
        }
        out.iter().all(|o| o.iter().all(|v| v.is_finite())).then_some(out)
    }

    /// The whole Jacobian factored densely (the fallback).
    pub(super) fn dense(&self, jac: &[Partials], r: &[f64]) -> Option<Vec<[f64; 4]>> {
        let nt = self.u.len();
        let mut a = DMatrix::<f64>::zeros(4 * nt, 4 * nt);
        for i in 0..nt {
            for &(j, p) in &jac[i] {
                for e in 0..3 {
                    for q in 0..4 {
                        a[(3 * i + e, 4 * j + q)] += p[e][q];
                    }
                }
            }
        }
        for i in 0..nt {
            let row = 3 * nt + i;
            a[(row, 4 * i + 3)] += 1.0;
            for j in 0..nt {
                a[(row, 4 * j + 3)] -= self.d[(i, j)] * self.u[j][1];
                a[(row, 4 * j + 1)] -= self.d[(i, j)] * self.u[j][3];
            }
        }
        let b = DVector::from_iterator(4 * nt, r.iter().map(|v| -v));
        let sol = a.lu().solve(&b)?;
        let out: Vec<[f64; 4]> = (0..nt)
            .map(|i| [sol[4 * i], sol[4 * i + 1], sol[4 * i + 2], sol[4 * i + 3]])
            .collect();
        out.iter().all(|o| o.iter().all(|v| v.is_finite())).then_some(out)
    }
}

/// Row `src` (shared) and row `dst` (mutable) of a row-major matrix with `nt` columns.
fn rows2(x: &mut [f64], nt: usize, src: usize, dst: usize) -> (&[f64], &mut [f64]) {
    debug_assert_ne!(src, dst);
    if src < dst {
        let (a, b) = x.split_at_mut(dst * nt);
        (&a[src * nt..(src + 1) * nt], &mut b[..nt])
    } else {
        let (a, b) = x.split_at_mut(src * nt);
        (&b[..nt], &mut a[dst * nt..(dst + 1) * nt])
    }
}
