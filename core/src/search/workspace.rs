//! The storage one Ω-A* search runs in, handed in by the caller.
//!
//! Like smoltcp's socket buffers, the caller owns the memory (static arrays on a
//! microcontroller, one `Vec` per buffer on a host) and the search only borrows it, so a plan
//! never allocates. Cost per node of capacity: `size_of::<Node<D>>()` (80 bytes for D = 7) +
//! one [`OpenEntry`] (16 bytes) + two [`Slot`]s (16 bytes) when the table is twice the node
//! count. When the node pool or the OPEN list is full the search stops with
//! `SearchError::OutOfMemory`; the workspace is reset at the start of every search, so it can
//! be reused at once.
//!
//! ```
//! use omcbsa_core::search::{Node, OpenEntry, Slot, Workspace, WorkspaceBuffers, WorkspaceError};
//!
//! // On a host, one buffer each (a `Vec` would do as well).
//! let mut nodes = [Node::<7>::default(); 64];
//! let mut open = [OpenEntry::default(); 128];
//! let mut table = [Slot::default(); 128];
//! let ws = Workspace::new(&mut nodes, &mut open, &mut table).unwrap();
//! assert_eq!((ws.capacity(), ws.used()), (64, 0));
//!
//! // In one value, e.g. a `static` on a microcontroller.
//! let mut buffers = WorkspaceBuffers::<7, 64, 128>::new();
//! assert!(buffers.workspace().is_ok());
//!
//! // The table must be a power of two larger than the node pool.
//! let mut small = WorkspaceBuffers::<7, 64, 64>::new();
//! assert_eq!(small.workspace().err(), Some(WorkspaceError::TableCapacity));
//! let mut none = WorkspaceBuffers::<7, 0, 1>::new();
//! assert_eq!(none.workspace().err(), Some(WorkspaceError::NodeCapacity));
//! ```

use super::open::{OpenEntry, OpenList};

/// A search state `(q, t, j)` and its bookkeeping.
#[derive(Clone, Copy, Debug)]
pub struct Node<const D: usize> {
    /// The configuration.
    pub q: [f64; D],
    /// Cost to come.
    pub g: f64,
    /// Index of the parent node, `u32::MAX` for initial states.
    pub parent: u32,
    /// Step index (0-based: the pose this configuration realises).
    pub t: u16,
    /// Collisions with other robots' paths counted along the path so far.
    pub c: u16,
    /// Trajectory index.
    pub j: u8,
    /// Expanded already.
    pub closed: bool,
    /// Whether the motion from the parent has been checked (and counted in `c`): Ω-A* checks
    /// it only when the state is popped.
    pub checked: bool,
    /// The motion from the parent failed its check: the state is gone and its cell free.
    pub dead: bool,
    /// Bit `k`: the path so far meets the query's other robot `k` (what `c` counts, by
    /// robot).
    pub met: Met,
}

/// A set of a query's other robots, by their index among them.
pub type Met = u8;

// Every other robot of a query has a bit.
const _: () = assert!(crate::problem::MAX_ROBOTS <= Met::BITS as usize + 1);

impl<const D: usize> Default for Node<D> {
    fn default() -> Self {
        Node {
            q: [0.0; D],
            g: 0.0,
            parent: u32::MAX,
            t: 0,
            c: 0,
            j: 0,
            closed: false,
            checked: false,
            dead: false,
            met: 0,
        }
    }
}

/// One bucket of the duplicate-detection table. A slot is empty unless its `epoch` is the
/// current search's, so starting a search does not have to clear the table.
#[derive(Clone, Copy, Debug, Default)]
pub struct Slot {
    epoch: u32,
    node: u32,
}

/// Why a workspace could not be made from the given buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WorkspaceError {
    /// The node buffer is empty or holds more than `u32::MAX - 1` nodes.
    NodeCapacity,
    /// The table's length must be a power of two larger than the node count.
    TableCapacity,
}

/// Storage for one search at a time: a node arena, the OPEN heap and a hash table of the
/// discretised states already generated (`D = 7`: 80 bytes a node, 16 an OPEN entry, 8 a
/// table slot). Making one clears the table (`O(table length)`);
/// each search after that starts in `O(1)`.
pub struct Workspace<'a, const D: usize> {
    nodes: &'a mut [Node<D>],
    used: usize,
    pub(crate) open: OpenList<'a>,
    table: &'a mut [Slot],
    epoch: u32,
}

impl<'a, const D: usize> Workspace<'a, D> {
    /// A workspace over the caller's buffers: `nodes` (not empty), `open` (the OPEN list;
    /// twice the nodes is ample) and `table` (a power of two larger than `nodes`). Clears
    /// the table.
    pub fn new(
        nodes: &'a mut [Node<D>],
        open: &'a mut [OpenEntry],
        table: &'a mut [Slot],
    ) -> Result<Self, WorkspaceError> {
        if nodes.is_empty() || nodes.len() >= u32::MAX as usize {
            return Err(WorkspaceError::NodeCapacity);
        }
        // Larger than the node pool: a lookup stops at an empty slot, so a full table would
        // loop for ever once every node is stored.
        if !table.len().is_power_of_two() || table.len() <= nodes.len() {
            return Err(WorkspaceError::TableCapacity);
        }
        // The buffers may come from an earlier workspace whose slots carry epochs this one
        // would take for its own: start from a clean table.
        table.iter_mut().for_each(|s| *s = Slot::default());
        Ok(Workspace {
            nodes,
            used: 0,
            open: OpenList::new(open),
            table,
            epoch: 0,
        })
    }

    /// Node capacity.
    pub fn capacity(&self) -> usize {
        self.nodes.len()
    }

    /// Nodes generated by the current (or last) search.
    pub fn used(&self) -> usize {
        self.used
    }

    /// Forgets every node; O(1).
    pub(crate) fn reset(&mut self) {
        self.used = 0;
        self.open.clear();
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            // Stamps wrapped around: old slots could look current, so clear them once.
            self.table.iter_mut().for_each(|s| *s = Slot::default());
            self.epoch = 1;
        }
    }

    pub(crate) fn node(&self, i: u32) -> &Node<D> {
        &self.nodes[i as usize]
    }

    pub(crate) fn node_mut(&mut self, i: u32) -> &mut Node<D> {
        &mut self.nodes[i as usize]
    }

    /// Looks the discretised state up; returns the node already stored for it, or the free
    /// slot it would go into.
    pub(crate) fn find(&self, key: &StateKey<D>) -> Result<u32, usize> {
        let mask = self.table.len() - 1;
        let mut i = key.hash() as usize & mask;
        loop {
            let slot = self.table[i];
            if slot.epoch != self.epoch {
                return Err(i);
            }
            let n = &self.nodes[slot.node as usize];
            if StateKey::new(&n.q, n.t, n.j, key.resolution) == *key {
                return Ok(slot.node);
            }
            i = (i + 1) & mask;
        }
    }

    /// Stores `node` in the arena and in table slot `slot` (from [`Workspace::find`]);
    /// `None` when the arena is full.
    pub(crate) fn insert(&mut self, slot: usize, node: Node<D>) -> Option<u32> {
        if self.used == self.nodes.len() {
            return None;
        }
        let i = self.used as u32;
        self.nodes[self.used] = node;
        self.used += 1;
        self.table[slot] = Slot {
            epoch: self.epoch,
            node: i,
        };
        Some(i)
    }
}

/// A state discretised for duplicate detection: `(round(q / resolution), t, j)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct StateKey<const D: usize> {
    cells: [i32; D],
    t: u16,
    j: u8,
    resolution: f64,
}

impl<const D: usize> StateKey<D> {
    pub(crate) fn new(q: &[f64; D], t: u16, j: u8, resolution: f64) -> Self {
        let mut cells = [0i32; D];
        for (c, v) in cells.iter_mut().zip(q) {
            *c = libm::round(v / resolution) as i32;
        }
        StateKey {
            cells,
            t,
            j,
            resolution,
        }
    }

    /// A fixed (not randomly seeded) hash, so runs are repeatable.
    fn hash(&self) -> u64 {
        let mut h = 0xcbf2_9ce4_8422_2325u64 ^ ((self.t as u64) << 8 | self.j as u64);
        for c in &self.cells {
            h = (h ^ (*c as u32 as u64)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        // Final avalanche (SplitMix64's), so the low bits used as the bucket index mix well.
        h = (h ^ (h >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h = (h ^ (h >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^ (h >> 31)
    }
}

/// Buffers for a [`Workspace`] of `N` nodes, for callers that want them in one value (a
/// `static` on a microcontroller). `T` must be a power of two `> N`. About `N * 100 + T * 8`
/// bytes: large ones belong in static or boxed storage, not on a small stack.
pub struct WorkspaceBuffers<const D: usize, const N: usize, const T: usize> {
    /// The node arena.
    pub nodes: [Node<D>; N],
    /// The OPEN list's storage.
    pub open: [OpenEntry; N],
    /// The duplicate-detection table.
    pub table: [Slot; T],
}

impl<const D: usize, const N: usize, const T: usize> WorkspaceBuffers<D, N, T> {
    /// Cleared buffers.
    pub fn new() -> Self {
        WorkspaceBuffers {
            nodes: [Node::default(); N],
            open: [OpenEntry::default(); N],
            table: [Slot::default(); T],
        }
    }

    /// A workspace over these buffers (see [`Workspace::new`] for the errors).
    pub fn workspace(&mut self) -> Result<Workspace<'_, D>, WorkspaceError> {
        Workspace::new(&mut self.nodes, &mut self.open, &mut self.table)
    }
}

impl<const D: usize, const N: usize, const T: usize> Default for WorkspaceBuffers<D, N, T> {
    fn default() -> Self {
        Self::new()
    }
}
