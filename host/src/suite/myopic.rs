//! Whether the IK-tracking baseline solves a problem: the generator resamples problems it
//! solves (see the crate docs of `suite`), on a fixed budget of work rather than of time so
//! that generation stays deterministic.

use std::cell::Cell;

use omcbsa_core::baselines::{IkTracking, IkTrackingParams};
use omcbsa_core::planner::{Clock, Planner, Request, Solution, Status, Until};
use omcbsa_core::problem::{Problem, MAX_ROBOTS};

use super::witness::{Arms, MOTION_STEP};
use crate::models::DOF;

/// Looks at the clock IK tracking may take: it looks once per assignment and once per seed
/// of every robot, so this bounds the tracks it tries.
const BUDGET: u64 = 4000;

/// A clock that advances one tick each time it is read.
struct Ticks(Cell<u64>);

impl Clock for Ticks {
    fn seconds(&self) -> f64 {
        let t = self.0.get() + 1;
        self.0.set(t);
        t as f64
    }
}

/// Whether IK tracking (the baseline, with its default parameters but the suite's motion step)
/// solves `problem` within [`BUDGET`].
pub fn ik_tracking_solves(problem: &Problem<DOF>) -> bool {
    let mut paths = vec![[0.0; DOF]; MAX_ROBOTS * problem.horizon()];
    let mut planner = IkTracking {
        params: IkTrackingParams {
            motion_step: MOTION_STEP,
            ..IkTrackingParams::default()
        },
    };
    let clock = Ticks(Cell::new(0));
    let until = Until::new(&clock, BUDGET as f64);
    let mut req = Request::new(problem, until, Solution::new(&mut paths));
    Planner::<Arms, DOF>::solve(&mut planner, &mut req) == Status::Solved
}
