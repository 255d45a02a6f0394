//! What a long run (an evolutionary fit, an aerodynamic optimisation) writes as it goes: its
//! history file, one line a generation, and its checkpoints, every few generations and when it
//! stops. Both go into the run's [`Outputs`]: the history file is put in place with the run's
//! other outputs, each checkpoint replaces the last at once (and is put back if the run fails).

use crate::error::Result;
use crate::export::{Output, Outputs};
use crate::optim::evo::Watched;

/// The history file's first line: its columns.
pub const HISTORY_HEADER: &str = "generation,best,mean,evaluations,seconds\n";

/// A run's history file and checkpoints (either may be absent).
#[derive(Clone, Copy, Debug)]
pub struct RunRecord {
    history: Option<Output>,
    /// History lines written so far.
    written: usize,
    checkpoint: Option<Output>,
    /// Generations between checkpoints (at least 1).
    every: u64,
}

impl RunRecord {
    /// Write the history to `history` and a checkpoint to `checkpoint` every `every`
    /// generations (at least 1) and when the run stops.
    #[must_use]
    pub fn new(history: Option<Output>, checkpoint: Option<Output>, every: u64) -> Self {
        RunRecord {
            history,
            written: 0,
            checkpoint,
            every: every.max(1),
        }
    }

    /// After a generation of `run` (or once for a resumed run that has already stopped): the
    /// history lines not yet written (the header first), and a checkpoint when one is due.
    /// Nothing before the run has a history.
    pub fn generation(&mut self, run: &dyn Watched, outs: &mut Outputs) -> Result<()> {
        let h = run.history();
        if h.is_empty() {
            return Ok(());
        }
        if let Some(o) = self.history {
            let path = outs.path(o).to_path_buf();
            let io = |source| crate::Error::Io {
                path: path.clone(),
                source,
            };
            let w = outs.writer(o)?;
            if self.written == 0 {
                w.write_all(HISTORY_HEADER.as_bytes()).map_err(io)?;
            }
            for p in &h[self.written..] {
                writeln!(
                    w,
                    "{},{:e},{:e},{},{:.6}",
                    p.generation, p.best, p.mean, p.evaluations, p.seconds
                )
                .map_err(io)?;
            }
            self.written = h.len();
        }
        match self.checkpoint {
            Some(o) if run.stopping() || run.generation().is_multiple_of(self.every) => {
                outs.interim(o, &run.checkpoint().to_bytes())
            }
            _ => Ok(()),
        }
    }

    /// After the run: a history file with no generation in it still gets its header.
    pub fn close(&self, outs: &mut Outputs) -> Result<()> {
        match (self.history, self.written) {
            (Some(o), 0) => outs.put(o, HISTORY_HEADER.as_bytes()),
            _ => Ok(()),
        }
    }
}
