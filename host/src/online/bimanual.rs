//! Long bimanual episodes at a policy's own rate, for `omcbsa bench-online --family bimanual`:
//! the two tasks of the scripted policies of bimanual imitation-learning benchmarks (ALOHA's
//! "transfer cube" and "insertion"), as the grippers' poses over 8 s and more.
//!
//! - **Transfer.** One hand picks a cube from the table (pointing down), lifts it to a meeting
//!   point; the other hand comes from the side, pointing across, grasps it there; the first
//!   lets go and rises.
//! - **Insertion.** One hand picks a socket, the other a peg, both from above; both lift and
//!   bring them together over the table, the peg's hand closing in on the socket's.
//!
//! Two Gen3s face each other across a table, as the benchmark's two arms do; a third and a
//! fourth stand at the table's sides, a fifth and a sixth at two opposite corners (they may
//! take a hand, or hold still). Every arm starts at
//! Kinova's retract posture, so the first chunk needs an approach. Object positions, the
//! meeting point and the grasp yaw are drawn from a seeded generator; every keyframe is
//! checked reachable (IK) by the arm the task was drawn for, and an episode is drawn again
//! when one is not (the planner still chooses the assignment).

use omcbsa_core::ik::{ik_multi_start, IkParams, MultiStart};
use omcbsa_core::model::Frame;

use crate::models::{Fleet, ModelKind, DOF};
use omcbsa_core::nalgebra::{Rotation3, UnitQuaternion};
use omcbsa_core::rng::Rng;

use super::diagnose::follow;
use super::Setup;
use crate::format::{Pose, RobotSpec, ToleranceSpec};
use crate::format::{ProblemFile, TrajectorySpec, PROBLEM_FORMAT};
use crate::pose::from_frame;
use crate::suite::frames::{aligned, v3, yaw, V3};
use crate::suite::layout::obstacle_box;
use crate::suite::obstacle_spec;
use crate::suite::witness::RETRACT;
use omcbsa_core::problem::{Assigned, MAX_STEPS};

/// The benchmark's control rate, Hz, for which the keyframes' steps are written.
const BASE_HZ: f64 = 50.0;
/// Steps of an episode at `BASE_HZ` (50 Hz).
pub const EPISODE_STEPS: usize = 420;
/// The two facing arms stand this far from the table's centre.
const FACING_X: f64 = 0.6;
/// The side arms stand this far from the table's centre.
const SIDE_Y: f64 = 0.7;
/// The corner arms (a fifth and a sixth) stand this far from the table's centre.
const CORNER: f64 = 0.85;
/// Tool centre point beyond Kinova's tool frame (fingertips), m.
const TCP_LENGTH: f64 = 0.12;
/// Downward slope of the taking hand's pointing direction (about 31 degrees).
const TAKER_TILT: f64 = 0.4;
/// Draws of an episode's random values before giving up on a seed.
const DRAWS: usize = 64;

/// One episode: where the arms stand, and every hand's pose at every step.
#[derive(Clone, Debug)]
pub struct Episode {
    /// The episode's name.
    pub name: String,
    /// Where the arms stand and what is around them.
    pub setup: Setup,
    /// `hands[j][k]`: hand `j` at policy step `k`.
    pub hands: Vec<Vec<Pose>>,
}

/// Which scripted task.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Task {
    /// One hand picks a cube from the table and another takes it over at a meeting point.
    Transfer,
    /// One hand picks a socket, the other a peg, and they bring them together.
    Insertion,
}

impl Task {
    /// Every task.
    pub const ALL: [Task; 2] = [Task::Transfer, Task::Insertion];

    /// The task's name (`transfer`, `insertion`).
    pub fn name(self) -> &'static str {
        match self {
            Task::Transfer => "transfer",
            Task::Insertion => "insertion",
        }
    }
}

/// A hand's pose at a keyframe step (at [`BASE_HZ`]).
type Key = (usize, Frame);

fn down(pos: V3, yaw_angle: f64) -> Frame {
    aligned(pos, v3(0.0, 0.0, -1.0), yaw(yaw_angle) * v3(1.0, 0.0, 0.0))
}

/// Pointing along +x and down by [`TAKER_TILT`]: a hand reaching across the table towards
/// the other arm (level, it could not come closer than about 0.55 m to its base).
fn across(pos: V3) -> Frame {
    aligned(pos, v3(1.0, 0.0, -TAKER_TILT), v3(0.0, 0.0, -1.0))
}

/// The hands' keyframes of one draw: `(keys of hand 0, keys of hand 1)`; hand 0 belongs to
/// the arm at +x, hand 1 to the arm at -x.
fn keys(task: Task, rng: &mut Rng) -> [Vec<Key>; 2] {
    let end = EPISODE_STEPS;
    match task {
        Task::Transfer => {
            let cube = v3(rng.uniform(0.02, 0.14), rng.uniform(-0.14, 0.14), 0.025);
            let cube_yaw = rng.uniform(-0.5, 0.5);
            let meet = v3(
                rng.uniform(-0.04, 0.06),
                rng.uniform(-0.08, 0.08),
                rng.uniform(0.22, 0.3),
            );
            let up = v3(0.0, 0.0, 1.0);
            let picker = vec![
                (0, down(cube + 0.18 * up, cube_yaw)),
                (90, down(cube + 0.08 * up, cube_yaw)),
                (130, down(cube, cube_yaw)),
                (170, down(cube, cube_yaw)),
                (250, down(meet, 0.0)),
                (340, down(meet, 0.0)),
                (380, down(meet + 0.12 * up, 0.0)),
                (end, down(meet + 0.12 * up, 0.0)),
            ];
            let side = v3(1.0, 0.0, 0.0);
            let taker = vec![
                (0, across(meet - 0.14 * side + 0.14 * up)),
                (250, across(meet - 0.12 * side + 0.1 * up)),
                (310, across(meet - 0.06 * side + 0.035 * up)),
                (340, across(meet - 0.06 * side + 0.035 * up)),
                (end, across(meet - 0.14 * side + 0.12 * up)),
            ];
            [picker, taker]
        }
        Task::Insertion => {
            let peg = v3(rng.uniform(0.06, 0.16), rng.uniform(-0.14, 0.14), 0.03);
            let socket = v3(rng.uniform(-0.16, -0.06), rng.uniform(-0.14, 0.14), 0.03);
            let (peg_yaw, socket_yaw) = (rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5));
            let meet = v3(
                rng.uniform(-0.03, 0.03),
                rng.uniform(-0.06, 0.06),
                rng.uniform(0.18, 0.26),
            );
            let up = v3(0.0, 0.0, 1.0);
            let side = v3(1.0, 0.0, 0.0);
            let grasp = |at: V3, a: f64| {
                vec![
                    (0, down(at + 0.18 * up, a)),
                    (90, down(at + 0.08 * up, a)),
                    (130, down(at, a)),
                    (170, down(at, a)),
                ]
            };
            let mut peg_hand = grasp(peg, peg_yaw);
            peg_hand.extend([
                (260, down(meet + 0.16 * side, 0.0)),
                (360, down(meet + 0.08 * side, 0.0)),
                (end, down(meet + 0.08 * side, 0.0)),
            ]);
            let mut socket_hand = grasp(socket, socket_yaw);
            socket_hand.extend([
                (260, down(meet - 0.08 * side, 0.0)),
                (end, down(meet - 0.08 * side, 0.0)),
            ]);
            [peg_hand, socket_hand]
        }
    }
}

/// The pose at `step` (at [`BASE_HZ`], fractional) between keyframes: position and rotation
/// eased from one keyframe to the next, with zero speed at each.
fn sample(keys: &[Key], step: f64) -> Frame {
    let k = keys.partition_point(|(s, _)| (*s as f64) <= step);
    if k == 0 {
        return keys[0].1;
    }
    if k == keys.len() {
        return keys[k - 1].1;
    }
    let ((s0, f0), (s1, f1)) = (keys[k - 1], keys[k]);
    let s = crate::suite::frames::ease((step - s0 as f64) / (s1 - s0) as f64);
    let q0 = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(f0.rot));
    let q1 = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(f1.rot));
    Frame {
        rot: q0.slerp(&q1, s).to_rotation_matrix().into_inner(),
        pos: f0.pos.lerp(&f1.pos, s),
    }
}

/// The arms: two facing across the table, then the side arms, then two at opposite corners.
fn bases(arms: usize) -> Vec<Frame> {
    let up = v3(0.0, 0.0, 1.0);
    let corner = CORNER / std::f64::consts::SQRT_2;
    [
        aligned(v3(FACING_X, 0.0, 0.0), up, v3(-1.0, 0.0, 0.0)),
        aligned(v3(-FACING_X, 0.0, 0.0), up, v3(1.0, 0.0, 0.0)),
        aligned(v3(0.0, -SIDE_Y, 0.0), up, v3(0.0, 1.0, 0.0)),
        aligned(v3(0.0, SIDE_Y, 0.0), up, v3(0.0, -1.0, 0.0)),
        aligned(v3(corner, corner, 0.0), up, v3(-1.0, -1.0, 0.0)),
        aligned(v3(-corner, -corner, 0.0), up, v3(1.0, 1.0, 0.0)),
    ]
    .into_iter()
    .take(arms)
    .collect()
}

/// Where the Gen3's fingertips are in its tool frame (the flange).
pub(super) fn tcp() -> Frame {
    Frame {
        rot: Rotation3::identity().into_inner(),
        pos: v3(0.0, 0.0, TCP_LENGTH),
    }
}

/// Every keyframe is reachable by the arm at `base`.
fn reachable(base: &Frame, keys: &[Key], rng: &mut Rng) -> bool {
    let params = IkParams::default();
    let multi = MultiStart {
        attempts: 32,
        ..MultiStart::default()
    };
    let mut out = [[0.0; DOF]; 1];
    let model = ModelKind::default().id();
    keys.iter().all(|(_, pose)| {
        let target = base.inverse().compose(pose).compose(&tcp().inverse());
        matches!(
            ik_multi_start::<Fleet, DOF>(model, &target, &params, &multi, rng, &mut out),
            Ok(1)
        )
    })
}

/// Most arms an episode has.
pub const MAX_ARMS: usize = 6;

/// Episode `seed` of `task` on `arms` arms (2 to [`MAX_ARMS`]) at `hz` policy steps per second.
pub fn episode(task: Task, arms: usize, seed: u64, hz: f64) -> Option<Episode> {
    let bases = bases(arms);
    let mut rng = Rng::new(0xb1a7 ^ seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ task as u64);
    let [first, second] = (0..DRAWS).find_map(|_| {
        let k = keys(task, &mut rng);
        (reachable(&bases[0], &k[0], &mut rng) && reachable(&bases[1], &k[1], &mut rng))
            .then_some(k)
    })?;
    let steps = ((EPISODE_STEPS as f64) * hz / BASE_HZ).round() as usize + 1;
    let hand = |keys: &[Key]| -> Vec<Pose> {
        (0..steps)
            .map(|k| from_frame(&sample(keys, k as f64 * BASE_HZ / hz)))
            .collect()
    };
    let names = ["east", "west", "south", "north", "north_east", "south_west"];
    let setup = Setup {
        robots: (bases.iter().zip(names))
            .map(|(b, name)| RobotSpec {
                name: name.to_string(),
                model: ModelKind::default().name().to_string(),
                base: from_frame(b),
                initial: Some(RETRACT.to_vec()),
                tcp: Some(from_frame(&tcp())),
                tool: Some(crate::demo::gripper()),
            })
            .collect(),
        obstacles: vec![table()],
        tolerance: ToleranceSpec::default(),
        dt: 1.0 / hz,
    };
    let hands = vec![hand(&first), hand(&second)];
    witnessed(&setup, &hands, &mut rng).then(|| Episode {
        name: format!("bimanual_{}_{arms}arms_{seed:03}", task.name()),
        setup,
        hands,
    })
}

/// Seeds of IK for the witness's first configurations.
const WITNESS_SEEDS: usize = 8;

/// Whether the two facing arms can follow the hands (arm `j` hand `j`, the others holding at
/// retract) by IK from step to step within the joint limits and speeds and without collision
/// (see [`super::diagnose::follow`]), from some IK solution at the first pose: the episode
/// can be embodied, and the planner is not the judge of that.
fn witnessed(setup: &Setup, hands: &[Vec<Pose>], rng: &mut Rng) -> bool {
    let window = |from: usize, initial: &[[f64; 7]]| -> Option<omcbsa_core::problem::Problem<7>> {
        let len = hands[0].len().saturating_sub(from).min(MAX_STEPS - 1);
        let mut robots = setup.robots.clone();
        for (r, q) in robots.iter_mut().zip(initial) {
            r.initial = Some(q.to_vec());
        }
        let file = ProblemFile {
            format: PROBLEM_FORMAT.to_string(),
            name: "witness".to_string(),
            dt: setup.dt,
            robots,
            trajectories: (hands.iter().enumerate())
                .map(|(j, h)| TrajectorySpec {
                    name: format!("hand_{j}"),
                    poses: h[from..from + len].to_vec(),
                })
                .collect(),
            obstacles: setup.obstacles.clone(),
            tolerance: setup.tolerance,
        };
        let mut p = crate::load::problem::<Fleet, DOF>(&file).ok()?;
        for (i, r) in p.robots.iter_mut().enumerate() {
            r.assigned = match i {
                0 | 1 => Assigned::Track(i as u8),
                _ => Assigned::Hold,
            };
        }
        Some(p)
    };
    let params = IkParams::default();
    let multi = MultiStart {
        attempts: 32,
        ..MultiStart::default()
    };
    let n = setup.robots.len();
    (0..WITNESS_SEEDS).any(|_| {
        let mut q = vec![RETRACT; n];
        for (i, h) in hands.iter().enumerate() {
            let Ok(base) = crate::pose::to_frame(&setup.robots[i].base) else {
                return false;
            };
            let Ok(first) = crate::pose::to_frame(&h[0]) else {
                return false;
            };
            let target = base.inverse().compose(&first).compose(&tcp().inverse());
            let mut out = [[0.0; DOF]; 1];
            let model = ModelKind::default().id();
            if !matches!(
                ik_multi_start::<Fleet, DOF>(model, &target, &params, &multi, rng, &mut out),
                Ok(1)
            ) {
                return false;
            }
            q[i] = out[0];
        }
        let mut from = 0;
        loop {
            let Some(p) = window(from, &q) else {
                return false;
            };
            match follow::<Fleet, DOF>(&p, usize::from(from > 0), setup) {
                Ok(end) => q = end[..n].to_vec(),
                Err(_) => return false,
            }
            let len = p.horizon();
            if from + len >= hands[0].len() {
                return true;
            }
            from += len - 1;
        }
    })
}

/// The table the arms stand around, its top at z = 0.
pub(super) fn table() -> crate::format::ObstacleSpec {
    obstacle_spec(&obstacle_box(
        "table",
        v3(0.0, 0.0, -0.02),
        [0.4, 0.45, 0.02],
    ))
}

/// The family: for each arm count, `per_task` episodes of each task.
pub fn family(arms: &[usize], per_task: usize, hz: f64) -> Vec<Episode> {
    let mut out = Vec::new();
    for &n in arms {
        for task in Task::ALL {
            for seed in 0..per_task as u64 {
                out.extend(episode(task, n, seed, hz));
            }
        }
    }
    out
}
