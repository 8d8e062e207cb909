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
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::motion::{motion_is_free, motions_collide, ArmMotion};
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;

use super::family::Hand;
use super::frames::{aligned, rot, v3, V3};
use super::layout::Station;

pub type Gen3 = KinovaGen3;
pub type Q = [f64; 7];

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

/// An arm whose path is fixed.
pub struct Placed {
    pub base: Frame,
    pub path: Vec<Q>,
}

impl Scene<'_> {
    fn step_ok(&self, a: &Q, b: &Q) -> bool {
        (0..7).all(|j| (b[j] - a[j]).abs() <= STEP_FRACTION * Gen3::VELOCITY[j] * self.dt)
    }

    /// The motion of an arm at `base` from `from` to `to` over step `t - 1 -> t` (standing
    /// still at step 0), against the obstacles, itself and `placed`.
    fn motion_ok(&self, base: &Frame, from: &Q, to: &Q, t: usize, placed: &[Placed]) -> bool {
        // The suite's arms carry no tool.
        let tool = &Tool::NONE;
        let m = ArmMotion {
            base,
            tool,
            from,
            to,
        };
        motion_is_free::<Gen3, 7>(&m, self.obstacles, MOTION_STEP)
            && placed.iter().all(|o| {
                let other = ArmMotion {
                    base: &o.base,
                    tool,
                    from: &o.path[t.saturating_sub(1)],
                    to: &o.path[t],
                };
                !motions_collide::<Gen3, 7>(&m, &other, MOTION_STEP)
            })
    }

    /// Whether `path` is a valid motion for an arm at `base` among `placed`.
    pub fn path_ok(&self, base: &Frame, path: &[Q], placed: &[Placed]) -> bool {
        (0..path.len()).all(|t| {
            let from = &path[t.saturating_sub(1)];
            self.step_ok(from, &path[t]) && self.motion_ok(base, from, &path[t], t, placed)
        })
    }

    /// The world pose of the tool centre point.
    pub fn tcp_pose(&self, base: &Frame, q: &Q) -> Frame {
        base.compose(&Gen3::fk(q)).compose(&self.tcp)
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
        base: &Frame,
        poses: &[Frame],
        placed: &[Placed],
        rng: &mut Rng,
    ) -> Option<Vec<Q>> {
        let params = IkParams::default();
        'attempt: for attempt in 0..TRACK_ATTEMPTS {
            let seed = rng.configuration(&Gen3::LOWER, &Gen3::UPPER);
            let swing = if attempt + PLAIN_ATTEMPTS < TRACK_ATTEMPTS {
                rng.uniform(0.6, 1.0) * NULL_SWING * if rng.next_f64() < 0.5 { 1.0 } else { -1.0 }
            } else {
                0.0
            };
            let Ok(mut q) = ik::<Gen3, 7>(&self.target(base, &poses[0]), &seed, &params) else {
                continue;
            };
            let mut path = Vec::with_capacity(poses.len());
            for (t, pose) in poses.iter().enumerate() {
                let next = if t == 0 {
                    q
                } else {
                    let seed = along_null_space(&q, swing);
                    match ik::<Gen3, 7>(&self.target(base, pose), &seed, &params) {
                        Ok(next) => next,
                        Err(_) => continue 'attempt,
                    }
                };
                if !self.step_ok(&q, &next) || !self.motion_ok(base, &q, &next, t, placed) {
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
    pub fn hold(&self, base: &Frame, h: usize, placed: &[Placed], rng: &mut Rng) -> Option<Q> {
        let candidates = std::iter::once(RETRACT)
            .chain((0..TRACK_ATTEMPTS).map(|_| rng.configuration(&Gen3::LOWER, &Gen3::UPPER)));
        for q in candidates {
            if self.path_ok(base, &vec![q; h], placed) {
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
            let q = scene.hold(&bases[arm], h, &placed, rng)?;
            owners.push(arm);
            placed.push(Placed {
                base: bases[arm],
                path: vec![q; h],
            });
        }
        for &k in &order {
            let arm = hands[k].arm;
            let Some(path) = scene.track(&bases[arm], &hands[k].poses, &placed, rng) else {
                continue 'order;
            };
            owners.push(arm);
            placed.push(Placed {
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

/// A smooth random joint motion of `h` steps for an arm: it starts where IK puts the hand near
/// the arm's station (pointing forward and down by a random amount), then every joint follows
/// a sum of two slow sines whose speeds add up to at most half the step limit. `moving: false`
/// gives a still arm in the same kind of pose.
pub fn random_motion(
    scene: &Scene,
    base: &Frame,
    station: &Station,
    h: usize,
    moving: bool,
    placed: &[Placed],
    rng: &mut Rng,
) -> Option<Vec<Q>> {
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
        let seed = rng.configuration(&Gen3::LOWER, &Gen3::UPPER);
        let Ok(q0) = ik::<Gen3, 7>(&scene.target(base, &start), &seed, &params) else {
            continue;
        };
        // Per joint: two sines (cycles over the horizon, amplitude, phase).
        let waves: Vec<[(f64, f64, f64); 2]> = (0..7)
            .map(|j| {
                let budget = if moving {
                    0.5 * STEP_FRACTION * Gen3::VELOCITY[j] * scene.dt
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
                            a * ((w * t as f64 + phase).sin() - phase.sin())
                        })
                        .sum();
                    (q0[j] + offset).clamp(Gen3::LOWER[j], Gen3::UPPER[j])
                })
            })
            .collect();
        if scene.path_ok(base, &path, placed) {
            return Some(path);
        }
    }
    None
}

/// `q` moved by `amount` along the null space of its Jacobian (unchanged at a singularity).
fn along_null_space(q: &Q, amount: f64) -> Q {
    let (_, jacobian) = Gen3::jacobian(q);
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
