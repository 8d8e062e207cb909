//! Ω-A*: A* on the pose-constraint manifolds of one robot (single- and multi-goal), in a
//! caller-provided [`Workspace`].

mod omega_astar;
pub(crate) mod open;
pub mod refine;
mod validity;
mod workspace;

pub use omega_astar::{
    axes_cost, manifold_moves, plan, Found, OmegaParams, OtherArm, OthersMode, PointConstraint,
    Query, SearchError, SearchStats, StartCache, StartIk, MAX_MOVES, REFERENCE_DT,
};
pub use open::{OpenEntry, OpenList};
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
