//! The command log: every frame the executor sends (or, in a dry run, would send), as JSON
//! lines. The arm threads format a line and hand it to a writer thread of the log's own; they
//! never touch the file, because a write can block for tens of milliseconds while the kernel
//! flushes other processes' dirty pages, and an arm thread held up that long misses its
//! cycles.
//!
//! Costs: at most [`LogSink::QUEUE`] lines (about 100 bytes each) wait in memory for the
//! writer. A line that finds the queue full (the disk has not kept up for that long) is
//! dropped and counted, and the run reports it at its end, as it reports a failed write.

use crate::run::ExecError;
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;

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

/// What the arm threads hand the writer: a line, or a request to flush and answer with the
/// log's first error.
enum ToWriter {
    Line(String),
    Finish(SyncSender<Option<std::io::Error>>),
}

/// The writer thread's end: the file, and the first write error (later lines are dropped).
struct Writer {
    out: BufWriter<File>,
    error: Option<std::io::Error>,
}

impl Writer {
    fn run(mut self, from_arms: Receiver<ToWriter>) {
        for message in from_arms {
            match message {
                ToWriter::Line(line) if self.error.is_none() => {
                    self.error = self.out.write_all(line.as_bytes()).err();
                }
                ToWriter::Line(_) => {}
                ToWriter::Finish(answer) => {
                    if self.error.is_none() {
                        self.error = self.out.flush().err();
                    }
                    let _ = answer.send(self.error.take());
                }
            }
        }
    }
}

/// A log file shared by the arm threads; lines are in the order the frames were handed over.
/// When a write fails (the disk is full) or the writer falls [`LogSink::QUEUE`] lines behind,
/// the lines it cannot take are dropped and [`LogSink::finish`] returns the error: the run goes
/// on, and reports it at its end.
#[derive(Clone)]
pub struct LogSink {
    path: PathBuf,
    to_writer: SyncSender<ToWriter>,
    dropped: Arc<AtomicUsize>,
}

impl LogSink {
    /// The most lines waiting for the writer thread: about 1.5 s of three CAN arms at 250 Hz.
    pub const QUEUE: usize = 16_384;

    /// Creates (or truncates) the file at `path` and starts its writer thread, which ends when
    /// the last clone of the sink is dropped.
    pub fn create(path: &Path) -> std::io::Result<Self> {
        let writer = Writer {
            out: BufWriter::new(File::create(path)?),
            error: None,
        };
        let (to_writer, from_arms) = sync_channel(Self::QUEUE);
        std::thread::Builder::new()
            .name("command-log".into())
            .spawn(move || writer.run(from_arms))?;
        Ok(Self {
            path: path.to_path_buf(),
            to_writer,
            dropped: Arc::new(AtomicUsize::new(0)),
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Hands one line to the writer; never waits for the file.
    pub fn write(&self, entry: &LogEntry) {
        let taken = serde_json::to_string(entry).ok().and_then(|mut line| {
            line.push('\n');
            self.to_writer.try_send(ToWriter::Line(line)).ok()
        });
        if taken.is_none() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Waits until the writer has written every line handed over so far and flushed the file;
    /// the first error of the whole log, if any.
    pub fn finish(&self) -> std::io::Result<()> {
        let (answer, answered) = sync_channel(1);
        let writer_gone = || std::io::Error::other("the log's writer thread has gone");
        (self.to_writer.send(ToWriter::Finish(answer))).map_err(|_| writer_gone())?;
        if let Some(e) = answered.recv().map_err(|_| writer_gone())? {
            return Err(e);
        }
        match self.dropped.swap(0, Ordering::Relaxed) {
            0 => Ok(()),
            n => Err(std::io::Error::other(format!(
                "{n} lines dropped: the disk fell {} lines behind",
                Self::QUEUE
            ))),
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
