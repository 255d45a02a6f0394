//! The Kármán–Trefftz aerofoil and its exact potential flow: the panel method's analytic truth.
//!
//! A circle through `ζ = b` with centre `μ` maps to an aerofoil with a trailing-edge angle
//! `τ = (2 − k) π` by `z = k b (1 + Q) / (1 − Q)`, `Q = ((ζ − b)/(ζ + b))^k`. The flow past the
//! circle at angle of attack α with the circulation `Γ = 4π V R sin(α + β)` (β the angle of
//! `μ − b` below the real axis, the Kutta condition at `ζ = b`) maps to the flow past the
//! aerofoil: its surface speed is `|dF/dζ| / |dz/dζ|`, and its lift `ρ V Γ`. The map tends to
//! `z = ζ` far away, so α is the same in both planes.

use super::contour::{leading_edge_param, Contour};
use super::panel::Chord;
use glam::DVec2;
use nalgebra::Complex;
use std::f64::consts::PI;

type C = Complex<f64>;

/// A Kármán–Trefftz aerofoil.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KarmanTrefftz {
    /// The circle's centre `μ` (in units of `b`).
    pub centre: DVec2,
    /// The exponent `k = 2 − τ/π` (2: the cusped Joukowski aerofoil).
    pub k: f64,
    /// The point `b` on the real axis that becomes the trailing edge.
    pub b: f64,
}

impl KarmanTrefftz {
    /// The aerofoil of circle centre `centre` and trailing-edge angle `tau_deg` degrees, `b = 1`.
    #[must_use]
    pub fn new(centre: DVec2, tau_deg: f64) -> Self {
        KarmanTrefftz {
            centre,
            k: 2.0 - tau_deg / 180.0,
            b: 1.0,
        }
    }

    fn mu(&self) -> C {
        C::new(self.centre.x, self.centre.y)
    }

    /// The circle's radius `|b − μ|`.
    #[must_use]
    pub fn radius(&self) -> f64 {
        (C::new(self.b, 0.0) - self.mu()).norm()
    }

    /// The circle angle of the trailing edge: `arg(b − μ)`.
    fn phi_te(&self) -> f64 {
        (C::new(self.b, 0.0) - self.mu()).arg()
    }

    /// The circle point at parameter `t`: from the trailing edge counterclockwise.
    fn zeta(&self, t: f64) -> (C, f64) {
        let phi = self.phi_te() + 2.0 * PI * t;
        (self.mu() + C::from_polar(self.radius(), phi), phi)
    }

    /// `z(ζ)` and `dz/dζ`.
    fn map(&self, zeta: C) -> (C, C) {
        let b = C::new(self.b, 0.0);
        let k = self.k;
        let ratio = (zeta - b) / (zeta + b);
        let one = C::new(1.0, 0.0);
        if ratio.norm() == 0.0 {
            // The trailing edge: dz/dζ vanishes there like (ζ − b)^(k − 1).
            return (b * k, C::new(0.0, 0.0));
        }
        let q = ratio.powf(k);
        let z = b * k * (one + q) / (one - q);
        let dz = b * b * (4.0 * k * k) * q / ((zeta * zeta - b * b) * (one - q) * (one - q));
        (z, dz)
    }

    /// The aerofoil point at parameter `t ∈ [0, 1]` (trailing edge at both ends, upper
    /// surface first: counterclockwise).
    #[must_use]
    pub fn point(&self, t: f64) -> DVec2 {
        let (zeta, _) = self.zeta(t);
        let (z, _) = self.map(zeta);
        DVec2::new(z.re, z.im)
    }

    /// The circulation (clockwise positive) per unit free stream at `alpha` degrees.
    #[must_use]
    pub fn circulation(&self, alpha: f64) -> f64 {
        // Zero speed at the trailing edge: 2 V sin(φ_te − α) + Γ / (2π R) = 0.
        -4.0 * PI * self.radius() * (self.phi_te() - alpha.to_radians()).sin()
    }

    /// The exact surface speed (per unit free stream) at parameter `t` and `alpha` degrees;
    /// 0 at the trailing edge (a stagnation point when `k < 2`).
    #[must_use]
    pub fn speed(&self, t: f64, alpha: f64) -> f64 {
        let (zeta, phi) = self.zeta(t);
        let (_, dz) = self.map(zeta);
        let r = self.radius();
        let w = 2.0 * (phi - alpha.to_radians()).sin() + self.circulation(alpha) / (2.0 * PI * r);
        if dz.norm() == 0.0 {
            0.0
        } else {
            w.abs() / dz.norm()
        }
    }

    /// The exact pressure coefficient `1 − speed²` at parameter `t` and `alpha` degrees.
    #[must_use]
    pub fn cp(&self, t: f64, alpha: f64) -> f64 {
        1.0 - self.speed(t, alpha).powi(2)
    }

    /// The chord as the panel method measures it: leading edge farthest from the trailing edge.
    #[must_use]
    pub fn chord(&self) -> Chord {
        let f = |t: f64| self.point(t);
        let t_le = leading_edge_param(&f);
        let le = self.point(t_le);
        let te = self.point(0.0);
        Chord {
            le,
            te,
            le_node: 0,
            le_after: false,
            length: (te - le).length(),
        }
    }

    /// The exact lift coefficient at `alpha` degrees: `2 Γ / (V c)`.
    #[must_use]
    pub fn cl(&self, alpha: f64) -> f64 {
        2.0 * self.circulation(alpha) / self.chord().length
    }

    /// CL and CM (about the quarter chord) by integrating the exact pressures with `samples`
    /// trapezoidal steps in the circle angle (a check on [`cl`](Self::cl), and the reference
    /// CM).
    #[must_use]
    pub fn integrated(&self, alpha: f64, samples: usize) -> (f64, f64) {
        let chord = self.chord();
        let nodes: Vec<DVec2> = (0..=samples)
            .map(|k| self.point(k as f64 / samples as f64))
            .collect();
        let cp: Vec<f64> = (0..=samples)
            .map(|k| self.cp(k as f64 / samples as f64, alpha))
            .collect();
        super::panel::integrate(&nodes, &cp, alpha, &chord)
    }
}

/// The panel method's errors on a Kármán–Trefftz aerofoil at one node count and angle.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TruthErrors {
    /// Panel nodes.
    pub nodes: usize,
    /// Angle of attack, degrees.
    pub alpha: f64,
    /// The exact CL.
    pub cl_exact: f64,
    /// The panel method's CL.
    pub cl: f64,
    /// `|CL − CL_exact| / |CL_exact|`.
    pub cl_rel: f64,
    /// `|CM − CM_exact|` (CM_exact from the exact pressures, finely integrated).
    pub cm_abs: f64,
    /// The largest `|Cp − Cp_exact|` over the nodes, the two trailing-edge nodes excluded.
    pub cp_max: f64,
    /// The index of that node.
    pub cp_max_at: usize,
    /// `|Cp − Cp_exact|` at the trailing-edge nodes (the larger of the two).
    pub cp_te: f64,
}

impl KarmanTrefftz {
    /// Panel the aerofoil ([`panel_params`](super::panel_params)), solve, and compare with
    /// the exact flow at `alpha` degrees.
    pub fn errors(&self, paneling: &super::Paneling, alpha: f64) -> crate::Result<TruthErrors> {
        let nodes = paneling.nodes;
        let t = super::contour::panel_params(self, paneling)?;
        let pts: Vec<DVec2> = t.iter().map(|&u| self.point(u)).collect();
        let sol = super::panel::PanelSolution::solve(&pts)?;
        let c = sol.coefficients(alpha);
        let cl_exact = self.cl(alpha);
        let (_, cm_exact) = self.integrated(alpha, 1 << 20);
        let cp = sol.cp(alpha);
        let err: Vec<f64> = t
            .iter()
            .zip(&cp)
            .map(|(&u, &p)| (p - self.cp(u, alpha)).abs())
            .collect();
        let n = err.len();
        let (cp_max_at, cp_max) =
            err[1..n - 1].iter().enumerate().fold(
                (0, 0.0f64),
                |(k, m), (i, &e)| if e > m { (i + 1, e) } else { (k, m) },
            );
        Ok(TruthErrors {
            nodes,
            alpha,
            cl_exact,
            cl: c.cl,
            cl_rel: (c.cl - cl_exact).abs() / cl_exact.abs(),
            cm_abs: (c.cm - cm_exact).abs(),
            cp_max,
            cp_max_at,
            cp_te: err[0].max(err[n - 1]),
        })
    }
}

impl Contour for KarmanTrefftz {
    fn point(&self, t: f64) -> DVec2 {
        KarmanTrefftz::point(self, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_and_its_derivative_agree() {
        let kt = KarmanTrefftz::new(DVec2::new(-0.1, 0.1), 10.0);
        assert!((kt.point(0.0) - DVec2::new(kt.k, 0.0)).length() < 1e-12);
        for t in [0.1, 0.3, 0.5, 0.77] {
            let (zeta, _) = kt.zeta(t);
            let h = C::new(1e-6, 0.0);
            let (z1, dz) = kt.map(zeta);
            let (z2, _) = kt.map(zeta + h);
            assert!(((z2 - z1) / h - dz).norm() < 1e-5);
        }
    }

    #[test]
    fn the_trailing_edge_is_a_stagnation_point_and_lift_is_the_integrated_pressure() {
        let kt = KarmanTrefftz::new(DVec2::new(-0.1, 0.1), 10.0);
        for alpha in [0.0, 4.0, 8.0] {
            // The speed vanishes as (distance)^(1 - τ/π) / ... : slowly for a 10° edge.
            let (near, nearer) = (kt.speed(1e-5, alpha), kt.speed(1e-11, alpha));
            assert!(nearer < 0.6 * near, "{near} {nearer}");
            assert_eq!(kt.speed(0.0, alpha), 0.0);
            let (cl, _) = kt.integrated(alpha, 1 << 18);
            assert!(
                (cl - kt.cl(alpha)).abs() < 1e-7 * kt.cl(alpha).abs().max(1.0),
                "{cl} {}",
                kt.cl(alpha)
            );
        }
    }
}
