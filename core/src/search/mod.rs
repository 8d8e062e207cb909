//! Ω-A*: A* on the pose-constraint manifolds of one robot (single- and multi-goal), in a
//! caller-provided [`Workspace`].

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
    fn expired(&self) -> bool;
}

/// Never expires.
pub struct NoDeadline;

impl Deadline for NoDeadline {
    fn expired(&self) -> bool {
        false
    }
}
