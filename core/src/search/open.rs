//! The OPEN list: a binary min-heap over caller-provided storage.

/// One OPEN entry. Ordered by `f`, then by deeper `t` first (so equal-cost states finish
/// sooner), then by node index (so ties break the same way on every run).
#[derive(Clone, Copy, Debug, Default)]
pub struct OpenEntry {
    /// The priority (lowest first): cost to come plus the weighted heuristic.
    pub f: f64,
    /// Step index (deeper first among equal `f`).
    pub t: u32,
    /// Index of the node (or constraint-tree node) in its pool.
    pub node: u32,
}

impl OpenEntry {
    #[inline]
    fn before(&self, other: &OpenEntry) -> bool {
        if self.f != other.f {
            return self.f < other.f;
        }
        if self.t != other.t {
            return self.t > other.t;
        }
        self.node < other.node
    }
}

/// A binary heap of [`OpenEntry`] in a slice it does not own. Push fails when the slice is full.
/// `O(log n)` a push or pop, no allocation.
///
/// ```
/// use omcbsa_core::search::{OpenEntry, OpenList};
///
/// let mut storage = [OpenEntry::default(); 2];
/// let mut open = OpenList::new(&mut storage);
/// assert!(open.push(OpenEntry { f: 2.0, t: 0, node: 0 }));
/// assert!(open.push(OpenEntry { f: 1.0, t: 0, node: 1 }));
/// // Full: refused, nothing changed.
/// assert!(!open.push(OpenEntry { f: 0.5, t: 0, node: 2 }));
/// assert_eq!(open.pop().map(|e| e.node), Some(1));
/// assert_eq!(open.pop().map(|e| e.node), Some(0));
/// assert!(open.pop().is_none() && open.is_empty());
/// ```
pub struct OpenList<'a> {
    items: &'a mut [OpenEntry],
    len: usize,
}

impl<'a> OpenList<'a> {
    /// An empty list over `items`, which bounds how many entries it holds.
    pub fn new(items: &'a mut [OpenEntry]) -> Self {
        OpenList { items, len: 0 }
    }

    /// Entries held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether it holds no entry.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Forgets every entry; `O(1)`.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Inserts `e`; returns `false` (and changes nothing) when storage is full.
    #[must_use]
    pub fn push(&mut self, e: OpenEntry) -> bool {
        if self.len == self.items.len() {
            return false;
        }
        let mut i = self.len;
        self.len += 1;
        while i > 0 {
            let parent = (i - 1) / 2;
            if !e.before(&self.items[parent]) {
                break;
            }
            self.items[i] = self.items[parent];
            i = parent;
        }
        self.items[i] = e;
        true
    }

    /// Takes the first entry (least `f`, then deepest `t`, then least `node`).
    pub fn pop(&mut self) -> Option<OpenEntry> {
        if self.len == 0 {
            return None;
        }
        let top = self.items[0];
        self.len -= 1;
        if self.len > 0 {
            let last = self.items[self.len];
            let mut i = 0;
            loop {
                let l = 2 * i + 1;
                if l >= self.len {
                    break;
                }
                let r = l + 1;
                let c = if r < self.len && self.items[r].before(&self.items[l]) {
                    r
                } else {
                    l
                };
                if !self.items[c].before(&last) {
                    break;
                }
                self.items[i] = self.items[c];
                i = c;
            }
            self.items[i] = last;
        }
        Some(top)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pops_in_order_and_refuses_when_full() {
        let mut buf = [OpenEntry::default(); 8];
        let mut open = OpenList::new(&mut buf);
        let fs = [5.0, 1.0, 3.0, 1.0, 9.0, 0.5, 7.0, 2.0];
        for (i, f) in fs.iter().enumerate() {
            assert!(open.push(OpenEntry {
                f: *f,
                t: i as u32 % 3,
                node: i as u32
            }));
        }
        assert!(!open.push(OpenEntry {
            f: 0.0,
            t: 0,
            node: 99
        }));
        let mut last = OpenEntry {
            f: f64::NEG_INFINITY,
            t: u32::MAX,
            node: 0,
        };
        let mut n = 0;
        while let Some(e) = open.pop() {
            assert!(!e.before(&last), "{e:?} popped after {last:?}");
            last = e;
            n += 1;
        }
        assert_eq!(n, 8);
    }
}
