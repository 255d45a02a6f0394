//! XFOIL's integral boundary-layer closures at Mach 0 (Drela 1989; Drela & Giles 1987): the
//! shape parameters, skin friction, dissipation, equilibrium shear stress and the e^N envelope
//! amplification rate, in unit-chord, unit-free-stream variables.
//!
//! A station's state is `[θ, δ*, s, uₑ]`: momentum and displacement thickness, `s` the
//! amplification factor N (laminar) or `√Cτ` (turbulent and wake), and the edge speed.

/// The G–β locus constant A (`G = A √(1 + B β)`).
pub const GA: f64 = 6.7;
/// The G–β locus constant B.
pub const GB: f64 = 0.75;
/// The G–β low-Reynolds constant C.
pub const GC: f64 = 18.0;
/// Shear-lag constant (`SCCON`).
pub const SLAG_K: f64 = 5.6;
/// Wall/wake dissipation length ratio (`DLCON`).
pub const DLR: f64 = 0.9;
/// Initial `Cτ` after transition: `CTRCON · exp(−CTRCEX / (Hk − 1))` of equilibrium.
pub const CTAU_C: f64 = 1.8;
/// See [`CTAU_C`].
pub const CTAU_E: f64 = 3.3;

/// What kind of station a closure is evaluated for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kind {
    /// Turbulent (or wake) rather than laminar.
    pub turb: bool,
    /// In the wake (no wall: zero skin friction, doubled dissipation).
    pub wake: bool,
}

impl Kind {
    /// A laminar wall station.
    pub const LAMINAR: Kind = Kind {
        turb: false,
        wake: false,
    };
    /// A turbulent wall station.
    pub const TURBULENT: Kind = Kind {
        turb: true,
        wake: false,
    };
    /// A wake station.
    pub const WAKE: Kind = Kind {
        turb: true,
        wake: true,
    };
}

use super::dual::D;

/// The fluid: the chord Reynolds number (`ν = 1 / Re` in unit-chord, unit-speed variables).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fluid {
    /// Chord Reynolds number.
    pub re: f64,
    /// Critical amplification factor.
    pub ncrit: f64,
}

/// A station's state as dual numbers (see [`super::dual`]): the closures below give their
/// values and, for `N > 0`, their partials in the same evaluation.
pub type Du<const N: usize> = [D<N>; 4];

/// `H = δ* / θ`.
#[inline]
pub fn h<const N: usize>(u: &Du<N>) -> D<N> {
    u[1] / u[0]
}

/// The kinematic shape parameter, limited below (1.05 on the wall, 1.00005 in the wake) as
/// XFOIL limits it inside the closures.
#[inline]
pub fn hk_limited<const N: usize>(u: &Du<N>, k: Kind) -> D<N> {
    h(u).fmax(if k.wake { 1.00005 } else { 1.05 })
}

/// `Re_θ = Re uₑ θ`.
#[inline]
pub fn ret<const N: usize>(u: &Du<N>, f: &Fluid) -> D<N> {
    f.re * u[3] * u[0]
}

/// The kinetic-energy shape parameter `H* = θ* / θ`.
pub fn hs<const N: usize>(u: &Du<N>, k: Kind, f: &Fluid) -> D<N> {
    hs_of(hk_limited(u, k), ret(u, f), k)
}

/// [`hs`] from the limited `Hk` and `Re_θ`.
fn hs_of<const N: usize>(hk: D<N>, rt: D<N>, k: Kind) -> D<N> {
    if k.turb {
        let (hsmin, dhsinf) = (1.5, 0.015);
        let ho = if rt.v > 400.0 { 3.0 + 400.0 / rt } else { D::c(4.0) };
        let reb = rt.fmax(200.0);
        if hk.v < ho.v {
            let hr = (ho - hk) / (ho - 1.0);
            hsmin + 4.0 / reb + (2.0 - hsmin - 4.0 / reb) * hr * hr * 1.5 / (hk + 0.5)
        } else {
            let lrb = reb.ln();
            let aa = hk - ho + 4.0 / lrb;
            let bb = 0.007 * lrb / (aa * aa) + dhsinf / hk;
            hsmin + 4.0 / reb + (hk - ho) * (hk - ho) * bb
        }
    } else {
        let a = hk - 4.35;
        if hk.v < 4.35 {
            (0.0111 * a * a - 0.0278 * a * a * a) / (hk + 1.0) + 1.528 - 0.0002 * (a * hk) * (a * hk)
        } else {
            0.015 * a * a / hk + 1.528
        }
    }
}

/// The skin-friction coefficient `Cf` (zero in the wake); turbulent: never below the laminar
/// value (which only happens at unreasonably small `Re_θ`), as XFOIL's `BLVAR` takes it.
pub fn cf<const N: usize>(u: &Du<N>, k: Kind, f: &Fluid) -> D<N> {
    cf_of(hk_limited(u, k), ret(u, f), k)
}

/// [`cf`] from the kinematic shape parameter and `Re_θ` (the interval's midpoint value takes
/// the ends' means of the two, XFOIL's `BLMID`).
pub fn cf_of<const N: usize>(hk: D<N>, rt: D<N>, k: Kind) -> D<N> {
    cf_parts(hk, rt, k).0
}

/// [`cf_of`], and on a turbulent wall the turbulent formula's own value (which [`cdi`] reads
/// too; zero elsewhere).
fn cf_parts<const N: usize>(hk: D<N>, rt: D<N>, k: Kind) -> (D<N>, D<N>) {
    if k.wake {
        (D::c(0.0), D::c(0.0))
    } else if k.turb {
        let cft = cf_turbulent(hk, rt);
        (cft.max(cf_laminar(hk, rt)), cft)
    } else {
        (cf_laminar(hk, rt), D::c(0.0))
    }
}

/// Swafford's turbulent skin friction at Mach 0 (XFOIL's `CFT`).
fn cf_turbulent<const N: usize>(hk: D<N>, rt: D<N>) -> D<N> {
    let mut aa = -1.33 * hk;
    if aa.v < -17.0 {
        aa = -20.0 + 3.0 * ((aa + 17.0) / 3.0).exp();
    }
    let bb = rt.ln().fmax(3.0) / std::f64::consts::LN_10;
    let cc = -1.74 - 0.31 * hk;
    let dd = (4.0 - hk / 0.875).tanh();
    0.3 * aa.exp() * bb.pow(cc) + 1.1e-4 * (dd - 1.0)
}

/// The laminar skin friction (XFOIL's `CFL`).
fn cf_laminar<const N: usize>(hk: D<N>, rt: D<N>) -> D<N> {
    let num = if hk.v < 5.5 {
        0.0727 * (5.5 - hk).powi(3) / (hk + 1.0) - 0.07
    } else {
        0.015 * (1.0 - 1.0 / (hk - 4.5)).powi(2) - 0.07
    };
    num / rt
}

/// The normalised slip velocity `Us`.
pub fn us<const N: usize>(u: &Du<N>, k: Kind, f: &Fluid) -> D<N> {
    us_of(hs(u, k, f), hk_limited(u, k), h(u), k)
}

/// [`us`] from `H*`, the limited `Hk` and `H`.
fn us_of<const N: usize>(hsv: D<N>, hk: D<N>, h: D<N>, k: Kind) -> D<N> {
    let v = 0.5 * hsv * (1.0 - (hk - 1.0) / (GB * h));
    if !k.wake && v.v > 0.95 {
        D::c(0.98)
    } else {
        v.fmin(0.99995)
    }
}

/// `√Cτ_eq`, the equilibrium shear stress.
pub fn cteq<const N: usize>(u: &Du<N>, k: Kind, f: &Fluid) -> D<N> {
    let hsv = hs(u, k, f);
    cteq_of(
        hsv,
        us_of(hsv, hk_limited(u, k), h(u), k),
        hk_limited(u, k),
        h(u),
        ret(u, f),
        k,
    )
}

/// [`cteq`] from `H*`, `Us`, the limited `Hk`, `H` and `Re_θ`.
fn cteq_of<const N: usize>(hsv: D<N>, usv: D<N>, hk: D<N>, h: D<N>, rt: D<N>, k: Kind) -> D<N> {
    let cc = 0.5 / (GA * GA * GB);
    let hkc = if k.wake {
        hk - 1.0
    } else {
        (hk - 1.0 - GC / rt).fmax(0.01)
    };
    let num = cc * hsv * (hk - 1.0) * hkc * hkc;
    let den = (1.0 - usv) * h * hk * hk;
    (num / den).sqrt()
}

/// `√Cτ` just after transition.
pub fn cttr<const N: usize>(u: &Du<N>, f: &Fluid) -> D<N> {
    let hk = hk_limited(u, Kind::TURBULENT);
    CTAU_C * (-CTAU_E / (hk - 1.0)).exp() * cteq(u, Kind::TURBULENT, f)
}

/// The boundary-layer thickness `δ` of the shear-lag equation.
pub fn de<const N: usize>(u: &Du<N>, k: Kind) -> D<N> {
    de_of(u, hk_limited(u, k))
}

fn de_of<const N: usize>(u: &Du<N>, hk: D<N>) -> D<N> {
    (u[0] * (3.15 + 1.72 / (hk - 1.0)) + u[1]).min(12.0 * u[0])
}

/// The laminar dissipation from `H` and `Re_θ`.
fn cdi_lam<const N: usize>(hk: D<N>, rt: D<N>) -> D<N> {
    let num = if hk.v < 4.0 {
        0.00205 * (4.0 - hk).powf(5.5) + 0.207
    } else {
        let a = hk - 4.0;
        -0.0016 * a * a / (1.0 + 0.02 * a * a) + 0.207
    };
    num / rt
}

/// The dissipation function `2 CD / H*`.
pub fn cdi<const N: usize>(u: &Du<N>, k: Kind, f: &Fluid) -> D<N> {
    Station::new(u, k, f).cdi
}

/// [`cdi`] from the station's other closures (`cft`: the turbulent `Cf` at the limited `Hk`;
/// on the wall that limit is 1.05, as [`cdi`]'s own).
fn cdi_of<const N: usize>(u: &Du<N>, s: &Station<N>, cft: D<N>, k: Kind) -> D<N> {
    if !k.turb {
        return cdi_lam(s.h, s.rt);
    }
    let (hsv, usv, rt) = (s.hs, s.us, s.rt);
    let mut d = D::c(0.0);
    let lam = if k.wake {
        let hk = s.hk;
        let hs_lam = hs_of(s.h.fmax(1.05), rt, Kind::LAMINAR);
        2.0 * 1.1 * (1.0 - 1.0 / hk).powi(2) / hk / (hs_lam * rt)
    } else {
        let hk = s.h;
        let lr = rt.ln();
        let hmin = 1.0 + 2.1 / lr;
        let fac = 0.5 + 0.5 * ((hk - 1.0) / (hmin - 1.0)).tanh();
        d = d + cft * usv / hsv * fac;
        cdi_lam(s.h, rt)
    };
    d = d + u[2] * u[2] * (0.995 - usv) * 2.0 / hsv;
    d = d + 0.15 * (0.995 - usv).powi(2) * 2.0 / (hsv * rt);
    d = d.max(lam);
    if k.wake {
        2.0 * d
    } else {
        d
    }
}

/// A station's closures, each taken once: the interval equations read most of them at both
/// ends, some twice, and [`cdi`], [`cteq`] and [`us`] each take [`hs`] again. The same
/// operations as the functions above, so the same values: `h` is `H`, `hk` the limited `Hk`
/// ([`hk_limited`]), `rt` `Re_θ`, `hs` `H*`, `us` `Us`, `cf` `Cf`, `cdi` `2 CD / H*`, `cteq`
/// `√Cτ_eq` and `de` `δ`; `us`, `cteq` and `de` are only taken for a turbulent kind (zero
/// otherwise).
pub struct Station<const N: usize> {
    // The state's own parameters.
    pub h: D<N>,
    pub hk: D<N>,
    pub rt: D<N>,
    // The shape and friction closures.
    pub hs: D<N>,
    pub us: D<N>,
    pub cf: D<N>,
    // The dissipation and the shear-lag closures.
    pub cdi: D<N>,
    pub cteq: D<N>,
    pub de: D<N>,
}

impl<const N: usize> Station<N> {
    /// The closures of state `u` for kind `k`.
    pub fn new(u: &Du<N>, k: Kind, f: &Fluid) -> Station<N> {
        let (h, hk, rt) = (h(u), hk_limited(u, k), ret(u, f));
        let hs = hs_of(hk, rt, k);
        let (cf, cft) = cf_parts(hk, rt, k);
        let mut s = Station {
            h,
            hk,
            rt,
            hs,
            us: D::c(0.0),
            cf,
            cdi: D::c(0.0),
            cteq: D::c(0.0),
            de: D::c(0.0),
        };
        if k.turb {
            s.us = us_of(hs, hk, h, k);
            s.cteq = cteq_of(hs, s.us, hk, h, rt, k);
            s.de = de_of(u, hk);
        }
        s.cdi = cdi_of(u, &s, cft, k);
        s
    }
}

/// The equilibrium `(1/uₑ) duₑ/dξ` of the shear-lag equation, from averaged quantities.
pub fn uq<const N: usize>(ds: D<N>, cf: D<N>, hk: D<N>, rt: D<N>, k: Kind) -> D<N> {
    let (a, c) = if k.wake { (GA * DLR, 0.0) } else { (GA, GC) };
    let hk = hk.fmax(if k.wake { 1.00005 } else { 1.05 });
    let hkc = (hk - 1.0 - c / rt).fmax(0.01);
    (0.5 * cf - (hkc / (a * hk)).powi(2)) / (GB * ds)
}

/// The envelope amplification rate `dN/dξ` of one station (XFOIL's `DAMPL`).
pub fn damp<const N: usize>(u: &Du<N>, f: &Fluid) -> D<N> {
    let hk = h(u).fmax(1.05);
    let th = u[0];
    let hmi = 1.0 / (hk - 1.0);
    let aa = 2.492 * hmi.powf(0.43);
    let bb = (14.0 * hmi - 9.24).tanh();
    let grcrit = aa + 0.7 * (bb + 1.0);
    let gr = ret(u, f).fmax(1e-30).log10();
    let dgr = 0.08;
    if gr.v < grcrit.v - dgr {
        return D::c(0.0);
    }
    let rn = (gr - (grcrit - dgr)) / (2.0 * dgr);
    let rf = if rn.v >= 1.0 {
        D::c(1.0)
    } else {
        3.0 * rn * rn - 2.0 * rn * rn * rn
    };
    let ar = 3.87 * hmi - 2.52;
    let da = 0.028 * (hk - 1.0) - 0.0345 * (-ar * ar).exp();
    let af = -0.05 + 2.7 * hmi - 5.5 * hmi * hmi + 3.0 * hmi.powi(3);
    rf * af * da / th
}

/// The amplification rate over an interval (XFOIL 6.99's `AXSET`): the root mean square of the
/// ends' rates plus a small term that keeps `dN/dξ > 0` near `Ncrit`.
pub fn damp_interval<const N: usize>(u1: &Du<N>, u2: &Du<N>, f: &Fluid) -> D<N> {
    let (a1, a2) = (damp(u1, f), damp(u2, f));
    let ms = 0.5 * (a1 * a1 + a2 * a2);
    // Both rates zero (below the critical Re_θ): so are their partials, not √0's.
    let axa = if ms.v > 0.0 { ms.sqrt() } else { D::c(0.0) };
    let arg = (20.0 * (f.ncrit - 0.5 * (u1[2] + u2[2]))).fmin(20.0);
    let exn = if arg.v <= 0.0 { D::c(1.0) } else { (-arg).exp() };
    axa + exn * 0.002 / (u1[0] + u2[0])
}

/// Plain (`f64`) forms of the closures the solver reads outside the equations.
pub mod plain {
    use super::{Fluid, Kind};
    use crate::aero::viscous::dual::lift;

    /// [`super::h`].
    pub fn h(u: &[f64; 4]) -> f64 {
        u[1] / u[0]
    }

    /// [`super::cf`].
    pub fn cf(u: &[f64; 4], k: Kind, f: &Fluid) -> f64 {
        super::cf(&lift(u), k, f).v
    }

    /// [`super::cttr`].
    pub fn cttr(u: &[f64; 4], f: &Fluid) -> f64 {
        super::cttr(&lift(u), f).v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aero::viscous::dual::lift;

    const F: Fluid = Fluid { re: 1e6, ncrit: 9.0 };

    /// Blasius: H = 2.59, H* = 1.573, Cf Re_θ = 0.441, 2CD/H* Re_θ ≈ 0.4.
    #[test]
    fn laminar_closures_near_blasius() {
        let th = 1e-3;
        let u = lift(&[th, 2.59 * th, 0.0, 1.0]);
        let rt = ret(&u, &F).v;
        assert!((hs(&u, Kind::LAMINAR, &F).v - 1.573).abs() < 0.01);
        assert!((cf(&u, Kind::LAMINAR, &F).v * rt - 0.441).abs() < 0.02);
        assert!((cdi(&u, Kind::LAMINAR, &F).v * rt - 0.22).abs() < 0.01);
    }

    /// A flat-plate turbulent layer at Re_θ = 5000: Cf about 0.0027, H* about 1.75.
    #[test]
    fn turbulent_closures_are_plausible() {
        let th = 5e-3;
        let u = lift(&[th, 1.4 * th, 0.03, 1.0]);
        let c = cf(&u, Kind::TURBULENT, &F).v;
        assert!(c > 0.002 && c < 0.0035, "{c}");
        let hsv = hs(&u, Kind::TURBULENT, &F).v;
        assert!(hsv > 1.6 && hsv < 1.9, "{hsv}");
        assert!(cteq(&u, Kind::TURBULENT, &F).v > 0.0);
    }
}
