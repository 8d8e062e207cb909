//! The least time scaling that lets a planner follow hands too fast for the arms: when a
//! plan ends `no_solution` with the joints' limits cutting the search ([`TooFast`]), the same
//! problem is planned again with its steps `k dt` apart (the same poses, slower), growing `k`
//! from the planner's own estimate until a plan is found, then bisecting down towards the
//! largest `k` that still failed. What it reports was planned, not guessed: `time_scale`
//! solves, `refused_below` did not. At most [`ATTEMPTS`] plans, so it is bounded in time by
//! `ATTEMPTS` times the planning time limit.

use omcbsa_core::pace::TooFast;
use omcbsa_core::planner::Status;
use omcbsa_core::problem::Problem;

use crate::models::DOF;
use crate::planners::{PlannerKind, Storage};

/// Most plans one search for the scaling makes: up to 6 to find a scaling that plans, the
/// rest bisecting.
pub const ATTEMPTS: u32 = 10;

/// Most plans spent growing the scaling before giving up.
const GROWING: u32 = 6;

/// How much each growing step at least multiplies the scaling by.
const GROWTH: f64 = 1.25;

/// The outcome of [`least_scale`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaling {
    /// The smallest factor on `dt` found at which the planner solves the problem, or `None`
    /// when none of the factors tried did.
    pub time_scale: Option<f64>,
    /// The largest factor tried at which it did not (1: the problem as given).
    pub refused_below: f64,
    /// Plans made.
    pub attempts: u32,
}

/// Plans `problem` with `kind` at growing, then bisected, multiples of its `dt`, starting
/// from `too_fast.time_scale`, each plan within `timeout_s`.
pub fn least_scale(
    storage: &mut Storage,
    kind: PlannerKind,
    problem: &Problem<DOF>,
    too_fast: &TooFast,
    timeout_s: f64,
) -> Result<Scaling, String> {
    let mut scaled = Box::new(problem.clone());
    let mut plan_at = |k: f64| -> Result<(bool, Option<TooFast>), String> {
        scaled.dt = problem.dt * k;
        let outcome = storage.solve(kind, &scaled, timeout_s)?;
        Ok((outcome.status == Status::Solved, outcome.stats.too_fast))
    };
    let mut s = Scaling {
        time_scale: None,
        refused_below: 1.0,
        attempts: 0,
    };
    // The estimate is where the search's furthest cut step fits: a hair above it, so that
    // the step is strictly inside its limits.
    let mut k = too_fast.time_scale.max(1.0) * (1.0 + 1e-6);
    while s.attempts < GROWING {
        s.attempts += 1;
        let (solved, cut) = plan_at(k)?;
        if solved {
            s.time_scale = Some(k);
            break;
        }
        s.refused_below = k;
        let estimate = cut.map_or(0.0, |c| k * c.time_scale * (1.0 + 1e-6));
        k = (k * GROWTH).max(estimate);
    }
    while let (Some(hi), true) = (s.time_scale, s.attempts < ATTEMPTS) {
        let mid = (hi * s.refused_below).sqrt();
        if hi / s.refused_below < 1.01 {
            break;
        }
        s.attempts += 1;
        if plan_at(mid)?.0 {
            s.time_scale = Some(mid);
        } else {
            s.refused_below = mid;
        }
    }
    Ok(s)
}
