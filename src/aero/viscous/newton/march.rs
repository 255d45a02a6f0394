//! Marching along the surfaces: the boundary layer's start (each station by its own Newton
//! solve on the inviscid edge speed, mfoil's `init_boundary_layer`) and transition (the
//! amplification factor marched from the stagnation point, mfoil's `update_transition`).

use super::{fd_step, norm, System};
use crate::aero::viscous::closures::{self as c, Kind};
use crate::aero::viscous::dual::lift;
use crate::aero::viscous::equations::{self as eq, State};

impl System<'_> {
    /// March the amplification factor along a surface from its stagnation point; the last
    /// laminar position in the list (writing the factors it passes).
    fn march_amplification(&mut self, s: usize) -> usize {
        let l = self.surf[s].clone();
        let sst = self.sstag(&self.u);
        self.u[l[0]][2] = 0.0;
        for k in 1..l.len() {
            let (a, b) = (l[k - 1], l[k]);
            let x = [self.xi(a, sst), self.xi(b, sst)];
            if self.forced_s[s].is_finite() && x[1] >= (self.forced_s[s] - sst).abs() {
                return k - 1;
            }
            let u1 = self.u[a];
            let mut u2 = self.u[b];
            if self.turb[b] {
                u2[2] = u1[2] * 1.01;
            }
            let dx = x[1] - x[0];
            for it in 0..20 {
                let r = |v: f64| {
                    let mut w = u2;
                    w[2] = v;
                    w[2] - u1[2] - c::damp_interval(&lift(&u1), &lift(&w), &self.fl).v * dx
                };
                let r0 = r(u2[2]);
                if r0.abs() < 1e-12 {
                    break;
                }
                let h = fd_step(u2[2], 2);
                let dr = (r(u2[2] + h) - r0) / h;
                let mut d = -r0 / dr;
                let dmax = 0.5 * (1.01 - it as f64 / 20.0);
                if d.abs() > dmax {
                    d *= dmax / d.abs();
                }
                u2[2] += d;
            }
            if !(u2[2] <= self.fl.ncrit) {
                return k - 1;
            }
            self.u[b][2] = u2[2];
        }
        l.len() - 1
    }

    /// Re-march transition on both surfaces and flip the stations between the old and new
    /// transition points (mfoil's `update_transition`).
    pub(super) fn update_transition(&mut self) {
        for s in 0..2 {
            let l = self.surf[s].clone();
            let ilam0 = l
                .iter()
                .position(|&i| self.turb[i])
                .map_or(l.len() - 1, |k| k.max(1) - 1);
            let saved: Vec<f64> = l.iter().map(|&i| self.u[i][2]).collect();
            let ilam = self.march_amplification(s);
            if ilam == ilam0 {
                for (k, &i) in l.iter().enumerate() {
                    self.u[i][2] = saved[k];
                }
                continue;
            }
            if ilam < ilam0 {
                let sa0 = c::plain::cttr(&self.u[l[ilam + 1]], &self.fl);
                let sa1 = if ilam0 + 1 < l.len() {
                    self.u[l[ilam0 + 1]][2]
                } else {
                    sa0
                };
                let sst = self.sstag(&self.u);
                let x0 = self.xi(l[ilam + 1], sst);
                let dx = self.xi(l[(ilam0 + 1).min(l.len() - 1)], sst) - x0;
                for k in ilam + 1..=ilam0 {
                    let f = if dx == 0.0 || k == ilam + 1 {
                        0.0
                    } else {
                        (self.xi(l[k], sst) - x0) / dx
                    };
                    let f = if ilam + 1 == ilam0 { 1.0 } else { f };
                    self.u[l[k]][2] = (sa0 + f * (sa1 - sa0)).max(1e-7);
                    self.turb[l[k]] = true;
                }
            } else {
                for k in ilam0..=ilam {
                    self.turb[l[k]] = false;
                }
            }
        }
    }

    /// March the boundary layer on the inviscid edge speed, each station by Newton (direct,
    /// or inverse with a target `Hk` where the direct march separates), as mfoil starts it.
    pub(super) fn init_boundary_layer(&mut self) {
        self.march_boundary_layer(false);
        // A blunt edge's wake can leave the march with δ* under the gap (fx77w343 at 2°: 0.0371
        // against 0.0386 at its first wake station), which the closures see as a negative
        // thickness: then march again in the thickness they see.
        let under = (self.n..self.u.len()).any(|i| !(self.u[i][1] > self.wgap[i - self.n]));
        if under || !self.residual().iter().all(|v| v.is_finite()) {
            self.march_boundary_layer(true);
        }
    }

    /// The march of [`System::init_boundary_layer`]; with `in_gap`, the wake's stations are
    /// marched in the δ* the closures see (less the blunt edge's dead air, XFOIL's `DSWAKI`),
    /// so that the march's shape limits and inverse targets hold there, the gap added back
    /// when a station is stored.
    fn march_boundary_layer(&mut self, in_gap: bool) {
        let nu = 1.0 / self.fl.re;
        let ueinv = self.ueinv.clone();
        let sst = {
            let (a, b) = (ueinv[self.istag[0]].max(1e-10), ueinv[self.istag[1]].max(1e-10));
            let (sa, sb) = (self.body.s[self.istag[0]], self.body.s[self.istag[1]]);
            (b * sa + a * sb) / (a + b)
        };
        for s in 0..3 {
            let l = self.surf[s].clone();
            let xi: Vec<f64> = l.iter().map(|&i| self.xi(i, sst)).collect();
            let uemax = l.iter().map(|&i| ueinv[i].abs()).fold(0.0, f64::max);
            let ue: Vec<f64> = l.iter().map(|&i| ueinv[i].max(1e-8 * uemax)).collect();
            let mut kind = if s == 2 { Kind::WAKE } else { Kind::LAMINAR };
            if s < 2 {
                let k = ue[0] / xi[0];
                let th = (0.45 * nu / (6.0 * k)).sqrt();
                let mut ust = [th, 2.2 * th, 0.0, k * eq::XST];
                for _ in 0..20 {
                    let r = eq::similarity(&self.fl, &ust);
                    if norm(&r) < 1e-10 {
                        break;
                    }
                    let a = fd3(&|v: &State| eq::similarity(&self.fl, v), &ust, 3);
                    let Some(d) = solve_small(&a, &r) else { break };
                    let dm = (d[0] / ust[0]).abs().max((d[1] / ust[1]).abs());
                    let om = if dm < 0.2 { 1.0 } else { 0.2 / dm };
                    for q in 0..3 {
                        ust[q] -= om * d[q];
                    }
                }
                self.u[l[0]] = [ust[0], ust[1], 0.0, ue[0]];
            } else {
                let (ut, lt) = (
                    *self.surf[0].last().unwrap_or(&0),
                    *self.surf[1].last().unwrap_or(&0),
                );
                let w = eq::wake_start(
                    &self.fl,
                    (&self.u[ut], self.turb[ut]),
                    (&self.u[lt], self.turb[lt]),
                    self.body.gap,
                );
                self.u[l[0]] = [w[0], w[1], w[2], ue[0]];
                self.turb[l[0]] = true;
            }
            let mut tran = false;
            let mut k = 1;
            while k < l.len() {
                let (a, b) = (l[k - 1], l[k]);
                let x = [xi[k - 1], xi[k]];
                let g = if s == 2 {
                    [self.wgap[a - self.n], self.wgap[b - self.n]]
                } else {
                    [0.0; 2]
                };
                let with_gap = |v: &State, gap: f64| -> State {
                    let mut w = *v;
                    if in_gap {
                        w[1] += gap;
                    }
                    w
                };
                let u1 = with_gap(&self.u[a], -g[0]);
                let mut u2 = u1;
                u2[3] = ue[k];
                if tran {
                    u2[2] = c::plain::cttr(&u2, &self.fl);
                }
                self.turb[b] = tran || kind.turb;
                let forced = (self.forced_s[s.min(1)] - sst).abs();
                let res = |v: &State| -> [f64; 3] {
                    if tran {
                        let free = eq::transition_point(&self.fl, x, &u1, v).unwrap_or(x[1]);
                        let xt = if s < 2 && self.forced_s[s].is_finite() {
                            free.min(forced.max(x[0]))
                        } else {
                            free
                        };
                        eq::transition(&self.fl, x, xt, &u1, v)
                    } else {
                        eq::interval(
                            &self.fl,
                            kind,
                            false,
                            x,
                            &with_gap(&u1, g[0]),
                            &with_gap(v, g[1]),
                            g,
                        )
                    }
                };
                let turb_now = tran || kind.turb;
                let hmax = if turb_now { 2.5 } else { 3.8 };
                let mut direct = true;
                let mut hktgt = 0.0;
                let mut ok = false;
                for it in 0..30 {
                    let r = res(&u2);
                    if norm(&r) < 1e-10 {
                        ok = true;
                        break;
                    }
                    let d: [f64; 4] = if direct {
                        let a3 = fd3(&res, &u2, 3);
                        match solve_small(&a3, &r) {
                            Some(d) => [-d[0], -d[1], -d[2], 0.0],
                            None => break,
                        }
                    } else {
                        let a4 = fd34(&res, &u2);
                        let hk = c::plain::h(&u2);
                        let rr = [r[0], r[1], r[2], hk - hktgt];
                        match solve4(&a4, &[1.0 / u2[0] * -hk, 1.0 / u2[0], 0.0, 0.0], &rr) {
                            Some(d) => [-d[0], -d[1], -d[2], -d[3]],
                            None => break,
                        }
                    };
                    let mut dm = (d[0] / u1[0]).abs().max((d[1] / u1[1]).abs());
                    if !direct {
                        dm = dm.max((d[3] / u1[3]).abs());
                    }
                    if turb_now {
                        dm = dm.max((d[2] / u1[2].max(1e-7)).abs());
                    } else if direct {
                        dm = dm.max((d[2] / 10.0).abs());
                    }
                    let om = if dm > 0.3 { 0.3 / dm } else { 1.0 };
                    let mut ui = u2;
                    for q in 0..4 {
                        ui[q] += om * d[q];
                    }
                    if turb_now {
                        ui[2] = ui[2].clamp(1e-7, 0.3);
                    }
                    let hk = c::plain::h(&ui);
                    if direct && (hk > hmax || it > 12) {
                        direct = false;
                        let hk0 = c::plain::h(&u1);
                        let hkr = (x[1] - x[0]) / u1[0];
                        hktgt = if kind.wake {
                            let mut h2 = hk0;
                            for _ in 0..6 {
                                h2 -= (h2 + 0.03 * hkr * (h2 - 1.0).powi(3) - hk0)
                                    / (1.0 + 0.09 * hkr * (h2 - 1.0).powi(2));
                            }
                            h2.max(1.01)
                        } else if turb_now {
                            (hk0 - 0.15 * hkr).max(hmax)
                        } else {
                            (hk0 + 0.03 * hkr).max(hmax)
                        };
                        if it > 12 {
                            u2 = u1;
                            u2[3] = ue[k];
                        }
                    } else {
                        u2 = ui;
                    }
                }
                if !ok && !u2.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    u2 = u1;
                    u2[3] = ue[k];
                    let f = (x[1] / x[0]).sqrt();
                    u2[0] *= f;
                    u2[1] *= f;
                }
                if !kind.turb && !tran && s < 2 {
                    let forced_here = self.forced_s[s].is_finite() && x[1] >= forced;
                    if u2[2] > self.fl.ncrit || forced_here {
                        tran = true;
                        continue;
                    }
                }
                self.u[b] = with_gap(&u2, g[1]);
                if tran {
                    kind = Kind::TURBULENT;
                    tran = false;
                }
                k += 1;
            }
        }
        self.stagnation_move();
    }
}

/// Forward-difference partials of a 3-vector function in the first `k` state components
/// (columns `k..N` stay zero).
fn fd<const N: usize>(f: &dyn Fn(&State) -> [f64; 3], u: &State, k: usize) -> [[f64; N]; 3] {
    let base = f(u);
    let mut a = [[0.0; N]; 3];
    for q in 0..k.min(N) {
        let mut v = *u;
        let h = fd_step(v[q], q);
        v[q] += h;
        let r = f(&v);
        for e in 0..3 {
            a[e][q] = (r[e] - base[e]) / h;
        }
    }
    a
}

/// [`fd`] in the first `k` of three components.
fn fd3(f: &dyn Fn(&State) -> [f64; 3], u: &State, k: usize) -> [[f64; 3]; 3] {
    fd(f, u, k)
}

/// [`fd`] in all four components (3 × 4).
fn fd34(f: &dyn Fn(&State) -> [f64; 3], u: &State) -> [[f64; 4]; 3] {
    fd(f, u, 4)
}

fn solve_small(a: &[[f64; 3]; 3], r: &[f64; 3]) -> Option<[f64; 3]> {
    let m = nalgebra::Matrix3::from_fn(|i, j| a[i][j]);
    let x = m.lu().solve(&nalgebra::Vector3::new(r[0], r[1], r[2]))?;
    x.iter().all(|v| v.is_finite()).then(|| [x[0], x[1], x[2]])
}

/// Solve the 3 × 4 system with a fourth row `last`.
fn solve4(a: &[[f64; 4]; 3], last: &[f64; 4], r: &[f64; 4]) -> Option<[f64; 4]> {
    let m = nalgebra::Matrix4::from_fn(|i, j| if i < 3 { a[i][j] } else { last[j] });
    let x = m.lu().solve(&nalgebra::Vector4::new(r[0], r[1], r[2], r[3]))?;
    x.iter().all(|v| v.is_finite()).then(|| [x[0], x[1], x[2], x[3]])
}
