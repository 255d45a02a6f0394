//! `inverse:TARGET`: the shape whose pressure distribution matches a target's at the angle of
//! attack (inverse design).

use super::{AeroObjective, Conditions, Prepared, Target, Warn};
use crate::aero::batch::{Objective, TargetCp};
use crate::aero::contour::Paneling;
use crate::aero::design::Hold;
use crate::aero::input::Aerofoil;
use crate::error::{Error, Result};
use std::path::PathBuf;

/// Match the target's Cp (the kernel scores the arclength-weighted mean of `(Cp − Cp_t)²`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Inverse;

impl AeroObjective for Inverse {
    fn name(&self) -> &'static str {
        "inverse"
    }
    fn argument(&self) -> Option<&'static str> {
        Some("TARGET (an aerofoil file or curve report)")
    }
    fn score(&self) -> &'static str {
        "the arclength-weighted mean of (Cp − Cp_target)²"
    }
    /// Turning the shape changes its pressures, so the match may turn it.
    fn hold(&self) -> Hold {
        Hold::Similarity
    }
    /// The target's pressures at `alpha`, on the start's paneling.
    fn prepare(
        &self,
        argument: Option<&str>,
        on: &Paneling,
        at: &Conditions,
        warn: Warn<'_>,
    ) -> Result<Prepared> {
        at.inviscid(self.name())?;
        let alpha = at.alpha;
        let path = PathBuf::from(argument.ok_or_else(|| Error::invalid("inverse needs a TARGET"))?);
        let (points, analysis) = Aerofoil::analyse(&path, on, ", not a curve", warn)?;
        let table = TargetCp::of(&analysis.solution, alpha)?;
        Ok(Prepared {
            objective: Objective::Inverse(table),
            target: Some(Target {
                path,
                points,
                analysis,
            }),
            viscous: None,
        })
    }
}
