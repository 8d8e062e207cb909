//! The paper's baselines, behind the same [`crate::planner::Planner`] interface and on the
//! same kinematics, IK and collision code as Ω-CBSA:
//! - [`IkTracking`]: every assignment, IK of the first pose from random seeds, then IK tracking.
//! - [`Descartes`]: PP-Descartes, per-robot pose-constrained roadmaps in priority order.
//! - [`CompositeAstar`]: A* over joint states of all robots with Ω-A*'s successors.

mod composite;
mod descartes;
mod ik_tracking;

pub use composite::{CompositeAstar, CompositeNode, CompositeParams, CompositeStorage};
pub use descartes::{Descartes, DescartesParams, DescartesStorage};
pub use ik_tracking::{IkTracking, IkTrackingParams};
