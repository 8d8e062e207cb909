//! An arm's capsules grouped by link, for the batched kernel ([`super::ArmLanes`]): a box
//! around each link's capsules is tested before the capsules' own, against an obstacle or
//! against a link it forms self-collision pairs with, so that one test rules out every pair
//! of two links far apart. The boxes of a group are unions of its capsules' boxes (exact
//! minima and maxima), so a capsule near something lies in a group near it too: the answers
//! are those of testing every capsule.

use super::pose::{bits, MAX_POSE_CAPSULES};
use crate::model::{LinkCapsule, MAX_LINK_FRAMES};

/// Most groups: one per link frame, and one for the tool's capsules.
pub(super) const MAX_GROUPS: usize = MAX_LINK_FRAMES + 1;

// Groups and capsules are kept as bit sets.
const _: () = assert!(MAX_GROUPS <= u32::BITS as usize);

/// An arm's capsules by group, and its self-collision pairs by capsule and by group.
#[derive(Clone, Copy, Debug)]
pub(super) struct Groups {
    /// What these groups are of: the addresses of the model's capsules, self-collision pairs
    /// and tool pairs, and the count of capsules with the tool's.
    of: (usize, usize, usize, usize),
    /// Per capsule, its group: its link, or [`MAX_LINK_FRAMES`] for a tool capsule.
    pub(super) group: [u8; MAX_POSE_CAPSULES],
    /// Per group, its capsules (bit `i`: capsule `i`).
    pub(super) members: [u32; MAX_GROUPS],
    /// The groups that hold capsules.
    pub(super) used: u32,
    /// Per capsule, the capsules it forms a self-collision pair with.
    pub(super) partners: [u32; MAX_POSE_CAPSULES],
    /// Per group, the groups from it on (itself included) holding a partner of one of its
    /// capsules.
    pub(super) pair_groups: [u32; MAX_GROUPS],
    /// The groups before the first one paired with an earlier group: the links nearest the
    /// base, which move least. Pairs have both groups near the base or the later one not.
    pub(super) near_base: u32,
}

impl Groups {
    /// No arm.
    pub(super) const EMPTY: Groups = Groups {
        of: (0, 0, 0, 0),
        group: [0; MAX_POSE_CAPSULES],
        members: [0; MAX_GROUPS],
        used: 0,
        partners: [0; MAX_POSE_CAPSULES],
        pair_groups: [0; MAX_GROUPS],
        near_base: 0,
    };

    /// The groups of an arm with the model's `capsules` and self-collision `pairs`, and
    /// `len - capsules.len()` tool capsules, each paired with the link capsules `tool_self`.
    /// Kept as they are when they are of the same arm already (the model's tables are
    /// statics, known by their addresses).
    pub(super) fn update(
        &mut self,
        capsules: &'static [LinkCapsule],
        pairs: &'static [(u8, u8)],
        tool_self: &'static [u8],
        len: usize,
    ) {
        let of = (
            capsules.as_ptr() as usize,
            pairs.as_ptr() as usize,
            tool_self.as_ptr() as usize,
            len,
        );
        if self.of == of {
            return;
        }
        *self = Groups::EMPTY;
        self.of = of;
        let links = capsules.len();
        for i in 0..len {
            let group = capsules
                .get(i)
                .map_or(MAX_LINK_FRAMES, |c| usize::from(c.link));
            self.group[i] = group as u8;
            self.members[group] |= 1 << i;
            self.used |= 1 << group;
        }
        let tool = (links..len).flat_map(|t| tool_self.iter().map(move |&c| (t, usize::from(c))));
        let pairs = pairs.iter().map(|&(a, b)| (usize::from(a), usize::from(b)));
        for (a, b) in pairs.chain(tool) {
            self.partners[a] |= 1 << b;
            self.partners[b] |= 1 << a;
            let (g, h) = (self.group[a], self.group[b]);
            self.pair_groups[usize::from(g.min(h))] |= 1 << g.max(h);
        }
        // The first group paired with one before it.
        let later = (0..MAX_GROUPS).fold(0u32, |m, g| m | self.pair_groups[g] & !(1 << g));
        if later != 0 {
            self.near_base = self.used & ((1 << later.trailing_zeros()) - 1);
        }
    }

    /// The self-collision pairs between groups `g` and `h` (`g <= h`), each once: `(a, b)`
    /// with `a` in `g` and `b` in `h`.
    #[inline(always)]
    pub(super) fn pairs(&self, g: usize, h: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        bits(self.members[g]).flat_map(move |a| {
            // Within one group, each pair from its lower capsule.
            let after = if g == h {
                u32::MAX.checked_shl(a as u32 + 1).unwrap_or(0)
            } else {
                u32::MAX
            };
            bits(self.partners[a] & self.members[h] & after).map(move |b| (a, b))
        })
    }
}
