//! Shared plumbing of the subcommands: error classification, output targets, warnings.

pub mod adapt;
pub mod adapt_surface;
pub mod bench;
pub mod blade;
pub mod compare;
pub mod eval;
pub mod export;
pub mod fit;
pub mod fit_surface;
pub mod naca;
pub mod sample;

use anyhow::Result;
use std::io::Write;
use std::path::{Path, PathBuf};

/// An error in the user's arguments that clap cannot see (exit status 2).
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// A usage error as an `anyhow::Error`.
pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    UsageError(msg.into()).into()
}

/// 2 for bad input or arguments, 1 for every other failure.
pub fn exit_status(e: &anyhow::Error) -> u8 {
    for cause in e.chain() {
        if cause.is::<UsageError>() {
            return 2;
        }
        if let Some(err) = cause.downcast_ref::<bezchain::Error>() {
            return if err.is_user_error() { 2 } else { 1 };
        }
    }
    1
}

/// The error and its causes on one line.
pub fn one_line(e: &anyhow::Error) -> String {
    // The chain of causes, outermost first; a cause whose text its parent already shows (an
    // I/O error that prints its source, say) is said once.
    let mut text = String::new();
    for cause in e.chain() {
        let part = cause.to_string();
        if text.contains(&part) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&part);
    }
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// clap parser for `auto|gpu|cpu`.
pub fn parse_backend(s: &str) -> std::result::Result<bezchain::eval::Backend, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

/// clap parser for `AxB` pairs of positive integers (degrees, patch counts).
pub fn parse_pair(s: &str) -> std::result::Result<[usize; 2], String> {
    let bad = || format!("'{s}' is not of the form AxB (e.g. 3x3)");
    let (a, b) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let a: usize = a.trim().parse().map_err(|_| bad())?;
    let b: usize = b.trim().parse().map_err(|_| bad())?;
    Ok([a, b])
}

/// Print reader warnings on stderr, one line each, prefixed with the file.
pub fn warn_all(path: &Path, warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
}

/// Where an output goes: a file (written atomically) or standard output (`-`).
#[derive(Clone, Debug)]
pub enum Target {
    /// Standard output.
    Stdout,
    /// A file, replaced atomically.
    File(PathBuf),
}

impl Target {
    /// `-` is standard output, anything else a file.
    pub fn parse(s: &Path) -> Target {
        if s.as_os_str() == "-" {
            Target::Stdout
        } else {
            Target::File(s.to_path_buf())
        }
    }

    /// Write `bytes` to the target.
    pub fn write(&self, bytes: &[u8]) -> Result<()> {
        match self {
            Target::Stdout => {
                let mut out = std::io::stdout().lock();
                out.write_all(bytes)?;
                out.flush()?;
            }
            Target::File(path) => bezchain::geometry::write_atomic(path, |w| w.write_all(bytes))?,
        }
        Ok(())
    }
}

/// Print a command's readable text on standard output, or on standard error when its JSON
/// report goes to standard output (so that the JSON stays parseable). Flushed at once, so long
/// runs show each piece as it is made.
pub fn say(json: Option<&Target>, text: &str) {
    if matches!(json, Some(Target::Stdout)) {
        eprint!("{text}");
    } else {
        print!("{text}");
        let _ = std::io::stdout().flush();
    }
}

/// Serialise `value` as pretty JSON (with a final newline) to `target`.
pub fn write_json<T: serde::Serialize>(target: &Target, value: &T) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    target.write(text.as_bytes())
}
