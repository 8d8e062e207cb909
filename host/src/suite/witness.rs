//! Witnesses: collision-free joint-space motions that solve a problem, found while generating
//! it, so that the suite knows which of its problems are solvable.
//!
//! The checks are the planners' own (core `motion`): every step's motion of an arm is clear of
//! the obstacles, of the arm itself and of the arms already placed over the same step, and no
//! joint moves more than [`STEP_FRACTION`] of its velocity limit times `dt` (so a planner has
//! room to spare). The generator then confirms every witness with the host validator.

use omcbsa_core::geometry::Obstacle;
use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::kinematics::null_space_basis;
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::motion::{motion_is_free, motions_collide, ArmMotion};
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;

use super::frames::{aligned, rot, sin, v3, V3};
use super::layout::Station;
use crate::models::DOF;

/// The models the suite's arms are of (each arm's an index into it).
pub type Arms = crate::models::Fleet;
pub type Q = [f64; DOF];

/// Share of `velocity * dt` a witness joint may move per step.
pub const STEP_FRACTION: f64 = 0.75;
/// Largest point displacement between collision checks along a witness's motion (metres). The
/// suite's own, coarser than the planners' default: the generator was made with it, and a
/// planner change must not change the suite.
pub const MOTION_STEP: f64 = 0.01;
/// Random IK seeds tried per arm and priority order.
const TRACK_ATTEMPTS: usize = 8;
/// Largest null-space push per step of a swinging witness (rad along a unit null vector).
const NULL_SWING: f64 = 0.08;
/// Attempts of [`Scene::track`] without a null-space swing.
const PLAIN_ATTEMPTS: usize = 2;
/// Priority orders tried for one task.
const ORDERS: usize = 3;

/// Kinova's retract configuration (arm folded back over its base), with joint 4 kept off its
/// limit: the pose an idle arm holds.
pub const RETRACT: Q = [
    0.0,
    -0.35,
    std::f64::consts::PI,
    -2.5,
    0.0,
    -0.87,
    std::f64::consts::FRAC_PI_2,
];

/// What every arm of a problem moves among.
pub struct Scene<'a> {
    pub obstacles: &'a [Obstacle],
    pub dt: f64,
    pub tcp: Frame,
}

/// Kinova's [`RETRACT`] within the joint limits of model `model` (the pose itself for the
/// Gen3; for another arm a folded pose to try first, checked like any other).
pub fn retract(model: u8) -> Q {
    let (lower, upper) = (Arms::lower(model), Arms::upper(model));
    std::array::from_fn(|j| RETRACT[j].clamp(lower[j], upper[j]))
}

/// One hand trajectory and the arm it was designed for (the witness tracks it with that arm
/// first).
#[derive(Clone, Debug)]
pub struct Hand {
    pub arm: usize,
    pub poses: Vec<Frame>,
}

/// An arm whose path is fixed.
pub struct Placed {
    pub model: u8,
    pub base: Frame,
    pub path: Vec<Q>,
}

impl Scene<'_> {
    fn step_ok(&self, model: u8, a: &Q, b: &Q) -> bool {
        let velocity = Arms::velocity(model);
        (0..DOF).all(|j| (b[j] - a[j]).abs() <= STEP_FRACTION * velocity[j] * self.dt)
    }

    /// The motion of an arm at `base` from `from` to `to` over step `t - 1 -> t` (standing
    /// still at step 0), against the obstacles, itself and `placed`.
    fn motion_ok(
        &self,
        model: u8,
        base: &Frame,
        from: &Q,
        to: &Q,
        t: usize,
        placed: &[Placed],
    ) -> bool {
        // The suite's arms carry no tool.
        let tool = &Tool::NONE;
        let m = ArmMotion {
            model,
            base,
            tool,
            from,
            to,
        };
        motion_is_free::<Arms, DOF>(&m, self.obstacles, MOTION_STEP)
            && placed.iter().all(|o| {
                let other = ArmMotion {
                    model: o.model,
                    base: &o.base,
                    tool,
                    from: &o.path[t.saturating_sub(1)],
                    to: &o.path[t],
                };
                !motions_collide::<Arms, DOF>(&m, &other, MOTION_STEP)
            })
    }

    /// Whether `path` is a valid motion for an arm of model `model` at `base` among `placed`.
    pub fn path_ok(&self, model: u8, base: &Frame, path: &[Q], placed: &[Placed]) -> bool {
        (0..path.len()).all(|t| {
            let from = &path[t.saturating_sub(1)];
            self.step_ok(model, from, &path[t])
                && self.motion_ok(model, base, from, &path[t], t, placed)
        })
    }

    /// The world pose of the tool centre point.
    pub fn tcp_pose(&self, model: u8, base: &Frame, q: &Q) -> Frame {
        base.compose(&Arms::fk(model, q)).compose(&self.tcp)
    }

    /// IK target in the model's base frame for a world TCP pose.
    pub fn target(&self, base: &Frame, pose: &Frame) -> Frame {
        base.inverse().compose(pose).compose(&self.tcp.inverse())
    }

    /// Tracks `poses` by IK from random seeds, each step from the previous configuration,
    /// checking as it goes. All but the last [`PLAIN_ATTEMPTS`] attempts also swing the arm
    /// through its null space (the seed of each step is pushed a fixed amount along the
    /// Jacobian's null space before IK projects it back, so the elbow drifts steadily to one
    /// side), so witnesses are not what plain IK tracking finds.
    /// The first path that passes, if any.
    pub fn track(
        &self,
        model: u8,
        base: &Frame,
        poses: &[Frame],
        placed: &[Placed],
        rng: &mut Rng,
    ) -> Option<Vec<Q>> {
        let params = IkParams::default();
        'attempt: for attempt in 0..TRACK_ATTEMPTS {
            let seed = rng.configuration(Arms::lower(model), Arms::upper(model));
            let swing = if attempt + PLAIN_ATTEMPTS < TRACK_ATTEMPTS {
                rng.uniform(0.6, 1.0) * NULL_SWING * if rng.next_f64() < 0.5 { 1.0 } else { -1.0 }
            } else {
                0.0
            };
            let Ok(mut q) = ik::<Arms, DOF>(model, &self.target(base, &poses[0]), &seed, &params)
            else {
                continue;
            };
            let mut path = Vec::with_capacity(poses.len());
            for (t, pose) in poses.iter().enumerate() {
                let next = if t == 0 {
                    q
                } else {
                    let seed = along_null_space(model, &q, swing);
                    match ik::<Arms, DOF>(model, &self.target(base, pose), &seed, &params) {
                        Ok(next) => next,
                        Err(_) => continue 'attempt,
                    }
                };
                if !self.step_ok(model, &q, &next)
                    || !self.motion_ok(model, base, &q, &next, t, placed)
                {
                    continue 'attempt;
                }
                q = next;
                path.push(q);
            }
            return Some(path);
        }
        None
    }

    /// A configuration an idle arm can hold among `placed` for `h` steps: the retract pose if
    /// it is clear, else a random clear one.
    pub fn hold(
        &self,
        model: u8,
        base: &Frame,
        h: usize,
        placed: &[Placed],
        rng: &mut Rng,
    ) -> Option<Q> {
        let (lower, upper) = (Arms::lower(model), Arms::upper(model));
        let candidates = std::iter::once(retract(model))
            .chain((0..TRACK_ATTEMPTS).map(|_| rng.configuration(lower, upper)));
        for q in candidates {
            if self.path_ok(model, base, &vec![q; h], placed) {
                return Some(q);
            }
        }
        None
    }
}

/// A witness for task hands: the arms not in `hands` hold first, then the hands' arms track
/// their hand one after the other, in up to [`ORDERS`] random priority orders. Returns every
/// arm's path (holding arms included) in arm order.
pub fn task_witness(
    scene: &Scene,
    models: &[u8],
    bases: &[Frame],
    hands: &[Hand],
    rng: &mut Rng,
) -> Option<Vec<Vec<Q>>> {
    let h = hands.first()?.poses.len();
    let mut order: Vec<usize> = (0..hands.len()).collect();
    'order: for _ in 0..ORDERS {
        shuffle(&mut order, rng);
        let mut owners: Vec<usize> = Vec::with_capacity(bases.len());
        let mut placed: Vec<Placed> = Vec::with_capacity(bases.len());
        for arm in (0..bases.len()).filter(|a| hands.iter().all(|hand| hand.arm != *a)) {
            let q = scene.hold(models[arm], &bases[arm], h, &placed, rng)?;
            owners.push(arm);
            placed.push(Placed {
                model: models[arm],
                base: bases[arm],
                path: vec![q; h],
            });
        }
        for &k in &order {
            let arm = hands[k].arm;
            let poses = &hands[k].poses;
            let Some(path) = scene.track(models[arm], &bases[arm], poses, &placed, rng) else {
                continue 'order;
            };
            owners.push(arm);
            placed.push(Placed {
                model: models[arm],
                base: bases[arm],
                path,
            });
        }
        let mut paths: Vec<(usize, Vec<Q>)> = owners
            .into_iter()
            .zip(placed.into_iter().map(|p| p.path))
            .collect();
        paths.sort_by_key(|(arm, _)| *arm);
        return Some(paths.into_iter().map(|(_, p)| p).collect());
    }
    None
}

/// The arm a random motion is for, and what kind of motion.
pub struct MotionSpec<'a> {
    /// The arm's model.
    pub model: u8,
    /// Where its base stands.
    pub base: &'a Frame,
    /// Where its hand works.
    pub station: &'a Station,
    /// Steps of the motion.
    pub steps: usize,
    /// `false`: a still arm, in the same kind of pose.
    pub moving: bool,
}

/// A smooth random joint motion of `spec.steps` steps for an arm, clear of the arms `placed`:
/// it starts where IK puts the hand near the arm's station (pointing forward and down by a
/// random amount), then every joint follows a sum of two slow sines whose speeds add up to at
/// most half the step limit.
pub fn random_motion(
    scene: &Scene,
    spec: &MotionSpec,
    placed: &[Placed],
    rng: &mut Rng,
) -> Option<Vec<Q>> {
    let MotionSpec {
        model,
        base,
        station,
        steps: h,
        moving,
    } = *spec;
    let params = IkParams::default();
    let span = (h - 1).max(1) as f64;
    for _ in 0..TRACK_ATTEMPTS {
        let jitter = v3(
            rng.uniform(-0.1, 0.1),
            rng.uniform(-0.1, 0.1),
            rng.uniform(-0.08, 0.12),
        );
        let side = station.front.cross(&v3(0.0, 0.0, 1.0));
        let pitch = rng.uniform(0.0, 1.3);
        let approach: V3 = rot(side, pitch) * station.front;
        let start = aligned(station.point + jitter, approach, side);
        let (lower, upper) = (Arms::lower(model), Arms::upper(model));
        let seed = rng.configuration(lower, upper);
        let Ok(q0) = ik::<Arms, DOF>(model, &scene.target(base, &start), &seed, &params) else {
            continue;
        };
        // Per joint: two sines (cycles over the horizon, amplitude, phase).
        let waves: Vec<[(f64, f64, f64); 2]> = (0..DOF)
            .map(|j| {
                let budget = if moving {
                    0.5 * STEP_FRACTION * Arms::velocity(model)[j] * scene.dt
                } else {
                    0.0
                };
                std::array::from_fn(|_| {
                    let cycles = rng.uniform(0.3, 1.2);
                    // Largest step of A sin(2 pi c t / span) is A * 2 pi c / span.
                    let amplitude = rng.uniform(0.3, 1.0) * 0.5 * budget * span
                        / (2.0 * std::f64::consts::PI * cycles);
                    (
                        cycles,
                        amplitude,
                        rng.uniform(0.0, 2.0 * std::f64::consts::PI),
                    )
                })
            })
            .collect();
        let path: Vec<Q> = (0..h)
            .map(|t| {
                std::array::from_fn(|j| {
                    let offset: f64 = (waves[j].iter())
                        .map(|&(c, a, phase)| {
                            let w = 2.0 * std::f64::consts::PI * c / span;
                            a * (sin(w * t as f64 + phase) - sin(phase))
                        })
                        .sum();
                    (q0[j] + offset).clamp(lower[j], upper[j])
                })
            })
            .collect();
        if scene.path_ok(model, base, &path, placed) {
            return Some(path);
        }
    }
    None
}

/// `q` moved by `amount` along the null space of its Jacobian (unchanged at a singularity).
fn along_null_space(model: u8, q: &Q, amount: f64) -> Q {
    let (_, jacobian) = Arms::jacobian(model, q);
    match null_space_basis(&jacobian).first() {
        Some(n) => std::array::from_fn(|j| q[j] + amount * n[j]),
        None => *q,
    }
}

/// Fisher-Yates with the suite's generator.
pub fn shuffle<T>(items: &mut [T], rng: &mut Rng) {
    for i in (1..items.len()).rev() {
        let j = (rng.next_u64() % (i as u64 + 1)) as usize;
        items.swap(i, j);
    }
}
