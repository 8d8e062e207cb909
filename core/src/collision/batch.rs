//! The batched kernel: an arm at [`LANES`] configurations at once ([`ArmLanes`]), its
//! capsules and their boxes kept structure-of-arrays (one [`F64s`] per coordinate, a lane per
//! configuration), and the checks of [`ArmPose`] over every lane: obstacles, self-collision
//! and another arm, each lane left alone once it is known to hit.
//!
//! Lane `k` is, bit for bit, the [`ArmPose`] of configuration `k`: the generated kinematics
//! run once over [`F64s`] ([`crate::model::Model::link_frames_lanes`]), and the placing here
//! takes [`ArmPose::place_only`]'s operations in its order ([`FrameOf`]). The checks test the
//! same boxes with the same comparisons in SIMD, a link's box first (around its capsules'
//! boxes: [`super::groups`]), then the exact query on what is left: capsule pairs in SIMD
//! with the scalar code's operations ([`Segments::hits`]), obstacles on the lanes that a
//! cheap conservative test in SIMD does not clear ([`Segments::apart_from`]): in SIMD where
//! the scalar query needs no iteration ([`Segments::obstacle_decided`]), else with the scalar
//! query ([`Obstacle::hits_capsule`]). So a lane hits exactly when the [`ArmPose`] check of
//! its configuration does (`core/tests/batch.rs` checks it on random cases, hits and misses
//! alike). Whether any lane hits can be asked while placing ([`ArmLanes::place_any_hit`]),
//! which stops at the first hit.

use core::ops::ControlFlow;

use nalgebra::Vector3;

use super::groups::{Groups, MAX_GROUPS};
use super::pose::{at_origin, bits, ArmPose, MAX_POSE_CAPSULES};
pub(super) use crate::geometry::lanes::Point;
use crate::geometry::lanes::Segments;
use crate::geometry::{Aabb, Capsule, Obstacle};
use crate::lanes::{lane, lanes_of, max, min, F64s, Mask, LANES};
use crate::model::{Frame, FrameOf, Models};
use crate::tool::Tool;

/// An axis-aligned box per lane, as [`Aabb`]: `min..=max`.
#[derive(Clone, Copy, Debug)]
pub struct Boxes {
    /// The least corner.
    pub min: Point,
    /// The greatest corner.
    pub max: Point,
}

impl Boxes {
    /// [`Aabb::EMPTY`] in every lane.
    pub const EMPTY: Boxes = Boxes {
        min: [F64s::splat(f64::INFINITY); 3],
        max: [F64s::splat(f64::NEG_INFINITY); 3],
    };

    /// `b` in every lane.
    pub fn splat(b: &Aabb) -> Boxes {
        Boxes {
            min: core::array::from_fn(|i| F64s::splat(b.min[i])),
            max: core::array::from_fn(|i| F64s::splat(b.max[i])),
        }
    }

    /// [`Aabb::union`], lane by lane.
    #[inline(always)]
    fn union(&self, other: &Boxes) -> Boxes {
        Boxes {
            min: core::array::from_fn(|i| min(self.min[i], other.min[i])),
            max: core::array::from_fn(|i| max(self.max[i], other.max[i])),
        }
    }

    /// The lanes where [`Aabb::near`] holds.
    #[inline(always)]
    pub fn near(&self, other: &Boxes, margin: f64) -> Mask {
        if margin == 0.0 {
            // Adding a zero changes at most the sign of a zero, which `<` does not see.
            self.near_grown(other, |v| v)
        } else {
            let m = F64s::splat(margin);
            self.near_grown(other, |v| v + m)
        }
    }

    /// The lanes where each box's least corner is below the other's greatest, `grow`n.
    #[inline(always)]
    fn near_grown(&self, other: &Boxes, grow: impl Fn(F64s) -> F64s) -> Mask {
        // One mask of all six comparisons, turned into bits once.
        let axis = |i: usize| {
            self.min[i].simd_lt(grow(other.max[i])) & other.min[i].simd_lt(grow(self.max[i]))
        };
        (axis(0) & axis(1) & axis(2)).to_bitmask() as Mask
    }

    /// Lane `k`'s box.
    pub fn lane(&self, k: usize) -> Aabb {
        Aabb {
            min: Vector3::from_fn(|i, _| lane(self.min[i], k)),
            max: Vector3::from_fn(|i, _| lane(self.max[i], k)),
        }
    }
}

/// The obstacles a batched check keeps the arm clear of, and by how much.
#[derive(Clone, Copy, Debug)]
pub struct Scene<'a> {
    /// The obstacles.
    pub obstacles: &'a [Obstacle],
    /// Their boxes made once for many checks, as a planner can for a fixed scene:
    /// `boxes[n]` is [`Obstacle::aabb`] of `obstacles[n]` (for an obstacle past its end, made
    /// by each check).
    pub boxes: &'a [Aabb],
    /// The least distance kept (m).
    pub margin: f64,
}

/// An arm's collision capsules in the world at [`LANES`] configurations: lane `k` of every
/// field is the [`ArmPose`] of configuration `k`.
#[derive(Clone, Copy, Debug)]
pub struct ArmLanes {
    /// Per capsule (the model's, then the tool's), the ends of its axis.
    a: [Point; MAX_POSE_CAPSULES],
    b: [Point; MAX_POSE_CAPSULES],
    radius: [f64; MAX_POSE_CAPSULES],
    boxes: [Boxes; MAX_POSE_CAPSULES],
    len: usize,
    links: usize,
    on_base: u32,
    self_pairs: &'static [(u8, u8)],
    tool_self: &'static [u8],
    aabb: Boxes,
    moving_aabb: Boxes,
    /// The lanes holding a configuration; the others repeat one of them and are never
    /// reported.
    lanes: Mask,
    /// The capsules by link, and around each link's capsules a box.
    groups: Groups,
    group_boxes: [Boxes; MAX_GROUPS],
    /// The capsules placed.
    only: u32,
}

impl ArmLanes {
    /// No configuration.
    pub const EMPTY: ArmLanes = ArmLanes {
        a: [[F64s::splat(0.0); 3]; MAX_POSE_CAPSULES],
        b: [[F64s::splat(0.0); 3]; MAX_POSE_CAPSULES],
        radius: [0.0; MAX_POSE_CAPSULES],
        boxes: [Boxes::EMPTY; MAX_POSE_CAPSULES],
        len: 0,
        links: 0,
        on_base: 0,
        self_pairs: &[],
        tool_self: &[],
        aabb: Boxes::EMPTY,
        moving_aabb: Boxes::EMPTY,
        lanes: 0,
        groups: Groups::EMPTY,
        group_boxes: [Boxes::EMPTY; MAX_GROUPS],
        only: 0,
    };

    /// The lanes holding a configuration.
    pub fn lanes(&self) -> Mask {
        self.lanes
    }

    /// Leaves only the lanes of `keep` to the checks (the others are never reported).
    pub fn keep(&mut self, keep: Mask) {
        self.lanes &= keep;
    }

    /// Places the arm of model `model` of `M`, its base frame at `base`, carrying `tool`, at
    /// the configurations `qs` (at most [`LANES`]; lane `k` holds `qs[k]`), as
    /// [`ArmPose::place`] each.
    pub fn place<M: Models<D>, const D: usize>(
        &mut self,
        model: u8,
        base: &Frame,
        tool: &Tool,
        qs: &[[f64; D]],
    ) {
        let n = qs.len().min(LANES);
        let Some(last) = n.checked_sub(1) else {
            self.lanes = 0;
            return;
        };
        let q = core::array::from_fn(|j| F64s::new(core::array::from_fn(|k| qs[k.min(last)][j])));
        self.place_lanes::<M, D>(model, base, tool, &q, ((1u16 << n) - 1) as Mask, u32::MAX);
    }

    /// Places the arm at configuration `q` (lane `k` of each joint's [`F64s`] is
    /// configuration `k`), the lanes `lanes` reported, only the capsules whose bit is set in
    /// `only` placed: [`ArmPose::place_only`] lane by lane.
    pub fn place_lanes<M: Models<D>, const D: usize>(
        &mut self,
        model: u8,
        base: &Frame,
        tool: &Tool,
        q: &[F64s; D],
        lanes: Mask,
        only: u32,
    ) {
        self.begin::<M, D>(model, tool, lanes, only);
        let _ = place_ends::<M, D>(model, base, tool, q, only, |i, a, b, radius, on_base| {
            self.put(i, a, b, radius, on_base);
            ControlFlow::Continue(())
        });
        self.finish();
    }

    /// [`ArmLanes::place_lanes`] of every capsule, answering [`ArmLanes::any_hit`] on the
    /// way, the likeliest hits first, stopping at the first hit in any lane.
    ///
    /// - The links from the first one paired with an earlier link for self-collision
    ///   (the forearm on the Panda) to the tool, each checked as soon as it is placed
    ///   against the obstacles and against those of them it forms pairs with; the kinematics
    ///   stop at the first hit. These links reach farthest: on the Panda's random
    ///   configurations the forearm decides 55 of 64 batches of 8, so a batch that holds a
    ///   hit is rarely placed whole.
    /// - Then the links before them, nearest the base (the first of all never against
    ///   obstacles): placed (the kinematics again, up to the last of them), their
    ///   self-collision pairs, then the obstacles.
    ///
    /// True when some lane hits: then the arm is left part placed, with no lane (no later
    /// check reports anything). False: the arm is placed as `place_lanes` places it, every
    /// lane clear of the obstacles and itself.
    pub fn place_any_hit<M: Models<D>, const D: usize>(
        &mut self,
        model: u8,
        base: &Frame,
        tool: &Tool,
        q: &[F64s; D],
        lanes: Mask,
        scene: &Scene<'_>,
    ) -> bool {
        self.begin::<M, D>(model, tool, lanes, u32::MAX);
        let near_base = self.groups.near_base;
        let near = bits(near_base).fold(0, |m, g| m | self.groups.members[g]);
        // Each group's capsules come in order, the first setting its box (`put`): a group
        // is placed whole in one pass or the other.
        let far = place_ends::<M, D>(model, base, tool, q, !near, |i, a, b, radius, on_base| {
            self.put(i, a, b, radius, on_base);
            let g = usize::from(self.groups.group[i]);
            // A link's checks once its last capsule is placed.
            let last = u32::BITS - self.groups.members[g].leading_zeros() == i as u32 + 1;
            if last && self.far_group_hits(g, scene) {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        });
        let hit = far.is_break()
            || near != 0 && {
                let last = (u32::BITS - 1 - near.leading_zeros()) as usize;
                let _ = place_ends::<M, D>(model, base, tool, q, near, |i, a, b, radius, on| {
                    self.put(i, a, b, radius, on);
                    if i == last {
                        ControlFlow::Break(())
                    } else {
                        ControlFlow::Continue(())
                    }
                });
                let groups = near_base & !1;
                let around = bits(groups).fold(Boxes::EMPTY, |b, g| b.union(&self.group_boxes[g]));
                self.self_hits_until(scene.margin, 0, near_base, u32::MAX) != 0
                    || self.obstacle_hits_until(scene, 0, Some(&around), groups) != 0
            };
        if hit {
            self.lanes = 0;
        } else {
            self.finish();
        }
        hit
    }

    /// Whether group `g`, placed, hits in some lane, `g` not near the base: its capsules
    /// against the obstacles (unless it is the base link's, in an arm with no link near the
    /// base), then its self-collision pairs with the groups before it not near the base and
    /// itself.
    fn far_group_hits(&self, g: usize, scene: &Scene<'_>) -> bool {
        let groups = 1 << g;
        let far = !self.groups.near_base;
        (g != 0 && self.obstacle_hits_until(scene, 0, None, groups) != 0)
            || self.self_hits_until(scene.margin, 0, far, groups) != 0
    }

    /// The arm's fields of model `model` carrying `tool`, no capsule placed yet (those not
    /// in `only` empty, as they stay).
    fn begin<M: Models<D>, const D: usize>(
        &mut self,
        model: u8,
        tool: &Tool,
        lanes: Mask,
        only: u32,
    ) {
        self.len = M::capsules(model).len() + tool.capsules().len();
        self.links = M::capsules(model).len();
        self.self_pairs = M::self_pairs(model);
        self.tool_self = M::tool_self_capsules(model);
        let capsules = M::capsules(model);
        (self.groups).update(capsules, self.self_pairs, self.tool_self, self.len);
        // A group's box is set by its first capsule placed: the first of all when every
        // capsule is placed (`put`), else from empty.
        self.only = only;
        if only != u32::MAX {
            for g in bits(self.groups.used) {
                self.group_boxes[g] = Boxes::EMPTY;
            }
        }
        self.on_base = 0;
        self.lanes = lanes;
        for i in 0..self.len {
            if only & (1 << i) == 0 {
                (self.a[i], self.b[i]) = (ArmLanes::EMPTY.a[0], ArmLanes::EMPTY.b[0]);
                self.radius[i] = 0.0;
                self.boxes[i] = Boxes::EMPTY;
            }
        }
    }

    /// Capsule `i` placed: its ends, its box, the arm's boxes grown by it.
    #[inline(always)]
    fn put(&mut self, i: usize, a: &Point, b: &Point, radius: f64, on_base: bool) {
        // `Capsule::aabb`.
        let r = F64s::splat(radius);
        let aabb = Boxes {
            min: core::array::from_fn(|i| min(a[i], b[i]) - r),
            max: core::array::from_fn(|i| max(a[i], b[i]) + r),
        };
        (self.a[i], self.b[i], self.radius[i]) = (*a, *b, radius);
        self.boxes[i] = aabb;
        let g = usize::from(self.groups.group[i]);
        self.group_boxes[g] =
            if self.only == u32::MAX && self.groups.members[g].trailing_zeros() == i as u32 {
                aabb
            } else {
                self.group_boxes[g].union(&aabb)
            };
        if on_base {
            self.on_base |= 1 << i;
        }
    }

    /// The boxes around the arm, from its groups': the base link's is group 0.
    fn finish(&mut self) {
        let mut moving = Boxes::EMPTY;
        for g in bits(self.groups.used & !1) {
            moving = moving.union(&self.group_boxes[g]);
        }
        self.moving_aabb = moving;
        self.aabb = moving.union(&self.group_boxes[0]);
    }

    /// The axes of capsule `i`.
    #[inline(always)]
    fn segments(&self, i: usize) -> Segments {
        Segments {
            a: self.a[i],
            b: self.b[i],
        }
    }

    /// Capsule `i` in lane `k`.
    #[inline]
    pub fn capsule(&self, i: usize, k: usize) -> Capsule {
        let (a, b) = (&self.a[i], &self.b[i]);
        Capsule::new(
            Vector3::new(lane(a[0], k), lane(a[1], k), lane(a[2], k)),
            Vector3::new(lane(b[0], k), lane(b[1], k), lane(b[2], k)),
            self.radius[i],
        )
    }

    /// Lane `k` as an [`ArmPose`].
    pub fn pose(&self, k: usize) -> ArmPose {
        let mut pose = ArmPose {
            len: self.len,
            links: self.links,
            on_base: self.on_base,
            self_pairs: self.self_pairs,
            tool_self: self.tool_self,
            aabb: self.aabb.lane(k),
            moving_aabb: self.moving_aabb.lane(k),
            ..ArmPose::EMPTY
        };
        for i in 0..self.len {
            pose.capsules[i] = self.capsule(i, k);
            pose.boxes[i] = self.boxes[i].lane(k);
        }
        pose
    }

    /// The lanes where a capsule off the base link comes closer to an obstacle than
    /// `margin`: [`ArmPose::obstacle_hit`]`.is_some()`, lane by lane.
    pub fn obstacle_hits(&self, obstacles: &[Obstacle], margin: f64) -> Mask {
        let scene = Scene {
            obstacles,
            boxes: &[],
            margin,
        };
        self.obstacle_hits_boxed(&scene)
    }

    /// [`ArmLanes::obstacle_hits`] of `scene`, its obstacles' boxes made once for many calls.
    pub fn obstacle_hits_boxed(&self, scene: &Scene<'_>) -> Mask {
        // The base link's group (0) is never checked against obstacles.
        let groups = self.groups.used & !1;
        self.obstacle_hits_until(scene, self.lanes, Some(&self.moving_aabb), groups)
    }

    /// The lanes where a self-collision pair comes closer than `margin`:
    /// [`ArmPose::self_hit`]`.is_some()`, lane by lane.
    pub fn self_hits(&self, margin: f64) -> Mask {
        self.self_hits_until(margin, self.lanes, u32::MAX, u32::MAX)
    }

    /// Whether any lane's configuration comes closer than the scene's margin to one of its
    /// obstacles or to itself: `obstacle_hits(..) | self_hits(..) != 0`, stopping at the first
    /// hit.
    pub fn any_hit(&self, scene: &Scene<'_>) -> bool {
        let groups = self.groups.used & !1;
        self.lanes != 0
            && (self.obstacle_hits_until(scene, 0, Some(&self.moving_aabb), groups) != 0
                || self.self_hits_until(scene.margin, 0, u32::MAX, u32::MAX) != 0)
    }

    /// [`ArmLanes::obstacle_hits`] of the capsules of `groups` (not the base link's), all
    /// within `around` if given, stopping once a lane outside `wait` hits (with `wait` the lanes,
    /// once every lane does): then some hitting lanes may be missing.
    fn obstacle_hits_until(
        &self,
        &Scene {
            obstacles,
            boxes,
            margin,
        }: &Scene<'_>,
        wait: Mask,
        around: Option<&Boxes>,
        groups: u32,
    ) -> Mask {
        let mut hit: Mask = 0;
        for (n, o) in obstacles.iter().enumerate() {
            let ob = Boxes::splat(&boxes.get(n).copied().unwrap_or_else(|| o.aabb()));
            let near = around.map_or(self.lanes, |a| ob.near(a, margin) & self.lanes) & !hit;
            if near == 0 {
                continue;
            }
            for g in bits(groups) {
                let near = self.group_boxes[g].near(&ob, margin) & near & !hit;
                if near == 0 {
                    continue;
                }
                // A group of one capsule has that capsule's box, bit for bit.
                let one = self.groups.members[g].count_ones() == 1;
                for i in bits(self.groups.members[g] & !self.on_base) {
                    let mut near = if one {
                        near
                    } else {
                        self.boxes[i].near(&ob, margin) & near & !hit
                    };
                    if near != 0 {
                        near &= !self.segments(i).apart_from(o, self.radius[i] + margin);
                    }
                    if near.count_ones() > 2 {
                        // In SIMD what needs no iteration, where enough lanes share it to
                        // pay for the whole batch's; the scalar query for the rest.
                        let segments = self.segments(i);
                        let (hits, clear) = segments.obstacle_decided(o, self.radius[i], margin);
                        hit |= near & hits;
                        if hit & !wait != 0 {
                            return hit;
                        }
                        near &= !(hits | clear);
                    }
                    for k in lanes_of(near) {
                        if o.hits_capsule(&self.capsule(i, k), margin) {
                            hit |= 1 << k;
                            if !wait & (1 << k) != 0 {
                                return hit;
                            }
                        }
                    }
                }
            }
            if hit == self.lanes {
                break;
            }
        }
        hit
    }

    /// [`ArmLanes::self_hits`] of the pairs whose first group is in `earlier` and whose
    /// second (the later one, or the same) is in `later`, stopping as
    /// [`ArmLanes::obstacle_hits_until`] does.
    fn self_hits_until(&self, margin: f64, wait: Mask, earlier: u32, later: u32) -> Mask {
        let mut hit: Mask = 0;
        let groups = &self.groups;
        for g in bits(groups.used & earlier) {
            for h in bits(groups.pair_groups[g] & later) {
                let near = self.group_boxes[g].near(&self.group_boxes[h], margin);
                let near = near & self.lanes & !hit;
                if near == 0 {
                    continue;
                }
                for (a, b) in groups.pairs(g, h) {
                    let near = self.boxes[a].near(&self.boxes[b], margin) & near & !hit;
                    if near != 0 {
                        let reach = self.radius[a] + self.radius[b];
                        hit |= near & self.segments(a).hits(&self.segments(b), reach, margin);
                        if hit == self.lanes || hit & !wait != 0 {
                            return hit;
                        }
                    }
                }
            }
        }
        hit
    }

    /// The lanes where this arm comes closer than `margin` to `other` in the same lane, base
    /// links included: [`ArmPose::arm_hit`]`.is_some()`, lane by lane. Of the lanes both
    /// hold.
    pub fn arm_hits(&self, other: &ArmLanes, margin: f64) -> Mask {
        let near = self.aabb.near(&other.aabb, margin) & self.lanes & other.lanes;
        let mut hit: Mask = 0;
        if near == 0 {
            return 0;
        }
        // Link by link (a link's box around its capsules'), then the links' capsules.
        for g in bits(self.groups.used) {
            let row = self.group_boxes[g].near(&other.aabb, margin) & near;
            if row == 0 {
                continue;
            }
            for h in bits(other.groups.used) {
                let cell = self.group_boxes[g].near(&other.group_boxes[h], margin) & row & !hit;
                if cell == 0 {
                    continue;
                }
                for i in bits(self.groups.members[g]) {
                    for j in bits(other.groups.members[h]) {
                        let n = self.boxes[i].near(&other.boxes[j], margin) & cell & !hit;
                        if n != 0 {
                            let reach = self.radius[i] + other.radius[j];
                            hit |= n & self.segments(i).hits(&other.segments(j), reach, margin);
                        }
                    }
                }
                if hit == near {
                    return hit;
                }
            }
        }
        hit
    }

    /// [`ArmLanes::arm_hits`] against one pose in every lane (an arm standing).
    pub fn arm_hits_pose(&self, other: &ArmPose, margin: f64) -> Mask {
        let capsule = |j: usize| {
            let c = &other.capsules[j];
            let point = |p: &Vector3<f64>| [0, 1, 2].map(|i| F64s::splat(p[i]));
            let segments = Segments {
                a: point(&c.segment.a),
                b: point(&c.segment.b),
            };
            (Boxes::splat(&other.boxes[j]), segments, c.radius)
        };
        let aabb = Boxes::splat(&other.aabb);
        self.arm_hits_with(self.lanes, &aabb, other.len, capsule, margin)
    }

    /// [`ArmPose::arm_hit`] over `lanes`, the other arm's `len` capsules given by `capsule(j)`
    /// (boxes, axes, radius) and its whole box by `aabb`.
    #[inline(always)]
    fn arm_hits_with(
        &self,
        lanes: Mask,
        aabb: &Boxes,
        len: usize,
        capsule: impl Fn(usize) -> (Boxes, Segments, f64),
        margin: f64,
    ) -> Mask {
        let near = self.aabb.near(aabb, margin) & lanes;
        let mut hit: Mask = 0;
        if near == 0 {
            return 0;
        }
        for i in 0..self.len {
            let row = self.boxes[i].near(aabb, margin) & near;
            if row == 0 {
                continue;
            }
            for j in 0..len {
                let (boxes, segments, radius) = capsule(j);
                let near = self.boxes[i].near(&boxes, margin) & row & !hit;
                if near != 0 {
                    let reach = self.radius[i] + radius;
                    hit |= near & self.segments(i).hits(&segments, reach, margin);
                }
            }
            if hit == near {
                break;
            }
        }
        hit
    }
}

/// Places the arm of model `model` of `M`, its base frame at `base`, carrying `tool`, at
/// configuration `q` (a lane each) and hands each capsule in `only`, in order, to
/// `each(index, a, b, radius, on the base link)`: [`ArmPose::place_only`]'s operations, lane
/// by lane. Stops, placing nothing more (the kinematics too), when `each` breaks.
#[inline(always)]
pub(super) fn place_ends<M: Models<D>, const D: usize>(
    model: u8,
    base: &Frame,
    tool: &Tool,
    q: &[F64s; D],
    only: u32,
    mut each: impl FnMut(usize, &Point, &Point, f64, bool) -> ControlFlow<()>,
) -> ControlFlow<()> {
    const { M::CHECKED };
    let world = !at_origin(base);
    let base = FrameOf::<F64s>::splat(base);
    let capsules = M::capsules(model);
    // Each link's capsules as its frame comes (they are in link order: `check_model`), the
    // frame into the world first, as `ArmPose::place_only` does for every link.
    let mut next = 0;
    let tool_frame = M::link_frames_lanes(model, q, |link: usize, f: &FrameOf<F64s>| {
        let on_link = |i: usize| capsules.get(i).is_some_and(|c| usize::from(c.link) == link);
        if !on_link(next) {
            return ControlFlow::Continue(());
        }
        // Into the world, where the base frame is not the world's (else the frame as it is,
        // not copied).
        let composed;
        let frame = if world {
            composed = base.compose(f);
            &composed
        } else {
            f
        };
        while on_link(next) {
            let c = &capsules[next];
            if only & (1 << next) != 0 {
                let (a, b) = (
                    frame.apply(&c.a.map(F64s::splat)),
                    frame.apply(&c.b.map(F64s::splat)),
                );
                each(next, &a, &b, c.radius, link == 0)?;
            }
            next += 1;
        }
        ControlFlow::Continue(())
    })?;
    let links = capsules.len();
    let tools = tool.capsules().iter().enumerate();
    if tools.clone().any(|(t, _)| only & (1 << (links + t)) != 0) {
        let flange = if world {
            base.compose(&tool_frame)
        } else {
            tool_frame
        };
        for (t, c) in tools.filter(|(t, _)| only & (1 << (links + t)) != 0) {
            let (a, b) = (
                flange.apply(&c.a.map(F64s::splat)),
                flange.apply(&c.b.map(F64s::splat)),
            );
            each(links + t, &a, &b, c.radius, false)?;
        }
    }
    ControlFlow::Continue(())
}
