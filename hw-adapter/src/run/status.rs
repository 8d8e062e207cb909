//! What a running stream says about each arm while it moves ([`ArmStatus`]).

use super::JOINTS;
use std::time::Duration;

/// The latest feedback of an arm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    /// Joint positions, rad.
    pub positions: [f64; JOINTS],
    /// The control cycle it answers (`None` for feedback before the first cycle: start-up).
    pub cycle: Option<u64>,
}

/// Where an arm is in its run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArmState {
    /// Being set up: nothing has moved it yet.
    Starting,
    /// Following the queued waypoints.
    Moving,
    /// Holding still at the last waypoint queued: the queue ran dry (no fault; a push
    /// extending the queue moves it on) or nothing was pushed yet.
    Holding,
    /// Stopped after a fault, or on request: nothing more is sent to it.
    Stopped,
    /// The run ended normally: the queue done, the drives disabled.
    Finished,
}

/// One arm of a running stream.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmStatus {
    /// The arm's name.
    pub name: String,
    /// Where it is in its run.
    pub state: ArmState,
    /// The last command sent, rad (before the first cycle: where it starts).
    pub commanded: [f64; JOINTS],
    /// The latest feedback (`None` before any).
    pub measured: Option<Measured>,
    /// The largest |target - measured| over its joints in the latest feedback, rad, against
    /// the targets of the cycle that feedback answers.
    pub following_error: f64,
    /// Waypoints queued beyond the step being executed (0: holding at the queue's end, or on
    /// the way to its last waypoint).
    pub queue_depth: usize,
    /// How far its feedback trails its commands: from the cycle the latest feedback answers to
    /// the last cycle sent, in time (`None` before any answered cycle).
    pub lag: Option<Duration>,
}
