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
//! (`RANDOM_SAMPLES` for the random and approach families, `MIXED_SAMPLES` for the mixed
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
mod index;
pub(crate) mod layout;
mod myopic;
mod refine_family;
mod spec;
mod standing;
mod trap;
pub(crate) mod witness;

use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;

use index::{io, write_json};
use spec::{specs, Spec};

pub use family::{Family, MIXED_MODELS};
pub use index::{
    read_index, Error, SuiteEntry, SuiteIndex, Undrawn, INDEX_FILE, INDEX_FORMAT, WITNESS_DIR,
};
pub use layout::LayoutKind;
pub use refine_family::{gen_refine, RefineOptions};
pub use spec::{GenOptions, HARD_SAMPLES, MAX_DRAWS, TASK_SAMPLES};
pub use standing::Stance;
pub use trap::Tightness;

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

#[cfg(test)]
mod tests;
