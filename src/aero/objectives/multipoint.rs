//! `multipoint:FILE`: the largest weighted mean of the viscous lift-to-drag ratio over the
//! operating points of FILE, each an angle of attack or a design CL at its own Reynolds number
//! (the format: [`read_points`], `docs/ARCHITECTURE.md` §5.11).

use super::{AeroObjective, Conditions, Prepared, Warn};
use crate::aero::batch::Objective;
use crate::aero::contour::Paneling;
use crate::aero::design::Hold;
use crate::aero::operating::{read_points, Goal, ViscousGoal};
use crate::error::{Error, Result};
use std::path::Path;

/// Maximise the weighted mean of CL/CD over a file's points (scored its negative).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Multipoint;

impl AeroObjective for Multipoint {
    fn name(&self) -> &'static str {
        "multipoint"
    }
    fn argument(&self) -> Option<&'static str> {
        Some("FILE (weighted operating points, one a line: WEIGHT, alpha=A or cl=C, RE)")
    }
    fn score(&self) -> &'static str {
        "the weighted mean of −CL/CD over FILE's points, viscous"
    }
    /// Turning the shape would change its angles of attack: the chord line stays.
    fn hold(&self) -> Hold {
        Hold::ChordLine
    }
    fn prepare(
        &self,
        argument: Option<&str>,
        _: &Paneling,
        at: &Conditions,
        _: Warn<'_>,
    ) -> Result<Prepared> {
        if at.re.is_some() || at.cl.is_some() {
            return Err(Error::invalid(
                "multipoint takes every point's angle or CL and Reynolds number from its file: drop --re and --cl",
            ));
        }
        let path = Path::new(argument.ok_or_else(|| Error::invalid("multipoint needs a FILE"))?);
        Ok(Prepared {
            objective: Objective::None,
            target: None,
            viscous: Some(ViscousGoal {
                goal: Goal::MaxLd,
                points: read_points(path)?,
                ncrit: at.ncrit,
            }),
        })
    }
}
