//! Why a benchmark run stopped: the suite, a file, the results table or the options.

use std::path::PathBuf;

use crate::suite;

/// Why a benchmark run stopped.
#[derive(Debug)]
pub enum Error {
    /// The suite could not be read.
    Suite(suite::Error),
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The results table could not be read or written.
    Csv {
        /// The table.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The options break a rule; the message says which.
    Options(String),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Suite(e) => e.fmt(f),
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::Csv { path, message } => write!(f, "{}: {message}", path.display()),
            Error::Options(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {}

impl From<suite::Error> for Error {
    fn from(e: suite::Error) -> Self {
        Error::Suite(e)
    }
}
