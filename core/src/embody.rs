//! Planning from where the arms stand: a planner's search and the approach to its plan
//! ([`crate::approach`]) as one search, so that a start the arms cannot reach is never the end
//! of it.
//!
//! The planner chooses every robot's first configuration, preferring those near `initial`
//! (Ω-A* counts the joint-space distance in a start's cost). When no approach to the chosen
//! starts is found, the robots to blame are found (those whose approach fails even alone, or
//! else the pair whose bridges first collide), their starts are excluded
//! ([`crate::problem::StartExclusions`], checked at step 0 by every planner's validity
//! checker) and the planner searches again: it picks the next-best starts or another
//! assignment. When the planner has nothing left under the exclusions, they are lifted and the
//! approach's sample budget doubles, so the whole is probabilistically complete as
//! RRT-Connect is. It ends with a plan and its approach, with the deadline (`Timeout`), when
//! the planner proves there is no plan even with every start allowed (`NoSolution`), or when
//! the sample budget reaches its cap (`OutOfMemory("approach sample budget")`).
//!
//! Deterministic: the planner and the approach are, and the deadline only ends the loop.
//!
//! Memory: the request's buffers only ([`Embodiment`]); the start exclusions live in the
//! problem's robots ([`crate::problem::StartExclusions`], a few per robot) and are restored
//! before returning.
//!
//! A Gen3 standing upright, its hand to follow in front of it:
//!
//! ```
//! use omcbsa_core::approach::{ApproachParams, ApproachStorage, Method};
//! use omcbsa_core::baselines::{IkTracking, IkTrackingParams};
//! use omcbsa_core::embody::{solve_from_initial, Embodiment};
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//! use omcbsa_core::planner::{NoClock, Solution, Stats, Status, Until};
//! use omcbsa_core::problem::{Problem, Robot, Trajectory};
//!
//! const H: usize = 3;
//! let mut problem = Problem::<7>::new(0.1);
//! let mut gen3 = Robot::at(0, Frame::IDENTITY);
//! gen3.initial = Some([0.0; 7]);
//! problem.robots.push(gen3).unwrap();
//! let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
//! problem.trajectories.push(Trajectory::from_slice(&[hand; H]).unwrap()).unwrap();
//!
//! let (mut tree, mut parent, mut waypoints) = ([[0.0; 7]; 64], [0u32; 64], [[0.0; 7]; 16]);
//! let (mut paths, mut approach) = ([[0.0; 7]; H], [[0.0; 7]; 64]);
//! let mut req = Embodiment {
//!     problem: &mut problem,
//!     until: Until::never(&NoClock),
//!     out: Solution::new(&mut paths),
//!     stats: Stats::default(),
//!     approach: ApproachStorage {
//!         tree: &mut tree,
//!         parent: &mut parent,
//!         waypoints: &mut waypoints,
//!     },
//!     approach_out: &mut approach,
//!     params: ApproachParams::default(),
//! };
//! let mut planner = IkTracking { params: IkTrackingParams::default() };
//! let done = solve_from_initial::<KinovaGen3, _, 7>(&mut planner, &mut req);
//! assert_eq!(done.status, Status::Solved);
//! assert_eq!((done.attempts, done.approach.method), (1, Method::Together));
//! // The timeline: `initial`, the approach, then the plan, every step within the speeds.
//! let a = done.approach.len;
//! let mut last = [0.0; 7];
//! for q in approach[..a].iter().chain(&paths) {
//!     for j in 0..7 {
//!         assert!((q[j] - last[j]).abs() <= KinovaGen3::VELOCITY[j] * 0.1 + 1e-12);
//!     }
//!     last = *q;
//! }
//! ```

use crate::approach::{
    blocked_alone, check_starts, plan_approach, Approach, ApproachError, ApproachParams,
    ApproachQuery, ApproachStorage,
};
use crate::model::Models;
use crate::planner::{Planner, Request, Solution, Stats, Status, Until};
use crate::problem::{Problem, StartExclusions, MAX_ROBOTS};
use crate::search::Deadline;

/// Largest sample budget, as a multiple of [`ApproachParams::rrt_samples`].
pub const MAX_BUDGET_DOUBLINGS: u32 = 10;

/// A request to plan from where the arms stand: a planner's [`Request`] whose problem may be
/// annotated while planning (start exclusions, restored before [`solve_from_initial`]
/// returns), with the approach's storage, buffer and tunables.
pub struct Embodiment<'r, const D: usize> {
    /// The problem definition.
    pub problem: &'r mut Problem<D>,
    /// The termination condition, for the planner and the approach alike.
    pub until: Until<'r>,
    /// The plan, in the caller's storage.
    pub out: Solution<'r, D>,
    /// Counters, summed over the planner's runs.
    pub stats: Stats,
    /// The approach planners' storage.
    pub approach: ApproachStorage<'r, D>,
    /// Where the approach goes: robot `i`'s at `i * cap..`, `cap = len / robots`.
    pub approach_out: &'r mut [[f64; D]],
    /// The approach's tunables (its first sample budget and seed).
    pub params: ApproachParams,
}

/// How planning from where the arms stand ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Embodied {
    /// How it ended.
    pub status: Status,
    /// The approach written (meaningful when solved).
    pub approach: Approach,
    /// Planner runs (1 when the first plan's approach was found).
    pub attempts: u32,
    /// Why the last approach tried failed, if one did.
    pub last_miss: Option<ApproachError>,
    /// Seconds on the clock spent planning approaches (and finding whom to blame).
    pub approach_seconds: f64,
}

impl Embodied {
    /// Ended with `status` before any approach was tried.
    pub fn ended(status: Status, attempts: u32) -> Self {
        Embodied {
            status,
            approach: Approach::default(),
            attempts,
            last_miss: None,
            approach_seconds: 0.0,
        }
    }
}

/// Runs `planner` on the request's problem and plans the approach from `initial` to its plan
/// (when every robot has `initial`), trying other starts until the deadline as the module
/// says.
pub fn solve_from_initial<M: Models<D>, P: Planner<M, D>, const D: usize>(
    planner: &mut P,
    req: &mut Embodiment<'_, D>,
) -> Embodied {
    let mut done = Embodied::ended(Status::Solved, 0);
    if check_starts::<M, D>(req.problem).is_err() {
        done.status = Status::InvalidProblem(
            "a robot's initial configuration is outside its limits or collides",
        );
        return done;
    }
    let n = req.problem.robots.len();
    let h = req.problem.horizon();
    let with_approach = n > 0 && req.problem.robots.iter().all(|r| r.initial.is_some());
    let saved: [StartExclusions<D>; MAX_ROBOTS] = core::array::from_fn(|i| {
        (req.problem.robots.get(i)).map_or(StartExclusions::NONE, |r| r.excluded)
    });
    let restore = |problem: &mut Problem<D>| {
        for (r, s) in problem.robots.iter_mut().zip(&saved) {
            r.excluded = *s;
        }
    };
    let params = req.params;
    let mut round = 0u32;
    let mut excluding = false;
    loop {
        done.attempts += 1;
        let status = run_planner::<M, P, D>(planner, req);
        if status == Status::NoSolution && excluding {
            // Nothing left under the exclusions: lift them, with a larger budget.
            restore(req.problem);
            excluding = false;
            if !next_round(&mut round) {
                done.status = Status::OutOfMemory("approach sample budget");
                break;
            }
            continue;
        }
        if status != Status::Solved || !with_approach {
            done.status = status;
            break;
        }
        let q = ApproachQuery {
            problem: &*req.problem,
            plan: &*req.out.paths,
            horizon: h,
            params: ApproachParams {
                seed: params.seed.wrapping_add(u64::from(done.attempts)),
                rrt_samples: params.rrt_samples.saturating_mul(1 << round.min(31)),
                ..params
            },
            deadline: &req.until,
        };
        let began = req.until.now();
        let planned = plan_approach::<M, D>(&q, &mut req.approach, req.approach_out);
        done.approach_seconds += req.until.now() - began;
        let miss = match planned {
            Ok(a) => {
                done.approach = a;
                break;
            }
            Err(e) => e,
        };
        done.last_miss = Some(miss);
        let ApproachError::Blocked { robot, other } = miss else {
            done.status = approach_failed(miss);
            break;
        };
        let began = req.until.now();
        let alone = blocked_alone::<M, D>(&q, &mut req.approach);
        done.approach_seconds += req.until.now() - began;
        let alone = match alone {
            Ok(bits) => bits,
            Err(e @ (ApproachError::Timeout | ApproachError::OutOfMemory(_))) => {
                done.status = approach_failed(e);
                break;
            }
            Err(_) => 0,
        };
        let blame = if alone != 0 {
            alone
        } else {
            (1u32 << robot) | other.map_or(0, |o| 1 << o)
        };
        let (paths, radius) = (&*req.out.paths, params.exclusion_radius);
        let overflow = exclude_starts(req.problem, paths, h, blame, &saved, radius);
        if overflow && !next_round(&mut round) {
            done.status = Status::OutOfMemory("approach sample budget");
            break;
        }
        excluding = true;
        if req.until.expired() {
            done.status = Status::Timeout;
            break;
        }
    }
    restore(req.problem);
    done
}

/// The next round of [`solve_from_initial`]: the sample budget doubled; false past
/// [`MAX_BUDGET_DOUBLINGS`].
fn next_round(round: &mut u32) -> bool {
    *round += 1;
    *round <= MAX_BUDGET_DOUBLINGS
}

/// What an approach that could not be planned, for a reason other than a blocked arm, ends
/// the solve with.
fn approach_failed(miss: ApproachError) -> Status {
    match miss {
        ApproachError::Timeout => Status::Timeout,
        ApproachError::OutOfMemory(pool) => Status::OutOfMemory(pool),
        ApproachError::TooLong { .. } => Status::OutOfMemory("approach buffer"),
        _ => Status::InvalidProblem("the approach could not be planned"),
    }
}

/// Excludes, for each robot in the bit set `blame`, its planned start (`paths[i * h]`) within
/// `radius`. A robot whose room is full starts its list over from `saved` (the caller's
/// exclusions): then true, and the caller starts a new round.
fn exclude_starts<const D: usize>(
    problem: &mut Problem<D>,
    paths: &[[f64; D]],
    h: usize,
    blame: u32,
    saved: &[StartExclusions<D>],
    radius: f64,
) -> bool {
    let mut overflow = false;
    let n = problem.robots.len();
    for i in (0..n).filter(|&i| blame & (1 << i) != 0) {
        let start = paths[i * h];
        let ex = &mut problem.robots[i].excluded;
        ex.radius = radius;
        if !ex.push(start) {
            // This robot's room is full: start its list over, as a new round.
            *ex = saved[i];
            ex.radius = radius;
            let _ = ex.push(start);
            overflow = true;
        }
    }
    overflow
}

/// One run of the planner on the problem as it stands, into the request's storage; its
/// counters are added to the request's.
pub fn run_planner<M: Models<D>, P: Planner<M, D>, const D: usize>(
    planner: &mut P,
    req: &mut Embodiment<'_, D>,
) -> Status {
    let mut run = Request {
        problem: &*req.problem,
        until: req.until,
        out: Solution::new(&mut *req.out.paths),
        stats: req.stats,
    };
    let status = planner.solve(&mut run);
    req.stats = run.stats;
    req.out.assignment = run.out.assignment;
    status
}
