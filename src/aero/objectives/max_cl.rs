//! `max-cl`: the largest inviscid lift coefficient at the angle of attack. Unconstrained it
//! drives every variable to its box (an inviscid solver rewards camber and a blunt base without
//! limit), so it is refused without a constraint.

use super::{AeroObjective, Conditions, Prepared, Warn};
use crate::aero::batch::Objective;
use crate::aero::contour::Paneling;
use crate::aero::design::Hold;
use crate::error::Result;

/// Maximise CL (the kernel scores `−CL`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaxCl;

impl AeroObjective for MaxCl {
    fn name(&self) -> &'static str {
        "max-cl"
    }
    fn argument(&self) -> Option<&'static str> {
        None
    }
    fn score(&self) -> &'static str {
        "−CL"
    }
    /// Turning the shape would change the angle of attack: the chord line stays.
    fn hold(&self) -> Hold {
        Hold::ChordLine
    }
    fn needs_constraint(&self) -> bool {
        true
    }
    fn prepare(&self, _: Option<&str>, _: &Paneling, at: &Conditions, _: Warn<'_>) -> Result<Prepared> {
        at.inviscid(self.name())?;
        Ok(Prepared {
            objective: Objective::MaxCl,
            target: None,
            viscous: None,
        })
    }
}
