//! `results.csv`: one row per (problem, planner) run, appended and flushed as runs finish, so
//! an interrupted benchmark keeps what it did and a rerun skips it.

use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::error::Error;
use super::quality::PathQuality;

/// One run.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The problem's name.
    pub problem: String,
    /// Its motion family.
    pub family: String,
    /// Its layout of arms.
    pub layout: String,
    /// Robots in the problem.
    pub robots: usize,
    /// Trajectories in the problem.
    pub trajectories: usize,
    /// Steps of every trajectory.
    #[serde(rename = "H")]
    pub horizon: usize,
    /// Whether the suite holds a witness solution for it.
    pub known_solvable: bool,
    /// The planner's name.
    pub planner: String,
    /// The run's time limit, s.
    pub timeout_s: f64,
    /// The planner's status, or `error` when the run could not happen or the planner failed.
    pub status: String,
    /// For `solved` runs, whether the host validator accepts the solution; empty otherwise.
    pub valid: Option<bool>,
    /// Solved with a valid solution (within the timeout: a planner stops at it).
    pub success: bool,
    /// The planning time the planner reports.
    pub time_s: f64,
    /// Wall-clock time of the whole call, loading and checking excluded.
    pub wall_s: f64,
    /// Search node expansions, when the planner reports them.
    pub expansions: Option<u64>,
    /// Path quality of a successful run's plan (see [`super::quality::PathQuality`]); empty
    /// for the other runs, and for figures that do not apply.
    pub path_length_rad: Option<f64>,
    /// Fastest joint speed as a fraction of that joint's limit (1: at the limit).
    pub max_speed_frac: Option<f64>,
    /// Largest joint acceleration as a fraction of that joint's limit.
    pub max_accel_frac: Option<f64>,
    /// Least distance between two arms over the steps, metres (negative: overlap).
    pub min_arm_clearance_m: Option<f64>,
    /// Least distance between an arm and an obstacle over the steps, metres.
    pub min_obstacle_clearance_m: Option<f64>,
    /// Ω-A*'s cost `g` of the paths, summed over the tracking robots.
    pub path_cost: Option<f64>,
    /// The approach from `initial` to the plan (solved runs): configurations per robot,
    /// seconds of motion, planning time (included in `time_s`), and how it was found
    /// (`none`, `together`, `ordered`, `rrt-connect`).
    pub approach_steps: Option<u64>,
    /// Seconds of the approach's motion.
    pub approach_duration_s: Option<f64>,
    /// Milliseconds spent planning the approach.
    pub approach_time_ms: Option<f64>,
    /// How the approach was found.
    pub approach_method: String,
    /// Planner runs: more than 1 when starts were excluded because no approach reached them.
    pub planner_runs: Option<u64>,
    /// Why a run failed, or what the validator found wrong with a "success".
    pub message: String,
}

impl Row {
    /// Sets the path-quality columns.
    pub fn set_quality(&mut self, q: &PathQuality) {
        self.path_length_rad = Some(q.path_length_rad);
        self.max_speed_frac = Some(q.max_speed_frac);
        self.max_accel_frac = q.max_accel_frac;
        self.min_arm_clearance_m = q.min_arm_clearance_m;
        self.min_obstacle_clearance_m = q.min_obstacle_clearance_m;
        self.path_cost = Some(q.path_cost);
    }

    /// The row's key: (problem, planner). A resumed run skips the keys already there.
    pub fn key(&self) -> (&str, &str) {
        (&self.problem, &self.planner)
    }
}

/// `row` as `results.csv` holds it, with the header line first when `header`.
fn csv_text(row: &Row, header: bool) -> Result<String, Error> {
    let csv_err = |e: &dyn std::fmt::Display| Error::Csv {
        path: PathBuf::new(),
        message: e.to_string(),
    };
    let mut w = csv::WriterBuilder::new()
        .has_headers(header)
        .from_writer(Vec::new());
    w.serialize(row).map_err(|e| csv_err(&e))?;
    let bytes = w.into_inner().map_err(|e| csv_err(&e))?;
    String::from_utf8(bytes).map_err(|e| csv_err(&e))
}

/// The header line the current [`Row`] writes (no line end).
pub fn csv_header() -> Result<String, Error> {
    let text = csv_text(&Row::default(), true)?;
    Ok(text.lines().next().unwrap_or_default().to_string())
}

/// `row` as one record of `results.csv`, its line end included (a message may span lines,
/// quoted).
pub fn csv_line(row: &Row) -> Result<String, Error> {
    csv_text(row, false)
}

/// Appends rows to a results file, flushing each.
pub struct Appender {
    path: PathBuf,
    writer: csv::Writer<File>,
}

impl Appender {
    pub fn append(&mut self, row: &Row) -> Result<(), Error> {
        let csv_err = |e: &dyn std::fmt::Display| Error::Csv {
            path: self.path.clone(),
            message: e.to_string(),
        };
        self.writer.serialize(row).map_err(|e| csv_err(&e))?;
        self.writer.flush().map_err(|e| csv_err(&e))
    }
}

/// Opens `path` for appending and returns the rows already in it. A last line cut short by an
/// interruption is dropped; a file with another header is refused rather than mixed.
pub fn open(path: &Path) -> Result<(Vec<Row>, Appender), Error> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let expected = csv_header()?;
    let mut rows = Vec::new();
    let existing = match std::fs::read(path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(io(e)),
    };
    let complete = existing
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    if complete < existing.len() {
        let file = OpenOptions::new().write(true).open(path).map_err(io)?;
        file.set_len(complete as u64).map_err(io)?;
    }
    if complete > 0 {
        let mut reader = csv::Reader::from_reader(&existing[..complete]);
        let found = reader.headers().map_err(|e| Error::Csv {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let found = found.iter().collect::<Vec<_>>().join(",");
        if found != expected {
            return Err(Error::Csv {
                path: path.to_path_buf(),
                message: format!(
                    "its header is `{found}`, this version writes `{expected}`: use another --out directory"
                ),
            });
        }
        for (i, record) in reader.deserialize::<Row>().enumerate() {
            let row = record.map_err(|e| Error::Csv {
                path: path.to_path_buf(),
                message: format!("row {}: {e}", i + 1),
            })?;
            rows.push(row);
        }
    }
    let mut file = OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(io)?;
    if complete == 0 {
        writeln!(file, "{expected}").map_err(io)?;
    }
    let writer = csv::WriterBuilder::new()
        .has_headers(false)
        .from_writer(file);
    Ok((
        rows,
        Appender {
            path: path.to_path_buf(),
            writer,
        },
    ))
}
