//! The benchmark suite generator (`omcbsa gen-bench`): a fixed-seed, byte-for-byte
//! reproducible set of problems with 2 to 6 arms (Kinova Gen3s; Gen3s and Franka Pandas in
//! the mixed family), in four crowded layouts, over motion families shaped like policy outputs.
//!
//! Every problem is built from a witness: a collision-free joint motion per arm (IK tracking
//! of the task's hands from random seeds while the elbow swings through the null space, or for
//! the random, approach and mixed families a smooth random joint motion mapped to the hands by
//! forward kinematics) and, where the arms stand somewhere (`initial`), an approach from there
//! found by a plain RRT-Connect over the validator's own checks (`connect`), the whole witness
//! confirmed by the host validator. None of it runs a planner under test, so which problems
//! are known to be solvable does not depend on them. Fixtures are then placed where plain,
//! myopic IK tracking of each hand (from the witness's start and from other starts, by every
//! arm in reach) takes an elbow or forearm but no witness arm goes (see `trap`), so that
//! solving takes the redundancy the witness used. Its trajectories are listed in shuffled
//! order, so the listed order is not the assignment.
//!
//! Resampling: a task whose witness search fails is resampled, up to [`TASK_SAMPLES`] samples
//! ([`RANDOM_SAMPLES`] for the random and approach families, [`MIXED_SAMPLES`] for the mixed
//! one). A sample with a witness that the IK-tracking baseline still solves (within a fixed
//! budget of work, see `myopic`) is also resampled, up to [`HARD_SAMPLES`] samples with witness
//! paths and arms that can stand; then the first of them with a validated witness is kept
//! (of the approach family: preferably one whose straight bridge collides). These are the only
//! two grounds: no other planner is run, so the suite is not biased for or against any planner
//! but IK tracking.
//!
//! Redraws: each problem has a stream of seeds (from the suite's seed, its family and its
//! number). When no sample of a seed has a validated witness, the problem is drawn again from
//! the stream's next seed, up to [`MAX_DRAWS`] seeds; the index records the seed it was drawn
//! from and how many seeds came before (`redraws`). A problem no seed draws is left out and
//! listed in the index (`undrawn`): generation never stops for one problem.
//!
//! Reproducible: each problem depends on its own seeds alone (not on the threads or the order
//! they run in), transcendental functions come from `libm` (the same bits on every platform),
//! and the files are written in a fixed order with the shortest round-trip decimal of each
//! number. `docs/bench/suite.sha256` holds the default suite's checksums.
//!
//! Output: `OUTDIR/<name>.json` per problem, `OUTDIR/witnesses/<name>.json` (the witness as an
//! `omcbsa.solution.v1` file) per problem, and the index `OUTDIR/suite.json`.

mod connect;
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
/// Samples of a task family tried from one seed.
pub const TASK_SAMPLES: u64 = 10;
/// Samples with a witness tried before one that IK tracking solves is kept.
pub const HARD_SAMPLES: usize = 10;
/// Samples of the random and approach families tried from one seed.
const RANDOM_SAMPLES: u64 = 64;
/// Samples of the mixed family (random motions of Gen3s and Pandas) tried from one seed: a
/// Panda finds a clear random motion in a crowded layout about a third as often as a Gen3.
const MIXED_SAMPLES: u64 = 256;
/// Seeds a problem is drawn from before it is left out.
pub const MAX_DRAWS: u32 = 16;

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
    /// Problems drawn from a later seed than their first.
    pub redrawn: usize,
    /// Problems left out: no seed drew them.
    pub undrawn: Vec<String>,
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
    /// Problems no seed drew (see the module's docs), left out.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub undrawn: Vec<Undrawn>,
}

/// A problem left out of a suite.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Undrawn {
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
    /// Seeds the stream of the problem's seeds.
    stream: u64,
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
            let stream = opts.seed ^ ((f as u64) << 32 | k as u64);
            let name = format!("{}_{}_{robots}arms_{k:03}", family.name(), layout.name());
            let stance = (family == Family::Approach).then(|| Stance::ALL[k % Stance::ALL.len()]);
            specs.push(Spec {
                name,
                family,
                layout,
                robots,
                stream,
                traps,
                stance,
            });
        }
    }
    specs
}

impl Spec {
    /// The problem's seeds, in the order it is drawn from them.
    fn seeds(&self) -> impl Iterator<Item = u64> {
        let mut stream = Rng::new(self.stream);
        std::iter::repeat_with(move || stream.next_u64())
    }
}

/// A problem of the suite, or why there is none.
enum Drawn {
    Problem(Box<emit::Generated>),
    Undrawn(Undrawn),
}

/// The problem of `spec` from the first of its first `draws` seeds that draws it.
fn draw(spec: &Spec, draws: u32) -> Result<Drawn, Error> {
    let mut tried = Vec::new();
    for seed in spec.seeds().take(draws as usize) {
        if let Some(mut g) = emit::generate(spec, seed)? {
            g.entry.redraws = tried.len() as u32;
            return Ok(Drawn::Problem(Box::new(g)));
        }
        tried.push(seed);
    }
    Ok(Drawn::Undrawn(Undrawn {
        name: spec.name.clone(),
        seeds: tried,
    }))
}

/// Writes the suite into `outdir` (created if missing). Problems are generated in parallel
/// and written in a fixed order; the same options give the same bytes.
pub fn gen_bench(outdir: &Path, opts: &GenOptions) -> Result<GenReport, Error> {
    let start = Instant::now();
    let drawn: Vec<Drawn> = specs(opts, Tightness::SUITE)
        .par_iter()
        .map(|spec| draw(spec, MAX_DRAWS))
        .collect::<Result<_, _>>()?;
    let (mut generated, mut undrawn) = (Vec::new(), Vec::new());
    for d in drawn {
        match d {
            Drawn::Problem(g) => generated.push(*g),
            Drawn::Undrawn(u) => undrawn.push(u),
        }
    }
    write_suite(outdir, opts.seed, generated, undrawn, start)
}

/// Writes the problems, their witnesses and the index into `outdir` (created if missing), in
/// the order given.
fn write_suite(
    outdir: &Path,
    seed: u64,
    generated: Vec<emit::Generated>,
    undrawn: Vec<Undrawn>,
    start: Instant,
) -> Result<GenReport, Error> {
    let witness_dir = outdir.join(WITNESS_DIR);
    std::fs::create_dir_all(&witness_dir).map_err(io(&witness_dir))?;
    let mut problems = Vec::with_capacity(generated.len());
    for g in generated {
        write_json(&outdir.join(&g.entry.file), &g.problem)?;
        if let Some(file) = &g.entry.witness {
            write_json(&outdir.join(file), &g.witness)?;
        }
        problems.push(g.entry);
    }
    let known_solvable = problems.iter().filter(|e| e.known_solvable).count();
    let redrawn = problems.iter().filter(|e| e.redraws > 0).count();
    let index = SuiteIndex {
        format: INDEX_FORMAT.to_string(),
        seed,
        problems,
        undrawn,
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
        redrawn,
        undrawn: index.undrawn.iter().map(|u| u.name.clone()).collect(),
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

#[cfg(test)]
mod tests;
