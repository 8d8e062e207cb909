//! The one interface every planner implements (Ω-CBSA, the prioritised planners and the
//! baselines), in OMPL's vocabulary: a problem definition ([`Problem`]), a planner, a
//! termination condition ([`Clock`] + timeout) and a solution written to caller storage.

use crate::model::Model;
use crate::problem::{Assigned, Problem, Start, MAX_ROBOTS};
use crate::search::Deadline;

/// Time since planning started, in seconds. The core has no clock of its own: the host passes
/// `std::time::Instant`, a microcontroller its cycle counter.
pub trait Clock {
    fn seconds(&self) -> f64;
}

/// A clock that never advances: planning ends only by success or exhaustion.
pub struct NoClock;

impl Clock for NoClock {
    fn seconds(&self) -> f64 {
        0.0
    }
}

/// "Stop when `clock` reaches `at`."
pub struct Until<'c> {
    pub clock: &'c dyn Clock,
    pub at: f64,
}

impl Deadline for Until<'_> {
    fn expired(&self) -> bool {
        self.clock.seconds() >= self.at
    }
}

/// How planning ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Solved,
    /// The search space was exhausted.
    NoSolution,
    Timeout,
    /// A bounded pool was exhausted; the message names it.
    OutOfMemory(&'static str),
    /// The problem cannot be planned; the message says why.
    InvalidProblem(&'static str),
}

/// Counters a planner reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Ω-A* (or roadmap / composite) node expansions.
    pub expansions: u64,
    /// Single-robot planner calls.
    pub low_level_calls: u32,
    /// Constraint-tree nodes generated (Ω-CBSA).
    pub ct_nodes: u32,
    /// Conflicts branched on (Ω-CBSA).
    pub conflicts_resolved: u32,
    /// Ω-CBSA: of `conflicts_resolved`, the motion conflicts (two arms meeting between steps
    /// and at neither step), branched on a point both hold at one instant of the motion.
    pub motion_conflicts: u32,
    /// Whether the root of Ω-CBSA's last constraint tree (warm-started by repeated IK
    /// tracking) had no conflicts.
    pub warm_start_solved: bool,
    /// The refinement level the answer came from (see [`crate::search::refine`]): the one
    /// that solved, or the last one searched.
    pub level: u8,
    /// Why the planner ended without a plan, when it ended by proof (`NoSolution`).
    pub reason: Option<&'static str>,
    /// Ω-CBSA: conflicts branched on with constraints that are not mutually disjunctive (no
    /// instant with the two arms overlapping was found within the sweep's tolerance), so the
    /// completeness guarantee does not cover that branching.
    pub inexact_branches: u32,
    /// Ω-CBSA: constraint-tree nodes with counted conflicts and no conflict to branch on,
    /// left unexpanded (reported here, never reported as solved).
    pub unbranched_nodes: u32,
}

/// Where a planner writes its answer. `paths` holds robot `i`'s configuration at step `t` at
/// index `i * H + t`, so it must hold `robots * H` configurations.
pub struct Solution<'a, const D: usize> {
    /// Trajectory tracked by each robot; `None` for a robot that holds its initial
    /// configuration.
    pub assignment: [Option<u8>; MAX_ROBOTS],
    pub paths: &'a mut [[f64; D]],
}

impl<'a, const D: usize> Solution<'a, D> {
    pub fn new(paths: &'a mut [[f64; D]]) -> Self {
        Solution {
            assignment: [None; MAX_ROBOTS],
            paths,
        }
    }

    /// Robot `i`'s path for a horizon of `h` steps.
    pub fn path(&self, i: usize, h: usize) -> &[[f64; D]] {
        &self.paths[i * h..(i + 1) * h]
    }
}

/// A multi-robot planner for model `M`.
pub trait Planner<M: Model<D>, const D: usize> {
    /// The name used on the command line and in benchmark tables.
    fn name(&self) -> &'static str;

    /// Plans `problem` until solved, exhausted, out of memory or `timeout` seconds on `clock`.
    fn solve(
        &mut self,
        problem: &Problem<D>,
        clock: &dyn Clock,
        timeout: f64,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Status;
}

/// Checks that `problem` fits the planners' assumptions and `out` can hold the answer.
pub fn check_problem<const D: usize>(
    problem: &Problem<D>,
    out: &Solution<'_, D>,
) -> Result<usize, Status> {
    let h = problem.horizon();
    if h == 0 {
        return Err(Status::InvalidProblem("no trajectory or empty trajectory"));
    }
    if problem.trajectories.iter().any(|t| t.len() != h) {
        return Err(Status::InvalidProblem("trajectories differ in length"));
    }
    if problem.trajectories.len() > problem.robots.len() {
        return Err(Status::InvalidProblem("more trajectories than robots"));
    }
    if problem.trajectories.len() < problem.robots.len()
        && problem.robots.iter().any(|r| r.initial.is_none())
    {
        // Some robot must hold, and any of them may be the one.
        return Err(Status::InvalidProblem(
            "fewer trajectories than robots: every robot needs an initial configuration",
        ));
    }
    check_online(problem)?;
    if out.paths.len() < problem.robots.len() * h {
        return Err(Status::OutOfMemory("solution path buffer"));
    }
    // Negated so that NaN is refused too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(problem.dt > 0.0) {
        return Err(Status::InvalidProblem("dt must be positive"));
    }
    Ok(h)
}

/// Checks the robots' fixed starts and fixed assignment: a start at `initial` or a hold needs
/// `initial`; fixed trajectories exist, are taken once, and when every robot's part is fixed,
/// every trajectory is taken.
fn check_online<const D: usize>(problem: &Problem<D>) -> Result<(), Status> {
    let mut taken = 0u32;
    for r in &problem.robots {
        if r.initial.is_none() && (r.start == Start::AtInitial || r.assigned == Assigned::Hold) {
            return Err(Status::InvalidProblem(
                "a robot that starts at or holds its initial configuration needs one",
            ));
        }
        if let Assigned::Track(j) = r.assigned {
            if usize::from(j) >= problem.trajectories.len() {
                return Err(Status::InvalidProblem(
                    "fixed assignment to no such trajectory",
                ));
            }
            if taken & (1 << j) != 0 {
                return Err(Status::InvalidProblem(
                    "fixed assignment gives a trajectory twice",
                ));
            }
            taken |= 1 << j;
        }
    }
    let all_fixed = problem.robots.iter().all(|r| r.assigned != Assigned::Free);
    if all_fixed && taken.count_ones() as usize != problem.trajectories.len() {
        return Err(Status::InvalidProblem(
            "fixed assignment leaves a trajectory untracked",
        ));
    }
    Ok(())
}

/// For the planners that choose every start state and the whole assignment themselves (the
/// baselines): refuses a problem with a robot whose start or trajectory is fixed.
pub fn check_free<const D: usize>(problem: &Problem<D>) -> Result<(), Status> {
    if problem
        .robots
        .iter()
        .any(|r| r.start != Start::Sampled || r.assigned != Assigned::Free)
    {
        return Err(Status::InvalidProblem(
            "this planner cannot start robots at given configurations or keep an assignment",
        ));
    }
    Ok(())
}
