//! The command log: every frame the executor sends (or, in a dry run, would send), as JSON lines.

use serde::Serialize;
use std::io::{BufWriter, Write};
use std::path::Path;

#[derive(Clone, Debug, Serialize)]
pub struct LogEntry {
    /// Seconds since the executor started (planned time in a dry run).
    pub t: f64,
    pub arm: String,
    /// `candump` style, e.g. `201#809698000F00`.
    pub frame: String,
    /// What the frame means, e.g. `RPDO1 node 1 target 1.0000000 rad cw 0x000f`.
    pub what: String,
}

/// Writes `entries` sorted by time to `path`, one JSON object per line.
pub fn write_jsonl(path: &Path, entries: &mut [LogEntry]) -> std::io::Result<()> {
    entries.sort_by(|a, b| a.t.total_cmp(&b.t));
    let mut out = BufWriter::new(std::fs::File::create(path)?);
    for e in entries.iter() {
        serde_json::to_writer(&mut out, e)?;
        out.write_all(b"\n")?;
    }
    out.flush()
}
