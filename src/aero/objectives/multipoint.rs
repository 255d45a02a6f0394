//! `multipoint:FILE`: the largest weighted mean of the viscous lift-to-drag ratio over the
//! operating points of FILE, each an angle of attack or a design CL at its own Reynolds number
//! (the format: [`read_points`], `docs/ARCHITECTURE.md` §5.11).

use super::{About, AeroObjective, Prepared, Request};
use crate::aero::operating::{read_points, Goal};
use crate::error::{Error, Result};
use std::path::Path;

/// Maximise the weighted mean of CL/CD over a file's points (scored its negative). Turning
/// the shape would change its angles of attack: the chord line stays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Multipoint;

impl AeroObjective for Multipoint {
    fn about(&self) -> About {
        About::new(
            "multipoint",
            "the weighted mean of −CL/CD over FILE's points, viscous",
        )
        .argument("FILE (weighted operating points, one a line: WEIGHT, alpha=A or cl=C, RE)")
    }
    fn prepare(&self, request: Request<'_>) -> Result<Prepared> {
        let at = request.at;
        if at.re.is_some() || at.cl.is_some() {
            return Err(Error::invalid(
                "multipoint takes every point's angle or CL and Reynolds number from its file: drop --re and --cl",
            ));
        }
        let path = Path::new(
            request
                .argument
                .ok_or_else(|| Error::invalid("multipoint needs a FILE"))?,
        );
        Ok(Prepared::viscous(Goal::MaxLd, read_points(path)?, at.ncrit))
    }
}
