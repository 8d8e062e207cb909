//! IK tracking, the standard practical pipeline: for every assignment, robots in turn take an
//! IK solution of their first pose from random seeds and track the rest by IK from the
//! previous configuration, avoiding the robots placed before them; the next assignment on
//! failure.

use crate::ik::IkParams;
use crate::model::Models;
use crate::planner::{Horizon, Planner, PlannerKind, Request, Status, Takes};
use crate::pp::Orders;
use crate::problem::MAX_ROBOTS;
use crate::rng::Rng;
use crate::search::{Deadline, OtherArm, OthersMode, Validity};
use crate::tracking::{track, Steps};

/// Tunables of the IK-tracking baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkTrackingParams {
    /// First-pose seeds tried per robot (the first is `initial` when given).
    pub seeds: u32,
    /// The IK projection's settings.
    pub ik: IkParams,
    /// See [`crate::search::OmegaParams::motion_step`].
    pub motion_step: f64,
    /// Seed of the random first-pose seeds.
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

/// The IK-tracking baseline: no storage of its own (it writes the request's paths only), no
/// search; fast and myopic. It chooses every start and the assignment itself, so it refuses a
/// problem with a robot whose start or trajectory is fixed
/// ([`crate::planner::Takes::FreeOnly`]). The [`crate::planner`] module's example runs it.
pub struct IkTracking {
    /// Its settings.
    pub params: IkTrackingParams,
}

impl<M: Models<D>, const D: usize> Planner<M, D> for IkTracking {
    const TAKES: Takes = Takes::FreeOnly;

    fn kind(&self) -> PlannerKind {
        PlannerKind::IkTracking
    }

    fn plan(&mut self, req: &mut Request<'_, D>, h: Horizon) -> Status {
        let (problem, h) = (req.problem, h.get());
        // Every assignment once; the priority order is always the robots' order.
        let n = problem.robots.len();
        let mut orders = Orders::new(n, problem.trajectories.len(), true);
        loop {
            if req.until.expired() {
                return Status::Timeout;
            }
            if self.attempt::<M, D>(req, h, &orders) {
                return Status::Solved;
            }
            if !orders.next_assignment() {
                return Status::NoSolution;
            }
        }
    }
}

impl IkTracking {
    /// Tracks every robot in turn under the assignment `orders` is at.
    fn attempt<M: Models<D>, const D: usize>(
        &self,
        req: &mut Request<'_, D>,
        h: usize,
        orders: &Orders,
    ) -> bool {
        let (problem, deadline) = (req.problem, &req.until);
        let (out, stats) = (&mut req.out, &mut req.stats);
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
                &robot,
                &problem.obstacles,
                problem.dt,
                self.params.motion_step,
            )
            .with_others(&others, OthersMode::Avoid);
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
