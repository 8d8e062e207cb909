//! Errors that name the field of the input they are about.

use std::fmt;

/// One thing wrong with the input, at `path` (`robots[2].initial`, `dt`, or empty for the
/// whole document).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldError {
    /// Where: `robots[2].initial`, `dt`, or empty for the whole document.
    pub path: String,
    /// What is wrong.
    pub message: String,
}

/// Longest message or path kept whole. Messages may quote the input (serde quotes an unknown
/// field or variant in full), and one line must not grow with it: a 50 MB name would make a
/// 50 MB message.
pub const MAX_MESSAGE_CHARS: usize = 300;

/// Names quoted in messages are cut to this many characters.
pub const MAX_NAME_CHARS: usize = 40;

impl FieldError {
    /// An error at `path`; both are cut to a bounded length ([`MAX_MESSAGE_CHARS`]).
    pub fn new(path: impl Into<String>, message: impl Into<String>) -> Self {
        FieldError {
            path: clipped(path.into(), MAX_NAME_CHARS * 2),
            message: clipped(message.into(), MAX_MESSAGE_CHARS),
        }
    }

    /// The same error seen from the enclosing value: `position[1]` within `base` becomes
    /// `base.position[1]`.
    pub fn within(self, prefix: &str) -> Self {
        let path = match (prefix.is_empty(), self.path.is_empty()) {
            (true, _) => self.path,
            (false, true) => prefix.to_string(),
            (false, false) if self.path.starts_with('[') => format!("{prefix}{}", self.path),
            (false, false) => format!("{prefix}.{}", self.path),
        };
        FieldError {
            path,
            message: self.message,
        }
    }
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.path.is_empty() {
            f.write_str(&self.message)
        } else {
            write!(f, "{}: {}", self.path, self.message)
        }
    }
}

/// `text` if it has at most `max` characters, else its start and end around a note of how
/// much was left out.
pub fn clipped(text: String, max: usize) -> String {
    let chars = text.chars().count();
    if chars <= max {
        return text;
    }
    let keep = max / 2;
    let head: String = text.chars().take(keep).collect();
    let tail: String = text.chars().skip(chars - keep).collect();
    format!("{head} …[{} characters cut]… {tail}", chars - 2 * keep)
}

/// A name from the input, quoted as `Debug` does, and cut after [`MAX_NAME_CHARS`]
/// characters: `"left"`, `"aaaa…" (50000000 bytes)`.
pub fn quoted(name: &str) -> String {
    match name.char_indices().nth(MAX_NAME_CHARS) {
        None => format!("{name:?}"),
        Some((cut, _)) => format!("{:?} ({} bytes)", format!("{}…", &name[..cut]), name.len()),
    }
}

/// Everything wrong with one input document (at least one entry).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InputError {
    /// The errors, in the order found.
    pub errors: Vec<FieldError>,
}

impl InputError {
    /// One error at `path`.
    pub fn one(path: impl Into<String>, message: impl Into<String>) -> Self {
        InputError {
            errors: vec![FieldError::new(path, message)],
        }
    }

    /// Whether some error is at `path` and its message contains `text`.
    pub fn has(&self, path: &str, text: &str) -> bool {
        self.errors
            .iter()
            .any(|e| e.path == path && e.message.contains(text))
    }
}

impl From<FieldError> for InputError {
    fn from(e: FieldError) -> Self {
        InputError { errors: vec![e] }
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for InputError {}

/// Errors kept for one document; beyond, they are only counted, so that a report stays small
/// however large the input.
pub const MAX_ERRORS: usize = 1000;

/// Collects the errors of one document so that all of them are reported at once (up to
/// [`MAX_ERRORS`], then how many more).
#[derive(Debug, Default)]
pub struct Errors {
    list: Vec<FieldError>,
    omitted: usize,
}

impl Errors {
    /// Adds an error at `path`.
    pub fn push(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.add(FieldError::new(path, message));
    }

    /// Adds an error (counted only, beyond [`MAX_ERRORS`]).
    pub fn add(&mut self, e: FieldError) {
        if self.list.len() < MAX_ERRORS {
            self.list.push(e);
        } else {
            self.omitted += 1;
        }
    }

    /// `Ok(())` if nothing was collected.
    pub fn finish(mut self) -> Result<(), InputError> {
        if self.omitted > 0 {
            let more = format!("and {} more errors, not listed", self.omitted);
            self.list.push(FieldError::new("", more));
        }
        if self.list.is_empty() {
            Ok(())
        } else {
            Err(InputError { errors: self.list })
        }
    }
}
