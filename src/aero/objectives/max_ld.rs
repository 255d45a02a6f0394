//! `max-ld`: the largest viscous lift-to-drag ratio at the angle of attack, or at a design CL
//! (`--cl`, the angle then solved for), at `--re`.

use super::{About, AeroObjective, Prepared, Request};
use crate::aero::operating::{Condition, Goal};
use crate::error::Result;

/// Maximise CL/CD (scored `−CL/CD`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaxLd;

impl AeroObjective for MaxLd {
    fn about(&self) -> About {
        About::new("max-ld", "−CL/CD, viscous, at --alpha or at the design --cl")
    }
    fn prepare(&self, request: Request<'_>) -> Result<Prepared> {
        let at = request.at;
        let point = at.cl.map_or(Condition::Alpha(at.alpha), Condition::Cl);
        at.one_point(self.name(), Goal::MaxLd, point)
    }
}
