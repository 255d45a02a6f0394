//! The discrete boundary-layer equations between two stations (XFOIL's `BLDIF`): momentum,
//! kinetic-energy shape parameter, and amplification (laminar) or shear lag (turbulent), in
//! logarithmic differences; the similarity station at the stagnation point; the interval that
//! holds the transition point; the junction of the two surfaces into the wake.

use super::closures::{self as c, Du, Fluid, Kind};
use super::dual::{lift, D};

/// A station's state `[θ, δ*, s, uₑ]` (see [`super::closures`]).
pub type State = [f64; 4];

/// The upwinding weight of the second station (½: trapezoidal, 1: backward Euler), large
/// where `Hk` changes fast.
fn upwind_weight<const N: usize>(hk1: D<N>, hk2: D<N>, k: Kind) -> D<N> {
    let huc = if k.wake { 1.0 } else { 5.0 } / (hk2 * hk2);
    let la = ((hk2 - 1.0) / (hk1 - 1.0)).abs().ln();
    let hls = (la * la).fmin(15.0);
    1.0 - 0.5 * (-hls * huc).exp()
}

fn mix<const N: usize>(w: D<N>, a: D<N>, b: D<N>) -> D<N> {
    (1.0 - w) * a + w * b
}

/// The three residuals of the interval `x[0] → x[1]` (arc length from the stagnation point),
/// both stations of kind `k`. `simi`: the similarity station (both states equal, `uₑ ∝ ξ`).
/// `wgap`: the blunt trailing edge's dead-air thickness at either station (wake only).
pub fn interval(
    fl: &Fluid,
    k: Kind,
    simi: bool,
    x: [f64; 2],
    u1: &State,
    u2: &State,
    wgap: [f64; 2],
) -> [f64; 3] {
    let r = interval_d(fl, k, simi, x.map(D::<0>::c), &lift(u1), &lift(u2), wgap);
    r.map(|v| v.v)
}

/// [`interval`] in dual numbers: the residuals and their partials in whatever variables `x`
/// and the two states carry (the chain rule through every closure).
pub fn interval_d<const N: usize>(
    fl: &Fluid,
    k: Kind,
    simi: bool,
    x: [D<N>; 2],
    u1: &Du<N>,
    u2: &Du<N>,
    wgap: [f64; 2],
) -> [D<N>; 3] {
    let mut u1 = *u1;
    let mut u2 = *u2;
    u1[1] = u1[1] - wgap[0];
    u2[1] = u2[1] - wgap[1];
    let um0 = 0.5 * (u1[0] + u2[0]);
    let (mut thlog, mut uelog, mut xlog, mut dx) = (
        (u2[0] / u1[0]).ln(),
        (u2[3] / u1[3]).ln(),
        (x[1] / x[0]).ln(),
        x[1] - x[0],
    );
    let (s1, s2) = (c::Station::new(&u1, k, fl), c::Station::new(&u2, k, fl));
    let mut hslog = (s2.hs / s1.hs).ln();
    if simi {
        thlog = D::c(0.0);
        hslog = D::c(0.0);
        uelog = D::c(1.0);
        xlog = D::c(1.0);
        dx = 0.5 * (x[0] + x[1]);
    }
    let upw = upwind_weight(s1.h, s2.h, k);
    let hav = 0.5 * (s1.h + s2.h);
    let hw = 0.5 * (wgap[0] / u1[0] + wgap[1] / u2[0]);

    let lag = if k.turb {
        let salog = (u2[2] / u1[2]).ln();
        let dea = 0.5 * (s1.de + s2.de);
        let usa = 0.5 * (s1.us + s2.us);
        let hka = mix(upw, s1.h, s2.h);
        let rta = 0.5 * (s1.rt + s2.rt);
        let cfa = mix(upw, s1.cf, s2.cf);
        let dsa = 0.5 * (u1[1] + u2[1]);
        let uq = c::uq(dsa, cfa, hka, rta, k);
        let cteq = mix(upw, s1.cteq, s2.cteq);
        let saa = mix(upw, u1[2], u2[2]);
        let clag = c::SLAG_K / c::GB / (1.0 + usa);
        let ald = if k.wake { c::DLR } else { 1.0 };
        clag * (cteq - ald * saa) * dx - 2.0 * dea * salog + 2.0 * dea * (uq * dx - uelog)
    } else if simi {
        u1[2] + u2[2]
    } else {
        u2[2] - u1[2] - c::damp_interval(&u1, &u2, fl) * dx
    };

    let (cfxt1, cfxt2) = (s1.cf * x[0] / u1[0], s2.cf * x[1] / u2[0]);
    // The midpoint's Cf from the ends' mean Hk and Re_θ (XFOIL's BLMID).
    let hka = 0.5 * (s1.hk + s2.hk);
    let rta = 0.5 * (s1.rt + s2.rt);
    let cfxtm = c::cf_of(hka, rta, k) * 0.5 * (x[0] + x[1]) / um0;
    let cfxt_mom = 0.25 * cfxt1 + 0.5 * cfxtm + 0.25 * cfxt2;
    let mom = thlog + (2.0 + hav + hw) * uelog - 0.5 * xlog * cfxt_mom;

    let cdixt = mix(upw, s1.cdi * x[0] / u1[0], s2.cdi * x[1] / u2[0]);
    let cfxtu = mix(upw, cfxt1, cfxt2);
    let shape = hslog + (1.0 - hav - hw) * uelog + xlog * (0.5 * cfxtu - cdixt);
    [mom, shape, lag]
}

/// Where the amplification factor reaches `Ncrit` in `x[0] → x[1]` (laminar, `u1[2]` the
/// factor at the first station), states interpolated linearly; `None` when it does not.
pub fn transition_point(fl: &Fluid, x: [f64; 2], u1: &State, u2: &State) -> Option<f64> {
    let dx = x[1] - x[0];
    let at = |xt: f64| -> State {
        let w2 = (xt - x[0]) / dx;
        let mut ut = [0.0; 4];
        for q in 0..4 {
            ut[q] = (1.0 - w2) * u1[q] + w2 * u2[q];
        }
        ut[2] = fl.ncrit;
        ut
    };
    let r = |xt: f64| fl.ncrit - u1[2] - (xt - x[0]) * c::damp_interval(&lift(u1), &lift(&at(xt)), fl).v;
    // The residual falls as xt grows (the factor grows); bracket, then secant-bisect.
    let (mut lo, mut hi) = (x[0], x[1]);
    let (mut rlo, rhi) = (r(lo), r(hi));
    if rhi > 0.0 || !rhi.is_finite() {
        return None;
    }
    if rlo <= 0.0 {
        return Some(x[0]);
    }
    let mut rh = rhi;
    for _ in 0..60 {
        let mid = (lo * rh - hi * rlo) / (rh - rlo);
        let mid = if mid > lo && mid < hi {
            mid
        } else {
            0.5 * (lo + hi)
        };
        let rm = r(mid);
        if rm.abs() < 1e-13 || hi - lo < 1e-14 * dx.abs().max(1e-300) {
            return Some(mid);
        }
        if rm > 0.0 {
            lo = mid;
            rlo = rm;
            // Illinois: keep the secant from stalling on one side.
            rh *= 0.5;
        } else {
            hi = mid;
            rh = rm;
            rlo *= 0.5;
        }
    }
    Some(0.5 * (lo + hi))
}

/// The residuals of an interval holding the transition point `xt` (free, from
/// [`transition_point`], or forced): laminar from `x[0]` to `xt`, turbulent from `xt` to `x[1]`,
/// the state at `xt` interpolated, its `√Cτ` the post-transition value.
pub fn transition(fl: &Fluid, x: [f64; 2], xt: f64, u1: &State, u2: &State) -> [f64; 3] {
    let dx = x[1] - x[0];
    let w2 = ((xt - x[0]) / dx).clamp(0.0, 1.0);
    let mut ut = [0.0; 4];
    for q in 0..4 {
        ut[q] = (1.0 - w2) * u1[q] + w2 * u2[q];
    }
    // Keep the two sub-intervals from vanishing (their logarithms).
    let xt = xt.clamp(x[0] + 1e-6 * dx, x[1] - 1e-6 * dx);
    let mut utl = ut;
    utl[2] = fl.ncrit;
    let mut utt = ut;
    utt[2] = c::plain::cttr(&ut, fl);
    let rl = interval(fl, Kind::LAMINAR, false, [x[0], xt], u1, &utl, [0.0; 2]);
    let rt = interval(fl, Kind::TURBULENT, false, [xt, x[1]], &utt, u2, [0.0; 2]);
    // The third equation is the turbulent part's shear lag alone (XFOIL's TRDIF): the laminar
    // part's amplification equation only places xt, and vanishes there unless xt is forced.
    [rl[0] + rt[0], rl[1] + rt[1], rt[2]]
}

/// The state at the stagnation point extrapolated from the first two stations of a surface
/// (`θ`, `δ*`, `s` linear in ξ, `uₑ = K ξ` at `ξ = XST`), as the similarity station uses it.
pub const XST: f64 = 1e-6;

/// See [`XST`].
pub fn stagnation_state(x: [f64; 2], u1: &State, u2: &State) -> State {
    let dx = x[1] - x[0];
    let (w1, w2) = (x[1] / dx, -x[0] / dx);
    let rx = x[1] / x[0];
    let k = rx / dx * u1[3] - 1.0 / (rx * dx) * u2[3];
    [
        w1 * u1[0] + w2 * u2[0],
        w1 * u1[1] + w2 * u2[1],
        w1 * u1[2] + w2 * u2[2],
        k * XST,
    ]
}

/// The similarity residuals at the stagnation point.
pub fn similarity(fl: &Fluid, ust: &State) -> [f64; 3] {
    interval(fl, Kind::LAMINAR, true, [XST, XST], ust, ust, [0.0; 2])
}

/// The wake's first state from the two trailing-edge states: `θ` and `δ*` add (plus the gap),
/// `√Cτ` θ-weighted (a laminar edge takes its post-transition value).
pub fn wake_start(fl: &Fluid, upper: (&State, bool), lower: (&State, bool), gap: f64) -> [f64; 3] {
    let ct = |(u, turb): (&State, bool)| if turb { u[2] } else { c::plain::cttr(u, fl) };
    let (uu, ul) = (upper.0, lower.0);
    let th = uu[0] + ul[0];
    [
        th,
        uu[1] + ul[1] + gap,
        (ct(upper) * uu[0] + ct(lower) * ul[0]) / th,
    ]
}
