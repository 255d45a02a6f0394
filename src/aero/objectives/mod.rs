//! The objectives of an aerodynamic optimisation, one file each, every one an
//! [`AeroObjective`]: it names itself (`--objective max-cl`), says what follows its word, how
//! it scores a shape and what the shape keeps of its start, and prepares the kernel's
//! [`Objective`] (reading a target when it has one).
//!
//! Adding an objective is one new file implementing [`AeroObjective`] and one line in
//! [`OBJECTIVES`]: the command's parsing, its usage message and the report's texts follow from
//! the list. An inviscid objective is scored by the panel kernel (one the kernel does not
//! compute yet needs its [`Objective`] variant in `shaders/aero.wgsl` and its CPU mirror too);
//! a viscous one hands over its operating points ([`ViscousGoal`]) and is scored on the CPU.

mod inverse;
mod max_cl;
mod max_ld;
mod min_cd;
mod multipoint;

pub use inverse::Inverse;
pub use max_cl::MaxCl;
pub use max_ld::MaxLd;
pub use min_cd::MinCd;
pub use multipoint::Multipoint;

use super::analysis::Analysis;
use super::batch::Objective;
use super::contour::Paneling;
use super::design::Hold;
pub use super::input::Warn;
use super::operating::{Condition, Goal, OperatingPoint, ViscousGoal};
use crate::error::{Error, Result};
use crate::keyword::or_list;
use glam::DVec2;
use std::path::PathBuf;

/// Every objective, in the order the usage lists them.
pub const OBJECTIVES: &[&dyn AeroObjective] = &[&MaxLd, &MinCd, &Multipoint, &Inverse, &MaxCl];

/// The operating conditions as the command line gives them, for [`AeroObjective::prepare`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditions {
    /// Angle of attack, degrees.
    pub alpha: f64,
    /// A design CL (`--cl`), when given.
    pub cl: Option<f64>,
    /// The Reynolds number (`--re`), when given: the scoring is then viscous.
    pub re: Option<f64>,
    /// Ncrit of the e^N transition (`--ncrit`, default 9).
    pub ncrit: f64,
}

impl Conditions {
    /// An error when `--re` or `--cl` is given to an objective (`name`) that takes neither.
    pub fn inviscid(&self, name: &str) -> Result<()> {
        if self.re.is_some() {
            return Err(Error::invalid(format!(
                "{name} is scored inviscid: drop --re (max-ld, min-cd and multipoint are viscous)"
            )));
        }
        if self.cl.is_some() {
            return Err(Error::invalid(format!("{name} takes no --cl")));
        }
        Ok(())
    }

    /// The Reynolds number, or an error saying `name` needs one.
    pub fn re(&self, name: &str) -> Result<f64> {
        self.re
            .ok_or_else(|| Error::invalid(format!("{name} is viscous: give the Reynolds number with --re")))
    }

    /// The viscous objective `name` scoring `goal` at one operating point, `at` and `--re`.
    pub fn one_point(&self, name: &str, goal: Goal, at: Condition) -> Result<Prepared> {
        let point = OperatingPoint {
            weight: 1.0,
            at,
            re: self.re(name)?,
        };
        Ok(Prepared::viscous(goal, vec![point], self.ncrit))
    }
}

/// What an objective is, as the command line and the report say it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct About {
    /// The word that names it, on the command line and in reports (`max-cl`).
    pub name: &'static str,
    /// What follows the word and a colon, as the usage says it (`TARGET (an aerofoil file or
    /// curve report)`); `None` when nothing does.
    pub argument: Option<&'static str>,
    /// How it scores a valid shape that meets the constraints, as the report says it (`−CL`).
    pub score: &'static str,
    /// What the shape keeps of its start while it is optimised.
    pub hold: Hold,
    /// Whether the objective is refused without a constraint (one that, unconstrained, has no
    /// optimum a designer would build).
    pub needs_constraint: bool,
}

impl About {
    /// The objective `name` scoring `score`: no argument, no constraint needed, and the chord
    /// line held (turning the shape would change the angle of attack it is scored at).
    #[must_use]
    pub const fn new(name: &'static str, score: &'static str) -> About {
        About {
            name,
            argument: None,
            score,
            hold: Hold::ChordLine,
            needs_constraint: false,
        }
    }

    /// The same, taking `argument` after its word and a colon.
    #[must_use]
    pub const fn argument(self, argument: &'static str) -> About {
        About {
            argument: Some(argument),
            ..self
        }
    }

    /// The same, holding `hold` instead of the chord line.
    #[must_use]
    pub const fn hold(self, hold: Hold) -> About {
        About { hold, ..self }
    }

    /// The same, refused without a constraint.
    #[must_use]
    pub const fn needs_constraint(self) -> About {
        About {
            needs_constraint: true,
            ..self
        }
    }
}

/// What [`AeroObjective::prepare`] is given.
pub struct Request<'a> {
    /// The text after the colon, for objectives that take an argument.
    pub argument: Option<&'a str>,
    /// The start's paneling.
    pub on: &'a Paneling,
    /// The operating conditions.
    pub at: &'a Conditions,
    /// Where the readers' warnings go.
    pub warn: Warn<'a>,
}

/// An objective of `bezchain optimise`, named on the command line by its word and, for some,
/// an argument after a colon (`inverse:TARGET`). An implementation says what it is
/// ([`About`]) and how it prepares the kernel; the rest follows from that.
pub trait AeroObjective: Sync {
    /// Its word, argument, score, hold and whether it needs a constraint.
    fn about(&self) -> About;

    /// The kernel's objective at the conditions `request.at` on the paneling `request.on`,
    /// the viscous operating points and the target shape when the objective has them.
    fn prepare(&self, request: Request<'_>) -> Result<Prepared>;

    /// [`About::name`].
    fn name(&self) -> &'static str {
        self.about().name
    }

    /// [`About::argument`].
    fn argument(&self) -> Option<&'static str> {
        self.about().argument
    }

    /// [`About::score`].
    fn score(&self) -> &'static str {
        self.about().score
    }

    /// [`About::hold`].
    fn hold(&self) -> Hold {
        self.about().hold
    }

    /// [`About::needs_constraint`].
    fn needs_constraint(&self) -> bool {
        self.about().needs_constraint
    }
}

/// What an objective hands the optimisation.
#[derive(Clone, Debug, PartialEq)]
pub struct Prepared {
    /// What the kernel scores.
    pub objective: Objective,
    /// The shape to match, for objectives that have one.
    pub target: Option<Target>,
    /// The operating points, for viscous objectives (the kernel's objective is then
    /// [`Objective::None`]).
    pub viscous: Option<ViscousGoal>,
}

impl Prepared {
    /// An objective the panel kernel scores.
    #[must_use]
    pub fn kernel(objective: Objective) -> Prepared {
        Prepared {
            objective,
            target: None,
            viscous: None,
        }
    }

    /// A viscous objective scored on the CPU at `points`.
    #[must_use]
    pub fn viscous(goal: Goal, points: Vec<OperatingPoint>, ncrit: f64) -> Prepared {
        Prepared {
            objective: Objective::None,
            target: None,
            viscous: Some(ViscousGoal { goal, points, ncrit }),
        }
    }
}

/// A target shape: the file it came from, its points (the result's offsets are measured from
/// them) and its analysis.
#[derive(Clone, Debug, PartialEq)]
pub struct Target {
    /// The file as given.
    pub path: PathBuf,
    /// Its points (a report's chain sampled at 401 even parameters).
    pub points: Vec<DVec2>,
    /// Its panel solution.
    pub analysis: Analysis,
}

/// The objective `spec` names (`max-cl`, `inverse:TARGET`; the word in any case) and its
/// argument; otherwise an error listing the usages.
pub fn parse(spec: &str) -> Result<(&'static dyn AeroObjective, Option<&str>)> {
    let (word, argument) = match spec.split_once(':') {
        Some((word, argument)) => (word, Some(argument)),
        None => (spec, None),
    };
    OBJECTIVES
        .iter()
        .find(|o| {
            o.name().eq_ignore_ascii_case(word)
                && match (o.argument(), argument) {
                    (None, None) => true,
                    (Some(_), Some(a)) => !a.is_empty(),
                    _ => false,
                }
        })
        .map(|&o| (o, argument))
        .ok_or_else(|| {
            let usages: Vec<String> = OBJECTIVES
                .iter()
                .map(|o| match o.argument() {
                    Some(a) => format!("{}:{a}", o.name()),
                    None => o.name().to_string(),
                })
                .collect();
            let usages: Vec<&str> = usages.iter().map(String::as_str).collect();
            Error::invalid(format!("expected {}", or_list(&usages)))
        })
}

/// How the optimisers rank shapes, as the report states it: every objective's score.
#[must_use]
pub fn constraint_handling() -> String {
    let scores: Vec<String> = OBJECTIVES
        .iter()
        .map(|o| format!("{}: {}", o.name(), o.score()))
        .collect();
    format!(
        "penalties ranked as Deb's rules: a valid shape meeting the constraints scores its objective ({}); \
a valid shape breaking them 1e3 + the summed shortfalls (t/c below the minimum overall and at each station, CM \
and CL below their minimums, the trailing-edge angle's in radians, the area below its minimum); a valid shape \
whose viscous analysis does not converge 1e4 + its geometric shortfalls; an unusable shape (non-finite, a \
surface folding back in x by more than 1e-3 chord, upper below lower, coincident nodes or a singular system) \
1e6 + how far it is from valid; so every feasible shape ranks before every infeasible one, and no shape is \
rewarded for failing to converge",
        scores.join("; ")
    )
}

/// What the design variables leave fixed, as the report states it: the objectives that hold
/// the chord line named.
#[must_use]
pub fn chord_line() -> String {
    let holding: Vec<&str> = OBJECTIVES
        .iter()
        .filter(|o| o.hold() == Hold::ChordLine)
        .map(|o| o.name())
        .collect();
    format!(
        "both trailing-edge points and the leading edge's x stay where the start has them (pressures do not \
change when a shape moves or scales, and an inviscid solver rewards a thick blunt base with lift real flow \
would not give), and for {} the leading edge's y too (turning the shape would change the angle of attack): \
the dependents are the stored numbers solved from those conditions, the variables the others",
        holding.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_objective_parses_by_its_word_and_others_are_listed() {
        assert_eq!(parse("MAX-CL").unwrap().0.name(), "max-cl");
        assert_eq!(parse("max-ld").unwrap().0.name(), "max-ld");
        let (o, a) = parse("inverse:a:b.dat").unwrap();
        assert_eq!((o.name(), a), ("inverse", Some("a:b.dat")));
        let (o, a) = parse("multipoint:p.txt").unwrap();
        assert_eq!((o.name(), a), ("multipoint", Some("p.txt")));
        for bad in ["foo", "inverse:", "inverse", "max-cl:x", "multipoint"] {
            let e = parse(bad).err().unwrap().to_string();
            assert_eq!(
                e,
                "expected max-ld, min-cd, multipoint:FILE (weighted operating points, one a line: WEIGHT, \
alpha=A or cl=C, RE), inverse:TARGET (an aerofoil file or curve report) or max-cl",
                "{bad}"
            );
        }
        assert!(constraint_handling().contains("; max-cl: −CL)"));
        assert!(constraint_handling().contains("inverse: the arclength-weighted mean of (Cp − Cp_target)²"));
        assert!(chord_line().contains("and for max-ld, min-cd, multipoint, max-cl the leading edge's y too"));
    }
}
