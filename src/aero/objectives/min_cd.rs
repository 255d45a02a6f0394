//! `min-cd`: the least viscous drag at a design CL (`--cl`, the angle solved for) at `--re`.

use super::{AeroObjective, Conditions, Prepared, Warn};
use crate::aero::batch::Objective;
use crate::aero::contour::Paneling;
use crate::aero::design::Hold;
use crate::aero::operating::{Condition, Goal, OperatingPoint, ViscousGoal};
use crate::error::{Error, Result};

/// Minimise CD at a design CL (scored `CD`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MinCd;

impl AeroObjective for MinCd {
    fn name(&self) -> &'static str {
        "min-cd"
    }
    fn argument(&self) -> Option<&'static str> {
        None
    }
    fn score(&self) -> &'static str {
        "CD, viscous, at the design --cl"
    }
    /// The chord line stays (the angle is solved for, so turning would only move it).
    fn hold(&self) -> Hold {
        Hold::ChordLine
    }
    fn prepare(&self, _: Option<&str>, _: &Paneling, at: &Conditions, _: Warn<'_>) -> Result<Prepared> {
        let cl = at
            .cl
            .ok_or_else(|| Error::invalid("min-cd needs the design lift coefficient: give --cl"))?;
        let point = OperatingPoint {
            weight: 1.0,
            at: Condition::Cl(cl),
            re: at.re(self.name())?,
        };
        Ok(Prepared {
            objective: Objective::None,
            target: None,
            viscous: Some(ViscousGoal {
                goal: Goal::MinCd,
                points: vec![point],
                ncrit: at.ncrit,
            }),
        })
    }
}
