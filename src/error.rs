//! The library's one error type and its `Result` alias.

use std::path::PathBuf;

/// Everything the library can fail with. Parse errors name the file and the line.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A line of an input file could not be understood.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file concerned.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with that line.
        message: String,
    },
    /// An input file is well-formed but unusable as a whole (empty, too few points, ...).
    #[error("{path}: {message}")]
    Input {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// A layout, option or argument is outside what the method supports.
    #[error("{0}")]
    Invalid(String),
    /// A numerical method failed (singular system, no convergence where it is required).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// The GPU path failed or is unavailable where it was required.
    #[error("gpu: {0}")]
    Gpu(String),
    /// An output (plot, mesh, render) could not be produced.
    #[error("output: {0}")]
    Output(String),
    /// Another process of the run failed (or this one, as the run's collective reported it),
    /// not for the input's sake: the message as that process gave it (docs/ARCHITECTURE.md
    /// §4.3).
    #[error("{0}")]
    Team(String),
}

impl Error {
    /// An [`Error::Invalid`] from anything printable.
    pub fn invalid(msg: impl Into<String>) -> Self {
        Error::Invalid(msg.into())
    }

    /// This error as one about the file `path`: an [`Error::Invalid`] (a shape or layout the
    /// method cannot take) becomes [`Error::Input`] naming it; errors that name their file
    /// already, or are not about the input, stay as they are.
    #[must_use]
    pub fn in_file(self, path: &std::path::Path) -> Self {
        match self {
            Error::Invalid(message) => Error::Input {
                path: path.to_path_buf(),
                message,
            },
            e => e,
        }
    }

    /// `Ok` when `value` is finite and ≥ 0, else the input error "`what` must be finite and
    /// ≥ 0, not `value`" (options' tolerances, targets, margins).
    pub(crate) fn check_non_negative(what: &str, value: f64) -> Result<()> {
        if value >= 0.0 && value.is_finite() {
            Ok(())
        } else {
            Err(Error::invalid(format!(
                "{what} must be finite and ≥ 0, not {value}"
            )))
        }
    }

    /// True for errors caused by the user's input or arguments (the CLI exits with status 2).
    #[must_use]
    pub fn is_user_error(&self) -> bool {
        matches!(
            self,
            Error::Io { .. } | Error::Parse { .. } | Error::Input { .. } | Error::Invalid(_)
        )
    }
}

/// The library's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
