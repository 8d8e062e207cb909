//! The fixed-capacity problem the planners read.
//!
//! The host parses `omcbsa.problem.v1` files and fills one of these; input beyond a capacity
//! is refused by the host with the capacity's name, never truncated. The lists are
//! [`heapless::Vec`]s, whose `push` returns the item back (`Err`) when full.
//!
//! A problem is `dt`, the robots (model, base, tool, where each stands), the hands'
//! trajectories (one pose per step, all of one length H), the obstacles and the tolerance.
//! Every robot tracks at most one trajectory; with fewer trajectories than robots, the others
//! hold where they stand (`initial`).
//!
//! ```
//! use omcbsa_core::geometry::{Obstacle, Shape};
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//! use omcbsa_core::nalgebra::{Matrix3, Vector3};
//! use omcbsa_core::problem::{Problem, Robot, Trajectory, MAX_ROBOTS};
//!
//! // Two Gen3s 1 m apart, the second turned to face the first; poses 0.1 s apart.
//! let mut problem = Problem::<7>::new(0.1);
//! problem.robots.push(Robot::at(0, Frame::IDENTITY)).unwrap();
//! let facing = Frame {
//!     rot: Matrix3::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0),
//!     pos: Vector3::new(1.0, 0.0, 0.0),
//! };
//! problem.robots.push(Robot::at(0, facing)).unwrap();
//!
//! // One hand, three poses sliding 1 cm a step along y.
//! let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
//! let slide = |t: usize| Frame { pos: hand.pos + Vector3::y() * (0.01 * t as f64), ..hand };
//! let traj: Trajectory = (0..3).map(slide).collect();
//! problem.trajectories.push(traj).unwrap();
//! // A table top under the arms.
//! let table = Obstacle {
//!     shape: Shape::Box { half_extents: [0.5, 0.5, 0.01] },
//!     pose: Frame { pos: Vector3::new(0.5, 0.0, -0.02), ..Frame::IDENTITY },
//! };
//! problem.obstacles.push(table).unwrap();
//! assert_eq!(problem.horizon(), 3);
//!
//! // Storage runs out: the ninth robot is handed back, not dropped silently.
//! for _ in 2..MAX_ROBOTS {
//!     problem.robots.push(Robot::at(0, Frame::IDENTITY)).unwrap();
//! }
//! assert!(problem.robots.push(Robot::at(0, Frame::IDENTITY)).is_err());
//! ```

use heapless::Vec;

use crate::geometry::Obstacle;
use crate::model::Frame;
use crate::tool::Tool;

/// Most robots in one problem.
pub const MAX_ROBOTS: usize = 8;
/// Most poses in one trajectory (the horizon H).
pub const MAX_STEPS: usize = 256;
/// Most obstacles in one problem.
pub const MAX_OBSTACLES: usize = 64;

/// Pose tolerance of the tracked trajectories.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Position error, metres.
    pub position: f64,
    /// Angle of the relative rotation, radians.
    pub orientation: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance {
            position: 0.001,
            orientation: 0.01,
        }
    }
}

/// One robot of the problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Robot<const D: usize> {
    /// The robot's model: an index into the planner's [`crate::model::Models`] (0 when it is
    /// one model).
    pub model: u8,
    /// Pose of the model's base frame in the world.
    pub base: Frame,
    /// Tool centre point relative to the model's tool frame.
    pub tcp: Frame,
    /// Current configuration, if given (required for robots without a trajectory).
    pub initial: Option<[f64; D]>,
    /// Collision shape of what the flange carries ([`Tool::NONE`]: nothing).
    pub tool: Tool,
    /// Where the robot's path begins (online planning continues from where the arm is).
    pub start: Start,
    /// The trajectory the robot must take (online planning keeps the first chunk's hands).
    pub assigned: Assigned,
    /// First configurations the planners may not choose: starts from which no approach was
    /// found ([`crate::embody`] fills it; [`StartExclusions::NONE`] otherwise).
    pub excluded: StartExclusions<D>,
}

impl<const D: usize> Robot<D> {
    /// A robot of model `model` (an index into the planner's models) with its base at `base`:
    /// no tool, the tool centre point at the model's tool frame, no `initial`, start and
    /// assignment chosen by the planner.
    pub fn at(model: u8, base: Frame) -> Self {
        Robot {
            model,
            base,
            tcp: Frame::IDENTITY,
            initial: None,
            tool: Tool::NONE,
            start: Start::Sampled,
            assigned: Assigned::Free,
            excluded: StartExclusions::NONE,
        }
    }

    /// The IK target of a hand pose: the pose of the model's tool frame, in the base frame,
    /// that puts the tool centre point at the hand's world pose. The two inverses are taken
    /// once, for all the poses of a trajectory.
    pub fn ik_target(&self) -> impl Fn(&Frame) -> Frame {
        let (base_inv, tcp_inv) = (self.base.inverse(), self.tcp.inverse());
        move |hand| base_inv.compose(hand).compose(&tcp_inv)
    }
}

/// Most start configurations excluded per robot at once.
pub const MAX_EXCLUDED_STARTS: usize = 4;

/// Regions of a robot's configuration space its path may not begin in: the joint-space balls
/// of radius `radius` (Euclidean, rad) around `configs[..len]`. Checked by
/// [`crate::search::Validity::state`] at step 0, so every planner honours it.
///
/// ```
/// use omcbsa_core::problem::{StartExclusions, MAX_EXCLUDED_STARTS};
///
/// let mut ex = StartExclusions::<2>::NONE;
/// ex.radius = 0.5;
/// assert!(ex.push([0.0, 0.0]));
/// assert!(ex.excludes(&[0.3, 0.3]) && !ex.excludes(&[0.4, 0.4]));
/// for k in 1..MAX_EXCLUDED_STARTS {
///     assert!(ex.push([k as f64, 0.0]));
/// }
/// // Full: the next one is refused and nothing changes.
/// assert!(ex.is_full() && !ex.push([9.0, 9.0]));
/// assert_eq!(ex.configs().len(), MAX_EXCLUDED_STARTS);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartExclusions<const D: usize> {
    configs: [[f64; D]; MAX_EXCLUDED_STARTS],
    len: u8,
    /// Radius of every excluded ball.
    pub radius: f64,
}

impl<const D: usize> StartExclusions<D> {
    /// Nothing excluded.
    pub const NONE: StartExclusions<D> = StartExclusions {
        configs: [[0.0; D]; MAX_EXCLUDED_STARTS],
        len: 0,
        radius: 0.0,
    };

    /// The excluded centres.
    pub fn configs(&self) -> &[[f64; D]] {
        &self.configs[..usize::from(self.len)]
    }

    /// Excludes the ball around `q`; `false` (nothing changed) when full.
    pub fn push(&mut self, q: [f64; D]) -> bool {
        let Some(slot) = self.configs.get_mut(usize::from(self.len)) else {
            return false;
        };
        *slot = q;
        self.len += 1;
        true
    }

    /// Whether [`MAX_EXCLUDED_STARTS`] balls are excluded (a further `push` fails).
    pub fn is_full(&self) -> bool {
        usize::from(self.len) == MAX_EXCLUDED_STARTS
    }

    /// Excludes nothing any more (the radius is kept).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Whether `q` lies in an excluded ball.
    pub fn excludes(&self, q: &[f64; D]) -> bool {
        self.configs().iter().any(|c| {
            let d2: f64 = c.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            d2 <= self.radius * self.radius
        })
    }
}

/// Where a robot's path begins.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Start {
    /// Anywhere on the first pose's manifold: the planners sample start states (IK from
    /// `initial` first, then random seeds); the approach from `initial` is planned with them
    /// ([`crate::embody`], [`crate::approach`]).
    #[default]
    Sampled,
    /// Exactly at `initial`, at step 0: the path's first configuration is `initial` and pose 0
    /// of its trajectory is not tracked. Online planning puts the arm's configuration one step
    /// before a chunk at step 0, so reaching the chunk's first pose (step 1) from it is a step
    /// like any other, within the velocity limits and collision-checked.
    AtInitial,
}

/// A robot's fixed part of the assignment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Assigned {
    /// The planner chooses.
    #[default]
    Free,
    /// The robot tracks this trajectory and no other.
    Track(u8),
    /// The robot holds `initial`.
    Hold,
}

impl Assigned {
    /// The trajectories (bit set) the robot may take.
    pub fn mask(self) -> u32 {
        match self {
            Assigned::Free => u32::MAX,
            Assigned::Track(j) => 1u32.checked_shl(u32::from(j)).unwrap_or(0),
            Assigned::Hold => 0,
        }
    }

    /// Whether the robot may hold, given whether the planner would let it.
    pub fn may_hold(self, planner_allows: bool) -> bool {
        match self {
            Assigned::Free => planner_allows,
            Assigned::Track(_) => false,
            Assigned::Hold => true,
        }
    }
}

/// One hand trajectory: where a tool centre point must be at each step, in the world frame.
pub type Trajectory = Vec<Frame, MAX_STEPS>;

/// A whole problem. All trajectories have the same length H.
///
/// About `MAX_ROBOTS * MAX_STEPS * 96` bytes (about 200 kB for 7 joints): keep it in static
/// or boxed storage on a small stack. The planners check it before they plan
/// ([`crate::planner::open`]): an empty or ragged set of trajectories, more trajectories than
/// robots, a `dt` that is not positive or a fixed assignment that does not add up is
/// [`crate::planner::Status::InvalidProblem`] with the reason, never a panic.
#[derive(Clone, Debug)]
pub struct Problem<const D: usize> {
    /// Time between consecutive poses, s.
    pub dt: f64,
    /// The arms.
    pub robots: Vec<Robot<D>, MAX_ROBOTS>,
    /// The hands' trajectories, each of H poses.
    pub trajectories: Vec<Trajectory, MAX_ROBOTS>,
    /// Fixed obstacles in the world frame.
    pub obstacles: Vec<Obstacle, MAX_OBSTACLES>,
    /// How closely a tool centre point must follow its trajectory.
    pub tolerance: Tolerance,
}

impl<const D: usize> Problem<D> {
    /// An empty problem with poses `dt` seconds apart and the default tolerance.
    pub fn new(dt: f64) -> Self {
        Problem {
            dt,
            robots: Vec::new(),
            trajectories: Vec::new(),
            obstacles: Vec::new(),
            tolerance: Tolerance::default(),
        }
    }

    /// The horizon H (number of poses per trajectory).
    pub fn horizon(&self) -> usize {
        self.trajectories.first().map_or(0, |t| t.len())
    }
}
