//! The coupled viscous–inviscid system at one angle and its Newton solution: per station the
//! state `[θ, δ*, s, uₑ]`, three boundary-layer equations and the edge-speed equation
//! `uₑ = uₑ,inv + D (uₑ δ*)`, all solved together (mfoil's global formulation of XFOIL's
//! method); the stagnation point moves with the solution and transition is re-marched after
//! every step.
//!
//! **Linear solve.** The Jacobian is `[B C; E F]`: `B` the boundary-layer equations' partials
//! in `(θ, δ*, s)`, block lower-triangular in marching order (each station couples to the one
//! upstream), `C` their partials in `uₑ` (a few per row), `E = −D diag(uₑ)` and
//! `F = I − D diag(δ*)` dense. `B` is eliminated by block forward substitution and the dense
//! Schur complement in `uₑ` (stations × stations) is factored ([`crate::numeric::Lu`]); a full
//! dense factorisation is the fallback when a block of `B` is singular. The factorisation is
//! kept for chord steps while they converge fast enough (`CHORD_RATE`). Partials of the
//! interval equations (laminar, turbulent, wake: all rows but a few) are exact, by dual numbers
//! through the closures ([`super::dual`]); the similarity, transition and wake-start rows take
//! forward differences of the station functions (relative step 1e-7).
//!
//! **Start and transition.** The march that starts the boundary layer and the amplification
//! factor's march that places transition are in `march.rs`.

use super::closures::{self as c, Du, Fluid, Kind};
use super::coupling::{ue_of_mass, Body, Wake};
use super::dual::D;
use super::equations::{self as eq, State};
pub use linear::Factored;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

mod linear;
mod march;

/// Which of a station's equations a row block holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Row {
    /// The similarity station of a surface: `(first, second)` stations.
    Similarity(usize, usize),
    /// The interval from the previous station.
    Interval(usize),
    /// The wake's first station.
    WakeStart,
}

/// The coupled system of one body at one angle.
#[derive(Clone)]
pub struct System<'a> {
    body: &'a Body,
    wake: Wake,
    fl: Fluid,
    /// Body nodes.
    n: usize,
    /// Body's side per node: +1 upper, −1 lower.
    sgn: Vec<f64>,
    /// The body nodes either side of the stagnation point (upper, lower).
    istag: [usize; 2],
    d: DMatrix<f64>,
    /// Inviscid edge speed per station (signed so that it is positive downstream).
    ueinv: Vec<f64>,
    /// The state per station.
    pub u: Vec<State>,
    /// Turbulent stations.
    pub turb: Vec<bool>,
    wgap: Vec<f64>,
    /// Forced transition as arc length on the body (upper, lower); infinite when free.
    forced_s: [f64; 2],
    /// Station lists: upper surface from the stagnation point, lower, wake.
    surf: [Vec<usize>; 3],
    rows: Vec<Row>,
    /// Exact partials where `System::partials_exact` gives them (the default); `false`:
    /// forward differences everywhere, as a last try for a point the exact Newton loses.
    pub exact: bool,
    /// A factored Jacobian: before a solve, a start's (a nearby solution's: the first step is
    /// a chord step on it when its layout is this system's); after a converged solve, the
    /// last one the solve used.
    pub jacobian: Option<Arc<Factored>>,
}

/// A row block's partials: per station it depends on, ∂R/∂(θ, δ*, s, uₑ) of its three equations.
type Partials = Vec<(usize, [[f64; 4]; 3])>;

/// What one Newton solve did.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    /// Newton iterations taken.
    pub iterations: usize,
    /// Why the solve ended.
    pub stop: Stop,
}

impl Outcome {
    /// Whether the residual fell below tolerance.
    #[must_use]
    pub fn converged(&self) -> bool {
        self.stop == Stop::Converged
    }
}

/// Why a Newton solve ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stop {
    /// The residual norm fell below tolerance.
    Converged,
    /// The residual was not finite (a closure outside its range), at this iteration.
    NotFinite,
    /// The residual norm stopped falling, at this value.
    Stalled(f64),
    /// The Newton system was singular.
    Singular,
    /// A step left the state not finite.
    Diverged,
    /// The iteration limit was reached, at this residual norm.
    Limit(f64),
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stop::Converged => write!(f, "converged"),
            Stop::NotFinite => write!(
                f,
                "the boundary-layer residual is not finite (a closure outside its range)"
            ),
            Stop::Stalled(r) => write!(f, "the Newton residual stalled at {r:.2e}"),
            Stop::Singular => write!(f, "the Newton system is singular"),
            Stop::Diverged => write!(f, "a Newton step left the boundary layer not finite"),
            Stop::Limit(r) => write!(f, "the Newton iteration limit was reached at residual {r:.2e}"),
        }
    }
}

/// Residual norm (2-norm over all equations) taken as converged. The last steps converge
/// quadratically, so the update after it is of this order too, far inside XFOIL's test (an RMS
/// relative update under 1e-4); against 1e-9, the benchmark's mean CD moves by 3e-8 relative
/// and a point takes a step fewer.
const TOL: f64 = 1e-7;

/// A Newton step's factored Jacobian is reused (a chord step) while each step cuts the residual
/// norm at least this much; a slower step, a moved stagnation point or a flipped transition
/// flag factors afresh. On the benchmark's population (64 shapes × 11 angles) 0.1 took 23 %
/// fewer factorisations for 30 % more steps (a chord step costs a seventh of a factored one);
/// 0.03 and 0.3 gained less.
const CHORD_RATE: f64 = 0.1;

/// A start's factorisation (a nearby solution's, [`System::jacobian`]) is kept after its first
/// step if that step halved the residual norm. Far from the solution a step rarely cuts it
/// tenfold, so at [`CHORD_RATE`] it was dropped after one step; the benchmark's shapes (32 ×
/// 11 angles, single-threaded) took 5 % less CPU time at 0.5 than at 0.1 (the same test on
/// every solve's first step measured 0.3, 0.5, 0.7 and 1.0 within 4 % of each other).
const BORROWED_RATE: f64 = 0.5;

/// In [`System::solve_held`], above this residual norm the transition points stay where they
/// are: re-marched on a state far from the solution (the first steps from a marched start),
/// they can jump by tens of stations, often off the surface, and Newton does not recover.
const HOLD_TRANSITION_ABOVE: f64 = 0.5;

impl<'a> System<'a> {
    /// The system at `alpha` degrees, its boundary layer started by marching on the inviscid
    /// edge speed, or from `warm` (a previous solution's states and flags on the same body).
    pub fn new(
        body: &'a Body,
        alpha: f64,
        fl: Fluid,
        xtr: [f64; 2],
        warm: Option<(&[State], &[bool])>,
    ) -> crate::error::Result<System<'a>> {
        let n = body.nodes.len();
        let nw = super::coupling::wake_nodes(n);
        let wake = body.wake(alpha, nw)?;
        // Stagnation: the first node where γ turns from positive (upper) to negative.
        let g = &wake.uinv[..n];
        let j = (1..n)
            .find(|&j| g[j - 1] > 0.0 && g[j] <= 0.0)
            .ok_or_else(|| crate::error::Error::Numerical("no stagnation point on the contour".into()))?;
        let sgn: Vec<f64> = (0..n).map(|i| if i < j { 1.0 } else { -1.0 }).collect();
        let mut sys = System {
            body,
            d: DMatrix::zeros(0, 0),
            ueinv: Vec::new(),
            wgap: vec![0.0; nw],
            forced_s: [f64::INFINITY; 2],
            u: vec![[0.0; 4]; n + nw],
            turb: vec![false; n + nw],
            surf: [Vec::new(), Vec::new(), Vec::new()],
            rows: Vec::new(),
            exact: true,
            jacobian: None,
            istag: [j - 1, j],
            sgn,
            n,
            fl,
            wake,
        };
        sys.relayout();
        sys.set_forced(xtr);
        sys.set_wake_gap();
        let ueinv = sys.ueinv.clone();
        match warm {
            Some((u, turb)) if u.len() == n + nw => {
                for i in 0..n + nw {
                    sys.u[i] = u[i];
                    sys.u[i][3] = ueinv[i].max(1e-6);
                    sys.turb[i] = turb[i];
                }
                // Edge speeds consistent with the carried mass defects.
                let m: DVector<f64> = DVector::from_iterator(n + nw, u.iter().map(|s| s[1] * s[3].abs()));
                let ue = DVector::from_vec(ueinv.clone()) + &sys.d * m;
                for i in 0..n + nw {
                    sys.u[i][3] = ue[i];
                }
                // A speed that changed sign moves the stagnation point (it must see the sign
                // before any floor): only then are the speeds kept off zero.
                sys.stagnation_move();
                for s in sys.u.iter_mut() {
                    s[3] = s[3].max(1e-6);
                }
                sys.update_transition();
            }
            _ => sys.init_boundary_layer(),
        }
        Ok(sys)
    }

    /// Station lists, row kinds, the signed inviscid speeds and `D` for the current sides.
    fn relayout(&mut self) {
        let n = self.n;
        let nw = self.wake.uinv.len() - n;
        self.surf = [
            (0..=self.istag[0]).rev().collect(),
            (self.istag[1]..n).collect(),
            (n..n + nw).collect(),
        ];
        let mut rows = vec![Row::WakeStart; n + nw];
        for s in 0..2 {
            let l = &self.surf[s];
            rows[l[0]] = Row::Similarity(l[0], l[1]);
            for k in 1..l.len() {
                rows[l[k]] = Row::Interval(l[k - 1]);
            }
        }
        for k in 1..nw {
            rows[n + k] = Row::Interval(n + k - 1);
        }
        self.rows = rows;
        self.ueinv = (0..n + nw)
            .map(|i| {
                if i < n {
                    self.sgn[i] * self.wake.uinv[i]
                } else {
                    self.wake.uinv[i]
                }
            })
            .collect();
        self.d = ue_of_mass(&self.wake, &self.body.s, &self.sgn);
    }

    fn x_over_c(&self, i: usize) -> f64 {
        let c = &self.body.chord;
        let d = c.te - c.le;
        (self.body.nodes[i] - c.le).dot(d) / d.length_squared()
    }

    /// Forced transition at chord fraction `xtr` (upper, lower) as arc length on the body.
    fn set_forced(&mut self, xtr: [f64; 2]) {
        for s in 0..2 {
            self.forced_s[s] = f64::INFINITY;
            if !(xtr[s] < 1.0) {
                continue;
            }
            let l = &self.surf[s];
            for k in 1..l.len() {
                let (a, b) = (self.x_over_c(l[k - 1]), self.x_over_c(l[k]));
                if a <= xtr[s] && b > xtr[s] {
                    let w = (xtr[s] - a) / (b - a);
                    self.forced_s[s] = (1.0 - w) * self.body.s[l[k - 1]] + w * self.body.s[l[k]];
                    break;
                }
            }
            if self.forced_s[s].is_infinite() && xtr[s] <= self.x_over_c(l[1]) {
                self.forced_s[s] = self.body.s[l[1]];
            }
        }
    }

    /// The blunt trailing edge's dead-air thickness along the wake (closing over 2.5 gaps).
    fn set_wake_gap(&mut self) {
        let flen = 2.5;
        let h = self.body.gap;
        let dtdx = self.body.dtdx.clamp(-3.0 / flen, 3.0 / flen);
        let lw = flen * h;
        for k in 0..self.wgap.len() {
            let xib = self.wake.s[k] / lw;
            self.wgap[k] = if lw > 0.0 && xib <= 1.0 {
                h * (1.0 + (2.0 + flen * dtdx) * xib) * (1.0 - xib).powi(2)
            } else {
                0.0
            };
        }
    }

    /// The stagnation point's arc length from the edge speeds of its two nodes.
    fn sstag(&self, u: &[State]) -> f64 {
        let [a, b] = self.istag.map(|j| D::<0>::c(u[j][3]));
        self.sstag_of(a, b).v
    }

    /// [`System::sstag`] from the two nodes' edge speeds `ua`, `ub` as dual numbers (the
    /// exact partials carry them).
    fn sstag_of<const N: usize>(&self, ua: D<N>, ub: D<N>) -> D<N> {
        let (sa, sb) = (self.body.s[self.istag[0]], self.body.s[self.istag[1]]);
        (ub * sa + ua * sb) / (ua + ub)
    }

    /// ξ of station `i`: distance from the stagnation point (the wake continues the lower side).
    fn xi(&self, i: usize, sst: f64) -> f64 {
        self.xi_of(i, D::<0>::c(sst)).v
    }

    /// [`System::xi`] from a stagnation arc length `sst` as a dual number.
    fn xi_of<const N: usize>(&self, i: usize, sst: D<N>) -> D<N> {
        if i < self.n {
            (self.body.s[i] - sst).abs()
        } else {
            self.body.s[self.n - 1] - sst + self.wake.s[i - self.n]
        }
    }

    fn surface_of(&self, i: usize) -> usize {
        if i >= self.n {
            2
        } else if i <= self.istag[0] {
            0
        } else {
            1
        }
    }

    fn kind(&self, i: usize) -> Kind {
        if i >= self.n {
            Kind::WAKE
        } else if self.turb[i] {
            Kind::TURBULENT
        } else {
            Kind::LAMINAR
        }
    }

    /// The transition point (ξ) of the interval `a → b` on surface `s`.
    fn transition_xi(&self, u: &[State], s: usize, x: [f64; 2], a: usize, b: usize) -> f64 {
        let free = eq::transition_point(&self.fl, x, &u[a], &u[b]).unwrap_or(x[1]);
        let forced = (self.forced_s[s] - self.sstag(u)).abs();
        if self.forced_s[s].is_finite() {
            free.min(forced.max(x[0]))
        } else {
            free
        }
    }

    /// The three equations of station `i`'s row block.
    fn block(&self, i: usize, u: &[State]) -> [f64; 3] {
        let sst = self.sstag(u);
        match self.rows[i] {
            Row::Similarity(a, b) => {
                let ust = eq::stagnation_state([self.xi(a, sst), self.xi(b, sst)], &u[a], &u[b]);
                eq::similarity(&self.fl, &ust)
            }
            Row::WakeStart => {
                let (ut, lt) = (
                    *self.surf[0].last().unwrap_or(&0),
                    *self.surf[1].last().unwrap_or(&0),
                );
                let w = eq::wake_start(
                    &self.fl,
                    (&u[ut], self.turb[ut]),
                    (&u[lt], self.turb[lt]),
                    self.body.gap,
                );
                [u[i][0] - w[0], u[i][1] - w[1], u[i][2] - w[2]]
            }
            Row::Interval(p) => {
                let x = [self.xi(p, sst), self.xi(i, sst)];
                if i >= self.n {
                    let g = [self.wgap[p - self.n], self.wgap[i - self.n]];
                    eq::interval(&self.fl, Kind::WAKE, false, x, &u[p], &u[i], g)
                } else if self.turb[p] == self.turb[i] {
                    eq::interval(&self.fl, self.kind(i), false, x, &u[p], &u[i], [0.0; 2])
                } else {
                    let xt = self.transition_xi(u, self.surface_of(i), x, p, i);
                    eq::transition(&self.fl, x, xt, &u[p], &u[i])
                }
            }
        }
    }

    /// The stations a row block depends on.
    fn deps(&self, i: usize) -> Vec<usize> {
        let mut d = match self.rows[i] {
            Row::Similarity(a, b) => vec![a, b],
            Row::WakeStart => vec![
                *self.surf[0].last().unwrap_or(&0),
                *self.surf[1].last().unwrap_or(&0),
                i,
            ],
            Row::Interval(p) => vec![p, i],
        };
        if !matches!(self.rows[i], Row::WakeStart) {
            for s in self.istag {
                if !d.contains(&s) {
                    d.push(s);
                }
            }
        }
        d
    }

    /// Every residual: three per station, then the edge-speed equation per station.
    fn residual(&self) -> Vec<f64> {
        let nt = self.u.len();
        let mut r = vec![0.0; 4 * nt];
        for i in 0..nt {
            let b = self.block(i, &self.u);
            r[3 * i..3 * i + 3].copy_from_slice(&b);
        }
        let m = DVector::from_iterator(nt, self.u.iter().map(|s| s[1] * s[3]));
        let dm = &self.d * m;
        for i in 0..nt {
            r[3 * nt + i] = self.u[i][3] - self.ueinv[i] - dm[i];
        }
        r
    }

    /// The exact partials of row block `i` when it is a plain interval (one kind at both
    /// ends, or the wake), by dual numbers through the closures and the equations: per
    /// dependency (in [`System::deps`]'s order), ∂R/∂(θ, δ*, s, uₑ). The stagnation nodes' `uₑ`
    /// enter through ξ; where one of them is a station of the row, both ways add up.
    fn partials_exact(&self, i: usize) -> Option<Partials> {
        let Row::Interval(p) = self.rows[i] else {
            return None;
        };
        if i < self.n && self.turb[p] != self.turb[i] {
            return None;
        }
        const N: usize = 10;
        let var = |j: usize, off: usize| -> Du<N> {
            let u = self.u[j];
            [
                D::var(u[0], off),
                D::var(u[1], off + 1),
                D::var(u[2], off + 2),
                D::var(u[3], off + 3),
            ]
        };
        let (u1, u2) = (var(p, 0), var(i, 4));
        let [a, b] = self.istag;
        let slot = |j: usize, extra: usize| {
            if j == p {
                3
            } else if j == i {
                7
            } else {
                extra
            }
        };
        let ua = D::<N>::var(self.u[a][3], slot(a, 8));
        let ub = D::<N>::var(self.u[b][3], slot(b, 9));
        let sst = self.sstag_of(ua, ub);
        let x = [self.xi_of(p, sst), self.xi_of(i, sst)];
        let r = if i >= self.n {
            let g = [self.wgap[p - self.n], self.wgap[i - self.n]];
            eq::interval_d(&self.fl, Kind::WAKE, false, x, &u1, &u2, g)
        } else {
            eq::interval_d(&self.fl, self.kind(i), false, x, &u1, &u2, [0.0; 2])
        };
        let block = |off: usize| {
            let mut m = [[0.0; 4]; 3];
            for e in 0..3 {
                for q in 0..4 {
                    m[e][q] = r[e].d[off + q];
                }
            }
            m
        };
        let mut out: Partials = vec![(p, block(0)), (i, block(4))];
        for (j, k) in [(a, 8), (b, 9)] {
            if j != p && j != i {
                let mut m = [[0.0; 4]; 3];
                for e in 0..3 {
                    m[e][3] = r[e].d[k];
                }
                out.push((j, m));
            }
        }
        Some(out)
    }

    /// Partials of row block `i`: exact where [`System::partials_exact`] gives them, else
    /// forward differences (the similarity, transition and wake-start rows): per dependency,
    /// ∂R/∂(θ, δ*, s, uₑ).
    fn partials(&mut self, i: usize, base: &[f64; 3]) -> Partials {
        if self.exact {
            if let Some(p) = self.partials_exact(i) {
                return p;
            }
        }
        self.partials_fd(i, base)
    }

    /// Forward-difference partials of row block `i`: per dependency, ∂R/∂(θ, δ*, s, uₑ).
    fn partials_fd(&mut self, i: usize, base: &[f64; 3]) -> Partials {
        let deps = self.deps(i);
        // The stations the row holds come first; the stagnation nodes added after them enter
        // through ξ alone, which reads their uₑ: their other partials are zero.
        let own = if matches!(self.rows[i], Row::WakeStart) {
            3
        } else {
            2
        };
        let mut out = Vec::with_capacity(deps.len());
        let mut u = std::mem::take(&mut self.u);
        for (k, &j) in deps.iter().enumerate() {
            let mut p = [[0.0; 4]; 3];
            for q in if k < own { 0 } else { 3 }..4 {
                let v = u[j][q];
                let h = fd_step(v, q);
                u[j][q] = v + h;
                let r = self.block(i, &u);
                u[j][q] = v;
                for e in 0..3 {
                    p[e][q] = (r[e] - base[e]) / h;
                }
            }
            out.push((j, p));
        }
        self.u = u;
        out
    }

    /// One Newton step's update `Δ[θ, δ*, s, uₑ]` per station (`None` when singular), and the
    /// factored Jacobian where the block factorisation held.
    fn step(&mut self, r: &[f64]) -> (Option<Factored>, Option<Vec<[f64; 4]>>) {
        let nt = self.u.len();
        let mut jac: Vec<Partials> = Vec::with_capacity(nt);
        for i in 0..nt {
            let base = [r[3 * i], r[3 * i + 1], r[3 * i + 2]];
            jac.push(self.partials(i, &base));
        }
        self.solve_fresh(jac, r)
    }

    /// Take a limited step (mfoil's relaxation rules) and keep `H` above its floor.
    fn update(&mut self, du: &[[f64; 4]]) {
        let nt = self.u.len();
        let mut omega: f64 = 1.0;
        for k in 0..2 {
            let fmin = (0..nt)
                .map(|i| du[i][k] / self.u[i][k])
                .fold(f64::INFINITY, f64::min);
            if fmin < -0.5 {
                omega = omega.min((0.5 / fmin).abs());
            }
        }
        let ctmax = (0..nt)
            .filter(|&i| self.turb[i])
            .map(|i| self.u[i][2])
            .fold(0.0, f64::max);
        let (mut dlam, mut dturb) = (0.0_f64, 0.0_f64);
        for i in 0..nt {
            let (v, d) = (self.u[i][2], du[i][2]);
            let skip = if self.turb[i] { v < 0.1 * ctmax } else { v < 0.2 };
            if !skip && v != 0.0 && d != 0.0 && v + d < 0.0 {
                omega = omega.min(0.8 * (v / d).abs());
            }
            if self.turb[i] {
                dturb = dturb.max(d.abs());
            } else {
                dlam = dlam.max(d.abs());
            }
        }
        if dlam > 0.0 {
            omega = omega.min(2.0 / dlam);
        }
        if dturb > 0.0 {
            omega = omega.min(0.05 / dturb);
        }
        let duemax = du.iter().map(|d| d[3].abs()).fold(0.0, f64::max);
        if duemax > 0.0 {
            omega = omega.min(0.2 / duemax);
        }
        for i in 0..nt {
            for q in 0..4 {
                self.u[i][q] += omega * du[i][q];
            }
            // `H` pushed back past its floor by as much again. In the wake the floor is on the
            // shape the closures see, δ* less the blunt edge's dead air (XFOIL's `DSLIM` on
            // `DSTR − DSWAKI`), and δ* is never left under it (a δ* under the gap would stay
            // there); on the body the rule is as before.
            if i >= self.n {
                let (hmin, gap) = (1.00005, self.wgap[i - self.n]);
                let (th, ds) = (self.u[i][0], self.u[i][1] - gap);
                let hk = ds / th;
                if hk < hmin {
                    self.u[i][1] = gap + (ds + 2.0 * (hmin - hk) * ds).max(hmin * th);
                }
            } else {
                let hk = c::plain::h(&self.u[i]);
                if hk < 1.02 {
                    self.u[i][1] += 2.0 * (1.02 - hk) * self.u[i][1];
                }
            }
            if self.turb[i] && self.u[i][2] < 0.0 {
                self.u[i][2] = 0.1 * ctmax;
            }
        }
    }

    /// Move the stagnation point to where the edge speed changes sign, re-siding the nodes it
    /// passes (mfoil's `stagpoint_move`).
    fn stagnation_move(&mut self) {
        let n = self.n;
        let [a, b] = self.istag;
        let mut moved = false;
        if self.u[b][3] < 0.0 {
            // Lower-side nodes with negative speed belong to the upper side.
            if let Some(j) = (b..n).find(|&j| self.u[j][3] > 0.0) {
                for k in b..j {
                    self.u[k][3] = -self.u[k][3];
                }
                self.istag = [j - 1, j];
                moved = true;
            }
        } else if self.u[a][3] < 0.0 {
            if let Some(j) = (0..=a).rev().find(|&j| self.u[j][3] > 0.0) {
                for k in j + 1..=a {
                    self.u[k][3] = -self.u[k][3];
                }
                self.istag = [j, j + 1];
                moved = true;
            }
        }
        if moved && self.istag[0] >= 1 && self.istag[1] + 1 < n {
            for i in 0..n {
                self.sgn[i] = if i <= self.istag[0] { 1.0 } else { -1.0 };
            }
            self.relayout();
        }
    }

    /// Newton to convergence or `max_iter` iterations.
    pub fn solve(&mut self, max_iter: usize) -> Outcome {
        self.newton(max_iter, f64::INFINITY)
    }

    /// [`System::solve`], the transition points held while the residual norm is large (for
    /// the first ten steps at most): the second try of a point the first did not converge.
    pub fn solve_held(&mut self, max_iter: usize) -> Outcome {
        self.newton(max_iter, HOLD_TRANSITION_ABOVE)
    }

    fn newton(&mut self, max_iter: usize, hold_above: f64) -> Outcome {
        let mut hist: Vec<f64> = Vec::with_capacity(max_iter);
        // The last factored Jacobian, while the layout it was taken on holds (at first a
        // start's).
        let mut kept: Option<Arc<Factored>> = self.jacobian.take().filter(|f| f.fits(self));
        let borrowed = kept.is_some();
        for it in 0..max_iter {
            let r = self.residual();
            let rn = norm(&r);
            if !rn.is_finite() {
                return Outcome {
                    iterations: it,
                    stop: Stop::NotFinite,
                };
            }
            if rn < TOL {
                self.jacobian = kept;
                return Outcome {
                    iterations: it,
                    stop: Stop::Converged,
                };
            }
            // A chord step (the kept Jacobian) must have cut the residual by CHORD_RATE.
            // (A start's factorisation, on its first step: BORROWED_RATE.)
            let rate = if hist.len() == 1 && borrowed {
                BORROWED_RATE
            } else {
                CHORD_RATE
            };
            if hist.last().is_some_and(|&last| rn > rate * last) {
                kept = None;
            }
            hist.push(rn);
            if stalled(&hist) {
                return Outcome {
                    iterations: it,
                    stop: Stop::Stalled(rn),
                };
            }
            let chord = kept.as_ref().and_then(|f| f.solve(&self.d, &r));
            let du = match chord {
                Some(du) => Some(du),
                None => {
                    let (f, du) = self.step(&r);
                    kept = f.map(Arc::new);
                    du
                }
            };
            let Some(du) = du else {
                return Outcome {
                    iterations: it,
                    stop: Stop::Singular,
                };
            };
            let (istag, turb) = (self.istag, self.turb.clone());
            self.update(&du);
            self.stagnation_move();
            if rn < hold_above || it >= 10 {
                self.update_transition();
            }
            if self.istag != istag || self.turb != turb {
                kept = None;
            }
            if self.u.iter().any(|s| !s.iter().all(|v| v.is_finite())) {
                return Outcome {
                    iterations: it + 1,
                    stop: Stop::Diverged,
                };
            }
        }
        let rn = norm(&self.residual());
        Outcome {
            iterations: max_iter,
            stop: if rn < TOL {
                Stop::Converged
            } else {
                Stop::Limit(rn)
            },
        }
    }

    /// CL, CM, CD (Squire–Young at the wake's end) and CDf (skin friction).
    pub fn forces(&self, alpha: f64) -> Forces {
        let n = self.n;
        let cp: Vec<f64> = (0..n).map(|i| 1.0 - self.u[i][3] * self.u[i][3]).collect();
        let (cl, cm) = crate::aero::panel::integrate(&self.body.nodes, &cp, alpha, &self.body.chord);
        let last = self.u[self.u.len() - 1];
        let cd = 2.0 * last[0] * last[3].powf((5.0 + c::plain::h(&last)) / 2.0);
        let (sn, cs) = alpha.to_radians().sin_cos();
        let sst = self.sstag(&self.u);
        let xstag = {
            let [a, b] = self.istag;
            let w = (sst - self.body.s[a]) / (self.body.s[b] - self.body.s[a]);
            (1.0 - w) * self.body.nodes[a] + w * self.body.nodes[b]
        };
        let mut cdf = 0.0;
        let mut separated = false;
        for s in 0..2 {
            let (mut cf1, mut ue1, mut x1) = (0.0, 0.0, xstag);
            for &i in &self.surf[s] {
                let cf2 = c::plain::cf(&self.u[i], self.kind(i), &self.fl);
                if self.turb[i] && cf2 < 0.0 {
                    separated = true;
                }
                let ue2 = self.u[i][3];
                let x2 = self.body.nodes[i];
                let dv = x2 - x1;
                cdf += 0.25 * (cf1 * ue1 * ue1 + cf2 * ue2 * ue2) * (dv.x * cs + dv.y * sn);
                (cf1, ue1, x1) = (cf2, ue2, x2);
            }
        }
        // Per unit chord: the body is already in unit-chord coordinates.
        let xtr = [self.transition_x(0), self.transition_x(1)];
        Forces {
            cl,
            cm,
            cd,
            cdf: 2.0 * cdf,
            xtr,
            separated,
        }
    }

    /// The transition point of a surface as a chord fraction (1 when laminar to the edge).
    fn transition_x(&self, s: usize) -> f64 {
        let l = &self.surf[s];
        let Some(k) = l.iter().position(|&i| self.turb[i]) else {
            return 1.0;
        };
        if k == 0 {
            return self.x_over_c(l[0]);
        }
        let (a, b) = (l[k - 1], l[k]);
        let sst = self.sstag(&self.u);
        let x = [self.xi(a, sst), self.xi(b, sst)];
        let xt = self.transition_xi(&self.u, s, x, a, b);
        let w = ((xt - x[0]) / (x[1] - x[0])).clamp(0.0, 1.0);
        (1.0 - w) * self.x_over_c(a) + w * self.x_over_c(b)
    }
}

/// The coefficients of a solved system.
#[derive(Clone, Copy, Debug)]
pub struct Forces {
    /// Lift coefficient.
    pub cl: f64,
    /// Moment about the quarter chord.
    pub cm: f64,
    /// Drag from the wake's momentum deficit.
    pub cd: f64,
    /// Skin-friction drag.
    pub cdf: f64,
    /// Transition points (upper, lower), chord fractions.
    pub xtr: [f64; 2],
    /// Turbulent separation (negative skin friction) somewhere on the body.
    pub separated: bool,
}

/// Newton iterations over which an unchanging residual norm means a stall.
const STALL_WINDOW: usize = 10;

/// Whether the last [`STALL_WINDOW`] residual norms agree within 0.1 %: the step is limited to
/// nothing, or the iterate cycles, and more iterations will not converge (a point's iterations
/// on the benchmark's population sat there for up to 70 iterations; no converging solve had
/// such a window).
fn stalled(hist: &[f64]) -> bool {
    let Some(w) = hist.len().checked_sub(STALL_WINDOW).map(|k| &hist[k..]) else {
        return false;
    };
    let (lo, hi) = w
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(a, b), &v| (a.min(v), b.max(v)));
    hi - lo <= 1e-3 * lo
}

fn norm(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum::<f64>().sqrt()
}

/// The forward-difference step in state component `q` at value `v`: relative 1e-7, with a
/// floor (1e-3 for the amplification or shear-stress variable, which can be zero).
fn fd_step(v: f64, q: usize) -> f64 {
    if q == 2 {
        1e-7 * v.abs().max(1e-3)
    } else {
        1e-7 * v.abs().max(1e-12)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn body(file: &str) -> Body {
        Body::new(&crate::aero::viscous::shipped_nodes(file)).unwrap()
    }

    /// A solve started from a neighbour's solution converges to the same point with the
    /// neighbour's factorisation as its first chord matrix as without it, and hands its own
    /// on; a factorisation taken on another layout is not used.
    #[test]
    fn a_carried_factorisation_changes_the_path_not_the_solution() {
        let b = body("data/naca4413.dat");
        let fl = Fluid { re: 1e6, ncrit: 9.0 };
        let mut first = System::new(&b, 2.0, fl, [1.0; 2], None).unwrap();
        assert!(first.solve(80).converged());
        let carried = first
            .jacobian
            .clone()
            .expect("a converged solve keeps its factorisation");
        assert!(carried.fits(&first));
        let solve = |jacobian: Option<Arc<Factored>>| {
            let mut sys = System::new(&b, 3.0, fl, [1.0; 2], Some((&first.u, &first.turb))).unwrap();
            sys.jacobian = jacobian;
            let out = sys.solve(80);
            assert!(out.converged(), "{}", out.stop);
            let f = sys.forces(3.0);
            (f.cl, f.cd, sys.jacobian.is_some())
        };
        let (cl0, cd0, _) = solve(None);
        let (cl1, cd1, kept) = solve(Some(carried.clone()));
        assert!(kept);
        assert!(
            (cl1 - cl0).abs() < 1e-6 && ((cd1 - cd0) / cd0).abs() < 1e-5,
            "CL {cl0} {cl1}, CD {cd0} {cd1}"
        );
        // Another layout: a cold start at 8° moves the stagnation point and transition.
        let other = System::new(&b, 8.0, fl, [1.0; 2], None).unwrap();
        assert!(!carried.fits(&other));
    }

    /// Every row block whose partials come from dual numbers (laminar, turbulent and wake
    /// intervals) agrees with central differences of its residuals, at the marched start and
    /// at the converged solution.
    #[test]
    fn exact_partials_match_central_differences() {
        let b = body("data/naca4413.dat");
        let fl = Fluid { re: 1e6, ncrit: 9.0 };
        let mut sys = System::new(&b, 3.0, fl, [1.0; 2], None).unwrap();
        let mut kinds = [0usize; 3];
        for pass in 0..2 {
            if pass == 1 {
                assert!(sys.solve(80).converged());
            }
            let nt = sys.u.len();
            for i in 0..nt {
                let Some(exact) = sys.partials_exact(i) else {
                    continue;
                };
                kinds[if i >= sys.n { 2 } else { usize::from(sys.turb[i]) }] += 1;
                let scale: f64 = exact
                    .iter()
                    .flat_map(|(_, m)| m.iter().flatten())
                    .fold(0.0, |a, v| a.max(v.abs()));
                let mut u = sys.u.clone();
                for (j, m) in &exact {
                    for q in 0..4 {
                        let v = u[*j][q];
                        let h = 1e-6 * if q == 2 { v.abs().max(1e-3) } else { v.abs() };
                        u[*j][q] = v + h;
                        let rp = sys.block(i, &u);
                        u[*j][q] = v - h;
                        let rm = sys.block(i, &u);
                        u[*j][q] = v;
                        for e in 0..3 {
                            let cd = (rp[e] - rm[e]) / (2.0 * h);
                            // Relative 2e-5, and an absolute floor at the differences' own
                            // round-off (a wake row's ξ through the stagnation point).
                            let tol = 2e-5 * cd.abs() + 1e-8 * scale;
                            assert!(
                                (m[e][q] - cd).abs() <= tol,
                                "row {i} eq {e} station {j} var {q}: exact {} central {cd}",
                                m[e][q]
                            );
                        }
                    }
                }
            }
        }
        assert!(kinds.iter().all(|&k| k > 10), "{kinds:?}");
    }
}
