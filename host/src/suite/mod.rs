//! The benchmark suite generator (`omcbsa gen-bench`): a fixed-seed, byte-for-byte
//! reproducible set of problems with 2 to 6 arms (Kinova Gen3s; Gen3s and Franka Pandas in
//! the mixed family), in four crowded layouts, over motion families shaped like policy outputs.
//!
//! Every problem is built from a witness when one is found: a collision-free joint motion per
//! arm (IK tracking of the task's hands from random seeds while the elbow swings through the
//! null space, or for the random family a smooth random joint motion mapped to the hands by
//! forward kinematics), confirmed by the host validator. Fixtures are then placed where plain,
//! myopic IK tracking of each hand (from the witness's start and from other starts, by every
//! arm in reach) takes an elbow or forearm but no witness arm goes (see `trap`), so that
//! solving takes the redundancy the witness used. Its trajectories are listed in shuffled
//! order, so the listed order is not the assignment.
//!
//! Resampling: a task whose witness search fails is resampled, up to [`TASK_SAMPLES`] samples
//! (`RANDOM_SAMPLES` for the random family, `MIXED_SAMPLES` for the mixed one). A sample
//! with a witness that the IK-tracking baseline still solves (within a fixed budget of work,
//! see `myopic`) is also resampled, up to [`HARD_SAMPLES`] samples with a witness; then the first of them is kept. These are the
//! only two grounds: no other planner is run, so the suite is not biased for or against any
//! planner but IK tracking. If every sample fails to find a witness, the last one is still
//! emitted, recorded as not known to be solvable (it may be, or not).
//!
//! Output: `OUTDIR/<name>.json` per problem, `OUTDIR/witnesses/<name>.json` (the witness as an
//! `omcbsa.solution.v1` file) per known-solvable problem, and the index `OUTDIR/suite.json`.

mod emit;
pub(crate) use emit::obstacle_spec;
mod family;
pub(crate) mod frames;
pub(crate) mod layout;
mod myopic;
mod refine_family;
mod standing;
mod trap;
pub(crate) mod witness;

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use omcbsa_core::rng::Rng;

pub use family::{Family, MIXED_MODELS};
pub use layout::LayoutKind;
pub use refine_family::{gen_refine, RefineOptions};
pub use standing::Stance;
pub use trap::Tightness;

/// The index file of a suite directory.
pub const INDEX_FILE: &str = "suite.json";
/// The `format` string of the index.
pub const INDEX_FORMAT: &str = "omcbsa.suite.v1";
/// Where witnesses are written, under the suite directory.
pub const WITNESS_DIR: &str = "witnesses";
/// Samples of a task family tried before a problem is emitted without a witness.
pub const TASK_SAMPLES: u64 = 10;
/// Samples with a witness tried before one that IK tracking solves is kept.
pub const HARD_SAMPLES: usize = 10;
/// Samples of the random family tried before generation gives up (its problems always come
/// from a witness).
const RANDOM_SAMPLES: u64 = 64;
/// Samples of the mixed family (random motions of Gen3s and Pandas) tried before generation
/// gives up: a Panda finds a clear random motion in a crowded layout about a third as often
/// as a Gen3.
const MIXED_SAMPLES: u64 = 256;

/// How `omcbsa gen-bench` generates the suite.
#[derive(Clone, Debug, PartialEq)]
pub struct GenOptions {
    /// Seed of the whole suite.
    pub seed: u64,
    /// Problems per motion family, spread evenly over the family's layouts and arm counts.
    pub per_family: usize,
    /// The families generated (each with the problems it has in the whole suite).
    pub families: Vec<Family>,
}

impl Default for GenOptions {
    /// The published suite: 8 families x 76 = 608 problems.
    fn default() -> Self {
        GenOptions {
            seed: 20_250_606,
            per_family: 76,
            families: Family::ALL.to_vec(),
        }
    }
}

/// What [`gen_bench`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct GenReport {
    /// Problems written.
    pub problems: usize,
    /// Of them, those with a witness solution.
    pub known_solvable: usize,
    /// Wall time of generation, s.
    pub seconds: f64,
}

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
    /// Whether a witness solution shows it solvable.
    pub known_solvable: bool,
    /// The seed the problem was generated from.
    pub seed: u64,
    /// The witness solution file, relative to the suite directory, when known solvable.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub witness: Option<String>,
    /// The approach family: how the arms stand (`tucked`, `crossed`, `far_side`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stance: Option<String>,
    /// When every arm has `initial` and there is a witness: whether the straight bridge of
    /// all arms together from `initial` to the witness's first configurations collides.
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
    /// No sample of a random-family problem had a motion to build it from.
    NoMotion {
        /// The problem's name.
        problem: String,
        /// Samples tried.
        samples: u64,
    },
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::Index { path, message } => write!(f, "{}: {message}", path.display()),
            Error::Generation { problem, message } => write!(f, "generating {problem}: {message}"),
            Error::NoMotion { problem, samples } => write!(
                f,
                "generating {problem}: no random motion found in {samples} samples"
            ),
        }
    }
}

impl std::error::Error for Error {}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// What to generate for one problem.
struct Spec {
    name: String,
    family: Family,
    layout: LayoutKind,
    robots: usize,
    seed: u64,
    traps: Tightness,
    /// How the approach family's arms stand.
    stance: Option<Stance>,
}

fn specs(opts: &GenOptions, traps: Tightness) -> Vec<Spec> {
    let mut specs = Vec::new();
    // Seeds come from a family's place in `Family::ALL`, so a subset is the same problems.
    let chosen = (Family::ALL.into_iter().enumerate()).filter(|(_, f)| opts.families.contains(f));
    for (f, family) in chosen {
        let cells = family.cells();
        for k in 0..opts.per_family {
            let (layout, robots) = cells[k % cells.len()];
            let seed = Rng::new(opts.seed ^ ((f as u64) << 32 | k as u64)).next_u64();
            let name = format!("{}_{}_{robots}arms_{k:03}", family.name(), layout.name());
            let stance = (family == Family::Approach).then(|| Stance::ALL[k % Stance::ALL.len()]);
            specs.push(Spec {
                name,
                family,
                layout,
                robots,
                seed,
                traps,
                stance,
            });
        }
    }
    specs
}

/// Writes the suite into `outdir` (created if missing). Problems are generated in parallel
/// and written in a fixed order; the same options give the same bytes.
pub fn gen_bench(outdir: &Path, opts: &GenOptions) -> Result<GenReport, Error> {
    let start = Instant::now();
    let generated: Vec<emit::Generated> = specs(opts, Tightness::SUITE)
        .par_iter()
        .map(emit::generate)
        .collect::<Result<_, _>>()?;
    write_suite(outdir, opts.seed, generated, start)
}

/// Writes the problems, their witnesses and the index into `outdir` (created if missing), in
/// the order given.
fn write_suite(
    outdir: &Path,
    seed: u64,
    generated: Vec<emit::Generated>,
    start: Instant,
) -> Result<GenReport, Error> {
    let witness_dir = outdir.join(WITNESS_DIR);
    std::fs::create_dir_all(&witness_dir).map_err(io(&witness_dir))?;
    let mut problems = Vec::with_capacity(generated.len());
    for g in generated {
        write_json(&outdir.join(&g.entry.file), &g.problem)?;
        if let (Some(file), Some(witness)) = (&g.entry.witness, &g.witness) {
            write_json(&outdir.join(file), witness)?;
        }
        problems.push(g.entry);
    }
    let known_solvable = problems.iter().filter(|e| e.known_solvable).count();
    let index = SuiteIndex {
        format: INDEX_FORMAT.to_string(),
        seed,
        problems,
    };
    let index_path = outdir.join(INDEX_FILE);
    let text = serde_json::to_string_pretty(&index).map_err(|e| Error::Io {
        path: index_path.clone(),
        source: e.into(),
    })?;
    std::fs::write(&index_path, text + "\n").map_err(io(&index_path))?;
    Ok(GenReport {
        problems: index.problems.len(),
        known_solvable,
        seconds: start.elapsed().as_secs_f64(),
    })
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
fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<(), Error> {
    let mut text = serde_json::to_string(value).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        source: e.into(),
    })?;
    text.push('\n');
    std::fs::write(path, text).map_err(io(path))
}
