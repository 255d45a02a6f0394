//! Shared plumbing of the subcommands: error classification, argument bounds, warnings (the
//! outputs of a run are in [`output`]).

/// `eprintln!` for what a command tells on the way (what it read, what it chose, where it
/// wrote): nothing under `--quiet`. Warnings and errors use `eprintln!` itself.
macro_rules! tell {
    ($($arg:tt)*) => {
        if !$crate::cli::output::quiet() {
            eprintln!($($arg)*);
        }
    };
}

pub mod adapt;
pub mod adapt_surface;
pub mod aero;
pub mod bench;
pub mod blade;
pub mod compare;
pub mod eval;
pub mod evo;
pub mod export;
pub mod fit;
pub mod fit_surface;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod naca;
pub mod optimise;
pub mod output;
pub mod picture;
pub mod progress;
pub mod sample;

use anyhow::Result;
use bezchain::optim::Method;
use std::path::Path;

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

/// clap parser for the library's keyword enums (methods, metrics, backends, units): their
/// own `FromStr`, whose error lists the accepted words.
pub fn parse_word<T: std::str::FromStr<Err = bezchain::Error>>(s: &str) -> std::result::Result<T, String> {
    s.parse().map_err(|e: bezchain::Error| e.to_string())
}

/// clap parser for `--method` of a chain fit ([`Method::CURVE`]).
pub fn curve_method(s: &str) -> std::result::Result<Method, String> {
    Method::parse_among(s, Method::CURVE).map_err(|e| e.to_string())
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
        warn(path, w);
    }
}

/// Print notes about `path` on stderr, one line each (none under `--quiet`).
pub fn note_all(path: &Path, notes: &[String]) {
    if output::quiet() {
        return;
    }
    for n in notes {
        eprintln!("note: {}: {n}", path.display());
    }
}

/// Print one warning about `path` on stderr.
pub fn warn(path: &Path, warning: &str) {
    eprintln!("warning: {}: {warning}", path.display());
}

/// Refuse a size-like argument above `max` before anything is allocated for it: the message
/// names the flag, its value, the limit and what to do instead.
pub fn bounded(flag: &str, value: u64, max: u64, suggestion: &str) -> Result<()> {
    if value > max {
        return Err(usage(format!(
            "{flag} {value} is more than the largest allowed, {max}; {suggestion}"
        )));
    }
    Ok(())
}
