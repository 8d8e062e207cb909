//! Traps: fixtures (spheres) placed where myopic IK tracking takes an arm but no arm of the
//! witness ever goes. For every hand, IK tracking (each step's IK solution nearest the
//! previous configuration, which keeps the arm's elbow posture roughly where it started) is
//! run from the witness's own start, from the retract pose and from random starts, by every arm
//! that can reach the hand; each such track still clear of the scene gets a fixture on one of
//! its elbow or forearm points where it strays farthest from the witness. The witness swings
//! its elbows through the null space as it goes (see `witness`), so no single posture stays
//! near it all along: solving a trapped problem takes that null-space motion.

use omcbsa_core::collision::ArmPose;
use omcbsa_core::geometry::{Aabb, Obstacle, Shape};
use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::motion::{motion_is_free, motion_near_point, ArmMotion};
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;

use super::frames::{at, V3};
use super::layout::NamedObstacle;
use super::witness::{retract, Arms, Hand, Scene, MOTION_STEP, Q};
use crate::models::DOF;

/// Fixture radii tried, largest first: the largest that keeps the clearance from the witness.
const RADII: [f64; 4] = [0.08, 0.065, 0.05, 0.04];
/// How closely fixtures hem the witness in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tightness {
    /// Room left between a fixture and every witness arm, so a planner need not retrace the
    /// witness exactly.
    pub clearance: f64,
    /// Random starts of IK tracking per (hand, arm), besides the witness's start and the
    /// retract.
    pub starts: usize,
    /// Most fixtures per hand.
    pub per_hand: usize,
}

impl Tightness {
    /// The benchmark suite's.
    pub const SUITE: Tightness = Tightness {
        clearance: 0.05,
        starts: 6,
        per_hand: 4,
    };
    /// The refinement family's (`refine_family`): more fixtures, closer to the witness, so
    /// that the free postures are few and far between.
    pub const TIGHT: Tightness = Tightness {
        clearance: 0.02,
        starts: 12,
        per_hand: 8,
    };
}
/// Fixtures block no track before this share of the horizon: a planner may start from any
/// posture and needs time to swing its elbow.
const FIRST_STEP: f64 = 0.2;
/// Arms whose base is farther than this from a hand's first position are not tried on it.
const REACH: f64 = 1.0;
/// The points a fixture may sit on: the origins of joints 3 to 5 (upper arm, elbow, forearm),
/// as link frame indices (the Gen3's `half_arm_2_link` to `spherical_wrist_1_link`, the
/// Panda's `panda_link3` to `panda_link5`: both chains have no fixed joint before them).
const PROBES: [usize; 3] = [3, 4, 5];

/// Fixtures for every hand (named `fixture_<k>`), given the witness `paths` of every arm.
pub fn traps(
    tight: Tightness,
    scene: &Scene,
    models: &[u8],
    bases: &[Frame],
    hands: &[Hand],
    paths: &[Vec<Q>],
    rng: &mut Rng,
) -> Vec<NamedObstacle> {
    let witness = Witness::new(models, bases, paths, tight.clearance);
    let mut fixtures: Vec<Obstacle> = Vec::new();
    for hand in hands {
        let mut live: Vec<(usize, Vec<Q>)> = Vec::new();
        for (arm, (&model, base)) in models.iter().zip(bases).enumerate() {
            if (base.pos - hand.poses[0].pos).norm() > REACH {
                continue;
            }
            let own = (arm == hand.arm).then_some(paths[arm][0]);
            let (lower, upper) = (Arms::lower(model), Arms::upper(model));
            let starts: Vec<Q> = (own.into_iter().chain([retract(model)]))
                .chain((0..tight.starts).map(|_| rng.configuration(lower, upper)))
                .collect();
            for start in starts {
                if let Some(path) = track_plainly(scene, model, base, &hand.poses, &start) {
                    let clear =
                        |obstacles: &[Obstacle]| path_is_free(model, base, &path, obstacles);
                    if clear(scene.obstacles) && clear(&fixtures) {
                        live.push((arm, path));
                    }
                }
            }
        }
        let mut placed = 0;
        while placed < tight.per_hand {
            let Some((arm, path)) = live.pop() else {
                break;
            };
            let Some(fixture) = witness.block(models[arm], &bases[arm], &path) else {
                continue;
            };
            let fixture_only = std::slice::from_ref(&fixture);
            live.retain(|(a, p)| path_is_free(models[*a], &bases[*a], p, fixture_only));
            fixtures.push(fixture);
            placed += 1;
        }
    }
    (fixtures.into_iter().enumerate())
        .map(|(k, o)| (format!("fixture_{k}"), o))
        .collect()
}

/// Every witness arm at every step and half-step, to measure how far a point is from it.
struct Witness<'a> {
    models: &'a [u8],
    bases: &'a [Frame],
    paths: &'a [Vec<Q>],
    poses: Vec<ArmPose>,
    clearance: f64,
}

impl<'a> Witness<'a> {
    fn new(models: &'a [u8], bases: &'a [Frame], paths: &'a [Vec<Q>], clearance: f64) -> Self {
        let mut poses = Vec::new();
        for ((&model, base), path) in models.iter().zip(bases).zip(paths) {
            for (t, q) in path.iter().enumerate() {
                let prev = &path[t.saturating_sub(1)];
                let mid: Q = std::array::from_fn(|j| 0.5 * (prev[j] + q[j]));
                // The suite's arms carry no tool.
                poses.push(ArmPose::new::<Arms, DOF>(model, base, &Tool::NONE, &mid));
                poses.push(ArmPose::new::<Arms, DOF>(model, base, &Tool::NONE, q));
            }
        }
        Witness {
            models,
            bases,
            paths,
            poses,
            clearance,
        }
    }

    /// Distance from `p` to the nearest witness arm surface (sampled at half-steps). The arms
    /// are visited nearest box first, and those whose box is farther than the nearest surface
    /// found so far are passed over: their capsules are inside their box, so none is nearer
    /// (the same minimum, sooner).
    fn gap(&self, p: &V3) -> f64 {
        let point = Aabb::around(p, &V3::zeros());
        let mut boxes: Vec<(f64, &ArmPose)> = (self.poses.iter())
            .map(|a| (a.aabb().distance(&point), a))
            .collect();
        boxes.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut nearest = f64::INFINITY;
        for (distance, a) in boxes {
            // Past float noise, so the minimum is the same to the bit.
            if distance > nearest + 1e-9 {
                break;
            }
            for c in a.capsules() {
                nearest = nearest.min(c.segment.distance2_to_point(p).sqrt() - c.radius);
            }
        }
        nearest
    }

    /// Whether a sphere of `radius` at `p` keeps the clearance from every witness motion.
    fn clears(&self, p: &V3, radius: f64) -> bool {
        let point = [p.x, p.y, p.z];
        (self.models.iter().zip(self.bases).zip(self.paths)).all(|((&model, base), path)| {
            (0..path.len()).all(|t| {
                let m = ArmMotion {
                    model,
                    base,
                    tool: &Tool::NONE,
                    from: &path[t.saturating_sub(1)],
                    to: &path[t],
                };
                !motion_near_point::<Arms, DOF>(&m, &point, radius + self.clearance, MOTION_STEP)
            })
        })
    }

    /// A fixture on one of the [`PROBES`] points of the arm of model `model` at `base` along
    /// `path`, as far from the witness as can be, as large as keeps clear of it; `None` when
    /// none fits.
    fn block(&self, model: u8, base: &Frame, path: &[Q]) -> Option<Obstacle> {
        let mut frames = vec![Frame::IDENTITY; Arms::link_names(model).len()];
        let mut points: Vec<(f64, V3)> = Vec::new();
        let first = (FIRST_STEP * path.len() as f64).ceil() as usize;
        for q in &path[first..] {
            Arms::link_frames(model, q, &mut frames);
            for &l in PROBES.iter().filter(|&&l| l < frames.len()) {
                let p = base.compose(&frames[l]).pos;
                points.push((self.gap(&p), p));
            }
        }
        points.sort_by(|a, b| b.0.total_cmp(&a.0));
        (points.iter().take(3)).find_map(|(gap, p)| {
            let radius = RADII
                .into_iter()
                .filter(|r| r + self.clearance < *gap)
                .find(|r| self.clears(p, *r))?;
            Some(Obstacle {
                shape: Shape::Sphere { radius },
                pose: at(*p),
            })
        })
    }
}

/// IK tracking of `poses` from the IK solution nearest `start`, with nothing in mind but the
/// joint speed limits; `None` where it breaks down.
fn track_plainly(
    scene: &Scene,
    model: u8,
    base: &Frame,
    poses: &[Frame],
    start: &Q,
) -> Option<Vec<Q>> {
    let params = IkParams::default();
    let velocity = Arms::velocity(model);
    let mut q = ik::<Arms, DOF>(model, &scene.target(base, &poses[0]), start, &params).ok()?;
    let mut path = vec![q];
    for pose in &poses[1..] {
        let next = ik::<Arms, DOF>(model, &scene.target(base, pose), &q, &params).ok()?;
        if (0..DOF).any(|j| (next[j] - q[j]).abs() > velocity[j] * scene.dt) {
            return None;
        }
        q = next;
        path.push(q);
    }
    Some(path)
}

/// Whether the arm of model `model` at `base` moves along `path` clear of `obstacles` and of
/// itself.
fn path_is_free(model: u8, base: &Frame, path: &[Q], obstacles: &[Obstacle]) -> bool {
    (0..path.len()).all(|t| {
        let m = ArmMotion {
            model,
            base,
            tool: &Tool::NONE,
            from: &path[t.saturating_sub(1)],
            to: &path[t],
        };
        motion_is_free::<Arms, DOF>(&m, obstacles, MOTION_STEP)
    })
}
