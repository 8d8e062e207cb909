//! A `Cell`'s state, shared by the cell and the Embodier it plans with (which refuses chunks
//! pushed around a running cell): a leaf, so that neither imports the other.

use std::sync::{Mutex, MutexGuard, Weak};

use omcbsa::live::LiveCell;

/// A cell while it runs, or why it ended.
pub(crate) enum State {
    Running(Box<LiveCell>),
    Ended(String),
}

/// The cell of an Embodier, as it keeps it.
pub type CellRef = Weak<Mutex<State>>;

/// The state, whatever a panicking holder left (every path out of it leaves it whole).
pub(crate) fn lock(slot: &Mutex<State>) -> MutexGuard<'_, State> {
    slot.lock().unwrap_or_else(|p| p.into_inner())
}

/// Whether the cell still runs (a cell busy with a call runs).
pub fn running(slot: &CellRef) -> bool {
    slot.upgrade().is_some_and(|s| {
        s.try_lock()
            .map_or(true, |g| matches!(*g, State::Running(_)))
    })
}
