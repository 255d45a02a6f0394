//! The inviscid side of the coupling: the body's panel system kept factored, the wake streamline
//! behind the trailing edge, and how sources (the boundary layer's mass defect,
//! `σ = d(uₑ δ*)/dξ`) on the body and in the wake change the edge speed at every station.
//!
//! Body panels carry XFOIL's source distribution (`PSILIN`): linear over each half-panel, its
//! density at a panel's midpoint the mass defect's difference over the panel and at a node its
//! difference over the node's two panels; the wake's panels (between consecutive wake nodes)
//! carry the same distribution (`PSWLIN`), their stream function at the body cut along each
//! panel's own line downstream. Everything is in unit-chord coordinates centred on the
//! mid-chord.
//!
//! The half-panel distribution is what makes a short laminar bubble behind the leading edge come
//! out as XFOIL's at 160 nodes: with a uniform source per panel, SD7080's lower surface at −2°
//! peaked at `H` 4.5 against XFOIL's 5.9 and went turbulent at 0.107 chord against 0.055;
//! with it, 0.0545 (both codes near 0.13 at 320 nodes). In the wake, one uniform source cell
//! around each wake node left the thickest blunt sections' CL up to 12 % (of 0.5) off XFOIL's
//! (FX 79-W-660A past 4°); with the half-panels, 2 %.

use crate::aero::panel::{
    end_tangent, half_panel_columns, half_panel_differences, half_panel_unknowns, half_panels, influences,
    seen, sharp_control, wake_half_panels_psi, Chord, Influence, TrailingEdge, UnitSystem, HOPI,
};
use crate::error::{Error, Result};
use glam::DVec2;
use nalgebra::{DMatrix, Dyn, LU};

/// A body's factored panel system and the α-independent source responses.
pub struct Body {
    /// Nodes in unit-chord coordinates.
    pub nodes: Vec<DVec2>,
    /// Arc length at every node from the first.
    pub s: Vec<f64>,
    /// The chord in the same coordinates.
    pub chord: Chord,
    /// The trailing-edge gap across the mean of the end tangents (XFOIL's `ANTE`), unit chord.
    pub gap: f64,
    /// The slope at which the blunt edge's gap opens along the wake: the tangent of the angle
    /// between the two end tangents, negative where the surfaces converge (XFOIL's `DWDXTE`).
    pub dtdx: f64,
    te: TrailingEdge,
    lu: LU<f64, Dyn, Dyn>,
    /// Node speeds at α = 0° and 90°.
    gamma_ref: [Vec<f64>; 2],
    /// Node speed per unit of each body source unknown (N × (2N − 1), [`half_panel_unknowns`]).
    g_body: DMatrix<f64>,
}

/// The wake streamline and every station's edge speed response at one angle.
#[derive(Clone)]
pub struct Wake {
    /// Wake nodes, the first just behind the trailing-edge midpoint.
    pub points: Vec<DVec2>,
    /// Distance along the wake from its first node.
    pub s: Vec<f64>,
    /// Inviscid edge speed: node `γ` on the body (signed along the node order's reverse, as
    /// the panel method gives it), the speed along the wake in the wake.
    pub uinv: Vec<f64>,
    /// Response of the same quantities to the sources, `(N + Nw) × (N − 1 + Nw)`.
    pub u_sigma: DMatrix<f64>,
}

/// Points in the wake for `n` body nodes (mfoil's count over one chord).
pub fn wake_nodes(n: usize) -> usize {
    n / 10 + 10
}

/// `n` points from 0 to `len`, the first interval `d0`, growing geometrically.
fn geometric(d0: f64, len: f64, n: usize) -> Vec<f64> {
    let k = (n - 1) as f64;
    let mut r: f64 = 1.0;
    if d0 * k < len {
        // Σ d0 r^j = len: Newton on f(r) = d0 (r^k − 1)/(r − 1) − len, started large.
        r = 1.5;
        for _ in 0..100 {
            let f = d0 * (r.powf(k) - 1.0) / (r - 1.0) - len;
            let df = d0 * (k * r.powf(k - 1.0) * (r - 1.0) - (r.powf(k) - 1.0)) / ((r - 1.0) * (r - 1.0));
            let step = f / df;
            r = (r - step).max(1.0 + 1e-9);
            if step.abs() < 1e-14 {
                break;
            }
        }
    }
    let mut out = vec![0.0; n];
    let mut d = if r > 1.0 { d0 } else { len / k };
    for i in 1..n {
        out[i] = out[i - 1] + d;
        d *= r;
    }
    out
}

impl Body {
    /// Factor the panel system of `nodes` (counterclockwise from the upper trailing edge, any
    /// units).
    pub fn new(nodes: &[DVec2]) -> Result<Body> {
        let UnitSystem {
            local,
            te,
            lu,
            gamma: gamma_ref,
            sources: b,
            ..
        } = UnitSystem::solve(nodes, true)?;
        let chord = Chord::of(&local);
        let n = local.len();
        let mut s = vec![0.0; n];
        for i in 1..n {
            s[i] = s[i - 1] + (local[i] - local[i - 1]).length();
        }
        // The end tangents as the panel method's trailing edge has them (XFOIL's spline slopes),
        // and the gap across their mean, not normalised: XFOIL's ANTE (fx77w270: 0.041550
        // against its 0.04155; across the chords' unit bisector 0.04175).
        let t1 = end_tangent(local[0], local[1], local[2]);
        let t2 = end_tangent(local[n - 1], local[n - 2], local[n - 3]);
        let gap = (local[0] - local[n - 1]).perp_dot(0.5 * (t1 + t2)).abs();
        // t1 and t2 point downstream: converging surfaces (t1 turning down onto t2) close
        // the gap, a negative slope.
        let cross = t2.perp_dot(t1).clamp(-0.99, 0.99);
        let dtdx = cross / (1.0 - cross * cross).sqrt();
        let sol = lu
            .solve(&b)
            .ok_or_else(|| Error::Numerical("the panel system is singular".into()))?;
        let g_body = -sol.rows(0, n).into_owned();
        if g_body.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical("the source response is not finite".into()));
        }
        Ok(Body {
            nodes: local,
            s,
            chord,
            gap,
            dtdx,
            te,
            lu,
            gamma_ref,
            g_body,
        })
    }

    /// Node speeds at `alpha` degrees.
    pub fn gamma(&self, alpha: f64) -> Vec<f64> {
        let (sn, cs) = alpha.to_radians().sin_cos();
        (0..self.nodes.len())
            .map(|i| cs * self.gamma_ref[0][i] + sn * self.gamma_ref[1][i])
            .collect()
    }

    /// The flow's velocity at `f` (free stream plus the body's sheets; the component along
    /// `t` is `∂Ψ/∂(t⊥)`), with the influences' rows of its two components: the sheets' speed
    /// along any `t` is `t.x` times the first row's plus `t.y` times the second's.
    fn velocity(&self, gamma: &[f64], fs: DVec2, f: DVec2) -> (DVec2, [Influence; 2]) {
        let rows = influences(&self.nodes, &self.te, f, [DVec2::X.perp(), DVec2::Y.perp()], true);
        let dot = |row: &[f64]| row.iter().zip(gamma).map(|(a, g)| a * g).sum::<f64>();
        (
            DVec2::new(fs.x + dot(&rows[0].gamma), fs.y + dot(&rows[1].gamma)),
            rows,
        )
    }

    /// The wake at `alpha` degrees with `nw` nodes over one chord, and the edge speeds'
    /// response to the sources.
    pub fn wake(&self, alpha: f64, nw: usize) -> Result<Wake> {
        let n = self.nodes.len();
        let gamma = self.gamma(alpha);
        let (sn, cs) = alpha.to_radians().sin_cos();
        let fs = DVec2::new(cs, sn);
        let d0 = 0.5
            * ((self.nodes[1] - self.nodes[0]).length() + (self.nodes[n - 1] - self.nodes[n - 2]).length());
        let sw = geometric(d0, 1.0, nw);
        let te_mid = 0.5 * (self.nodes[0] + self.nodes[n - 1]);
        let dir = if self.te.bisector == DVec2::ZERO {
            DVec2::X
        } else {
            self.te.bisector
        };
        let mut pts = vec![te_mid + 1e-5 * dir];
        let mut tan = Vec::with_capacity(nw);
        // The sheets' velocity rows at each node, for the node's own rows below. Each node a
        // step along the flow's direction at the one before (XFOIL's XYWAKE: one velocity a
        // node; a Heun step's second velocity took 10 % of the benchmark's time and moved its
        // points' CD by 2.5e-5 relative).
        let mut at = Vec::with_capacity(nw);
        for i in 0..nw - 1 {
            let (v1, rows) = self.velocity(&gamma, fs, pts[i]);
            let v1 = v1.normalize_or_zero();
            let ds = sw[i + 1] - sw[i];
            tan.push(v1);
            at.push(rows);
            pts.push(pts[i] + ds * v1);
        }
        let (last, rows) = self.velocity(&gamma, fs, pts[nw - 1]);
        tan.push(last.normalize_or_zero());
        at.push(rows);
        if pts.iter().any(|p| !p.is_finite()) || tan.contains(&DVec2::ZERO) {
            return Err(Error::Numerical("the wake streamline could not be traced".into()));
        }
        // Wake panels between consecutive wake nodes, half-panel sources as the body's.
        let cells: Vec<(DVec2, DVec2)> = (0..nw - 1).map(|k| (pts[k], pts[k + 1])).collect();
        let nb = half_panel_unknowns(n);
        let np = nb + nw;
        // The wake's sources from its mass defects: the rows below are taken per source
        // unknown and turned into columns per wake station before the system's solve.
        let sw_of_m = wake_sigma_of_mass(&sw);
        // Body rows: the body sources' part is fixed, the wake's through the system.
        let mut bw = wake_source_rows(&self.nodes, &pts) * &sw_of_m;
        if sharp_control(&self.nodes, &self.te).is_some() {
            // The sharp edge's bisector condition sees the body's sheets and sources only, as
            // XFOIL's (QDCALC): the wake starts at the edge, a tenth of a panel from the
            // control point, where a source's tangential speed is logarithmically large and
            // would set the circulation by the wake's growth.
            bw.row_mut(n - 1).fill(0.0);
        }
        let solw = self
            .lu
            .solve(&bw)
            .ok_or_else(|| Error::Numerical("the panel system is singular".into()))?;
        // The body rows (column-major, n × np): the body sources' response, then the wake
        // stations'.
        let mut body = vec![0.0; n * np];
        body[..nb * n].copy_from_slice(self.g_body.as_slice());
        for k in 0..nw {
            for (b, s) in body[(nb + k) * n..(nb + k + 1) * n]
                .iter_mut()
                .zip(solw.column(k).iter())
            {
                *b = -s;
            }
        }
        // The wake nodes' rows past the first: the sheets' response through the system (one
        // product over all of them) and the sources' direct speeds.
        let mut uinv = gamma.clone();
        uinv.push(gamma[0]);
        let mut rows = vec![0.0; (nw - 1) * n];
        let mut direct = vec![0.0; (nw - 1) * np];
        for k in 1..nw {
            let (f, t) = (pts[k], tan[k]);
            // Along the wake: t.x times the x row plus t.y times the y row.
            let [ax, ay] = &at[k];
            let along = |x: &[f64], y: &[f64], j: usize| t.x * x[j] + t.y * y[j];
            let row: Vec<f64> = (0..n).map(|j| along(&ax.gamma, &ay.gamma, j)).collect();
            uinv.push(fs.dot(t) + row.iter().zip(&gamma).map(|(a, g)| a * g).sum::<f64>());
            for (j, v) in row.iter().enumerate() {
                rows[(k - 1) + j * (nw - 1)] = *v;
            }
            for p in 0..nb {
                direct[(k - 1) + p * (nw - 1)] = HOPI * along(&ax.sigma, &ay.sigma, p);
            }
            let mut own = vec![0.0; half_panel_unknowns(nw)];
            for (j, &(a, b)) in cells.iter().enumerate() {
                for (c, x) in half_panel_columns(nw, j)
                    .into_iter()
                    .zip(half_panels(&seen(f, a, b), t.perp()))
                {
                    own[c] += x;
                }
            }
            for m in 0..nw {
                let v: f64 = (0..own.len()).map(|q| own[q] * sw_of_m[(q, m)]).sum();
                direct[(k - 1) + (nb + m) * (nw - 1)] = HOPI * v;
            }
        }
        crate::numeric::gemm([nw - 1, n, np], 1.0, &rows, &body, 1.0, &mut direct);
        let u_sigma = DMatrix::from_fn(n + nw, np, |i, p| {
            if i < n {
                body[i + p * n]
            } else if i == n {
                // The first wake node takes the upper trailing edge's speed.
                body[p * n]
            } else {
                direct[(i - n - 1) + p * (nw - 1)]
            }
        });
        if u_sigma.iter().any(|v| !v.is_finite()) {
            return Err(Error::Numerical(
                "the wake's source response is not finite".into(),
            ));
        }
        Ok(Wake {
            points: pts,
            s: sw,
            uinv,
            u_sigma,
        })
    }
}

/// The stream function at every body node per unit of each wake source unknown (the
/// midpoints' densities, then the nodes'; [`wake_half_panels_psi`]), as right-hand sides of the
/// panel system (Kutta row zero; a sharp edge's bisector row is zeroed by the caller).
fn wake_source_rows(local: &[DVec2], pts: &[DVec2]) -> DMatrix<f64> {
    let n = local.len();
    let nw = pts.len();
    let mut b = DMatrix::<f64>::zeros(n + 1, half_panel_unknowns(nw));
    let mut row = vec![0.0; half_panel_unknowns(nw)];
    for i in 0..n {
        row.fill(0.0);
        wake_half_panels_psi(local[i], pts, &mut row);
        for (p, v) in row.iter().enumerate() {
            b[(i, p)] = HOPI * v;
        }
    }
    b
}

/// The sources from the mass defects `m = uₑ δ*` at every station (body nodes then wake nodes),
/// `sgn` the body nodes' side (+1 upper, −1 lower): `σ = S m`, as the columns of `S` (each a
/// short list of `(panel, weight)`).
pub fn sigma_of_mass(body_s: &[f64], wake_s: &[f64], sgn: &[f64]) -> Vec<Vec<(usize, f64)>> {
    let n = body_s.len();
    let nw = wake_s.len();
    let mut cols: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n + nw];
    // The body's: σ = −(q_hi − q_lo)/ds, q = sgn m.
    for (p, lo, hi) in half_panel_differences(n) {
        let ds = body_s[hi] - body_s[lo];
        cols[lo].push((p, sgn[lo] / ds));
        cols[hi].push((p, -sgn[hi] / ds));
    }
    let nb = half_panel_unknowns(n);
    // The wake's columns are its stations' own (see `wake_sigma_of_mass`).
    for k in 0..nw {
        cols[n + k].push((nb + k, 1.0));
    }
    cols
}

/// The wake's source unknowns ([`half_panel_unknowns`]) from its stations' mass defects,
/// `(2 Nw − 1) × Nw` ([`half_panel_differences`]).
fn wake_sigma_of_mass(wake_s: &[f64]) -> DMatrix<f64> {
    let nw = wake_s.len();
    let mut m = DMatrix::<f64>::zeros(half_panel_unknowns(nw), nw);
    for (p, lo, hi) in half_panel_differences(nw) {
        let ds = wake_s[hi] - wake_s[lo];
        m[(p, lo)] -= 1.0 / ds;
        m[(p, hi)] += 1.0 / ds;
    }
    m
}

/// The edge-speed response to the mass defects, `D = diag(sgn) · u_σ · S` (stations × stations).
pub fn ue_of_mass(wake: &Wake, body_s: &[f64], sgn: &[f64]) -> DMatrix<f64> {
    let nt = wake.uinv.len();
    let cols = sigma_of_mass(body_s, &wake.s, sgn);
    let mut d = DMatrix::<f64>::zeros(nt, nt);
    for (j, col) in cols.iter().enumerate() {
        for &(p, w) in col {
            for i in 0..nt {
                d[(i, j)] += wake.u_sigma[(i, p)] * w;
            }
        }
    }
    for i in 0..nt {
        let sg = if i < sgn.len() { sgn[i] } else { 1.0 };
        for j in 0..nt {
            d[(i, j)] *= sg;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometric_spacing_spans_the_length() {
        let s = geometric(0.005, 1.0, 26);
        assert!((s[25] - 1.0).abs() < 1e-9 && (s[1] - 0.005).abs() < 1e-12);
    }
}
