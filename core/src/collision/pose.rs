//! An arm's collision capsules placed in the world at one configuration ([`ArmPose`]), and
//! the checks of one placing: against obstacles, the arm's own links and another arm. A leaf
//! of the collision module: the motion checks and the batched kernel place arms with it.

use nalgebra::Vector3;

use crate::geometry::{Aabb, Capsule, Contact, Obstacle};
use crate::model::{Frame, Models, MAX_ARM_CAPSULES, MAX_LINK_FRAMES};
use crate::tool::{Tool, MAX_TOOL_CAPSULES};

/// Most capsules of one arm with its tool.
pub const MAX_POSE_CAPSULES: usize = MAX_ARM_CAPSULES + MAX_TOOL_CAPSULES;

// Base-link capsules and capsule pairs are kept as bit sets.
const _: () = assert!(MAX_POSE_CAPSULES <= u32::BITS as usize);

/// An arm's collision capsules in the world at one configuration: the model's link capsules,
/// then its tool's.
#[derive(Clone, Copy, Debug)]
pub struct ArmPose {
    /// In the order of `Model::CAPSULES`, then the tool's; the first `len` are used.
    pub(super) capsules: [Capsule; MAX_POSE_CAPSULES],
    pub(super) boxes: [Aabb; MAX_POSE_CAPSULES],
    pub(super) len: usize,
    /// How many of them are link capsules (the rest are the tool's).
    pub(super) links: usize,
    /// Bit `i` set: capsule `i` is on the base link, which is mounted and so never checked
    /// against obstacles.
    pub(super) on_base: u32,
    pub(super) self_pairs: &'static [(u8, u8)],
    /// Link capsules every tool capsule is checked against (`Model::TOOL_SELF_CAPSULES`).
    pub(super) tool_self: &'static [u8],
    /// Around all capsules, and around those off the base link.
    pub(super) aabb: Aabb,
    pub(super) moving_aabb: Aabb,
}

impl ArmPose {
    /// An arm with no capsules: it collides with nothing.
    pub const EMPTY: ArmPose = ArmPose {
        capsules: [Capsule::new(
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 0.0),
            0.0,
        ); MAX_POSE_CAPSULES],
        boxes: [Aabb::EMPTY; MAX_POSE_CAPSULES],
        len: 0,
        links: 0,
        on_base: 0,
        self_pairs: &[],
        tool_self: &[],
        aabb: Aabb::EMPTY,
        moving_aabb: Aabb::EMPTY,
    };

    /// The capsules of model `model` of `M` at configuration `q`, its base frame at `base` in
    /// the world, carrying `tool`.
    pub fn new<M: Models<D>, const D: usize>(
        model: u8,
        base: &Frame,
        tool: &Tool,
        q: &[f64; D],
    ) -> ArmPose {
        Self::new_only::<M, D>(model, base, tool, q, u32::MAX)
    }

    /// [`ArmPose::new`] with only the capsules whose bit is set in `only` placed (the boxes
    /// around the arm are around those): the others are empty and meet nothing. A sweep that
    /// has ruled most capsule pairs out places just the rest.
    pub fn new_only<M: Models<D>, const D: usize>(
        model: u8,
        base: &Frame,
        tool: &Tool,
        q: &[f64; D],
        only: u32,
    ) -> ArmPose {
        let mut pose = ArmPose::EMPTY;
        pose.place_only::<M, D>(model, base, tool, q, only);
        pose
    }

    /// [`ArmPose::new`] into this pose's storage: the same pose, without building a new one
    /// (about 2 KB) for each placing in a loop.
    pub fn place<M: Models<D>, const D: usize>(
        &mut self,
        model: u8,
        base: &Frame,
        tool: &Tool,
        q: &[f64; D],
    ) {
        self.place_only::<M, D>(model, base, tool, q, u32::MAX);
    }

    /// [`ArmPose::new_only`] into this pose's storage. Capsules past the arm's count are left
    /// as they are: nothing reads past `len`.
    pub fn place_only<M: Models<D>, const D: usize>(
        &mut self,
        model: u8,
        base: &Frame,
        tool: &Tool,
        q: &[f64; D],
        only: u32,
    ) {
        const { M::CHECKED };
        let mut frames = [Frame::IDENTITY; MAX_LINK_FRAMES];
        let linked = &mut frames[..M::link_names(model).len()];
        let tool_frame = M::link_frames(model, q, linked);
        let capsules = M::capsules(model);
        let links = capsules.len();
        // Into the world once per link that carries a capsule placed, not once per capsule;
        // not at all for an arm whose base frame is the world's (composing with the identity
        // changes at most the sign of a zero).
        let flange = if at_origin(base) {
            tool_frame
        } else {
            let carried =
                bits(only & ((1 << links) - 1)).fold(0u32, |m, i| m | 1 << capsules[i].link);
            for l in bits(carried) {
                linked[l] = base.compose(&linked[l]);
            }
            base.compose(&tool_frame)
        };
        self.len = links + tool.capsules().len();
        self.links = links;
        self.self_pairs = M::self_pairs(model);
        self.tool_self = M::tool_self_capsules(model);
        // The boxes around the arm gathered in locals and stored once: updated in place, each
        // capsule's would wait on the last one's store.
        let (mut still, mut moving, mut on_base) = (Aabb::EMPTY, Aabb::EMPTY, 0);
        let placed = |frame: &Frame, a: &[f64; 3], b: &[f64; 3], radius: f64| {
            let capsule =
                Capsule::new(frame.apply(&(*a).into()), frame.apply(&(*b).into()), radius);
            (capsule, capsule.aabb())
        };
        for i in bits(only & ((1 << links) - 1)) {
            let c = &capsules[i];
            let (capsule, aabb) = placed(&frames[usize::from(c.link)], &c.a, &c.b, c.radius);
            (self.capsules[i], self.boxes[i]) = (capsule, aabb);
            if c.link == 0 {
                on_base |= 1 << i;
                still = still.union(&aabb);
            } else {
                moving = moving.union(&aabb);
            }
        }
        for (k, c) in tool.capsules().iter().enumerate() {
            if only & (1 << (links + k)) != 0 {
                let (capsule, aabb) = placed(&flange, &c.a, &c.b, c.radius);
                (self.capsules[links + k], self.boxes[links + k]) = (capsule, aabb);
                moving = moving.union(&aabb);
            }
        }
        for i in bits(!only & ((1u64 << self.len) - 1) as u32) {
            self.capsules[i] = ArmPose::EMPTY.capsules[0];
            self.boxes[i] = Aabb::EMPTY;
        }
        (self.aabb, self.moving_aabb) = (moving.union(&still), moving);
        self.on_base = on_base;
    }

    /// The world capsules, in the order of `Model::CAPSULES`, then the tool's.
    pub fn capsules(&self) -> &[Capsule] {
        &self.capsules[..self.len]
    }

    /// The box around capsule `i` (empty for one not placed).
    pub fn capsule_box(&self, i: usize) -> Aabb {
        self.boxes[i]
    }

    /// Which tool capsule capsule `i` is (`None`: a link capsule).
    pub fn tool_capsule(&self, i: usize) -> Option<usize> {
        (self.links..self.len).contains(&i).then(|| i - self.links)
    }

    /// Whether capsule `i` is on the base link (mounted, never checked against obstacles).
    pub fn on_base(&self, i: usize) -> bool {
        self.on_base & (1 << i) != 0
    }

    /// The self-collision pairs (capsule indices): the model's link pairs, then each tool
    /// capsule with each link capsule it may hit.
    pub(super) fn self_pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        let links = self.self_pairs.iter().map(|&(a, b)| (a.into(), b.into()));
        let tool = (self.links..self.len)
            .flat_map(|t| self.tool_self.iter().map(move |&c| (t, usize::from(c))));
        links.chain(tool)
    }

    /// Bounding box of the whole arm.
    pub fn aabb(&self) -> &Aabb {
        &self.aabb
    }

    /// Index of the first obstacle that a capsule off the base link comes closer to than
    /// `margin` (or meets).
    pub fn obstacle_hit(&self, obstacles: &[Obstacle], margin: f64) -> Option<usize> {
        obstacles.iter().position(|o| {
            let ob = o.aabb();
            ob.near(&self.moving_aabb, margin)
                && (0..self.len).any(|i| {
                    !self.on_base(i)
                        && self.boxes[i].near(&ob, margin)
                        && o.hits_capsule(&self.capsules[i], margin)
                })
        })
    }

    /// The first of the self-collision pairs (capsule indices; a tool capsule comes first in
    /// its pairs) closer than `margin`.
    pub fn self_hit(&self, margin: f64) -> Option<(usize, usize)> {
        self.self_pairs()
            .find(|&(a, b)| self.pair_hits(a, self, b, margin))
    }

    /// Whether capsule `i` of this arm and capsule `j` of `other` (this arm too, for a self
    /// pair) come closer than `margin`: their boxes first, then the capsules.
    #[inline]
    pub(super) fn pair_hits(&self, i: usize, other: &ArmPose, j: usize, margin: f64) -> bool {
        self.pair_contact(i, other, j, margin) != Contact::Clear
    }

    /// [`ArmPose::pair_hits`], telling a touch from a near miss.
    #[inline]
    pub(super) fn pair_contact(&self, i: usize, other: &ArmPose, j: usize, margin: f64) -> Contact {
        if self.boxes[i].near(&other.boxes[j], margin) {
            self.capsules[i].contact(&other.capsules[j], margin)
        } else {
            Contact::Clear
        }
    }

    /// Whether capsule `i` of the arm at `ends` and capsule `j` of `other` (the same arm, for
    /// a self pair) may meet over a motion on which their points travel `travel` towards each
    /// other in all: clearance falls by at most that from either end, so clearances at the
    /// ends adding up to more rule contact out (`Clear`); overlapping at an end is a `Touch`.
    /// Boxes first (a lower bound on the distance), then the capsules.
    pub(super) fn pair_contact_over(
        ends: [&ArmPose; 2],
        i: usize,
        other: [&ArmPose; 2],
        j: usize,
        travel: f64,
    ) -> Contact {
        Self::pair_contact_within(ends, i, other, j, travel, || travel)
    }

    /// [`ArmPose::pair_contact_over`] for the smaller of two bounds on the travel: `travel`,
    /// and `tighter()`, computed only for a pair that the first leaves in question.
    #[inline]
    pub(super) fn pair_contact_within(
        ends: [&ArmPose; 2],
        i: usize,
        other: [&ArmPose; 2],
        j: usize,
        travel: f64,
        tighter: impl FnOnce() -> f64,
    ) -> Contact {
        if Self::boxes_apart(ends, i, other, j, travel) {
            return Contact::Clear;
        }
        let clearance = |k: usize| ends[k].capsules[i].signed_distance(&other[k].capsules[j]);
        let (c0, c1) = (clearance(0), clearance(1));
        if c0 < 0.0 || c1 < 0.0 {
            Contact::Touch
        } else if c0 + c1 > travel || c0 + c1 > tighter() {
            Contact::Clear
        } else {
            Contact::Near
        }
    }

    /// Whether the boxes of capsule `i` of the arm at `ends` and of capsule `j` of `other`
    /// are farther apart at the two ends, added up, than `travel`: the first test of
    /// [`ArmPose::pair_contact_over`], which rules contact out.
    #[inline]
    pub(super) fn boxes_apart(
        ends: [&ArmPose; 2],
        i: usize,
        other: [&ArmPose; 2],
        j: usize,
        travel: f64,
    ) -> bool {
        Aabb::apart_over(
            ends.map(|e| &e.boxes[i]),
            other.map(|e| &e.boxes[j]),
            travel,
        )
    }

    /// The first pair of capsules (this arm's, the other's), base links included, closer
    /// than `margin`.
    pub fn arm_hit(&self, other: &ArmPose, margin: f64) -> Option<(usize, usize)> {
        if !self.aabb.near(&other.aabb, margin) {
            return None;
        }
        (0..self.len)
            .filter(|&i| self.boxes[i].near(&other.aabb, margin))
            .find_map(|i| {
                (0..other.len)
                    .find(|&j| self.pair_hits(i, other, j, margin))
                    .map(|j| (i, j))
            })
    }

    /// A lower bound on the distance between the two arms' volumes (the smallest signed
    /// distance of their capsule pairs; each pair's boxes first, which skip most of them).
    pub fn clearance(&self, other: &ArmPose) -> f64 {
        let whole = self.aabb.distance(&other.aabb);
        if whole > 0.0 {
            return whole;
        }
        let mut least = f64::INFINITY;
        for (a, box_a) in self.capsules().iter().zip(&self.boxes) {
            for (b, box_b) in other.capsules().iter().zip(&other.boxes) {
                // Boxes apart by more than the least so far hold no closer pair; touching
                // boxes may hold a deeper overlap.
                if box_a.distance(box_b) <= least.max(0.0) {
                    least = least.min(a.signed_distance(b));
                }
            }
        }
        least
    }

    /// Whether `p` lies in any link volume (base included).
    pub fn contains_point(&self, p: &Vector3<f64>) -> bool {
        self.aabb.contains_point(p) && self.capsules().iter().any(|c| c.contains_point(p))
    }

    /// A point inside both arms inflated by `margin / 2` each, when they come closer than
    /// `margin` (inside both arms themselves for `margin = 0`): the witness of the most
    /// deeply overlapping capsule pair (see [`Capsule::witness`]), so that a constraint keeping
    /// one arm off it pushes the arms apart where they collide most.
    pub fn witness(&self, other: &ArmPose, margin: f64) -> Option<Vector3<f64>> {
        let grow = |c: &Capsule| Capsule {
            radius: c.radius + 0.5 * margin,
            ..*c
        };
        let mut deepest: Option<(f64, Vector3<f64>)> = None;
        for (a, box_a) in self.capsules().iter().zip(&self.boxes) {
            for (b, box_b) in other.capsules().iter().zip(&other.boxes) {
                if !box_a.near(box_b, margin) {
                    continue;
                }
                let depth = margin - a.signed_distance(b);
                if depth > deepest.map_or(0.0, |(d, _)| d) {
                    if let Some(p) = grow(a).witness(&grow(b)) {
                        deepest = Some((depth, p));
                    }
                }
            }
        }
        deepest.map(|(_, p)| p)
    }
}

/// Whether `base` is the world frame, so that placing in it skips composing with it.
#[inline]
pub(super) fn at_origin(base: &Frame) -> bool {
    *base == Frame::IDENTITY
}

/// The indices of the set bits of `m`, lowest first.
pub(super) fn bits(m: u32) -> impl Iterator<Item = usize> {
    bits64(u64::from(m))
}

/// The indices of the set bits of `m`, lowest first.
pub(super) fn bits64(mut m: u64) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        (m != 0).then(|| {
            let i = m.trailing_zeros() as usize;
            m &= m - 1;
            i
        })
    })
}
