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

use crate::approach::{
    blocked_alone, check_starts, plan_approach, Approach, ApproachError, ApproachParams,
    ApproachStorage,
};
use crate::model::Models;
use crate::planner::{Clock, Planner, Solution, Stats, Status, Until};
use crate::problem::{Problem, StartExclusions, MAX_ROBOTS};

/// Largest sample budget, as a multiple of [`ApproachParams::rrt_samples`].
pub const MAX_BUDGET_DOUBLINGS: u32 = 10;

/// How planning from where the arms stand ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Embodied {
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

/// Runs `planner` on `problem` and plans the approach from `initial` to its plan (when every
/// robot has `initial`), trying other starts until the deadline as the module says. The
/// approach goes to `approach_out` (robot `i` at `i * cap..`, `cap = len / robots`).
/// `problem`'s start exclusions are used while planning and restored before returning.
#[allow(clippy::too_many_arguments)]
pub fn solve_from_initial<M: Models<D>, P: Planner<M, D>, const D: usize>(
    planner: &mut P,
    problem: &mut Problem<D>,
    clock: &dyn Clock,
    timeout: f64,
    out: &mut Solution<'_, D>,
    storage: &mut ApproachStorage<'_, D>,
    approach_out: &mut [[f64; D]],
    params: &ApproachParams,
    stats: &mut Stats,
) -> Embodied {
    let mut done = Embodied {
        status: Status::Solved,
        approach: Approach::default(),
        attempts: 0,
        last_miss: None,
        approach_seconds: 0.0,
    };
    if check_starts::<M, D>(problem).is_err() {
        done.status = Status::InvalidProblem(
            "a robot's initial configuration is outside its limits or collides",
        );
        return done;
    }
    let n = problem.robots.len();
    let h = problem.horizon();
    let with_approach = n > 0 && problem.robots.iter().all(|r| r.initial.is_some());
    let saved: [StartExclusions<D>; MAX_ROBOTS] = core::array::from_fn(|i| {
        problem
            .robots
            .get(i)
            .map_or(StartExclusions::NONE, |r| r.excluded)
    });
    let restore = |problem: &mut Problem<D>| {
        for (r, s) in problem.robots.iter_mut().zip(&saved) {
            r.excluded = *s;
        }
    };
    let deadline = Until { clock, at: timeout };
    let mut round = 0u32;
    let mut excluding = false;
    loop {
        done.attempts += 1;
        let status = planner.solve(problem, clock, timeout, out, stats);
        if status == Status::NoSolution && excluding {
            // Nothing left under the exclusions: lift them, with a larger budget.
            restore(problem);
            excluding = false;
            round += 1;
            if round > MAX_BUDGET_DOUBLINGS {
                done.status = Status::OutOfMemory("approach sample budget");
                break;
            }
            continue;
        }
        if status != Status::Solved || !with_approach {
            done.status = status;
            break;
        }
        let p = ApproachParams {
            seed: params.seed.wrapping_add(u64::from(done.attempts)),
            ..*params
        };
        let samples = params.rrt_samples.saturating_mul(1 << round.min(31));
        let began = clock.seconds();
        let planned = plan_approach::<M, D>(
            problem,
            out.paths,
            h,
            &p,
            samples,
            storage,
            &deadline,
            approach_out,
        );
        done.approach_seconds += clock.seconds() - began;
        let miss = match planned {
            Ok(a) => {
                done.approach = a;
                break;
            }
            Err(e) => e,
        };
        done.last_miss = Some(miss);
        let ApproachError::Blocked { robot, other } = miss else {
            done.status = match miss {
                ApproachError::Timeout => Status::Timeout,
                ApproachError::OutOfMemory(pool) => Status::OutOfMemory(pool),
                ApproachError::TooLong { .. } => Status::OutOfMemory("approach buffer"),
                _ => Status::InvalidProblem("the approach could not be planned"),
            };
            break;
        };
        let began = clock.seconds();
        let alone = blocked_alone::<M, D>(problem, out.paths, h, &p, samples, storage, &deadline);
        done.approach_seconds += clock.seconds() - began;
        let alone = match alone {
            Ok(bits) => bits,
            Err(ApproachError::Timeout) => {
                done.status = Status::Timeout;
                break;
            }
            Err(ApproachError::OutOfMemory(pool)) => {
                done.status = Status::OutOfMemory(pool);
                break;
            }
            Err(_) => 0,
        };
        let blame = if alone != 0 {
            alone
        } else {
            (1u32 << robot) | other.map_or(0, |o| 1 << o)
        };
        let mut overflow = false;
        for i in (0..n).filter(|&i| blame & (1 << i) != 0) {
            let ex = &mut problem.robots[i].excluded;
            ex.radius = params.exclusion_radius;
            if !ex.push(out.paths[i * h]) {
                // This robot's room is full: start its list over, as a new round.
                *ex = saved[i];
                ex.radius = params.exclusion_radius;
                let _ = ex.push(out.paths[i * h]);
                overflow = true;
            }
        }
        if overflow {
            round += 1;
            if round > MAX_BUDGET_DOUBLINGS {
                done.status = Status::OutOfMemory("approach sample budget");
                break;
            }
        }
        excluding = true;
        if deadline.clock.seconds() >= timeout {
            done.status = Status::Timeout;
            break;
        }
    }
    restore(problem);
    done
}
