//! `max-cl`: the largest lift coefficient at the angle of attack.

use super::{AeroObjective, Prepared, Warn};
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
    fn prepare(&self, _: Option<&str>, _: &Paneling, _: f64, _: Warn<'_>) -> Result<Prepared> {
        Ok(Prepared {
            objective: Objective::MaxCl,
            target: None,
        })
    }
}
