//! Motions between consecutive steps (the straight joint-space segment `a -> b`) and the
//! predicates the planners share: Ω-A* (when it generates a state), Ω-CBSA (when it looks for
//! conflicts) and the baselines all go through these functions, so the low level and the high
//! level agree exactly on what collides. Motions are checked conservatively with
//! [`Sweep`]: a motion reported free is free (no link comes within
//! the sweep's margin of anything along it), while one that only passes within a few
//! millimetres of something may be reported as colliding. Nothing here allocates; a check
//! places the arm (about 2 KB of stack) at the ends and at the splits it needs.
//!
//! A Gen3 reaching forward turns about its first joint past a ball that it clears at both
//! ends of the motion, and past a second arm standing in the same place:
//!
//! ```
//! use omcbsa_core::collision::ArmPose;
//! use omcbsa_core::geometry::{Obstacle, Shape};
//! use omcbsa_core::model::{Frame, KinovaGen3};
//! use omcbsa_core::motion::{motion_is_free, motions_collide, ArmMotion, MOTION_STEP};
//! use omcbsa_core::nalgebra::Vector3;
//! use omcbsa_core::tool::Tool;
//!
//! let from = [-0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
//! let to = [0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
//! let base = Frame::IDENTITY;
//! let turn = ArmMotion { model: 0, base: &base, tool: &Tool::NONE, from: &from, to: &to };
//! let ball = Obstacle {
//!     shape: Shape::Sphere { radius: 0.05 },
//!     pose: Frame { pos: Vector3::new(0.45, -0.02, 0.57), ..Frame::IDENTITY },
//! };
//! // Clear at both ends...
//! for q in [&from, &to] {
//!     let arm = ArmPose::new::<KinovaGen3, 7>(0, &base, &Tool::NONE, q);
//!     assert_eq!(arm.obstacle_hit(&[ball], 0.0), None);
//! }
//! // ...but not on the way.
//! assert!(!motion_is_free::<KinovaGen3, 7>(&turn, &[ball], MOTION_STEP));
//! assert!(motion_is_free::<KinovaGen3, 7>(&turn, &[], MOTION_STEP));
//!
//! // A second Gen3 standing upright 0.6 m in front of the first.
//! let other_base = Frame { pos: Vector3::new(0.6, -0.02, 0.0), ..Frame::IDENTITY };
//! let up = [0.0; 7];
//! let stand = ArmMotion { model: 0, base: &other_base, tool: &Tool::NONE, from: &up, to: &up };
//! assert!(motions_collide::<KinovaGen3, 7>(&turn, &stand, MOTION_STEP));
//! // The first arm holding still at `from` stays clear of it.
//! let wait = ArmMotion { to: &from, ..turn };
//! assert!(!motions_collide::<KinovaGen3, 7>(&wait, &stand, MOTION_STEP));
//! ```

use nalgebra::Vector3;

use crate::collision::{sweeps_collide_posed, ArmPose, Obstacles, Sweep};
use crate::geometry::Obstacle;
use crate::model::{Frame, Models};
use crate::tool::Tool;

/// The default largest displacement (m) of any link point between two checked configurations
/// of a motion. The checks inflate the links by half of it, so a smaller step rejects fewer
/// motions that pass close to something; the sweeps' bisection keeps far-away motions at one
/// check whatever the step.
pub const MOTION_STEP: f64 = 0.01;

/// One arm's motion over one step.
#[derive(Clone, Copy, Debug)]
pub struct ArmMotion<'a, const D: usize> {
    /// The arm's model, an index into the planner's [`Models`] ([`crate::problem::Robot::model`]).
    pub model: u8,
    /// The arm's base frame in the world.
    pub base: &'a Frame,
    /// What the arm carries.
    pub tool: &'a Tool,
    /// The configuration at the start of the step.
    pub from: &'a [f64; D],
    /// The configuration at the end of the step (equal to `from` for an arm standing still).
    pub to: &'a [f64; D],
}

impl<'a, const D: usize> ArmMotion<'a, D> {
    /// The motion as a [`Sweep`], in pieces over which no point of the arm moves more than
    /// `max_step` metres.
    pub fn sweep<M: Models<D>>(&self, max_step: f64) -> Sweep<M, D> {
        Sweep::new(self.model, self.tool, self.from, self.to, max_step)
    }
}

/// Where two arms came too close during a motion: at the instant `s` (a fraction of the step)
/// the point lies within `margin` of both arms' volumes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// The instant, as a fraction of the step (`0..=1`).
    pub s: f64,
    /// The point, in the world, metres.
    pub point: [f64; 3],
    /// How far from both arms' volumes the point may be (0: inside both), metres.
    pub margin: f64,
}

/// Instants per sweep piece at which [`motions_contact`] looks for the arms overlapping.
pub const CONTACT_SAMPLES: usize = 4;

/// Whether the motion stays clear of the obstacles and of the arm itself.
pub fn motion_is_free<M: Models<D>, const D: usize>(
    m: &ArmMotion<'_, D>,
    obstacles: &[Obstacle],
    max_step: f64,
) -> bool {
    !m.sweep::<M>(max_step).arm_collides(m.base, obstacles)
}

/// [`motion_is_free`] for a caller that already placed the arm at both ends of the step, among
/// obstacles whose boxes it made once for many checks.
pub fn motion_is_free_posed<M: Models<D>, const D: usize>(
    m: &ArmMotion<'_, D>,
    ends: [&ArmPose; 2],
    obstacles: &Obstacles<'_>,
    max_step: f64,
) -> bool {
    !m.sweep::<M>(max_step)
        .arm_collides_among(m.base, obstacles, ends)
}

/// Whether two arms' simultaneous motions come too close (see
/// [`crate::collision::sweeps_collide`]).
pub fn motions_collide<M: Models<D>, const D: usize>(
    a: &ArmMotion<'_, D>,
    b: &ArmMotion<'_, D>,
    max_step: f64,
) -> bool {
    let ends = |m: &ArmMotion<'_, D>| {
        [
            ArmPose::new::<M, D>(m.model, m.base, m.tool, m.from),
            ArmPose::new::<M, D>(m.model, m.base, m.tool, m.to),
        ]
    };
    let ([a0, a1], [b0, b1]) = (ends(a), ends(b));
    motions_collide_posed::<M, D>(a, [&a0, &a1], b, [&b0, &b1], max_step)
}

/// [`motions_collide`] for callers that already placed both arms at both ends of the step.
pub fn motions_collide_posed<M: Models<D>, const D: usize>(
    a: &ArmMotion<'_, D>,
    a_ends: [&ArmPose; 2],
    b: &ArmMotion<'_, D>,
    b_ends: [&ArmPose; 2],
    max_step: f64,
) -> bool {
    let (sa, sb) = (a.sweep::<M>(max_step), b.sweep::<M>(max_step));
    // Cheap rejection: during the step every point of an arm stays within half its sweep
    // length of where it is at one end or the other.
    let boxed = |e: [&ArmPose; 2]| e[0].aabb().union(e[1].aabb());
    if !boxed(a_ends).near(&boxed(b_ends), 0.5 * (sa.length() + sb.length())) {
        return false;
    }
    sweeps_collide_posed(&sa, a.base, a_ends, &sb, b.base, b_ends)
}

/// How many times finer than the caller's sweep [`motions_conflict_posed`] confirms a
/// conflict, and [`motions_contact`] looks for where it is.
pub const CONFIRM: f64 = 4.0;

/// Whether two arms' simultaneous motions conflict, for Ω-CBSA: they come too close under the
/// sweep of `max_step` (as Ω-A* counts it) and still do under one [`CONFIRM`] times finer.
/// The finer check drops what is only the coarse sweep's inflation (arms passing a few
/// millimetres apart), which no branching could resolve disjunctively; it is conservative
/// too, so motions without a conflict never collide.
pub fn motions_conflict_posed<M: Models<D>, const D: usize>(
    a: &ArmMotion<'_, D>,
    a_ends: [&ArmPose; 2],
    b: &ArmMotion<'_, D>,
    b_ends: [&ArmPose; 2],
    max_step: f64,
) -> bool {
    motions_collide_posed::<M, D>(a, a_ends, b, b_ends, max_step)
        && motions_collide_posed::<M, D>(a, a_ends, b, b_ends, max_step / CONFIRM)
}

/// Where two arms' simultaneous motions first meet, for a branching that is mutually
/// disjunctive: the first instant (on a grid [`CONTACT_SAMPLES`] times finer than the sweep's
/// pieces) at which the arms overlap, with a point inside both (`margin` 0). No two arms that
/// never collide can both occupy one point at one instant, so of the two constraints "robot i
/// is not at `point` at `s`" every collision-free plan keeps one. When the arms never overlap
/// at those instants but come within the sweep's tolerance of each other (the conservative
/// check counts that as a conflict), the first instant they do so, with the tolerance as
/// `margin`; the caller must treat that branching as not disjunctive (`exact == false`).
/// `None` when they stay clear. The sweep is the confirming one of
/// [`motions_conflict_posed`] (`max_step / CONFIRM`), so its tolerance is the one that counted
/// the conflict.
pub fn motions_contact<M: Models<D>, const D: usize>(
    a: &ArmMotion<'_, D>,
    b: &ArmMotion<'_, D>,
    max_step: f64,
) -> Option<(Contact, bool)> {
    let fine = max_step / CONFIRM;
    let (sa, sb) = (a.sweep::<M>(fine), b.sweep::<M>(fine));
    let pieces = sa.count().max(sb.count());
    // The first of `count` instants at which the arms come closer than `margin`. Between
    // two instants the arms close in by at most `closing` (no point of either moves farther
    // than its sweep's length times the fraction of the motion), so the instants that the
    // clearance at one rules out are skipped: the same first instant, found from a few.
    let at = |count: usize, margin: f64| {
        let closing = (sa.length() + sb.length()) / count as f64;
        let mut i = 0;
        while i < count {
            let s = (i as f64 + 0.5) / count as f64;
            let (pa, pb) = (
                ArmPose::new::<M, D>(a.model, a.base, a.tool, &sa.at(s)),
                ArmPose::new::<M, D>(b.model, b.base, b.tool, &sb.at(s)),
            );
            if pa.arm_hit(&pb, margin).is_some() {
                return pa.witness(&pb, margin).map(|p| Contact {
                    s,
                    point: [p.x, p.y, p.z],
                    margin,
                });
            }
            // Instants i + j with j below (clearance - margin) / closing stay clear (by more
            // than `closing`, so rounding cannot matter); NaN or no motion skips one.
            let ahead = (pa.clearance(&pb) - margin) / closing;
            i += if ahead >= 2.0 && ahead.is_finite() {
                ahead as usize
            } else {
                1
            };
        }
        None
    };
    if let Some(c) = at(pieces * CONTACT_SAMPLES, 0.0) {
        return Some((c, true));
    }
    // The sweep's tolerance first; the pair-by-pair check may have bisected differently, so
    // wider ones after it rather than no branch at all.
    let margin = (sa.length() + sb.length()) / (2.0 * pieces as f64);
    (0..4).find_map(|k| at(pieces, margin * f64::from(1u32 << k)).map(|c| (c, false)))
}

/// Whether the arm comes within `margin` of `p` anywhere along its motion, checked on the
/// sweep's pieces unless the ends alone rule it out: the arm's points travel at most the
/// sweep's length, so if `p`'s clearances from the arm at the two ends add up to more than
/// that plus `2 margin`, no configuration between them comes within `margin` of it.
pub fn motion_near_point<M: Models<D>, const D: usize>(
    m: &ArmMotion<'_, D>,
    p: &[f64; 3],
    margin: f64,
    max_step: f64,
) -> bool {
    let [a, b] = m.sweep::<M>(max_step).ends(m.base);
    motion_near_point_posed::<M, D>(m, [&a, &b], p, margin, max_step)
}

/// [`motion_near_point`] for a caller that already placed the arm at both ends of the step.
pub fn motion_near_point_posed<M: Models<D>, const D: usize>(
    m: &ArmMotion<'_, D>,
    ends: [&ArmPose; 2],
    p: &[f64; 3],
    margin: f64,
    max_step: f64,
) -> bool {
    let sweep = m.sweep::<M>(max_step);
    let clearance = |arm: &ArmPose| point_clearance(arm, p);
    if clearance(ends[0]) + clearance(ends[1]) > sweep.length() + 2.0 * margin {
        return false;
    }
    (0..sweep.count()).any(|i| near_point(&sweep.arm(m.base, i), p, sweep.margin() + margin))
}

/// Distance from `p` to the arm's volume (negative inside it).
fn point_clearance(arm: &ArmPose, p: &[f64; 3]) -> f64 {
    let p = Vector3::new(p[0], p[1], p[2]);
    arm.capsules()
        .iter()
        .map(|c| libm::sqrt(c.segment.distance2_to_point(&p)) - c.radius)
        .fold(f64::INFINITY, f64::min)
}

/// Whether `p` is within `margin` of the arm's volume.
pub fn near_point(arm: &ArmPose, p: &[f64; 3], margin: f64) -> bool {
    let p = Vector3::new(p[0], p[1], p[2]);
    arm.capsules().iter().any(|c| {
        let r = c.radius + margin;
        c.segment.distance2_to_point(&p) <= r * r
    })
}
