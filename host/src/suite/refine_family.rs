//! The refinement family (`omcbsa gen-bench --refine N`): problems with a validated
//! witness on which Ω-CBSA's first refinement level finds no plan.
//!
//! Candidates come from the suite's own generator (every motion family, layout and arm count,
//! from a seed of their own), with the suite's fixtures or, `--tight`, fixtures that hem the
//! witness in more closely ([`Tightness::TIGHT`]: more of them, 2 cm from the witness instead
//! of 5). A candidate is
//! kept when its witness passes the host validator and Ω-CBSA, allowed level 0 only
//! ([`CbsParams::levels`]), ends with its search space exhausted. That is the only planner
//! run and its only test: whether the full planner then solves a kept problem is what the
//! family measures. Level 0 runs without a clock (its end is deterministic), so the same
//! options give the same bytes.
//!
//! [`CbsParams::levels`]: omcbsa_core::cbs::CbsParams::levels

use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;

use omcbsa_core::collision::ArmPose;
use omcbsa_core::planner::{NoClock, PlannerKind, Status, Until};
use omcbsa_core::search::refine::LEVEL_CAP;

use super::emit::Generated;
use super::witness::Arms;
use super::{draw, specs, write_suite, Drawn, Error, Family, GenOptions, GenReport, Tightness};
use crate::bench::WORKER_STACK;
use crate::load;
use crate::models::DOF;
use crate::planners::{Capacities, Storage};

/// How `omcbsa gen-bench --refine` finds its problems.
#[derive(Clone, Debug, PartialEq)]
pub struct RefineOptions {
    /// Seed of the candidates (not the suite's, so the family shares no problem with it).
    pub seed: u64,
    /// Problems wanted.
    pub problems: usize,
    /// Candidates generated before giving up with fewer.
    pub max_candidates: usize,
    /// The fixtures around the witness: the suite's, or [`Tightness::TIGHT`].
    pub traps: Tightness,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            seed: 20_261_123,
            problems: 60,
            max_candidates: 6_000,
            traps: Tightness::SUITE,
        }
    }
}

/// Candidates generated (in parallel) between checks of how many were kept.
const BATCH: usize = 48;

/// Writes the family into `outdir` like a suite (`suite.json`, problems, witnesses): the first
/// `opts.problems` candidates, in candidate order, that Ω-CBSA's level 0 misses.
pub fn gen_refine(outdir: &Path, opts: &RefineOptions) -> Result<GenReport, Error> {
    let start = Instant::now();
    // Enough suite-like specs, cycling through every family, layout and arm count.
    let per_family = opts.max_candidates.div_ceil(6).max(1);
    let mut candidates = specs(
        &GenOptions {
            seed: opts.seed,
            per_family,
            // The Gen3 families it was made from (the same problems as before mixed fleets).
            families: (Family::ALL.into_iter())
                .filter(|&f| f != Family::Mixed)
                .collect(),
        },
        opts.traps,
    );
    // Interleave the families, so that any prefix mixes them.
    candidates.sort_by_key(|s| (s.name.rsplit('_').next().map(str::to_owned), s.family as u8));
    candidates.truncate(opts.max_candidates);
    // Level 0 runs the planner, whose fixed-size workspaces live on the stack: the bench's
    // worker stacks, not the global pool's.
    let pool = rayon::ThreadPoolBuilder::new()
        .stack_size(WORKER_STACK)
        .build()
        .map_err(|e| Error::Generation {
            problem: "refinement family".into(),
            message: format!("cannot start the worker threads: {e}"),
        })?;
    let mut kept: Vec<Generated> = Vec::new();
    for batch in candidates.chunks(BATCH) {
        let found: Vec<Option<Generated>> = pool.install(|| {
            batch
                .par_iter()
                // A candidate is drawn from its first seed alone: one with nothing to build
                // from is no candidate.
                .map(|spec| match draw(spec, 1)? {
                    Drawn::Problem(g) => Ok(level0_misses(&g)?.then_some(*g)),
                    Drawn::Undrawn(_) => Ok(None),
                })
                .collect::<Result<_, Error>>()
        })?;
        kept.extend(found.into_iter().flatten());
        if kept.len() >= opts.problems {
            break;
        }
    }
    kept.truncate(opts.problems);
    for g in &mut kept {
        g.entry.family = format!("refine_{}", g.entry.family);
    }
    write_suite(outdir, opts.seed, kept, Vec::new(), start)
}

/// Whether `g`'s arms can stand at their `initial` (the tighter fixtures may take the retract
/// pose an arm starts from) and Ω-CBSA's level 0 exhausts its search space on it (its witness
/// is validated).
fn level0_misses(g: &Generated) -> Result<bool, Error> {
    let problem = load::problem::<Arms, DOF>(&g.problem).map_err(|e| Error::Generation {
        problem: g.entry.name.clone(),
        message: e.to_string(),
    })?;
    let standing: Vec<ArmPose> = (problem.robots.iter())
        .filter_map(|r| {
            r.initial
                .map(|q| ArmPose::new::<Arms, DOF>(r.model, &r.base, &r.tool, &q))
        })
        .collect();
    let blocked = standing.iter().enumerate().any(|(i, a)| {
        a.obstacle_hit(&problem.obstacles, 0.0).is_some()
            || a.self_hit(0.0).is_some()
            || standing[i + 1..]
                .iter()
                .any(|b| a.arm_hit(b, 0.0).is_some())
    });
    if blocked {
        return Ok(false);
    }
    let mut storage = Storage::new(Capacities::default(), problem.horizon());
    storage.cbs_params.levels = 1;
    let ran = storage
        .solve_core(PlannerKind::OmCbsa, &problem, Until::never(&NoClock))
        .map_err(|message| Error::Generation {
            problem: g.entry.name.clone(),
            message,
        })?;
    Ok(ran.status == Status::NoSolution && ran.stats.reason == Some(LEVEL_CAP))
}
