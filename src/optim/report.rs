//! What every solver reports back: its effort ([`SolveReport`]) and why it stopped
//! ([`StopReason`]).

use serde::Serialize;
use std::fmt;

/// Why a solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum StopReason {
    /// The requested tolerance was met.
    Converged,
    /// No step lowers the objective any more (it is at a minimum to rounding).
    NoProgress,
    /// The iteration limit was reached first.
    MaxIterations,
    /// The evaluation limit was reached first.
    MaxEvaluations,
    /// The method is exact in one step (linear least squares at fixed parameters).
    Exact,
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::Converged => "converged",
            StopReason::NoProgress => "no further progress",
            StopReason::MaxIterations => "iteration limit",
            StopReason::MaxEvaluations => "evaluation limit",
            StopReason::Exact => "exact",
        })
    }
}

/// The effort a solver spent and how it ended.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SolveReport {
    /// Iterations of the method (Levenberg-Marquardt steps tried, simplex transformations,
    /// BFGS line searches).
    pub iterations: usize,
    /// Objective evaluations: every full pass over the data points that yields the objective
    /// (with the gradient where the method needs it).
    pub evaluations: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Why it stopped.
    pub stop: StopReason,
}

impl SolveReport {
    /// True unless an iteration or evaluation limit cut the solver short.
    #[must_use]
    pub fn converged(&self) -> bool {
        !matches!(self.stop, StopReason::MaxIterations | StopReason::MaxEvaluations)
    }

    /// The cap that cut the solver short, as reports name it (`"evaluation cap"`,
    /// `"iteration cap"`); `None` when it stopped on its own.
    #[must_use]
    pub fn cap(&self) -> Option<&'static str> {
        match self.stop {
            StopReason::MaxEvaluations => Some("evaluation cap"),
            StopReason::MaxIterations => Some("iteration cap"),
            _ => None,
        }
    }
}
