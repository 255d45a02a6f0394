//! The outputs of one command run, all or nothing ([`bezchain::export::Outputs`]: every path
//! checked before the work, every file put in place together at the end), stamped with this
//! process's command line; and the readable text a command prints, which goes to standard
//! error when an output goes to standard output.

pub use bezchain::export::Output;
use std::io::Write;

/// The outputs of a run ([`bezchain::export::Outputs`], whose methods it has), with the
/// command's readable text ([`Outputs::say`]).
#[derive(Debug)]
pub struct Outputs(bezchain::export::Outputs);

impl Outputs {
    /// No outputs yet; the JSON reports are stamped with this process's command line.
    #[must_use]
    pub fn new() -> Self {
        Outputs(bezchain::export::Outputs::new(std::env::args().collect()))
    }

    /// Print a command's readable text on standard output, or on standard error when an
    /// output goes to standard output (so that it stays parseable). Flushed at once, so long
    /// runs show each piece as it is made.
    pub fn say(&self, text: &str) {
        say(self.uses_stdout(), text);
    }

    /// Put every output in place ([`bezchain::export::Outputs::commit`]); [`say`](Self::say)
    /// still works afterwards.
    pub fn commit(&mut self) -> anyhow::Result<()> {
        Ok(self.0.commit()?)
    }
}

impl Default for Outputs {
    fn default() -> Self {
        Self::new()
    }
}

impl std::ops::Deref for Outputs {
    type Target = bezchain::export::Outputs;
    fn deref(&self) -> &Self::Target {
        &self.0
    }
}

impl std::ops::DerefMut for Outputs {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut self.0
    }
}

/// Whether `--quiet` was given: nothing but warnings and errors is printed.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Set by `--quiet` (every command takes it).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

/// Whether `--quiet` was given.
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// Print readable text on standard output, or on standard error when `to_stderr` (an output
/// goes to standard output); flushed at once. Nothing under `--quiet`.
pub fn say(to_stderr: bool, text: &str) {
    if quiet() {
        return;
    }
    if to_stderr {
        eprint!("{text}");
    } else {
        print!("{text}");
        let _ = std::io::stdout().flush();
    }
}
