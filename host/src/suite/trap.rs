//! Traps: fixtures (spheres) placed where myopic IK tracking takes an arm but no arm of the
//! witness ever goes. For every hand, IK tracking (each step's IK solution nearest the
//! previous configuration, which keeps the arm's elbow posture roughly where it started) is
//! run from the witness's own start, from the retract pose and from random starts, by every arm
//! that can reach the hand; each such track still clear of the scene gets a fixture on one of
//! its elbow or forearm points where it strays farthest from the witness. The witness swings
//! its elbows through the null space as it goes (see `witness`), so no single posture stays
//! near it all along: solving a trapped problem takes that null-space motion.

use omcbsa_core::collision::ArmPose;
use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::model::{Frame, Model};
use omcbsa_core::motion::{motion_is_free, motion_near_point, ArmMotion};
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;

use super::family::Hand;
use super::frames::{at, V3};
use super::layout::NamedObstacle;
use super::witness::{Gen3, Scene, MOTION_STEP, Q, RETRACT};

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
/// The points a fixture may sit on: the origins of joints 3 to 5 (upper arm, elbow, forearm).
const PROBE_LINKS: [&str; 3] = ["half_arm_2_link", "forearm_link", "spherical_wrist_1_link"];

/// Fixtures for every hand (named `fixture_<k>`), given the witness `paths` of every arm.
pub fn traps(
    tight: Tightness,
    scene: &Scene,
    bases: &[Frame],
    hands: &[Hand],
    paths: &[Vec<Q>],
    rng: &mut Rng,
) -> Vec<NamedObstacle> {
    let probes: Vec<usize> = (PROBE_LINKS.iter())
        .filter_map(|l| Gen3::LINK_NAMES.iter().position(|n| n == l))
        .collect();
    let witness = Witness::new(bases, paths, tight.clearance);
    let mut fixtures: Vec<Obstacle> = Vec::new();
    for hand in hands {
        let mut live: Vec<(usize, Vec<Q>)> = Vec::new();
        for (arm, base) in bases.iter().enumerate() {
            if (base.pos - hand.poses[0].pos).norm() > REACH {
                continue;
            }
            let own = (arm == hand.arm).then_some(paths[arm][0]);
            let starts: Vec<Q> = (own.into_iter().chain([RETRACT]))
                .chain((0..tight.starts).map(|_| rng.configuration(&Gen3::LOWER, &Gen3::UPPER)))
                .collect();
            for start in starts {
                if let Some(path) = track_plainly(scene, base, &hand.poses, &start) {
                    let clear = |obstacles: &[Obstacle]| path_is_free(base, &path, obstacles);
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
            let Some(fixture) = witness.block(&bases[arm], &path, &probes) else {
                continue;
            };
            live.retain(|(a, p)| path_is_free(&bases[*a], p, std::slice::from_ref(&fixture)));
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
    bases: &'a [Frame],
    paths: &'a [Vec<Q>],
    poses: Vec<ArmPose>,
    clearance: f64,
}

impl<'a> Witness<'a> {
    fn new(bases: &'a [Frame], paths: &'a [Vec<Q>], clearance: f64) -> Self {
        let mut poses = Vec::new();
        for (base, path) in bases.iter().zip(paths) {
            for (t, q) in path.iter().enumerate() {
                let prev = &path[t.saturating_sub(1)];
                let mid: Q = std::array::from_fn(|j| 0.5 * (prev[j] + q[j]));
                // The suite's arms carry no tool.
                poses.push(ArmPose::new::<Gen3, 7>(base, &Tool::NONE, &mid));
                poses.push(ArmPose::new::<Gen3, 7>(base, &Tool::NONE, q));
            }
        }
        Witness {
            bases,
            paths,
            poses,
            clearance,
        }
    }

    /// Distance from `p` to the nearest witness arm surface (sampled at half-steps).
    fn gap(&self, p: &V3) -> f64 {
        (self.poses.iter())
            .flat_map(|a| a.capsules())
            .map(|c| c.segment.distance2_to_point(p).sqrt() - c.radius)
            .fold(f64::INFINITY, f64::min)
    }

    /// Whether a sphere of `radius` at `p` keeps the clearance from every witness motion.
    fn clears(&self, p: &V3, radius: f64) -> bool {
        let point = [p.x, p.y, p.z];
        (self.bases.iter().zip(self.paths)).all(|(base, path)| {
            (0..path.len()).all(|t| {
                let m = ArmMotion {
                    base,
                    tool: &Tool::NONE,
                    from: &path[t.saturating_sub(1)],
                    to: &path[t],
                };
                !motion_near_point::<Gen3, 7>(&m, &point, radius + self.clearance, MOTION_STEP)
            })
        })
    }

    /// A fixture on one of the `probes` points of the arm at `base` along `path`, as far from
    /// the witness as can be, as large as keeps clear of it; `None` when none fits.
    fn block(&self, base: &Frame, path: &[Q], probes: &[usize]) -> Option<Obstacle> {
        let mut frames = vec![Frame::IDENTITY; Gen3::LINK_NAMES.len()];
        let mut points: Vec<(f64, V3)> = Vec::new();
        let first = (FIRST_STEP * path.len() as f64).ceil() as usize;
        for q in &path[first..] {
            Gen3::link_frames(q, &mut frames);
            for &l in probes {
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
fn track_plainly(scene: &Scene, base: &Frame, poses: &[Frame], start: &Q) -> Option<Vec<Q>> {
    let params = IkParams::default();
    let mut q = ik::<Gen3, 7>(&scene.target(base, &poses[0]), start, &params).ok()?;
    let mut path = vec![q];
    for pose in &poses[1..] {
        let next = ik::<Gen3, 7>(&scene.target(base, pose), &q, &params).ok()?;
        if (0..7).any(|j| (next[j] - q[j]).abs() > Gen3::VELOCITY[j] * scene.dt) {
            return None;
        }
        q = next;
        path.push(q);
    }
    Some(path)
}

/// Whether the arm at `base` moves along `path` clear of `obstacles` and of itself.
fn path_is_free(base: &Frame, path: &[Q], obstacles: &[Obstacle]) -> bool {
    (0..path.len()).all(|t| {
        let m = ArmMotion {
            base,
            tool: &Tool::NONE,
            from: &path[t.saturating_sub(1)],
            to: &path[t],
        };
        motion_is_free::<Gen3, 7>(&m, obstacles, MOTION_STEP)
    })
}
