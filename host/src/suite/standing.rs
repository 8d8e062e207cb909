//! Where a problem's arms stand (`initial`).
//!
//! A problem that gives `initial` is planned from it, so its witness must reach its first
//! configurations from it too (its approach: `connect`). `initial` is checked as the loader
//! checks it (limits and collisions, `approach::check_initial`): an arm that cannot stand
//! where it was put stands at its witness's first configuration instead.
//!
//! The approach family ([`super::Family::Approach`]) puts every arm where a straight bridge to
//! its hand collides: folded at Kinova's retract pose, turned a quarter turn across its
//! neighbour, or half a turn to the far side of a post that stands between it and its hand.

use std::f64::consts::{FRAC_PI_2, PI};

use omcbsa_core::approach::check_starts;
use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::problem::Problem;

use super::frames::{at, v3};
use super::witness::{Arms, Q};
use crate::models::DOF;

/// How the approach family's arms stand, by problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stance {
    /// Folded at Kinova's retract pose.
    Tucked,
    /// Turned a quarter turn (joint 1) from the witness's start, across a neighbour.
    Crossed,
    /// Turned half a turn, with a post where the straight bridge's hand passes.
    FarSide,
}

impl Stance {
    /// Every stance.
    pub const ALL: [Stance; 3] = [Stance::Tucked, Stance::Crossed, Stance::FarSide];

    /// The stance's name (`tucked`, `crossed`, `far_side`).
    pub fn name(self) -> &'static str {
        match self {
            Stance::Tucked => "tucked",
            Stance::Crossed => "crossed",
            Stance::FarSide => "far_side",
        }
    }

    /// Arm `i`'s `initial` for a witness starting at `start`.
    pub fn initial(self, i: usize, start: &Q, retract: &Q) -> Q {
        let mut q = *start;
        match self {
            Stance::Tucked => return *retract,
            Stance::Crossed => {
                q[0] += if i.is_multiple_of(2) {
                    FRAC_PI_2
                } else {
                    -FRAC_PI_2
                }
            }
            Stance::FarSide => q[0] += PI,
        }
        q
    }

    /// The post of a far-side arm of model `model` on `base`: a thin column under where its
    /// tool passes half way along the straight bridge from `initial` to `start`, up to that
    /// height.
    pub fn post(
        self,
        model: u8,
        base: &Frame,
        initial: &Q,
        start: &Q,
        tcp: &Frame,
    ) -> Option<Obstacle> {
        if self != Stance::FarSide {
            return None;
        }
        let mid: Q = std::array::from_fn(|j| 0.5 * (initial[j] + start[j]));
        let hand = base.compose(&Arms::fk(model, &mid)).compose(tcp).pos;
        let top = hand.z - 0.02;
        (top > 0.1).then(|| Obstacle {
            shape: Shape::Box {
                half_extents: [0.03, 0.03, 0.5 * top],
            },
            pose: at(v3(hand.x, hand.y, 0.5 * top)),
        })
    }
}

/// Whether every arm (of `models`, on `bases`, with no tool) stays clear of `obstacle` along
/// its witness path, steps and motions, by the planners' checks.
pub fn clear_of(obstacle: &Obstacle, models: &[u8], bases: &[Frame], paths: &[Vec<Q>]) -> bool {
    use omcbsa_core::motion::{motion_is_free, ArmMotion, MOTION_STEP};
    use omcbsa_core::tool::Tool;
    let obstacles = [*obstacle];
    (models.iter().zip(bases).zip(paths)).all(|((&model, base), path)| {
        path.windows(2).all(|w| {
            let m = ArmMotion {
                model,
                base,
                tool: &Tool::NONE,
                from: &w[0],
                to: &w[1],
            };
            motion_is_free::<Arms, DOF>(&m, &obstacles, MOTION_STEP)
        })
    })
}

/// Moves arms that cannot stand at their `initial` (limits, collisions, as the loader checks)
/// to their `fallback` configuration until all can: the arm found blocked, else the arm it
/// touches. Returns `false` when some arm still cannot stand and has nowhere else to go.
pub fn stand_clear(problem: &mut Problem<DOF>, fallback: &[Option<Q>]) -> bool {
    use omcbsa_core::approach::Touch;
    while let Err(b) = check_starts::<Arms, DOF>(problem) {
        let other = match b.touch {
            Touch::Robot { robot } => Some(robot),
            _ => None,
        };
        let movable = [Some(b.robot), other]
            .into_iter()
            .flatten()
            .find(|&i| fallback[i].is_some() && problem.robots[i].initial != fallback[i]);
        let Some(i) = movable else {
            return false;
        };
        problem.robots[i].initial = fallback[i];
    }
    true
}
