//! `max-ld`: the largest viscous lift-to-drag ratio at the angle of attack, or at a design CL
//! (`--cl`, the angle then solved for), at `--re`.

use super::{AeroObjective, Conditions, Prepared, Warn};
use crate::aero::batch::Objective;
use crate::aero::contour::Paneling;
use crate::aero::design::Hold;
use crate::aero::operating::{Condition, Goal, OperatingPoint, ViscousGoal};
use crate::error::Result;

/// Maximise CL/CD (scored `−CL/CD`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaxLd;

impl AeroObjective for MaxLd {
    fn name(&self) -> &'static str {
        "max-ld"
    }
    fn argument(&self) -> Option<&'static str> {
        None
    }
    fn score(&self) -> &'static str {
        "−CL/CD, viscous, at --alpha or at the design --cl"
    }
    /// Turning the shape would change the angle of attack: the chord line stays.
    fn hold(&self) -> Hold {
        Hold::ChordLine
    }
    fn prepare(&self, _: Option<&str>, _: &Paneling, at: &Conditions, _: Warn<'_>) -> Result<Prepared> {
        let point = OperatingPoint {
            weight: 1.0,
            at: at.cl.map_or(Condition::Alpha(at.alpha), Condition::Cl),
            re: at.re(self.name())?,
        };
        Ok(Prepared {
            objective: Objective::None,
            target: None,
            viscous: Some(ViscousGoal {
                goal: Goal::MaxLd,
                points: vec![point],
                ncrit: at.ncrit,
            }),
        })
    }
}
