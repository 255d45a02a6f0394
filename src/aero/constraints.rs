//! The constraints of an optimisation that the panel kernel does not compute, checked in f64
//! on the CPU from an individual's nodes and coefficients: thickness at given stations, the
//! trailing-edge wedge angle, the enclosed area and a smallest CL ([`ExtraConstraints`]); and
//! which constraints a result sits on ([`Active`], `docs/ARCHITECTURE.md` §5.9).

use super::batch::{flags, PENALTY_CONSTRAINT};
use super::panel::Chord;
use crate::error::{Error, Result};
use glam::DVec2;
use serde::Serialize;

/// Where the trailing-edge wedge angle is measured from: the chord fraction of the points on
/// each surface that the lines to the trailing-edge points start at.
pub const TE_ANGLE_FROM: f64 = 0.95;

/// A constraint counts as active when the result lies within this fraction of its bound
/// (of `max(|bound|, 0.01)`) on the feasible side, or breaks it.
pub const ACTIVE_FRACTION: f64 = 0.01;

/// Constraints checked after the kernel (none by default).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExtraConstraints {
    /// `(x/c, t/c)`: the thickness at chord fraction `x/c` at least `t/c`.
    pub thickness_at: Vec<(f64, f64)>,
    /// The trailing-edge wedge angle (degrees, between the surfaces' lines from
    /// [`TE_ANGLE_FROM`] of the chord to their trailing-edge points) at least this.
    pub min_te_angle: Option<f64>,
    /// The enclosed area over chord² at least this.
    pub min_area: Option<f64>,
    /// CL at least this (viscous: at the first operating point).
    pub cl_min: Option<f64>,
}

impl ExtraConstraints {
    /// Whether there is anything to check.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.thickness_at.is_empty()
            && self.min_te_angle.is_none()
            && self.min_area.is_none()
            && self.cl_min.is_none()
    }

    /// `Ok` when every bound is meaningful; otherwise the error naming its option.
    pub fn check(&self) -> Result<()> {
        for &(x, t) in &self.thickness_at {
            if !(x > 0.0 && x < 1.0 && (0.0..1.0).contains(&t)) {
                return Err(Error::invalid(format!(
                    "--min-thickness-at takes X:T with 0 < X < 1 and 0 <= T < 1, not {x}:{t}"
                )));
            }
        }
        if self.min_te_angle.is_some_and(|a| !(0.0..90.0).contains(&a)) {
            return Err(Error::invalid("--min-te-angle takes degrees between 0 and 90"));
        }
        if self.min_area.is_some_and(|a| !(0.0..1.0).contains(&a)) {
            return Err(Error::invalid("--min-area takes an area/chord² between 0 and 1"));
        }
        if self.cl_min.is_some_and(|c| !c.is_finite()) {
            return Err(Error::invalid("--cl-min must be a finite number"));
        }
        Ok(())
    }

    /// The geometric bounds' shortfalls on `nodes` (counterclockwise from the upper trailing
    /// edge): the [`flags`] bits broken and the summed shortfall.
    #[must_use]
    pub fn geometry(&self, nodes: &[DVec2]) -> (u32, f64) {
        let m = Measures::of(nodes);
        let (mut fl, mut short) = (0u32, 0.0);
        for &(x, t) in &self.thickness_at {
            let have = m.thickness_at(x);
            if have < t {
                fl |= flags::THIN_AT;
                short += t - have;
            }
        }
        if let Some(a) = self.min_te_angle {
            let have = m.te_angle();
            if have < a {
                fl |= flags::TE_ANGLE;
                // Degrees to radians: a shortfall on the scale of the chord fractions.
                short += (a - have).to_radians();
            }
        }
        if let Some(a) = self.min_area {
            let have = m.area();
            if have < a {
                fl |= flags::AREA;
                short += a - have;
            }
        }
        (fl, short)
    }

    /// The shortfall of `cl` below [`cl_min`](Self::cl_min): the flag and the amount.
    #[must_use]
    pub fn lift(&self, cl: f64) -> (u32, f64) {
        match self.cl_min {
            Some(c) if cl < c => (flags::CL, c - cl),
            _ => (0, 0.0),
        }
    }
}

/// The score of a valid shape: its objective, or [`PENALTY_CONSTRAINT`] plus the summed
/// shortfall when it breaks a constraint.
#[must_use]
pub fn penalised(objective: f64, shortfall: f64) -> f64 {
    if shortfall > 0.0 {
        PENALTY_CONSTRAINT + shortfall
    } else {
        objective
    }
}

/// Geometric measures of a shape in its own chord axes (chord fractions).
pub struct Measures {
    upper: Vec<DVec2>,
    lower: Vec<DVec2>,
    area: f64,
}

impl Measures {
    /// The measures of `nodes` (counterclockwise from the upper trailing edge).
    #[must_use]
    pub fn of(nodes: &[DVec2]) -> Measures {
        let chord = Chord::of(nodes);
        let len = chord.length.max(f64::MIN_POSITIVE);
        let dir = (chord.te - chord.le) / len;
        let local = |p: &DVec2| {
            let d = *p - chord.le;
            DVec2::new(d.dot(dir) / len, dir.perp_dot(d) / len)
        };
        let k = chord.le_node;
        // Each surface from the leading edge back, the leading edge itself first.
        let le = DVec2::ZERO;
        let mut upper: Vec<DVec2> = vec![le];
        upper.extend(nodes[..k].iter().rev().map(local));
        let mut lower: Vec<DVec2> = vec![le];
        lower.extend(nodes[k..].iter().map(local));
        let n = nodes.len();
        let twice: f64 = (0..n)
            .map(|i| {
                let (a, b) = (local(&nodes[i]), local(&nodes[(i + 1) % n]));
                a.perp_dot(b)
            })
            .sum();
        Measures {
            upper,
            lower,
            area: 0.5 * twice.abs(),
        }
    }

    /// The surface's y at chord fraction `x` (the first crossing from the leading edge; the
    /// trailing-edge point's y beyond it).
    fn y(surface: &[DVec2], x: f64) -> f64 {
        for w in surface.windows(2) {
            let (a, b) = (w[0], w[1]);
            if (a.x <= x && x <= b.x || b.x <= x && x <= a.x) && a.x != b.x {
                return a.y + (x - a.x) / (b.x - a.x) * (b.y - a.y);
            }
        }
        surface.last().map_or(0.0, |p| p.y)
    }

    /// Upper less lower y at chord fraction `x`.
    #[must_use]
    pub fn thickness_at(&self, x: f64) -> f64 {
        Self::y(&self.upper, x) - Self::y(&self.lower, x)
    }

    /// The wedge angle at the trailing edge, degrees: between the lines from each surface's
    /// point at [`TE_ANGLE_FROM`] to its trailing-edge point.
    #[must_use]
    pub fn te_angle(&self) -> f64 {
        let slope = |s: &[DVec2]| {
            let end = s.last().copied().unwrap_or(DVec2::X);
            let from = DVec2::new(TE_ANGLE_FROM, Self::y(s, TE_ANGLE_FROM));
            (end.y - from.y).atan2(end.x - from.x)
        };
        (slope(&self.lower) - slope(&self.upper)).to_degrees()
    }

    /// The enclosed area over chord².
    #[must_use]
    pub fn area(&self) -> f64 {
        self.area
    }
}

/// A constraint the result sits on or breaks.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Active {
    /// Its option (`min-thickness`, `min-thickness-at 0.9`, `cm-min`, `cl-min`,
    /// `min-te-angle`, `min-area`).
    pub constraint: String,
    /// The bound.
    pub bound: f64,
    /// The result's value.
    pub value: f64,
}

/// The constraints among `(name, bound, value)` that are active: the value within
/// [`ACTIVE_FRACTION`] of its lower bound, or below it.
#[must_use]
pub fn active(all: Vec<(String, f64, f64)>) -> Vec<Active> {
    all.into_iter()
        .filter(|(_, bound, value)| value - bound <= ACTIVE_FRACTION * bound.abs().max(0.01))
        .map(|(constraint, bound, value)| Active {
            constraint,
            bound,
            value,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::test_contour;

    /// NACA 0012's thickness at stations, wedge angle and area against its thickness formula.
    #[test]
    fn naca0012_measures_match_its_formula() {
        let pts = test_contour("0012", 321);
        let m = Measures::of(&pts);
        let yt = |x: f64| {
            0.6 * (0.2969 * x.sqrt() - 0.1260 * x - 0.3516 * x * x + 0.2843 * x.powi(3) - 0.1015 * x.powi(4))
        };
        for x in [0.1, 0.3, 0.5, 0.9] {
            let t = m.thickness_at(x);
            assert!((t - 2.0 * yt(x)).abs() < 2e-4, "x {x}: {t} vs {}", 2.0 * yt(x));
        }
        // The area: 2 ∫ yt dx over the chord (0.6 × 0.0685...).
        let exact =
            2.0 * 0.6 * (0.2969 * 2.0 / 3.0 - 0.1260 / 2.0 - 0.3516 / 3.0 + 0.2843 / 4.0 - 0.1015 / 5.0);
        assert!((m.area() - exact).abs() < 1e-3 * exact, "{} vs {exact}", m.area());
        // The wedge angle from the chord lines from 0.95 to the trailing edge.
        let wedge = 2.0 * ((yt(0.95) - yt(1.0)) / 0.05).atan().to_degrees();
        assert!((m.te_angle() - wedge).abs() < 0.05, "{} vs {wedge}", m.te_angle());
        let c = ExtraConstraints {
            thickness_at: vec![(0.9, 0.05)],
            min_te_angle: Some(wedge + 1.0),
            min_area: Some(0.05),
            cl_min: Some(0.5),
        };
        let (fl, short) = c.geometry(&pts);
        assert_eq!(fl, flags::THIN_AT | flags::TE_ANGLE);
        assert!(short > 0.0);
        assert_eq!(c.lift(0.4).0, flags::CL);
        let act = active(vec![("a".into(), 0.12, 0.1205), ("b".into(), 0.12, 0.2)]);
        assert_eq!(act.len(), 1);
        assert_eq!(act[0].constraint, "a");
    }
}
