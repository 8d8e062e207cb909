//! Ω-A*: A* on the pose-constraint manifolds of one robot (single- and multi-goal), in a
//! caller-provided [`Workspace`].
//!
//! [`plan`] searches one robot's path over one or several trajectories ([`Query`]), with the
//! other robots' paths as moving obstacles ([`OtherArm`]) and Ω-CBSA's [`PointConstraint`]s;
//! [`Validity`] is the checker every planner shares; [`refine`] the finer levels planners
//! fall back to. A full workspace ends a search with [`SearchError::OutOfMemory`]; nothing
//! allocates.
//!
//! One Gen3 following a hand that rises 1 cm a step, with a workspace of 256 nodes:
//!
//! ```
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//! use omcbsa_core::problem::{Robot, Trajectory};
//! use omcbsa_core::search::{plan, NoDeadline, OmegaParams, OthersMode, Query, SearchError};
//! use omcbsa_core::search::{SearchStats, WorkspaceBuffers};
//!
//! const H: usize = 3;
//! let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
//! let pose = |t: usize| {
//!     let mut x = hand;
//!     x.pos.z += 0.01 * t as f64;
//!     x
//! };
//! let trajectories = [(0..H).map(pose).collect::<Trajectory>()];
//! let query = Query {
//!     robot: Robot::at(0, Frame::IDENTITY),
//!     trajectories: &trajectories,
//!     allowed: 1, // trajectory 0
//!     hold: false,
//!     obstacles: &[],
//!     others: &[],
//!     others_mode: OthersMode::Avoid,
//!     points: &[],
//!     dt: 0.1,
//!     starts: &[], // remember no IK answers between searches
//! };
//! // 256 nodes and OPEN entries, a table of 512 slots (a power of two, at least the nodes).
//! let mut buffers = Box::new(WorkspaceBuffers::<7, 256, 512>::new());
//! let mut ws = buffers.workspace().unwrap();
//! let (mut path, mut stats) = ([[0.0; 7]; H], SearchStats::default());
//! let params = OmegaParams::default();
//! let found = plan::<KinovaGen3, 7>(&query, &params, &mut ws, &NoDeadline, &mut path, &mut stats);
//! assert_eq!(found.unwrap().trajectory, Some(0));
//! assert!(stats.expansions >= 2 && ws.used() <= ws.capacity());
//! for (q, x) in path.iter().zip(&trajectories[0]) {
//!     assert!((KinovaGen3::fk(q).pos - x.pos).norm() <= params.ik.position_tolerance);
//! }
//!
//! // Too small a workspace: an error, not a panic.
//! let mut tiny = WorkspaceBuffers::<7, 1, 2>::new();
//! let mut ws = tiny.workspace().unwrap();
//! let lost = plan::<KinovaGen3, 7>(&query, &params, &mut ws, &NoDeadline, &mut path, &mut stats);
//! assert_eq!(lost, Err(SearchError::OutOfMemory));
//! ```

mod constraints;
mod omega_astar;
pub(crate) mod open;
mod params;
pub mod refine;
mod validity;
mod workspace;

pub use constraints::{OtherArm, OthersMode, PointConstraint};
pub use omega_astar::{
    manifold_moves, plan, step_cost, Found, Query, SearchError, SearchStats, StartCache, StartIk,
    MAX_MOVES,
};
pub use open::{OpenEntry, OpenList};
pub use params::{OmegaParams, REFERENCE_DT};
pub use validity::Validity;
pub use workspace::{Node, Slot, Workspace, WorkspaceBuffers, WorkspaceError};

/// Lets the caller stop a search: checked every few expansions.
pub trait Deadline {
    /// Whether the search must stop now.
    fn expired(&self) -> bool;
}

/// Never expires.
pub struct NoDeadline;

impl Deadline for NoDeadline {
    fn expired(&self) -> bool {
        false
    }
}
