//! What constrains one robot besides its problem: the other robots' paths (moving obstacles,
//! avoided or counted) and the point constraints of Ω-CBSA's branches. A leaf: the validity
//! checker and the search both read it.

use crate::model::Frame;
use crate::tool::Tool;

/// Another robot's path: a moving obstacle.
#[derive(Clone, Copy, Debug)]
pub struct OtherArm<'a, const D: usize> {
    /// Its model, an index into the planner's [`crate::model::Models`].
    pub model: u8,
    /// Its base frame in the world.
    pub base: Frame,
    /// What it carries.
    pub tool: Tool,
    /// One configuration per step.
    pub path: &'a [[f64; D]],
}

/// How the other robots' paths count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OthersMode {
    /// Collisions are allowed and counted in `c` (Ω-CBSA's low level).
    Count,
    /// Collisions are forbidden (prioritised planning).
    Avoid,
}

/// "This robot may not come within `margin` of `p` at step `t`" (`segment == false`), or at
/// the instant `t + s` of its motion from step `t` to `t + 1` (`segment == true`; the robot
/// is then at `q_t + s (q_{t+1} - q_t)`). Constraints at one instant, not over a whole
/// motion, so that the two children of a conflict are mutually disjunctive (see
/// [`crate::motion::motions_contact`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointConstraint {
    /// The step (or the step the motion starts from).
    pub t: u16,
    /// Whether the constraint holds at an instant of the motion `t -> t + 1` rather than at
    /// step `t`.
    pub segment: bool,
    /// Fraction of the step (`segment` constraints only).
    pub s: f64,
    /// The point, in the world, metres.
    pub p: [f64; 3],
    /// How near the robot may not come, metres (0: the point may not be inside it).
    pub margin: f64,
}
