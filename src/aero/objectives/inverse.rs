//! `inverse:TARGET`: the shape whose pressure distribution matches a target's at the angle of
//! attack (inverse design).

use super::{About, AeroObjective, Prepared, Request, Target};
use crate::aero::batch::{Objective, TargetCp};
use crate::aero::design::Hold;
use crate::aero::input::Aerofoil;
use crate::error::{Error, Result};
use std::path::PathBuf;

/// Match the target's Cp (the kernel scores the arclength-weighted mean of `(Cp − Cp_t)²`).
/// Turning the shape changes its pressures, so the match may turn it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Inverse;

impl AeroObjective for Inverse {
    fn about(&self) -> About {
        About::new("inverse", "the arclength-weighted mean of (Cp − Cp_target)²")
            .argument("TARGET (an aerofoil file or curve report)")
            .hold(Hold::Similarity)
    }
    /// The target's pressures at `alpha`, on the start's paneling.
    fn prepare(&self, request: Request<'_>) -> Result<Prepared> {
        request.at.inviscid(self.name())?;
        let argument = request
            .argument
            .ok_or_else(|| Error::invalid("inverse needs a TARGET"))?;
        let path = PathBuf::from(argument);
        let (points, analysis) = Aerofoil::analyse(&path, request.on, ", not a curve", request.warn)?;
        let table = TargetCp::of(&analysis.solution, request.at.alpha)?;
        Ok(Prepared {
            target: Some(Target {
                path,
                points,
                analysis,
            }),
            ..Prepared::kernel(Objective::Inverse(table))
        })
    }
}
