//! `CurveChain`: a chain of Bezier segments with generated joins, over a global parameter in `[0,
//! 1]`.

use super::layout::ChainLayout;
use crate::bezier::{BezierCurve, Vector};
use crate::error::{Error, Result};

/// A chain of Bezier curves: its layout, its design points and the expanded control points.
///
/// Segment `k` uses control points `k*d ..= (k+1)*d` and local parameter
/// `u = (t - t[k]) / h[k]`.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveChain<P: Vector> {
    layout: ChainLayout,
    design: Vec<P>,
    ctrl: Vec<P>,
}

impl<P: Vector> CurveChain<P> {
    /// A chain from its layout and `layout.design_count()` design points.
    pub fn new(layout: ChainLayout, design: Vec<P>) -> Result<Self> {
        if design.len() != layout.design_count() {
            return Err(Error::invalid(format!(
                "{} design points given, the layout needs {}",
                design.len(),
                layout.design_count()
            )));
        }
        let ctrl = layout.map().apply(&design);
        Ok(CurveChain { layout, design, ctrl })
    }

    /// The layout (degree, breaks, continuity).
    #[must_use]
    pub fn layout(&self) -> &ChainLayout {
        &self.layout
    }

    /// The design points (optimisation variables).
    #[must_use]
    pub fn design(&self) -> &[P] {
        &self.design
    }

    /// The expanded Bezier control points, `s * d + 1` of them.
    #[must_use]
    pub fn ctrl(&self) -> &[P] {
        &self.ctrl
    }

    /// Replace the design points and regenerate the expanded ones.
    pub fn set_design(&mut self, design: &[P]) {
        // `copy_from_slice` refuses a design of another size (a panic in every build).
        self.design.copy_from_slice(design);
        self.layout.map().apply_into(&self.design, &mut self.ctrl);
    }

    /// Control points of segment `k`.
    #[must_use]
    pub fn segment_ctrl(&self, k: usize) -> &[P] {
        let d = self.layout.degree();
        &self.ctrl[k * d..=(k + 1) * d]
    }

    /// Segment `k` as a Bezier curve over its local parameter.
    #[must_use]
    pub fn segment(&self, k: usize) -> BezierCurve<P> {
        BezierCurve::new(self.segment_ctrl(k).to_vec())
    }

    /// Evaluate the chain at global parameter `t`.
    #[must_use]
    pub fn eval(&self, t: f64) -> P {
        let (k, u) = self.layout.locate(t);
        self.segment(k).eval(u)
    }

    /// The derivative with respect to the global parameter, taken from the segment holding `t`
    /// (at a join, the segment that starts there).
    #[must_use]
    pub fn deriv(&self, t: f64) -> P {
        let (k, u) = self.layout.locate(t);
        self.segment(k).eval_deriv(u) * (1.0 / self.layout.segment_length(k))
    }

    /// Derivatives of order `order` (1 or 2) with respect to the global parameter at the end
    /// of segment `k` and the start of segment `k + 1`.
    #[must_use]
    pub fn join_derivs(&self, k: usize, order: u32) -> (P, P) {
        let (mut left, mut right) = (self.segment(k), self.segment(k + 1));
        for _ in 0..order {
            left = left.deriv();
            right = right.deriv();
        }
        let (hl, hr) = (self.layout.segment_length(k), self.layout.segment_length(k + 1));
        let l = *left.ctrl.last().unwrap_or(&P::ZERO) * (1.0 / hl.powi(order as i32));
        let r = right.ctrl[0] * (1.0 / hr.powi(order as i32));
        (l, r)
    }

    /// The largest relative jump of the `order`-th derivative across any join (0 for one segment).
    #[must_use]
    pub fn continuity_error(&self, order: u32) -> f64 {
        (0..self.layout.segments().saturating_sub(1))
            .map(|k| {
                let (l, r) = self.join_derivs(k, order);
                let scale = l.length().max(r.length()).max(f64::MIN_POSITIVE);
                (l - r).length() / scale
            })
            .fold(0.0, f64::max)
    }

    /// The same chain as a C1 chain of its degree and breaks, with the same expanded control
    /// points: its design points are the control points less the generated joins. An error
    /// when a join is only C0, or when the regenerated control points differ (they cannot,
    /// up to rounding, for joins at least C1).
    pub fn to_c1(&self) -> Result<CurveChain<P>> {
        let c1 = self
            .layout
            .as_c1()
            .ok_or_else(|| Error::invalid("a chain with C0 joins has no C1 form"))?;
        let d = c1.degree();
        let last = c1.segments() * d;
        let design: Vec<P> = self
            .ctrl
            .iter()
            .enumerate()
            .filter(|(r, _)| r % d != 0 || *r == 0 || *r == last)
            .map(|(_, &p)| p)
            .collect();
        let chain = CurveChain::new(c1, design)?;
        super::check_regenerated(chain.ctrl(), &self.ctrl, "chain")?;
        Ok(chain)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chain::Continuity;
    use glam::DVec2;
    use proptest::prelude::*;

    fn breaks_from(gaps: &[f64]) -> Vec<f64> {
        let total: f64 = gaps.iter().sum();
        let mut b = vec![0.0];
        let mut acc = 0.0;
        for g in &gaps[..gaps.len() - 1] {
            acc += g / total;
            b.push(acc);
        }
        b.push(1.0);
        b
    }

    /// A chain of degree `d` with breaks from `gaps` and design points from `seed`.
    fn random_chain(d: usize, gaps: &[f64], continuity: Continuity, seed: &[f64]) -> CurveChain<DVec2> {
        let layout = ChainLayout::with_breaks(d, breaks_from(gaps), continuity).unwrap();
        let design = (0..layout.design_count())
            .map(|i| DVec2::new(seed[2 * i], seed[2 * i + 1]))
            .collect();
        CurveChain::new(layout, design).unwrap()
    }

    proptest! {
        #[test]
        fn c1_and_c2_chains_are_as_smooth_as_their_joins(
            d in 2usize..7,
            order in 1usize..3,
            gaps in prop::collection::vec(0.05f64..1.0, 1..7),
            seed in prop::collection::vec(-1.0f64..1.0, 80),
        ) {
            // C2 needs degree 3 or more.
            prop_assume!(order < d);
            let chain = random_chain(d, &gaps, Continuity::at_least(order), &seed);
            for k in 1..=order as u32 {
                prop_assert!(chain.continuity_error(k) < 1e-9, "C{} jump {}", k, chain.continuity_error(k));
            }
        }
    }

    #[test]
    fn c0_chains_are_continuous_but_may_kink() {
        let layout = ChainLayout::uniform(2, 2, Continuity::C0).unwrap();
        let design = vec![
            DVec2::ZERO,
            DVec2::new(1.0, 1.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(3.0, 1.0),
            DVec2::new(4.0, 0.0),
        ];
        let chain = CurveChain::new(layout, design).unwrap();
        assert_eq!(chain.eval(0.5), DVec2::new(2.0, 0.0));
        assert!(chain.continuity_error(1) > 0.1);
    }

    #[test]
    fn wrong_design_count_is_an_error() {
        let layout = ChainLayout::uniform(3, 5, Continuity::C1).unwrap();
        assert!(CurveChain::new(layout, vec![DVec2::ZERO; 11]).is_err());
    }
}
