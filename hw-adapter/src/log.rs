//! The command log: every frame the executor sends (or, in a dry run, would send), as JSON
//! lines, written as the frames go out (nothing is kept in memory).

use crate::run::ExecError;
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// One line of the log: one frame.
#[derive(Clone, Debug, Serialize)]
pub struct LogEntry<'a> {
    /// Seconds since the executor started (planned time in a dry run).
    pub t: f64,
    /// The arm it was sent to.
    pub arm: &'a str,
    /// `candump` style, e.g. `201#809698000F00`.
    pub frame: String,
    /// What the frame means, e.g. `RPDO1 node 1 target 1.0000000 rad cw 0x000f`.
    pub what: &'a str,
}

struct Sink {
    out: BufWriter<File>,
    /// The first write error; later entries are dropped and the run reports it at its end.
    error: Option<std::io::Error>,
}

/// A log file shared by the arm threads; lines are in the order the frames were sent. Nothing
/// is kept in memory beyond the file's buffer. When a write fails (the disk is full), the
/// later lines are dropped and [`LogSink::finish`] returns the first error: the run goes on,
/// and reports it at its end.
#[derive(Clone)]
pub struct LogSink {
    path: PathBuf,
    sink: Arc<Mutex<Sink>>,
}

impl LogSink {
    /// Creates (or truncates) the file at `path`.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        Ok(Self {
            path: path.to_path_buf(),
            sink: Arc::new(Mutex::new(Sink {
                out: BufWriter::new(File::create(path)?),
                error: None,
            })),
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes one line (after a failed write: nothing).
    pub fn write(&self, entry: &LogEntry) {
        let mut s = self.sink.lock().unwrap_or_else(|p| p.into_inner());
        if s.error.is_none() {
            let written = serde_json::to_writer(&mut s.out, entry)
                .map_err(std::io::Error::from)
                .and_then(|()| s.out.write_all(b"\n"));
            if let Err(e) = written {
                s.error = Some(e);
            }
        }
    }

    /// Flushes the file; the first error of the whole log, if any.
    pub fn finish(&self) -> std::io::Result<()> {
        let mut s = self.sink.lock().unwrap_or_else(|p| p.into_inner());
        match s.error.take() {
            Some(e) => Err(e),
            None => s.out.flush(),
        }
    }
}

/// The log at `path`, created (`None`: no log).
pub(crate) fn open(path: Option<&Path>) -> Result<Option<LogSink>, ExecError> {
    path.map(|path| {
        LogSink::create(path).map_err(|error| ExecError::Log {
            path: path.to_path_buf(),
            error,
        })
    })
    .transpose()
}

/// Flushes `log`: the first error of the whole log as the run's error.
pub(crate) fn finish(log: Option<LogSink>) -> Result<(), ExecError> {
    match log {
        Some(log) => log.finish().map_err(|error| ExecError::Log {
            path: log.path().to_path_buf(),
            error,
        }),
        None => Ok(()),
    }
}
