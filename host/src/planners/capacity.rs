//! How large the planners' pools are ([`Capacities`]) and the start-seed cache: what the arena
//! is sized from.

/// Sizes of the bounded pools. Bytes: Ω-A* 112 per search node; Ω-CBSA about 220 per CT node,
/// `H * 56` per pooled path; composite A* about 490 per node.
#[derive(Clone, Copy, Debug)]
pub struct Capacities {
    /// Ω-A*'s search nodes (112 bytes each with the OPEN list and table).
    pub search_nodes: usize,
    /// Ω-CBSA's constraint-tree nodes (about 220 bytes each).
    pub ct_nodes: usize,
    /// Ω-CBSA's pooled paths (`H * 56` bytes each).
    pub path_slots: usize,
    /// Point constraints on the robot being replanned (Ω-CBSA).
    pub constraints: usize,
    /// Composite A*'s nodes (about 490 bytes each).
    pub composite_nodes: usize,
    /// PP-Descartes' IK samples per pose.
    pub descartes_samples: usize,
    /// RRT-Connect nodes of the approach (both trees; `robots * 56 + 4` bytes each).
    pub approach_nodes: usize,
    /// Waypoints of an approach kept before shortcutting.
    pub approach_waypoints: usize,
}

impl Default for Capacities {
    fn default() -> Self {
        Capacities {
            search_nodes: 1 << 16,
            ct_nodes: 1 << 13,
            path_slots: 1 << 13,
            constraints: 1 << 12,
            composite_nodes: 1 << 16,
            descartes_samples: 12,
            approach_nodes: 1 << 13,
            approach_waypoints: 1 << 10,
        }
    }
}

/// Start-seed IK answers kept per run (64 bytes each, 4 MiB): all of level 0's seeds for
/// every problem the core accepts, and the first few thousand of the finer refinement levels'
/// for problems with fewer robots and trajectories.
pub const START_CACHE_ENTRIES: usize = 1 << 16;
