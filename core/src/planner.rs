//! The one interface every planner implements (Ω-CBSA, the prioritised planners and the
//! baselines), in OMPL's vocabulary: a problem definition ([`Problem`]), a termination
//! condition ([`Until`]: a [`Clock`] and the time to stop), a planner, and a [`Request`] that
//! carries the problem, the deadline, the caller's storage for the answer ([`Solution`]) and
//! the counters. A planner holds its own parameters and pools; [`Planner::solve`] opens every
//! request the same way (the checks of [`open`]) before the planner's own [`Planner::plan`].
//!
//! ```
//! use omcbsa_core::baselines::{IkTracking, IkTrackingParams};
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//! use omcbsa_core::planner::{NoClock, Planner, Request, Solution, Status, Until};
//! use omcbsa_core::problem::{Problem, Robot, Trajectory};
//!
//! // One Gen3 holding its hand still where it is at the zero configuration.
//! let hand = KinovaGen3::fk(&[0.0; 7]);
//! let mut problem = Problem::<7>::new(0.02);
//! problem.robots.push(Robot::at(0, Frame::IDENTITY)).unwrap();
//! problem.trajectories.push(Trajectory::from_slice(&[hand; 4]).unwrap()).unwrap();
//!
//! let mut paths = [[0.0; 7]; 4];
//! let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
//! let mut planner = IkTracking { params: IkTrackingParams::default() };
//! assert_eq!(Planner::<KinovaGen3, 7>::solve(&mut planner, &mut req), Status::Solved);
//! assert_eq!(req.out.assignment[0], Some(0));
//! ```

use crate::model::Models;
use crate::problem::{Assigned, Problem, Start, MAX_ROBOTS};
use crate::reach::{unreachable_trajectory, UNREACHABLE};
use crate::search::Deadline;

/// Time since planning started, in seconds. The core has no clock of its own: the host passes
/// `std::time::Instant`, a microcontroller its cycle counter.
pub trait Clock {
    /// Seconds since the clock's start.
    fn seconds(&self) -> f64;
}

/// A clock that never advances: planning ends only by success or exhaustion.
pub struct NoClock;

impl Clock for NoClock {
    fn seconds(&self) -> f64 {
        0.0
    }
}

/// The termination condition of a request: "stop when `clock` reaches `at`". Made once by the
/// caller and copied, never rebuilt, by every search under it.
///
/// ```
/// use omcbsa_core::planner::{Clock, Until};
/// use omcbsa_core::search::Deadline;
///
/// /// A clock stopped at a given time (a microcontroller would read its cycle counter).
/// struct Stopped(f64);
/// impl Clock for Stopped {
///     fn seconds(&self) -> f64 {
///         self.0
///     }
/// }
///
/// let clock = Stopped(2.0);
/// assert!(Until::new(&clock, 1.5).expired());
/// assert!(!Until::new(&clock, 3.0).expired());
/// assert!(!Until::never(&clock).expired());
/// ```
#[derive(Clone, Copy)]
pub struct Until<'c> {
    /// The clock read.
    pub clock: &'c dyn Clock,
    /// Seconds on `clock` at which planning stops.
    pub at: f64,
}

impl<'c> Until<'c> {
    /// Stop when `clock` reaches `at` seconds.
    pub fn new(clock: &'c dyn Clock, at: f64) -> Self {
        Until { clock, at }
    }

    /// No deadline: planning ends only by success, exhaustion or a full pool.
    pub fn never(clock: &'c dyn Clock) -> Self {
        Until {
            clock,
            at: f64::INFINITY,
        }
    }

    /// Seconds on the clock now.
    pub fn now(&self) -> f64 {
        self.clock.seconds()
    }
}

impl Deadline for Until<'_> {
    fn expired(&self) -> bool {
        self.clock.seconds() >= self.at
    }
}

/// How planning ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// A plan was written to the request's [`Solution`]: every robot within its joint limits
    /// and speeds, tracking its trajectory within the tolerance, and collision-free.
    Solved,
    /// The search space was exhausted (or a trajectory is out of every robot's reach):
    /// [`Stats::reason`] says which.
    NoSolution,
    /// The request's [`Until`] passed first.
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
    /// The robots' paths, robot after robot (the caller's storage).
    pub paths: &'a mut [[f64; D]],
}

impl<'a, const D: usize> Solution<'a, D> {
    /// An empty answer written into `paths`.
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

/// One planning request: what to plan, until when, where the answer goes, and the counters
/// the planner adds to. Every planner's [`Planner::solve`] takes one.
pub struct Request<'r, const D: usize> {
    /// The problem definition.
    pub problem: &'r Problem<D>,
    /// The termination condition.
    pub until: Until<'r>,
    /// The answer, in the caller's storage.
    pub out: Solution<'r, D>,
    /// Counters; a planner adds to them, so one `Stats` can count several requests.
    pub stats: Stats,
}

impl<'r, const D: usize> Request<'r, D> {
    /// A request with zeroed counters.
    pub fn new(problem: &'r Problem<D>, until: Until<'r>, out: Solution<'r, D>) -> Self {
        Request {
            problem,
            until,
            out,
            stats: Stats::default(),
        }
    }
}

/// The horizon of a request [`open`] checked: only `open` makes one, so a planner's
/// [`Planner::plan`] cannot run on an unchecked request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Horizon(usize);

impl Horizon {
    /// Steps of every trajectory.
    pub fn get(self) -> usize {
        self.0
    }
}

/// The planners, by the names the command line, the benchmark, Python and the online runner
/// use: the one list of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlannerKind {
    /// Ω-CBSA ([`crate::cbs::OmegaCbsa`]).
    OmCbsa,
    /// OM-PP-A* ([`crate::pp::Prioritized`], [`crate::pp::Variant::MultiGoal`]).
    Pp,
    /// OM-PP-A*_single ([`crate::pp::Prioritized`], [`crate::pp::Variant::SingleGoal`]).
    PpSingle,
    /// IK tracking ([`crate::baselines::IkTracking`]).
    IkTracking,
    /// PP-Descartes ([`crate::baselines::Descartes`]).
    Descartes,
    /// Composite A* ([`crate::baselines::CompositeAstar`]).
    CompositeAstar,
    /// Ω-A* alone ([`crate::search::plan`]; one robot).
    OmegaAstar,
}

impl PlannerKind {
    /// The planner used where none is named: Ω-CBSA.
    pub const DEFAULT: PlannerKind = PlannerKind::OmCbsa;

    /// Every planner.
    pub const ALL: [PlannerKind; 7] = [
        PlannerKind::OmCbsa,
        PlannerKind::Pp,
        PlannerKind::PpSingle,
        PlannerKind::IkTracking,
        PlannerKind::Descartes,
        PlannerKind::CompositeAstar,
        PlannerKind::OmegaAstar,
    ];

    /// The planners of several robots, which the benchmark runs by default: all but the last
    /// of [`PlannerKind::ALL`] (Ω-A* alone plans one robot).
    pub const BENCH: [PlannerKind; 6] = {
        let mut bench = [PlannerKind::OmCbsa; 6];
        let mut i = 0;
        while i < bench.len() {
            bench[i] = Self::ALL[i];
            i += 1;
        }
        bench
    };

    /// The planner's name (`omcbsa`, `pp`, `pp-single`, ...), as [`PlannerKind::parse`]
    /// reads it.
    ///
    /// ```
    /// use omcbsa_core::planner::PlannerKind;
    ///
    /// assert_eq!(PlannerKind::DEFAULT.name(), "omcbsa");
    /// assert_eq!(PlannerKind::parse("pp-single"), Some(PlannerKind::PpSingle));
    /// assert_eq!(PlannerKind::parse("rrt"), None);
    /// for p in PlannerKind::ALL {
    ///     assert_eq!(PlannerKind::parse(p.name()), Some(p));
    /// }
    /// ```
    pub const fn name(self) -> &'static str {
        match self {
            PlannerKind::OmCbsa => "omcbsa",
            PlannerKind::Pp => "pp",
            PlannerKind::PpSingle => "pp-single",
            PlannerKind::IkTracking => "ik-tracking",
            PlannerKind::Descartes => "descartes",
            PlannerKind::CompositeAstar => "composite-astar",
            PlannerKind::OmegaAstar => "omega-astar",
        }
    }

    /// One line on what the planner does.
    pub const fn description(self) -> &'static str {
        match self {
            PlannerKind::OmCbsa => {
                "Ω-CBSA: conflict-based search with assignments over multi-goal Ω-A* (complete)"
            }
            PlannerKind::Pp => "OM-PP-A*: prioritised planning with multi-goal Ω-A* per robot",
            PlannerKind::PpSingle => {
                "OM-PP-A*_single: prioritised planning, one goal state per robot (baseline)"
            }
            PlannerKind::IkTracking => {
                "IK tracking: each robot follows its trajectory by IK from the last step (baseline)"
            }
            PlannerKind::Descartes => {
                "PP-Descartes: prioritised layered roadmaps of IK samples per pose (baseline)"
            }
            PlannerKind::CompositeAstar => {
                "composite A*: A* on all robots' null-space moves at once (baseline)"
            }
            PlannerKind::OmegaAstar => "Ω-A*: on-manifold A* for a single robot",
        }
    }

    /// The planner called `name` ([`PlannerKind::name`]), `None` for any other text.
    pub fn parse(name: &str) -> Option<PlannerKind> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }

    /// Whether the planner plans exactly one robot.
    pub const fn single_robot(self) -> bool {
        matches!(self, PlannerKind::OmegaAstar)
    }
}

impl Default for PlannerKind {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl core::fmt::Display for PlannerKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// A multi-robot planner for the models `M`: it holds its parameters and pools; a request
/// brings the rest.
pub trait Planner<M: Models<D>, const D: usize> {
    /// The problems it takes, checked by [`Planner::solve`] before it plans.
    const TAKES: Takes;

    /// Which planner this is (its name on the command line and in benchmark tables).
    fn kind(&self) -> PlannerKind;

    /// Plans a request [`open`] accepted, until solved, exhausted, out of memory or past
    /// `req.until`.
    fn plan(&mut self, req: &mut Request<'_, D>, h: Horizon) -> Status;

    /// Checks `req` as every planner must ([`open`]), then plans it.
    fn solve(&mut self, req: &mut Request<'_, D>) -> Status {
        match open::<M, D>(req, Self::TAKES) {
            Ok(h) => self.plan(req, h),
            Err(status) => status,
        }
    }
}

/// What a planner takes, for [`open`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Takes {
    /// Robots started at given configurations and fixed assignments (the online runner's).
    Fixed,
    /// Only robots whose start and assignment the planner chooses (the baselines).
    FreeOnly,
}

/// The opening of every planner's `solve`: the problem fits the planners' assumptions (and
/// the planner's, `takes`), the request's storage can hold the answer, and no trajectory has a
/// pose out of every robot's reach (a proof that nothing solves it: `NoSolution`, with the
/// reason in the request's stats). Returns the horizon, or the status to return.
///
/// Bad input is a status that says what is wrong, never a panic:
///
/// ```
/// use omcbsa_core::model::{Frame, KinovaGen3, Model};
/// use omcbsa_core::planner::{open, NoClock, Request, Solution, Status, Takes, Until};
/// use omcbsa_core::problem::{Problem, Robot, Trajectory};
///
/// let hand = KinovaGen3::fk(&[0.0; 7]);
/// let mut problem = Problem::<7>::new(0.1);
/// problem.robots.push(Robot::at(0, Frame::IDENTITY)).unwrap();
/// problem.trajectories.push(Trajectory::from_slice(&[hand; 3]).unwrap()).unwrap();
///
/// // Room for 3 configurations: enough for one robot over 3 steps.
/// let mut paths = [[0.0; 7]; 3];
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// assert_eq!(open::<KinovaGen3, 7>(&mut req, Takes::Fixed).map(|h| h.get()), Ok(3));
///
/// // Too little storage for the answer.
/// let mut short = [[0.0; 7]; 2];
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut short));
/// let refused = open::<KinovaGen3, 7>(&mut req, Takes::Fixed);
/// assert_eq!(refused, Err(Status::OutOfMemory("solution path buffer")));
///
/// // A time step that is not positive.
/// problem.dt = f64::NAN;
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// let refused = open::<KinovaGen3, 7>(&mut req, Takes::Fixed);
/// assert_eq!(refused, Err(Status::InvalidProblem("dt must be positive")));
/// ```
pub fn open<M: Models<D>, const D: usize>(
    req: &mut Request<'_, D>,
    takes: Takes,
) -> Result<Horizon, Status> {
    if takes == Takes::FreeOnly {
        check_free(req.problem)?;
    }
    let h = check_problem(req.problem, &req.out)?;
    if unreachable_trajectory::<M, D>(req.problem).is_some() {
        req.stats.reason = Some(UNREACHABLE);
        return Err(Status::NoSolution);
    }
    Ok(Horizon(h))
}

/// Checks that `problem` fits the planners' assumptions and `out` can hold the answer.
fn check_problem<const D: usize>(
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
fn check_free<const D: usize>(problem: &Problem<D>) -> Result<(), Status> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planner_names_parse_back_and_are_distinct() {
        for (i, p) in PlannerKind::ALL.iter().enumerate() {
            assert_eq!(PlannerKind::parse(p.name()), Some(*p));
            assert!(!p.description().is_empty());
            assert!(PlannerKind::ALL[..i].iter().all(|q| q.name() != p.name()));
        }
        assert_eq!(PlannerKind::parse("fast"), None);
        // The bench runs every planner of several robots.
        let single: [PlannerKind; 1] = [PlannerKind::OmegaAstar];
        for p in PlannerKind::ALL {
            assert_eq!(PlannerKind::BENCH.contains(&p), !single.contains(&p));
            assert_eq!(p.single_robot(), single.contains(&p));
        }
    }
}
