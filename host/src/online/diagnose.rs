//! Why a chunk has no plan, in words a user can act on: the first step at which following the
//! hands from where the arms are fails, the robot and hand there, and what blocks it (the
//! pose out of reach, a joint limit, a joint's speed, a collision and with what).
//!
//! The hands are followed by IK from each step's answer to the next, as the search's first
//! successor does; the search also turns the arms in their null spaces, so it may fail
//! later than this or, more rarely, earlier. The step found is where the plain way through
//! ends, which is where the user looks first.

use omcbsa_core::approach::{configurations_blocked, Blocked};
use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::model::Models;
use omcbsa_core::problem::{Assigned, Problem, MAX_ROBOTS};
use omcbsa_core::reach::tcp_reach;

use super::Setup;
use crate::approach::describe_touch;

/// A step at which a robot cannot go on.
#[derive(Clone, Debug, PartialEq)]
pub struct Blocking {
    pub robot: usize,
    /// The hand the robot holds (`None`: it holds still).
    pub hand: Option<usize>,
    /// The problem's step index.
    pub step: usize,
    pub what: String,
}

/// The first blocking step of `problem` (every robot with its assignment set and its
/// `initial` where it stands before step `first`); `what` names robots and obstacles as
/// `setup` does.
pub fn first_blocking<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    first: usize,
    setup: &Setup,
) -> Option<Blocking> {
    follow::<M, D>(problem, first, setup).err()
}

/// Follows the hands as [`first_blocking`] does: the configurations at the last step, or
/// where it is blocked.
pub fn follow<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    first: usize,
    setup: &Setup,
) -> Result<[[f64; D]; MAX_ROBOTS], Blocking> {
    let n = problem.robots.len();
    let mut q: [[f64; D]; MAX_ROBOTS] = core::array::from_fn(|i| {
        problem
            .robots
            .get(i)
            .and_then(|r| r.initial)
            .unwrap_or([0.0; D])
    });
    let params = IkParams::default();
    let hand_of = |i: usize| match problem.robots[i].assigned {
        Assigned::Track(j) => Some(usize::from(j)),
        _ => None,
    };
    for k in first..problem.horizon() {
        let prev = q;
        for (i, r) in problem.robots.iter().enumerate() {
            let Some(j) = hand_of(i) else { continue };
            let Some(pose) = problem.trajectories.get(j).and_then(|t| t.get(k)) else {
                continue;
            };
            let blocked = |what: String| Blocking {
                robot: i,
                hand: Some(j),
                step: k,
                what,
            };
            let far = (pose.pos - r.base.pos).norm();
            let reach = tcp_reach::<M, D>(r);
            if far > reach {
                return Err(blocked(format!(
                    "the hand's pose is {far:.3} m from the robot's base, beyond its reach of \
                     {reach:.3} m"
                )));
            }
            let target = r.base.inverse().compose(pose).compose(&r.tcp.inverse());
            let Ok(next) = ik::<M, D>(r.model, &target, &prev[i], &params) else {
                return Err(blocked(
                    "no configuration within the joint limits near the last one puts the hand \
                     there (a joint limit or the edge of the workspace)"
                        .to_string(),
                ));
            };
            let dt = problem.dt;
            let fast =
                (0..D).find(|&d| (next[d] - prev[i][d]).abs() > M::velocity(r.model)[d] * dt);
            if let Some(d) = fast {
                return Err(blocked(format!(
                    "joint {d} ({}) would turn at {:.2} rad/s, above its limit of {:.2} rad/s",
                    M::joint_names(r.model)[d],
                    (next[d] - prev[i][d]).abs() / dt,
                    M::velocity(r.model)[d]
                )));
            }
            q[i] = next;
        }
        if let Some(Blocked { robot, touch }) = configurations_blocked::<M, D>(problem, &q[..n]) {
            let what = format!(
                "it {}",
                describe_touch::<M, D>(
                    problem.robots[robot].model,
                    &setup.robots,
                    &setup.obstacles,
                    touch,
                    "at that step"
                )
            );
            return Err(Blocking {
                robot,
                hand: hand_of(robot),
                step: k,
                what,
            });
        }
    }
    Ok(q)
}
