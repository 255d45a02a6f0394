//! `max-cl`: the largest inviscid lift coefficient at the angle of attack. Unconstrained it
//! drives every variable to its box (an inviscid solver rewards camber and a blunt base without
//! limit), so it is refused without a constraint.

use super::{About, AeroObjective, Prepared, Request};
use crate::aero::batch::Objective;
use crate::error::Result;

/// Maximise CL (the kernel scores `−CL`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaxCl;

impl AeroObjective for MaxCl {
    fn about(&self) -> About {
        About::new("max-cl", "−CL").needs_constraint()
    }
    fn prepare(&self, request: Request<'_>) -> Result<Prepared> {
        request.at.inviscid(self.name())?;
        Ok(Prepared::kernel(Objective::MaxCl))
    }
}
