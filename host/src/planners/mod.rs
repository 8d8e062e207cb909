//! Every planner by name, with its storage allocated here, before the core is called: the
//! core itself never allocates. Each core planner declares its storage type; the one table,
//! `table::PLANNERS` (planners/table.rs), says per [`PlannerKind`] how to cut it from the one
//! arena (planners/arena.rs) and how to run the planner on it.

use std::time::Instant;

use crate::approach::{describe_miss, MAX_APPROACH};
use crate::format::{
    joint_paths_value, ProblemFile, SolutionFile, Status as FileStatus, SOLUTION_FORMAT,
};
use omcbsa_core::approach::{ApproachError, ApproachParams, Method};
use omcbsa_core::cbs::CbsParams;
use omcbsa_core::embody::{Embodied, Embodiment};
use omcbsa_core::planner::{Clock, Solution, Stats, Status, Until};
use omcbsa_core::problem::{Problem, MAX_ROBOTS};

mod arena;
mod capacity;
mod table;

use arena::Arena;
pub use capacity::{Capacities, START_CACHE_ENTRIES};
use table::{approach_storage, Settings};

pub use omcbsa_core::planner::PlannerKind;

/// One line per planner, `name: description`, for `--help`.
pub fn descriptions() -> String {
    (PlannerKind::ALL.iter())
        .map(|p| format!("{}: {}", p.name(), p.description()))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The planner of several robots named `name` (one of [`PlannerKind::BENCH`]), or an error
/// listing them.
pub fn parse_bench(name: &str) -> Result<PlannerKind, String> {
    PlannerKind::parse(name)
        .filter(|p| PlannerKind::BENCH.contains(p))
        .ok_or_else(|| {
            let known: Vec<&str> = PlannerKind::BENCH.iter().map(|p| p.name()).collect();
            format!("unknown planner {name:?} (known: {})", known.join(", "))
        })
}

/// The planner named `name`, or an error listing the known names.
pub fn parse(name: &str) -> Result<PlannerKind, String> {
    PlannerKind::parse(name).ok_or_else(|| {
        let known: Vec<&str> = PlannerKind::ALL.iter().map(|p| p.name()).collect();
        format!("unknown planner {name:?} (known: {})", known.join(", "))
    })
}

pub use crate::models::DOF;

/// What a planning run produced.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// How planning ended.
    pub status: Status,
    /// Wall time of the run, approach included, s.
    pub planning_time_s: f64,
    /// Per robot: the trajectory tracked, `None` when holding (meaningful when solved).
    pub assignment: Vec<Option<usize>>,
    /// Per robot: H configurations (only when solved).
    pub joint_paths: Vec<Vec<[f64; DOF]>>,
    /// Per robot: the approach from `initial` to `joint_paths[i][0]` (only when solved and
    /// every robot has `initial`; then the same length for every robot, possibly 0).
    pub approach: Option<Vec<Vec<[f64; DOF]>>>,
    /// How the approach was found.
    pub approach_info: ApproachInfo,
    /// The planner's counters over all its runs.
    pub stats: Stats,
}

/// How the approach of a run was found.
#[derive(Clone, Copy, Debug, Default)]
pub struct ApproachInfo {
    /// Which approach planner found it.
    pub method: Method,
    /// Configurations per robot.
    pub steps: usize,
    /// Seconds of motion (`(steps + 1) * dt` when there is one).
    pub duration_s: f64,
    /// Seconds spent planning approaches, included in the run's planning time.
    pub planning_time_s: f64,
    /// Planner runs (more than 1 when starts were excluded for want of an approach).
    pub attempts: u32,
    /// Why the last approach tried failed (when one did and the run is not solved).
    pub last_miss: Option<ApproachError>,
}

/// `std::time::Instant` as the core's clock.
pub struct WallClock(Instant);

impl WallClock {
    /// A clock reading 0 now.
    pub fn start() -> Self {
        WallClock(Instant::now())
    }
}

impl Clock for WallClock {
    fn seconds(&self) -> f64 {
        self.0.elapsed().as_secs_f64()
    }
}

/// Every planner's pools, allocated once and reused run after run: one arena as large as the
/// largest planner's storage (about 50 MB with the default [`Capacities`], plus
/// `path_slots * max_h * 56` bytes of Ω-CBSA's pooled paths), cut for each run by the
/// planner's entry of `table::PLANNERS`, and the plan and approach buffers. A pool that runs out
/// ends the run with [`Status::OutOfMemory`] naming it.
pub struct Storage {
    /// Ω-CBSA's settings (the paper's by default).
    pub cbs_params: CbsParams,
    /// The approach's settings.
    pub approach_params: ApproachParams,
    /// Whether runs plan the approach from `initial` (the default). Off, a planner runs alone
    /// and its plan begins wherever it chose: the peer that measures what the approach costs.
    pub with_approach: bool,
    caps: Capacities,
    max_h: usize,
    arena: Arena,
    /// The problem being planned, which the approach loop annotates with excluded starts.
    problem: Box<Problem<DOF>>,
    /// How the last [`Storage::solve_core`] ended, approach included.
    last: Embodied,
    /// The plan: robot `i`'s path from `i * h`.
    out: Vec<[f64; DOF]>,
    /// The approach: robot `i`'s from `i * MAX_APPROACH`.
    approach_out: Vec<[f64; DOF]>,
}

impl Storage {
    /// Pools for problems of horizon at most `max_h`.
    pub fn new(caps: Capacities, max_h: usize) -> Self {
        Storage {
            cbs_params: CbsParams::default(),
            approach_params: ApproachParams::default(),
            with_approach: true,
            caps,
            max_h,
            // Measuring hands out no buffer, so it cannot fail; if it did, the empty arena
            // would make every run an error naming the slab it lacks.
            arena: Arena::new(table::measure(caps, max_h).unwrap_or_default()),
            problem: Box::new(Problem {
                dt: 0.0,
                robots: heapless::Vec::new(),
                trajectories: heapless::Vec::new(),
                obstacles: heapless::Vec::new(),
                tolerance: Default::default(),
            }),
            last: Embodied::ended(Status::Timeout, 0),
            out: vec![[0.0; DOF]; MAX_ROBOTS * max_h],
            approach_out: vec![[0.0; DOF]; MAX_APPROACH * MAX_ROBOTS],
        }
    }

    /// Runs planner `kind` on `problem`, the approach from where the arms stand included
    /// ([`omcbsa_core::embody`]); this call allocates nothing but the returned [`Outcome`]'s
    /// vectors, after the core call.
    pub fn solve(
        &mut self,
        kind: PlannerKind,
        problem: &Problem<DOF>,
        timeout_s: f64,
    ) -> Result<Outcome, String> {
        let clock = WallClock::start();
        let ran = self.solve_core(kind, problem, Until::new(&clock, timeout_s))?;
        let planning_time_s = clock.seconds();
        let h = problem.horizon();
        let n = problem.robots.len();
        let solved = ran.status == Status::Solved;
        let last = self.last;
        let with_approach =
            self.with_approach && solved && problem.robots.iter().all(|r| r.initial.is_some());
        let a = last.approach.len;
        Ok(Outcome {
            status: ran.status,
            planning_time_s,
            assignment: ran.assignment[..n]
                .iter()
                .map(|a| a.map(usize::from))
                .collect(),
            joint_paths: if solved {
                (0..n)
                    .map(|i| self.out[i * h..(i + 1) * h].to_vec())
                    .collect()
            } else {
                Vec::new()
            },
            approach: with_approach.then(|| {
                (0..n)
                    .map(|i| self.approach_out[i * MAX_APPROACH..i * MAX_APPROACH + a].to_vec())
                    .collect()
            }),
            approach_info: ApproachInfo {
                method: last.approach.method,
                steps: a,
                duration_s: if a > 0 || last.approach.method != Method::None {
                    (a + 1) as f64 * problem.dt
                } else {
                    0.0
                },
                planning_time_s: last.approach_seconds,
                attempts: last.attempts,
                last_miss: last.last_miss.filter(|_| !solved),
            },
            stats: ran.stats,
        })
    }

    /// The core call alone (no allocation happens in it), until `until`: the status, the
    /// assignment and the counters; the paths are left in this storage, the approach too
    /// ([`Storage::last`]).
    pub fn solve_core(
        &mut self,
        kind: PlannerKind,
        problem: &Problem<DOF>,
        until: Until<'_>,
    ) -> Result<Ran, String> {
        let h = problem.horizon();
        if h > self.max_h {
            return Err(format!(
                "horizon {h} is longer than this storage was made for ({})",
                self.max_h
            ));
        }
        copy_problem(&mut self.problem, problem);
        let n = problem.robots.len();
        let settings = Settings {
            caps: self.caps,
            h,
            cbs: self.cbs_params,
            with_approach: self.with_approach,
        };
        let entry = table::entry(kind).map_err(|e| e.to_string())?;
        let mut cut = self.arena.cut();
        let approach = approach_storage(&mut cut, &self.caps).map_err(|e| e.to_string())?;
        let mut req = Embodiment {
            problem: &mut self.problem,
            until,
            out: Solution::new(&mut self.out),
            stats: Stats::default(),
            approach,
            // Robot `i`'s approach from `i * MAX_APPROACH`, as `Storage::solve` reads it.
            approach_out: &mut self.approach_out[..n * MAX_APPROACH],
            params: self.approach_params,
        };
        let last = (entry.run)(&mut cut, &settings, Some(&mut req))
            .map_err(|e| e.to_string())?
            .ok_or("the planner's entry did not run")?;
        let ran = Ran {
            status: last.status,
            assignment: req.out.assignment,
            stats: req.stats,
        };
        self.last = last;
        Ok(ran)
    }

    /// The longest horizon these pools plan.
    pub fn max_horizon(&self) -> usize {
        self.max_h
    }

    /// How the last [`Storage::solve_core`] ended: the approach (in this storage, robot `i`'s
    /// from index `i * MAX_APPROACH`), the planner runs, the last approach missed.
    pub fn last(&self) -> &Embodied {
        &self.last
    }
}

/// Pools kept from call to call, made anew (the old ones dropped first) when a problem with a
/// longer horizon comes: allocating them (tens of MB) costs more than planning a small
/// problem. Every caller that plans problem after problem (the benchmark's workers, Python's
/// `plan`) keeps one; with [`Storage::solve_core`]'s sizing rule the answer does not depend
/// on the horizon the pools were made for.
#[derive(Default)]
pub struct Pools(Option<Storage>);

impl Pools {
    /// Storage with the default capacities for horizons of at least `h`.
    pub fn for_horizon(&mut self, h: usize) -> &mut Storage {
        if self.0.as_ref().is_some_and(|s| s.max_horizon() < h) {
            self.0 = None;
        }
        self.0
            .get_or_insert_with(|| Storage::new(Capacities::default(), h))
    }
}

/// Copies `from` into `to` a part at a time (a whole problem is too large for a small stack).
fn copy_problem(to: &mut Problem<DOF>, from: &Problem<DOF>) {
    to.dt = from.dt;
    to.tolerance = from.tolerance;
    to.robots.clone_from(&from.robots);
    to.obstacles.clone_from(&from.obstacles);
    to.trajectories.clear();
    for t in &from.trajectories {
        // Capacities are the same, so nothing is dropped.
        if to.trajectories.push(heapless::Vec::new()).is_ok() {
            if let Some(last) = to.trajectories.last_mut() {
                let _ = last.extend_from_slice(t);
            }
        }
    }
}

/// How a core call ended (see [`Storage::solve_core`]).
#[derive(Clone, Copy, Debug)]
pub struct Ran {
    /// How planning ended.
    pub status: Status,
    /// Per robot, the trajectory it tracks (`None`: it holds), when solved.
    pub assignment: [Option<u8>; MAX_ROBOTS],
    /// The planner's counters over all its runs.
    pub stats: Stats,
}

/// A planner's counters as the solution file's `stats` object (docs/FORMATS.md).
pub fn stats_map(s: &Stats) -> serde_json::Map<String, serde_json::Value> {
    let mut stats = serde_json::Map::new();
    stats.insert("expansions".into(), s.expansions.into());
    stats.insert("low_level_calls".into(), s.low_level_calls.into());
    stats.insert("ct_nodes".into(), s.ct_nodes.into());
    stats.insert("conflicts_resolved".into(), s.conflicts_resolved.into());
    stats.insert("motion_conflicts".into(), s.motion_conflicts.into());
    stats.insert("warm_start_solved".into(), s.warm_start_solved.into());
    stats.insert("level".into(), s.level.into());
    if let Some(reason) = s.reason {
        stats.insert("reason".into(), reason.into());
    }
    stats.insert("inexact_branches".into(), s.inexact_branches.into());
    stats.insert("unbranched_nodes".into(), s.unbranched_nodes.into());
    stats
}

impl Outcome {
    /// The solution file of this outcome for `file`.
    pub fn to_solution_file(&self, file: &ProblemFile, planner: &str) -> SolutionFile {
        let (status, message) = match self.status {
            Status::Solved => (FileStatus::Solved, String::new()),
            Status::NoSolution => (
                FileStatus::NoSolution,
                self.stats
                    .reason
                    .unwrap_or("the search space was exhausted")
                    .to_string(),
            ),
            Status::Timeout => (
                FileStatus::Timeout,
                "the time limit was reached".to_string(),
            ),
            Status::OutOfMemory(pool) => (FileStatus::OutOfMemory, format!("{pool} is full")),
            Status::InvalidProblem(why) => (FileStatus::InvalidProblem, why.to_string()),
        };
        let message = match self.approach_info.last_miss {
            Some(miss) if status != FileStatus::Solved => {
                let names: Vec<String> = file.robots.iter().map(|r| r.name.clone()).collect();
                format!(
                    "{message}; after {} planner runs, the last approach tried: {}",
                    self.approach_info.attempts,
                    describe_miss(miss, &names)
                )
            }
            _ => message,
        };
        let mut stats = stats_map(&self.stats);
        let a = &self.approach_info;
        stats.insert("approach_method".into(), a.method.name().into());
        stats.insert("approach_steps".into(), a.steps.into());
        stats.insert("approach_duration_s".into(), a.duration_s.into());
        stats.insert(
            "approach_planning_time_ms".into(),
            (a.planning_time_s * 1e3).into(),
        );
        stats.insert("planner_runs".into(), a.attempts.into());
        SolutionFile {
            approach: (status == FileStatus::Solved)
                .then(|| self.approach.as_ref().map(|a| joint_paths_value(a)))
                .flatten(),
            format: SOLUTION_FORMAT.to_string(),
            problem: file.name.clone(),
            planner: planner.to_string(),
            status,
            message,
            planning_time_s: self.planning_time_s,
            assignment: if status == FileStatus::Solved {
                self.assignment.clone()
            } else {
                Vec::new()
            },
            joint_paths: (status == FileStatus::Solved)
                .then(|| joint_paths_value(&self.joint_paths)),
            stats,
        }
    }
}
