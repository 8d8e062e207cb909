//! What an approach is asked for and what it answers: the query, its tunables, the caller's
//! storage, the result and the errors. A leaf: the approach's planners all speak it.

use crate::problem::Problem;
use crate::search::Deadline;

use super::composite::Blocked;

/// An approach to plan: from where the robots of `problem` stand (`initial`; a robot without
/// one starts where its path does) to the first configurations of a plan, robot `i`'s path
/// being `plan[i * horizon..(i + 1) * horizon]`, with `params`, until `deadline`.
#[derive(Clone, Copy)]
pub struct ApproachQuery<'q, const D: usize> {
    /// The robots, obstacles and `dt`.
    pub problem: &'q Problem<D>,
    /// The plan the approach leads to.
    pub plan: &'q [[f64; D]],
    /// Steps of each robot's path in `plan`.
    pub horizon: usize,
    /// How to search (speed, samples, seed).
    pub params: ApproachParams,
    /// When to give up.
    pub deadline: &'q dyn Deadline,
}

/// Tunables of the approach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApproachParams {
    /// Share of each joint's velocity limit the approach may use (0 < speed <= 1).
    pub speed: f64,
    /// Share of each joint's acceleration limit ([`Model::ACCELERATION`](crate::model::Model::ACCELERATION)) the approach may
    /// use (0: no acceleration limit).
    pub acceleration: f64,
    /// See [`crate::search::OmegaParams::motion_step`].
    pub motion_step: f64,
    /// Whether the arms may take their straight bridges one at a time, in any order, when
    /// they cannot all move together.
    pub ordered: bool,
    /// Most priority orders tried one arm at a time with RRT-Connect per arm, before
    /// RRT-Connect on the composite space.
    pub rrt_orders: usize,
    /// RRT-Connect's longest edge, in seconds of motion at full speed. A motion check costs
    /// far less than in proportion to its length (the sweeps bisect, and a far-away motion is
    /// one check), so long edges reach as far with fewer nodes and checks.
    pub rrt_step: f64,
    /// RRT-Connect's samples per search ([`crate::embody`] doubles it on each retry).
    pub rrt_samples: u32,
    /// Seed of RRT-Connect's samples.
    pub seed: u64,
    /// Radius (joint space, rad) around a start whose approach failed in which
    /// [`crate::embody`] keeps the planner from choosing its next start.
    pub exclusion_radius: f64,
}

impl Default for ApproachParams {
    fn default() -> Self {
        ApproachParams {
            speed: 0.9,
            acceleration: 1.0,
            motion_step: crate::motion::MOTION_STEP,
            ordered: true,
            rrt_orders: 6,
            rrt_step: 0.5,
            rrt_samples: 400,
            seed: 0x0a99_7a0c,
            exclusion_radius: 0.5,
        }
    }
}

/// How the approach was found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// Nothing to do: every arm stands where its plan begins.
    #[default]
    None,
    /// All arms together along their straight bridges.
    Together,
    /// One arm at a time along its straight bridge.
    Ordered,
    /// One arm at a time, each along an RRT-Connect path around the others standing.
    OrderedRrt,
    /// RRT-Connect on the composite space, shortcut.
    Rrt,
}

impl Method {
    /// The name solution files and reports use (`none`, `together`, `ordered`,
    /// `ordered-rrt`, `rrt-connect`).
    pub fn name(self) -> &'static str {
        match self {
            Method::None => "none",
            Method::Together => "together",
            Method::Ordered => "ordered",
            Method::OrderedRrt => "ordered-rrt",
            Method::Rrt => "rrt-connect",
        }
    }
}

/// An approach written to the caller's buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Approach {
    /// Configurations per robot (`A`).
    pub len: usize,
    /// Which planner found it.
    pub method: Method,
}

/// Why no approach was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ApproachError {
    /// A robot's `initial` is outside its limits or collides.
    Start(Blocked),
    /// The approach needs `needed` configurations per robot; the buffer holds `capacity`.
    TooLong {
        /// Configurations per robot the approach needs.
        needed: usize,
        /// Configurations per robot the buffer holds.
        capacity: usize,
    },
    /// No planner found an approach within its budget. The first motion the arms moving
    /// together failed on: robot `robot`'s, against robot `other` or obstacles / itself.
    Blocked {
        /// The robot whose motion failed.
        robot: usize,
        /// The robot it met; `None`: an obstacle or itself.
        other: Option<usize>,
    },
    /// The deadline passed.
    Timeout,
    /// A buffer of [`ApproachStorage`] is full; the message names it.
    OutOfMemory(&'static str),
    /// The problem or the buffers do not fit (robots, paths).
    Invalid(&'static str),
}

/// Caller storage of the approach planners. Costs: a tree node `robots * D * 8` bytes of
/// `tree` and 4 of `parent` (a full tree ends that search as a spent sample budget does), a
/// waypoint `robots * D * 8` bytes.
pub struct ApproachStorage<'a, const D: usize> {
    /// RRT-Connect's two trees: `robots` configurations per node, half the nodes per tree.
    pub tree: &'a mut [[f64; D]],
    /// Each node's parent (at least as many as the nodes `tree` holds).
    pub parent: &'a mut [u32],
    /// The approach's waypoints, `robots` configurations each: at least `robots + 1` of them
    /// (the one-at-a-time orders), and as many as the longest RRT-Connect path kept.
    pub waypoints: &'a mut [[f64; D]],
}
