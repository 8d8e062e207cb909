//! The obstacles near a motion, their boxes kept [`LANES`] to a batch ([`Boxes`]), so that a
//! motion check rules most of them out for a capsule over a part of the motion in a few SIMD
//! operations ([`NearBoxes::reachable`]) before it runs its exact tests on the few left.

use super::batch::Boxes;
use crate::geometry::Aabb;
use crate::lanes::{lt, F64s, LANES};
use crate::problem::MAX_OBSTACLES;

/// Batches of obstacle boxes: obstacle `k` in lane `k % LANES` of batch `k / LANES`; lanes
/// past the last obstacle hold [`Aabb::EMPTY`], infinitely far from everything.
pub(super) struct NearBoxes {
    batches: [Boxes; MAX_OBSTACLES / LANES],
    len: usize,
}

const _: () = assert!(MAX_OBSTACLES.is_multiple_of(LANES));

impl NearBoxes {
    /// The boxes, at most [`MAX_OBSTACLES`] of them.
    pub(super) fn new<'a>(boxes: impl Iterator<Item = &'a Aabb>) -> NearBoxes {
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
