//! `min-cd`: the least viscous drag at a design CL (`--cl`, the angle solved for) at `--re`.

use super::{About, AeroObjective, Prepared, Request};
use crate::aero::operating::{Condition, Goal};
use crate::error::{Error, Result};

/// Minimise CD at a design CL (scored `CD`). The angle is solved for, so turning the shape
/// would only move it: the chord line stays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MinCd;

impl AeroObjective for MinCd {
    fn about(&self) -> About {
        About::new("min-cd", "CD, viscous, at the design --cl")
    }
    fn prepare(&self, request: Request<'_>) -> Result<Prepared> {
        let cl = (request.at.cl)
            .ok_or_else(|| Error::invalid("min-cd needs the design lift coefficient: give --cl"))?;
        request.at.one_point(self.name(), Goal::MinCd, Condition::Cl(cl))
    }
}
