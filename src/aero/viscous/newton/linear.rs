//! The linear solve of one Newton step: block forward substitution through the boundary-layer
//! partials `B`, then the dense Schur complement in `uₑ`, with the whole Jacobian factored
//! densely as the fallback (the layout of the system: [`super`]). The block factorisation is
//! kept ([`Factored`]) so that later steps on the same layout can reuse it (chord steps).

use super::{Partials, System};
use crate::numeric::Lu;
use nalgebra::{DMatrix, DVector};

/// Rows of `M` per band of the Schur complement's product.
const BAND: usize = 32;

/// One unit of the forward substitution: a station, or a surface's first two stations together,
/// with the LU factors of its diagonal block of `B` (`k = 3 · len` rows).
#[derive(Debug)]
struct Unit {
    stations: [usize; 2],
    len: usize,
    /// Unit lower factor (below the diagonal), upper factor (on and above it).
    l: [[f64; 6]; 6],
    u: [[f64; 6]; 6],
    /// The row permutation: factored row `r` is the unit's row `order[r]`.
    order: [usize; 6],
}

impl Unit {
    fn stations(&self) -> &[usize] {
        &self.stations[..self.len]
    }

    /// The unit's global rows (3 per station), in its own order.
    fn rows(&self) -> [usize; 6] {
        let mut rows = [0; 6];
        for (ui, row) in rows.iter_mut().enumerate().take(3 * self.len) {
            *row = 3 * self.stations[ui / 3] + ui % 3;
        }
        rows
    }

    /// Divide the diagonal block out of `w`-wide rows held in `buf`, one per unit row in the
    /// factored (permuted) order: forward through `l`, back through `u`.
    fn divide(&self, buf: &mut [f64], w: usize) {
        let k = 3 * self.len;
        for i in 0..k {
            let (head, tail) = buf.split_at_mut((i + 1) * w);
            let bi = &head[i * w..];
            for (r, br) in tail.chunks_mut(w).take(k - i - 1).enumerate() {
                let f = self.l[i + 1 + r][i];
                for (y, c) in br.iter_mut().zip(bi) {
                    *y -= c * f;
                }
            }
        }
        for i in (0..k).rev() {
            let (head, tail) = buf.split_at_mut(i * w);
            let bi = &mut tail[..w];
            for v in bi.iter_mut() {
                *v /= self.u[i][i];
            }
            for (r, br) in head.chunks_mut(w).enumerate() {
                let f = self.u[r][i];
                for (y, c) in br.iter_mut().zip(bi.iter()) {
                    *y -= c * f;
                }
            }
        }
    }
}

/// A Newton step's Jacobian, factored: `X = B⁻¹ C` by block forward substitution and the LU
/// factors of the Schur complement `S` in `uₑ`. `Factored::solve` solves it for any residual.
#[derive(Debug)]
pub struct Factored {
    jac: Vec<Partials>,
    units: Vec<Unit>,
    /// Each station's unit, as an index into `units`.
    unit_of: Vec<usize>,
    /// `X`, compact: station `i`'s three rows over its span only, row `e` at
    /// `x[off[i] + e·w..][..w]` with `w` the span's width.
    x: Vec<f64>,
    off: Vec<usize>,
    span: Vec<(usize, usize)>,
    s: Lu,
    /// The edge speeds the Jacobian was taken at.
    ue: Vec<f64>,
    /// The layout it was taken on: the stagnation nodes and the turbulent stations.
    istag: [usize; 2],
    turb: Vec<bool>,
}

impl System<'_> {
    /// Block forward substitution through `B`, then the dense Schur complement in `uₑ`,
    /// factored; the partials handed back where `B` is not block-triangular in marching order
    /// or a block (or `S`) is singular.
    ///
    /// `X = B⁻¹ C` is kept row by row, each station's three rows only over the span of `uₑ`
    /// columns it can reach: the hull of its own `C` columns and the spans of the stations
    /// upstream of it (a surface station reaches its surface up to the stagnation point, the
    /// wake everything upstream), about a third of the dense block's entries.
    pub(super) fn factor(&self, jac: Vec<Partials>) -> Result<Factored, Vec<Partials>> {
        let nt = self.u.len();
        let mut x: Vec<f64> = Vec::with_capacity(nt * nt);
        let mut off = vec![0usize; nt];
        let mut span = vec![(0usize, 0usize); nt];
        let mut unit_of = vec![usize::MAX; nt];
        // Units in dependency order: each surface's first two stations together.
        let mut order: Vec<([usize; 2], usize)> = Vec::with_capacity(nt);
        for s in 0..2 {
            let l = &self.surf[s];
            order.push(([l[0], l[1]], 2));
            order.extend(l[2..].iter().map(|&i| ([i, i], 1)));
        }
        order.extend(self.surf[2].iter().map(|&i| ([i, i], 1)));
        let mut units = Vec::with_capacity(order.len());
        for (ku, &(stations, len)) in order.iter().enumerate() {
            let unit = &stations[..len];
            let done = |j: usize| unit_of[j] < ku;
            // The unit's span: its C columns and its done dependencies' spans.
            let (mut lo, mut hi) = (nt, 0);
            for &i in unit {
                for &(j, ref p) in &jac[i] {
                    if p.iter().any(|row| row[3] != 0.0) {
                        (lo, hi) = (lo.min(j), hi.max(j + 1));
                    }
                    if !unit.contains(&j) && done(j) && span[j].0 < span[j].1 {
                        (lo, hi) = (lo.min(span[j].0), hi.max(span[j].1));
                    }
                }
            }
            let hi = hi.max(lo);
            let w = hi - lo;
            // The unit's rows of X before B's diagonal block is divided out: C less the done
            // stations' B entries times their solved rows.
            let mut a = [[0.0; 6]; 6];
            for &i in unit {
                off[i] = x.len();
                x.resize(x.len() + 3 * w, 0.0);
                for &(j, ref p) in &jac[i] {
                    for e in 0..3 {
                        if p[e][3] != 0.0 {
                            x[off[i] + e * w + j - lo] += p[e][3];
                        }
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
                    } else if done(j) {
                        let (jl, jh) = span[j];
                        let wj = jh - jl;
                        if wj == 0 {
                            continue;
                        }
                        // j is done, so its rows lie before i's.
                        let (done_rows, rows_i) = x.split_at_mut(off[i]);
                        for e in 0..3 {
                            let dst = &mut rows_i[e * w + jl - lo..][..wj];
                            for q in 0..3 {
                                let f = p[e][q];
                                if f == 0.0 {
                                    continue;
                                }
                                let src = &done_rows[off[j] + q * wj..][..wj];
                                for (d, s) in dst.iter_mut().zip(src) {
                                    *d -= f * s;
                                }
                            }
                        }
                    } else if p.iter().any(|row| row[..3].iter().any(|&w| w != 0.0)) {
                        // A station downstream in the order: B is not block-triangular here.
                        return Err(jac);
                    }
                    // Otherwise only its uₑ enters (the stagnation point): in C, not B.
                }
            }
            // B's diagonal block, factored.
            let k = 3 * len;
            let lu = DMatrix::from_fn(k, k, |i, j| a[i][j]).lu();
            if !lu.is_invertible() {
                return Err(jac);
            }
            let (l, u) = (lu.l(), lu.u());
            let mut perm = DVector::from_fn(k, |i, _| i as f64);
            lu.p().permute_rows(&mut perm);
            let mut unit = Unit {
                stations,
                len,
                l: [[0.0; 6]; 6],
                u: [[0.0; 6]; 6],
                order: [0; 6],
            };
            for i in 0..k {
                unit.order[i] = perm[i] as usize;
                for j in 0..k {
                    unit.l[i][j] = l[(i, j)];
                    unit.u[i][j] = u[(i, j)];
                }
            }
            // ... and divided out of the unit's rows of X.
            // The unit's rows are consecutive in x, its own row r at base + r·w.
            if w > 0 {
                let base = off[stations[0]];
                let mut buf = vec![0.0; k * w];
                for (r, b) in buf.chunks_mut(w).enumerate() {
                    b.copy_from_slice(&x[base + unit.order[r] * w..][..w]);
                }
                unit.divide(&mut buf, w);
                x[base..base + k * w].copy_from_slice(&buf);
            }
            for &i in unit.stations() {
                span[i] = (lo, hi);
                unit_of[i] = ku;
            }
            units.push(unit);
        }
        // S = I − D M with M = diag δ* − diag uₑ X_δ* (column-major), M taken in bands of
        // rows over their spans' hull: a surface's rows reach back to the stagnation point
        // only, so the bands skip about half of the dense product.
        let mut s = vec![0.0; nt * nt];
        for i in 0..nt {
            s[i + i * nt] = 1.0;
        }
        let mut band = Vec::new();
        for r0 in (0..nt).step_by(BAND) {
            let r1 = (r0 + BAND).min(nt);
            let (lo, hi) = (r0..r1).fold((nt, 0), |(lo, hi), i| {
                (lo.min(span[i].0).min(i), hi.max(span[i].1).max(i + 1))
            });
            let (c, w) = (r1 - r0, hi - lo);
            band.clear();
            band.resize(c * w, 0.0);
            for i in r0..r1 {
                let (il, ih) = span[i];
                let ue = self.u[i][3];
                let xr = &x[off[i] + (ih - il)..][..ih - il];
                for (j, v) in (il..ih).zip(xr) {
                    band[(i - r0) + (j - lo) * c] = -ue * v;
                }
                band[(i - r0) + (i - lo) * c] += self.u[i][1];
            }
            let d = &self.d.as_slice()[r0 * nt..r1 * nt];
            crate::numeric::gemm([nt, c, w], -1.0, d, &band, 1.0, &mut s[lo * nt..hi * nt]);
        }
        let Some(s) = Lu::factor(nt, s) else {
            return Err(jac);
        };
        Ok(Factored {
            jac,
            units,
            unit_of,
            x,
            off,
            span,
            s,
            ue: self.u.iter().map(|s| s[3]).collect(),
            istag: self.istag,
            turb: self.turb.clone(),
        })
    }

    /// One Newton step's update by the block factorisation (kept, for later steps), else by
    /// the dense fallback.
    pub(super) fn solve_fresh(
        &self,
        jac: Vec<Partials>,
        r: &[f64],
    ) -> (Option<Factored>, Option<Vec<[f64; 4]>>) {
        match self.factor(jac) {
            Ok(f) => match f.solve(&self.d, r) {
                Some(du) => (Some(f), Some(du)),
                None => {
                    let du = self.dense(&f.jac, r);
                    (None, du)
                }
            },
            Err(jac) => (None, self.dense(&jac, r)),
        }
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

impl Factored {
    /// The stations the factorisation was taken over.
    pub(super) fn len(&self) -> usize {
        self.ue.len()
    }

    /// Whether it was taken on `sys`'s layout (the same stations, stagnation nodes and
    /// turbulent stations), so that it can stand for `sys`'s Jacobian in a chord step.
    pub(super) fn fits(&self, sys: &System<'_>) -> bool {
        self.len() == sys.u.len() && self.istag == sys.istag && self.turb == sys.turb
    }

    /// The update `Δ[θ, δ*, s, uₑ]` per station for residual `r`: `z = B⁻¹ r` by the stored
    /// forward substitution, `Δuₑ` from `S`, then `Δ(θ, δ*, s) = −z − X Δuₑ`.
    pub(super) fn solve(&self, d: &DMatrix<f64>, r: &[f64]) -> Option<Vec<[f64; 4]>> {
        let nt = self.len();
        let mut z = r[..3 * nt].to_vec();
        for (ku, unit) in self.units.iter().enumerate() {
            for &i in unit.stations() {
                for &(j, ref p) in &self.jac[i] {
                    if self.unit_of[j] >= ku {
                        continue;
                    }
                    for e in 0..3 {
                        for q in 0..3 {
                            z[3 * i + e] -= p[e][q] * z[3 * j + q];
                        }
                    }
                }
            }
            let k = 3 * unit.len;
            let rows = unit.rows();
            let mut buf = [0.0; 6];
            for r in 0..k {
                buf[r] = z[rows[unit.order[r]]];
            }
            unit.divide(&mut buf[..k], 1);
            for r in 0..k {
                z[rows[r]] = buf[r];
            }
        }
        // rhs = −q − D (uₑ ∘ z_δ*).
        let uz = DVector::from_iterator(nt, (0..nt).map(|i| self.ue[i] * z[3 * i + 1]));
        let q = DVector::from_iterator(nt, (0..nt).map(|i| r[3 * nt + i]));
        let rhs = -q - d * uz;
        let du = self.s.solve(rhs.as_slice())?;
        let mut out = vec![[0.0; 4]; nt];
        for i in 0..nt {
            let (lo, hi) = self.span[i];
            for e in 0..3 {
                let xr = &self.x[self.off[i] + e * (hi - lo)..][..hi - lo];
                let mut v = -z[3 * i + e];
                for (a, b) in xr.iter().zip(&du[lo..hi]) {
                    v -= a * b;
                }
                out[i][e] = v;
            }
            out[i][3] = du[i];
        }
        out.iter().all(|o| o.iter().all(|v| v.is_finite())).then_some(out)
    }
}
