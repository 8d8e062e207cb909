//! Joint limits for the executor's own tests and examples, which run without the host: the
//! executor takes every arm's limits from its caller (the host derives them from each arm's
//! model, `omcbsa::execute::joint_limits`). These are the values the host gives a Kinova Gen3
//! at the cautious speed; a host test checks that they agree.

use omcbsa_hw::plan::{ArmLimits, JointLimits};

/// One arm's limits: joints 2, 4, 6 within ±2.24, ±2.57, ±2.09 rad, the others continuous;
/// 0.8727 rad/s; 1.0 rad/s² for joints 1-4 and 10.0 rad/s² for joints 5-7.
pub fn arm_limits() -> ArmLimits {
    let position = [None, Some(2.24), None, Some(2.57), None, Some(2.09), None];
    let acceleration = [1.0, 1.0, 1.0, 1.0, 10.0, 10.0, 10.0];
    std::array::from_fn(|j| JointLimits {
        position: position[j].map(|b| (-b, b)),
        velocity: 0.8727,
        acceleration: acceleration[j],
        // None here, so that the executor's tests see the law itself (the jerk filter has its
        // own tests in `stream`).
        jerk: f64::INFINITY,
    })
}

/// [`arm_limits`] for each of `arms` arms.
pub fn fleet_limits(arms: usize) -> Vec<ArmLimits> {
    vec![arm_limits(); arms]
}
