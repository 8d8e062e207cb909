//! What is wrong with a third-party file, and where.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::error::clipped;
use crate::error::MAX_MESSAGE_CHARS;

/// A file that cannot be read as its format says, or holds something the importer does not
/// support: the file, the element or field (`group_state "ready" (group panda0_arm)`,
/// `function add_panda_table_segments`), and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImportError {
    /// The file.
    pub file: PathBuf,
    /// Where in it (empty: the whole file).
    pub at: String,
    /// What is wrong.
    pub message: String,
}

impl ImportError {
    /// An error about `at` in `file`.
    pub fn new(file: &Path, at: impl Into<String>, message: impl Into<String>) -> Self {
        ImportError {
            file: file.to_path_buf(),
            at: clipped(at.into(), MAX_MESSAGE_CHARS),
            message: clipped(message.into(), MAX_MESSAGE_CHARS),
        }
    }
}

impl fmt::Display for ImportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: ", self.file.display())?;
        if !self.at.is_empty() {
            write!(f, "{}: ", self.at)?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for ImportError {}
