//! A scene's obstacles with their boxes kept [`LANES`] to a batch ([`Boxes`]), made once for
//! many motion checks ([`Obstacles`]), so that a check rules most of them out for a capsule
//! over a part of a motion in a few SIMD operations ([`NearBoxes::reachable`]) before it runs
//! its exact tests on the few left.

use super::batch::Boxes;
use crate::geometry::{Aabb, Obstacle};
use crate::lanes::{lt, F64s, LANES};
use crate::problem::MAX_OBSTACLES;

/// The obstacles motion checks keep an arm clear of ([`super::Sweep::arm_collides_among`]),
/// with their boxes in lanes: made once for a fixed scene (a problem's obstacles), as a
/// planner checks many motions among them. About 6 KB.
#[derive(Clone, Copy)]
pub struct Obstacles<'a> {
    pub(super) shapes: &'a [Obstacle],
    /// Per obstacle, its box, for the exact tests that follow the culling.
    pub(super) aabbs: [Aabb; MAX_OBSTACLES],
    pub(super) boxes: NearBoxes,
}

impl<'a> Obstacles<'a> {
    /// `shapes` with their boxes; `None` for more than [`MAX_OBSTACLES`] of them (a
    /// problem's never are).
    pub fn new(shapes: &'a [Obstacle]) -> Option<Obstacles<'a>> {
        (shapes.len() <= MAX_OBSTACLES).then(|| Obstacles::of(shapes))
    }

    /// `shapes`, at most [`MAX_OBSTACLES`] of them.
    fn of(shapes: &'a [Obstacle]) -> Obstacles<'a> {
        let mut aabbs = [Aabb::EMPTY; MAX_OBSTACLES];
        for (b, o) in aabbs.iter_mut().zip(shapes) {
            *b = o.aabb();
        }
        Obstacles {
            shapes,
            aabbs,
            boxes: NearBoxes::new(aabbs.into_iter().take(shapes.len())),
        }
    }

    /// The obstacles.
    pub fn shapes(&self) -> &'a [Obstacle] {
        self.shapes
    }
}

/// A problem's obstacles, never more than [`MAX_OBSTACLES`].
impl<'a> From<&'a heapless::Vec<Obstacle, MAX_OBSTACLES>> for Obstacles<'a> {
    fn from(shapes: &'a heapless::Vec<Obstacle, MAX_OBSTACLES>) -> Self {
        Obstacles::of(shapes)
    }
}

impl core::fmt::Debug for Obstacles<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Obstacles")
            .field("shapes", &self.shapes)
            .finish()
    }
}

/// Batches of obstacle boxes: obstacle `k` in lane `k % LANES` of batch `k / LANES`; lanes
/// past the last obstacle hold [`Aabb::EMPTY`], infinitely far from everything.
#[derive(Clone, Copy)]
pub(super) struct NearBoxes {
    batches: [Boxes; MAX_OBSTACLES / LANES],
    len: usize,
}

const _: () = assert!(MAX_OBSTACLES.is_multiple_of(LANES));

impl NearBoxes {
    /// The boxes, at most [`MAX_OBSTACLES`] of them.
    pub(super) fn new(boxes: impl Iterator<Item = Aabb>) -> NearBoxes {
        let mut near = NearBoxes {
            batches: [Boxes::EMPTY; MAX_OBSTACLES / LANES],
            len: 0,
        };
        let mut min = [[f64::INFINITY; LANES]; 3];
        let mut max = [[f64::NEG_INFINITY; LANES]; 3];
        for (k, b) in boxes.take(MAX_OBSTACLES).enumerate() {
            for i in 0..3 {
                (min[i][k % LANES], max[i][k % LANES]) = (b.min[i], b.max[i]);
            }
            near.len = k + 1;
            if k % LANES == LANES - 1 {
                near.batches[k / LANES] = Boxes {
                    min: min.map(F64s::new),
                    max: max.map(F64s::new),
                };
                min = [[f64::INFINITY; LANES]; 3];
                max = [[f64::NEG_INFINITY; LANES]; 3];
            }
        }
        if !near.len.is_multiple_of(LANES) {
            near.batches[near.len / LANES] = Boxes {
                min: min.map(F64s::new),
                max: max.map(F64s::new),
            };
        }
        near
    }

    /// Of the obstacles `of` (bit `k`: obstacle `k`), those a capsule may reach over a part
    /// of the motion: its boxes at the part's two ends are `at`, and its points travel at most
    /// `travel` towards anything, counted from both ends. An obstacle whose box is farther
    /// than `travel / 2` from both boxes (from the box around them) is out of reach: the
    /// distances from the two add up to more than `travel`, as the exact test that follows
    /// for the others would find too. Squared distances, without roots or ordering of NaNs: a
    /// NaN leaves an obstacle in question.
    #[inline]
    pub(super) fn reachable(&self, of: u64, at: [&Aabb; 2], travel: f64) -> u64 {
        let swept = at[0].union(at[1]);
        let half = 0.5 * travel;
        let reach2 = F64s::splat(half * half);
        let zero = F64s::splat(0.0);
        let (lo, hi) = (swept.min.map(F64s::splat), swept.max.map(F64s::splat));
        let mut left = 0;
        for n in 0..self.len.div_ceil(LANES) {
            if (of >> (n * LANES)) as u8 == 0 {
                continue;
            }
            let b = &self.batches[n];
            let gap = |i: usize| (lo[i] - b.max[i]).fast_max(b.min[i] - hi[i]).fast_max(zero);
            let (x, y, z) = (gap(0), gap(1), gap(2));
            let far = lt(reach2, x * x + y * y + z * z);
            left |= u64::from(!far) << (n * LANES);
        }
        left & of
    }

    /// Every obstacle.
    pub(super) fn all(&self) -> u64 {
        u64::MAX
            .checked_shr(u64::BITS - self.len as u32)
            .unwrap_or(0)
    }
}
