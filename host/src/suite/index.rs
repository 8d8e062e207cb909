//! The suite's files: the index (`suite.json`) and its entries, where witnesses go, reading
//! and writing, and the errors of both.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// The index file of a suite directory.
pub const INDEX_FILE: &str = "suite.json";
/// The `format` string of the index.
pub const INDEX_FORMAT: &str = "omcbsa.suite.v1";
/// Where witnesses are written, under the suite directory.
pub const WITNESS_DIR: &str = "witnesses";

/// The suite index (`suite.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteIndex {
    /// The index's format string.
    pub format: String,
    /// The seed of the whole suite.
    pub seed: u64,
    /// Every problem.
    pub problems: Vec<SuiteEntry>,
    /// Problems no seed drew (see the `suite` module's docs on redraws), left out.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undrawn: Vec<Undrawn>,
}

/// A problem left out of a suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Undrawn {
    /// The problem's name.
    pub name: String,
    /// The seeds tried, in order.
    pub seeds: Vec<u64>,
}

/// One problem of the suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteEntry {
    /// The problem's name.
    pub name: String,
    /// The problem file, relative to the suite directory.
    pub file: String,
    /// Its motion family.
    pub family: String,
    /// Its layout of arms.
    pub layout: String,
    /// Robots in it.
    pub robots: usize,
    /// Trajectories in it.
    pub trajectories: usize,
    /// Steps of every trajectory.
    #[serde(rename = "H")]
    pub horizon: usize,
    /// Whether a validated witness solves it (every problem `gen-bench` writes has one).
    pub known_solvable: bool,
    /// The seed the problem was drawn from.
    pub seed: u64,
    /// Seeds of the problem's stream tried before `seed` (none of their samples had a
    /// validated witness).
    #[serde(default)]
    pub redraws: u32,
    /// The witness solution file, relative to the suite directory, when known solvable.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub witness: Option<String>,
    /// How the witness was made: its paths (`swing-tracking`: IK tracking of the task's hands
    /// with the elbow swinging through the null space; `random-motion`: random joint motions,
    /// the hands their forward kinematics), then, when the arms stand somewhere, its approach
    /// (`+straight`: all arms straight together; `+rrt-connect`: RRT-Connect), every motion
    /// checked by the validator's checks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub witness_method: Option<String>,
    /// The approach family: how the arms stand (`tucked`, `crossed`, `far_side`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stance: Option<String>,
    /// When every arm has `initial` and there is a witness: whether the straight bridge of
    /// all arms together from `initial` to the witness's first configurations collides (by
    /// the validator's checks, step by step as an approach).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub straight_bridge_collides: Option<bool>,
    /// When the problem set says which arm goes where: `assignment[i]`, the trajectory robot
    /// `i` tracks (`null`: it holds). `omcbsa bench` plans under it and counts a plan with any
    /// other assignment as invalid. Absent, the planner chooses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub assignment: Option<Vec<Option<usize>>>,
}

/// Why the suite could not be generated or read.
#[derive(Debug)]
pub enum Error {
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// A suite index that cannot be read.
    Index {
        /// The index file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// The generator made a problem it cannot stand behind (a bug, reported, not written).
    Generation {
        /// The problem's name.
        problem: String,
        /// What is wrong with it.
        message: String,
    },
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::Index { path, message } => write!(f, "{}: {message}", path.display()),
            Error::Generation { problem, message } => write!(f, "generating {problem}: {message}"),
        }
    }
}

impl std::error::Error for Error {}

pub(super) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads `suite_dir/suite.json`.
pub fn read_index(suite_dir: &Path) -> Result<SuiteIndex, Error> {
    let path = suite_dir.join(INDEX_FILE);
    let text = std::fs::read_to_string(&path).map_err(io(&path))?;
    let index: SuiteIndex = serde_json::from_str(&text).map_err(|e| Error::Index {
        path: path.clone(),
        message: e.to_string(),
    })?;
    if index.format != INDEX_FORMAT {
        let message = format!("format is {:?}, expected {INDEX_FORMAT:?}", index.format);
        return Err(Error::Index { path, message });
    }
    Ok(index)
}

/// Compact JSON and a final newline: problem files are large and read by programs (the index
/// is written pretty, for people).
pub(super) fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), Error> {
    let mut text = serde_json::to_string(value).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e.into(),
    })?;
    text.push('\n');
    std::fs::write(path, text).map_err(io(path))
}
