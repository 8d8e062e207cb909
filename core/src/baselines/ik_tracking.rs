//! IK tracking, the standard practical pipeline: for every assignment, robots in turn take an
//! IK solution of their first pose from random seeds and track the rest by IK from the
//! previous configuration, avoiding the robots placed before them; the next assignment on
//! failure.

use crate::ik::IkParams;
use crate::model::Models;
use crate::planner::{open, Clock, Planner, PlannerKind, Solution, Stats, Status, Takes, Until};
use crate::pp::Orders;
use crate::problem::{Problem, MAX_ROBOTS};
use crate::rng::Rng;
use crate::search::{Deadline, OtherArm, OthersMode, Validity};
use crate::tracking::{track, Steps};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkTrackingParams {
    /// First-pose seeds tried per robot (the first is `initial` when given).
    pub seeds: u32,
    pub ik: IkParams,
    /// See [`crate::search::OmegaParams::motion_step`].
    pub motion_step: f64,
    pub seed: u64,
}

impl Default for IkTrackingParams {
    fn default() -> Self {
        IkTrackingParams {
            seeds: 10,
            ik: IkParams::default(),
            motion_step: crate::motion::MOTION_STEP,
            seed: 0x5eed,
        }
    }
}

pub struct IkTracking {
    pub params: IkTrackingParams,
}

impl<M: Models<D>, const D: usize> Planner<M, D> for IkTracking {
    fn name(&self) -> &'static str {
        PlannerKind::IkTracking.name()
    }

    fn solve(
        &mut self,
        problem: &Problem<D>,
        clock: &dyn Clock,
        timeout: f64,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Status {
        let h = match open::<M, D>(problem, out, Takes::FreeOnly, stats) {
            Ok(h) => h,
            Err(s) => return s,
        };
        let deadline = Until { clock, at: timeout };
        // Every assignment once; the priority order is always the robots' order.
        let n = problem.robots.len();
        let mut orders = Orders::new(n, problem.trajectories.len(), true);
        loop {
            if deadline.expired() {
                return Status::Timeout;
            }
            if self.attempt::<M, D>(problem, h, &orders, &deadline, out, stats) {
                return Status::Solved;
            }
            if !orders.next_assignment() {
                return Status::NoSolution;
            }
        }
    }
}

impl IkTracking {
    fn attempt<M: Models<D>, const D: usize>(
        &self,
        problem: &Problem<D>,
        h: usize,
        orders: &Orders,
        deadline: &Until<'_>,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> bool {
        for r in 0..problem.robots.len() {
            let robot = problem.robots[r];
            let (done, rest) = out.paths.split_at_mut(r * h);
            let mut others: heapless::Vec<OtherArm<'_, D>, MAX_ROBOTS> = heapless::Vec::new();
            for k in 0..r {
                let _ = others.push(OtherArm {
                    model: problem.robots[k].model,
                    base: problem.robots[k].base,
                    tool: problem.robots[k].tool,
                    path: &done[k * h..(k + 1) * h],
                });
            }
            let valid = Validity::<M, D>::new(
                robot.model,
                robot.base,
                robot.tool,
                &problem.obstacles,
                &others,
                OthersMode::Avoid,
                &[],
                problem.dt,
                self.params.motion_step,
            )
            .excluding(robot.excluded);
            let path = &mut rest[..h];
            stats.low_level_calls += 1;
            let ok = match orders.trajectory_of(r) {
                Some(j) => {
                    let mut rng = Rng::new(self.params.seed ^ ((r as u64) << 32 | j as u64));
                    (0..self.params.seeds).any(|attempt| {
                        if deadline.expired() {
                            return false;
                        }
                        let seed = match (attempt, robot.initial) {
                            (0, Some(init)) => init,
                            _ => rng.configuration(M::lower(robot.model), M::upper(robot.model)),
                        };
                        track::<M, D>(
                            &robot,
                            &problem.trajectories[j],
                            &seed,
                            &valid,
                            Steps::Nearest(&self.params.ik),
                            path,
                        )
                        .is_some()
                    })
                }
                None => match robot.initial {
                    Some(init) => {
                        path.iter_mut().for_each(|q| *q = init);
                        valid.hold(&init, h).is_some()
                    }
                    None => false,
                },
            };
            if !ok {
                return false;
            }
            out.assignment[r] = orders.trajectory_of(r).map(|j| j as u8);
        }
        true
    }
}
