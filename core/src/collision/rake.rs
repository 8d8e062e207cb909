//! How a motion check places the arms between the ends of a motion: one configuration at a
//! time as the bisection asks for it, or a rake of them per call, placed in the lanes of one
//! batch ahead of the bisection ([`Placing`]).
//!
//! The bisection ([`super::refine`]) splits a part of the motion at its middle and checks its
//! halves, and their halves where that fails. A rake places, in one batched call, the middle
//! of a part, of its two halves and of its four quarters: the seven placings three levels of
//! the bisection may ask for. Every check then reads the same capsules, bit for bit, as when
//! placed alone ([`super::batch`]), so the two give the same answer; the rake costs one batch
//! where the bisection goes three levels down, and places some configurations no check reads
//! where it stops sooner.

use core::ops::ControlFlow;

use super::batch::{place_ends, Point};
use super::pose::{ArmPose, MAX_POSE_CAPSULES};
use nalgebra::Vector3;

use crate::geometry::Capsule;
use crate::lanes::{lane, F64s, LANES};
use crate::model::{Frame, Models};
use crate::tool::Tool;

/// How a motion check ([`super::Sweep`]) places the arms between the motion's ends. The
/// answers are the same either way; only the time differs. By default one at a time: the
/// bisection reads about two placings per arm between the ends of a 1-rad motion, where a
/// rake places seven (`docs/bench/collision.md` has both, and the planners with each).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Placing {
    /// One configuration at a time, as the bisection asks for it.
    #[default]
    Single,
    /// The middle of a part, of its halves and of its quarters, placed together in one
    /// batched call ahead of the bisection.
    Rake,
}

/// Parts of the motion one rake places the middle of: a part, its halves, its quarters. Part
/// `n`'s halves are parts `2n + 1` and `2n + 2`.
pub(super) const RAKE_PARTS: usize = 7;
const _: () = assert!(RAKE_PARTS <= LANES);

/// The capsule ends of one arm at up to [`LANES`] configurations along its motion, a lane
/// each: a rake's placings.
#[derive(Clone, Copy)]
pub(super) struct Rake {
    a: [Point; MAX_POSE_CAPSULES],
    b: [Point; MAX_POSE_CAPSULES],
    radius: [f64; MAX_POSE_CAPSULES],
}

/// An arm's straight motion as [`Rake::place`] reads it: model `model`, base `base`,
/// carrying `tool`, from `q0` by `dq`.
pub(super) struct Moving<'a, const D: usize> {
    pub(super) model: u8,
    pub(super) base: &'a Frame,
    pub(super) tool: &'a Tool,
    pub(super) q0: &'a [f64; D],
    pub(super) dq: &'a [f64; D],
}

impl Rake {
    pub(super) const EMPTY: Rake = Rake {
        a: [[F64s::splat(0.0); 3]; MAX_POSE_CAPSULES],
        b: [[F64s::splat(0.0); 3]; MAX_POSE_CAPSULES],
        radius: [0.0; MAX_POSE_CAPSULES],
    };

    /// Places the capsules `only` of `arm` at `q0 + dq * s`, `s` a fraction of the motion
    /// per lane: [`super::Sweep::at`] and [`ArmPose::place_only`], lane by lane.
    pub(super) fn place<M: Models<D>, const D: usize>(
        &mut self,
        arm: &Moving<'_, D>,
        s: F64s,
        only: u32,
    ) {
        let q = core::array::from_fn(|j| F64s::splat(arm.q0[j]) + F64s::splat(arm.dq[j]) * s);
        let _ = place_ends::<M, D>(
            arm.model,
            arm.base,
            arm.tool,
            &q,
            only,
            |i, a, b, radius, _| {
                (self.a[i], self.b[i], self.radius[i]) = (*a, *b, radius);
                ControlFlow::Continue(())
            },
        );
    }

    /// Lane `k`'s capsules `only` and their boxes into `out`, an empty pose, the rest of
    /// `out` as in `like`, the arm at an end of the motion: what [`ArmPose::place_only`] of
    /// that configuration gives, as far as a motion check reads it.
    pub(super) fn pose(&self, k: usize, only: u32, like: &ArmPose, out: &mut ArmPose) {
        (out.len, out.links, out.on_base) = (like.len, like.links, like.on_base);
        (out.self_pairs, out.tool_self) = (like.self_pairs, like.tool_self);
        let at = |p: &Point| Vector3::new(lane(p[0], k), lane(p[1], k), lane(p[2], k));
        for i in super::pose::bits(only) {
            let capsule = Capsule::new(at(&self.a[i]), at(&self.b[i]), self.radius[i]);
            out.capsules[i] = capsule;
            out.boxes[i] = capsule.aabb();
        }
    }
}

/// Fewest splits below a part (of the [`RAKE_PARTS`] a rake covers) for which a rake is
/// placed: a part of a short motion, with one or two, is placed one configuration at a time.
pub(super) const RAKE_MIN_SPLITS: usize = 3;

/// Per rake part (in the numbering of [`RAKE_PARTS`]), for part 0 `first..end` of `count`,
/// the fraction of the motion at its middle (`mid / count`, as the bisection computes it);
/// a part too short to split repeats part 0's. And how many of the parts split.
pub(super) fn rake_fractions(first: usize, end: usize, count: usize) -> (F64s, usize) {
    let mut parts = [(first, end); RAKE_PARTS];
    let mut s = [0.0; LANES];
    let mut splits = 0;
    for n in 0..RAKE_PARTS {
        let (lo, hi) = parts[n];
        let mid = (lo + hi) / 2;
        s[n] = if hi - lo > 1 {
            splits += 1;
            mid as f64 / count as f64
        } else {
            s[0]
        };
        if 2 * n + 2 < RAKE_PARTS {
            (parts[2 * n + 1], parts[2 * n + 2]) = ((lo, mid), (mid, hi));
        }
    }
    let first_part = s[0];
    for v in &mut s[RAKE_PARTS..] {
        *v = first_part;
    }
    (F64s::new(s), splits)
}
