//! What a progress display and a checkpoint writer see of a run after each generation: one
//! trait for the evolutionary driver ([`super::Evolution`]) and the runs built on it (the
//! aerodynamic optimisation), so one monitor serves them all.

use super::checkpoint::Checkpoint;
use super::{Evolution, Progress};

/// A run as its monitor sees it between generations.
pub trait Watched {
    /// The method running, as the display names it (`ga`, `cmaes`, `ga+cmaes`).
    fn label(&self) -> String;

    /// Generations done.
    fn generation(&self) -> u64;

    /// The generation limit.
    fn limit(&self) -> u64;

    /// One line per generation so far (generation 0 first).
    fn history(&self) -> &[Progress];

    /// True when the run stops now (a checkpoint is then due whatever its interval).
    fn stopping(&self) -> bool;

    /// How the run stands after its last generation, in one line (empty before any).
    fn status(&self) -> String;

    /// Everything needed to continue the run bit-identically.
    fn checkpoint(&self) -> Checkpoint;
}

impl Watched for Evolution<'_> {
    fn label(&self) -> String {
        self.algorithm.to_string()
    }
    fn generation(&self) -> u64 {
        self.generation
    }
    fn limit(&self) -> u64 {
        self.generations() as u64
    }
    fn history(&self) -> &[Progress] {
        &self.history
    }
    fn stopping(&self) -> bool {
        self.stop().is_some()
    }
    /// The best and mean scores, individuals and point evaluations a second.
    fn status(&self) -> String {
        let Some(last) = self.history.last() else {
            return String::new();
        };
        format!(
            "best {:.4e} mean {:.3e} | {:.3e} individuals/s, {:.3e} point evals/s",
            last.best,
            last.mean,
            last.evaluations as f64 / last.seconds.max(1e-9),
            self.evals_per_second()
        )
    }
    fn checkpoint(&self) -> Checkpoint {
        Evolution::checkpoint(self)
    }
}
