//! Fixtures for the cross-crate tests: problems built from witnesses (joint paths mapped by
//! forward kinematics), written as problem files and read back through the host's loader, so
//! every test exercises the same path a user's file takes.

use omcbsa::format::{ProblemFile, SolutionFile};
use omcbsa::load;
use omcbsa::plan::plan_file;
use omcbsa::planners::DOF;
use omcbsa::validate::validate;
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::nalgebra::{Rotation3, Vector3};
use omcbsa_core::problem::Problem;
use omcbsa_core::tool::Tool;
use serde_json::{json, Value};

pub mod approach_scenes;

/// A pose as the file format writes it.
pub fn pose_json(f: &Frame) -> Value {
    let q = omcbsa_core::nalgebra::UnitQuaternion::from_matrix(&f.rot);
    json!({"position": [f.pos.x, f.pos.y, f.pos.z], "quat_xyzw": [q.i, q.j, q.k, q.w]})
}

/// A frame from a position and roll-pitch-yaw angles.
pub fn frame(xyz: [f64; 3], rpy: [f64; 3]) -> Frame {
    Frame {
        rot: *Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).matrix(),
        pos: Vector3::new(xyz[0], xyz[1], xyz[2]),
    }
}

/// World tool pose of a Gen3 on `base` at `q`.
pub fn tool(base: &Frame, q: &[f64; DOF]) -> Frame {
    base.compose(&KinovaGen3::fk(q))
}

/// A robot entry of a problem file.
pub fn robot_json(name: &str, base: &Frame, initial: Option<&[f64; DOF]>) -> Value {
    let mut r = json!({"name": name, "model": "kinova_gen3", "base": pose_json(base)});
    if let Some(q) = initial {
        r["initial"] = json!(q.to_vec());
    }
    r
}

/// The trajectory a Gen3 on `base` draws with its tool when it follows `path`.
pub fn trajectory_json(name: &str, base: &Frame, path: &[[f64; DOF]]) -> Value {
    let poses: Vec<Value> = path.iter().map(|q| pose_json(&tool(base, q))).collect();
    json!({"name": name, "poses": poses})
}

/// A problem file from its parts (obstacles as file-format JSON objects).
pub fn problem_json(
    name: &str,
    dt: f64,
    robots: Vec<Value>,
    trajectories: Vec<Value>,
    obstacles: Vec<Value>,
) -> ProblemFile {
    let v = json!({
        "format": "omcbsa.problem.v1",
        "name": name,
        "dt": dt,
        "robots": robots,
        "trajectories": trajectories,
        "obstacles": obstacles,
    });
    load::parse_problem(&v.to_string()).expect("fixture problem parses")
}

/// The checked core problem of a file.
pub fn core_problem(file: &ProblemFile) -> Problem<DOF> {
    load::problem::<KinovaGen3, DOF>(file).expect("fixture problem is valid")
}

/// A sphere obstacle.
pub fn sphere(name: &str, c: [f64; 3], r: f64) -> Value {
    json!({"name": name, "shape": "sphere", "radius": r, "pose": {"position": c, "quat_xyzw": [0, 0, 0, 1]}})
}

/// A box obstacle.
pub fn cuboid(name: &str, c: [f64; 3], half: [f64; 3]) -> Value {
    json!({"name": name, "shape": "box", "half_extents": half, "pose": {"position": c, "quat_xyzw": [0, 0, 0, 1]}})
}

/// Two arms on `bases`, each drawing one hand trajectory with its witness path; the
/// trajectories are listed in the reverse order (trajectory 0 is robot 1's).
pub fn swapped_pair_problem(
    name: &str,
    bases: [Frame; 2],
    paths: [&[[f64; DOF]]; 2],
    obstacles: Vec<Value>,
) -> ProblemFile {
    problem_json(
        name,
        0.2,
        vec![
            robot_json("a", &bases[0], None),
            robot_json("b", &bases[1], None),
        ],
        vec![
            trajectory_json("h1", &bases[1], paths[1]),
            trajectory_json("h0", &bases[0], paths[0]),
        ],
        obstacles,
    )
}

/// A smooth joint path: `q0 + amp * sin(pi * t / (H - 1))` per joint.
pub fn smooth_path(q0: &[f64; DOF], amp: &[f64; DOF], h: usize) -> Vec<[f64; DOF]> {
    (0..h)
        .map(|t| {
            let s = (std::f64::consts::PI * t as f64 / (h.max(2) - 1) as f64).sin();
            let mut q = *q0;
            for i in 0..DOF {
                q[i] += amp[i] * s;
            }
            q
        })
        .collect()
}

/// Plans `file` with `planner` and checks the answer with the validator; returns the solution.
/// Every solution a planner reports solved must validate: this asserts it.
pub fn plan_and_validate(file: &ProblemFile, planner: &str, timeout: f64) -> SolutionFile {
    let kind = omcbsa::planners::parse(planner).expect("a known planner");
    let sol = plan_file(file, kind, timeout).expect("problem plans");
    assert!(
        !sol.message.contains("failed validation"),
        "{planner}: {}",
        sol.message
    );
    if sol.status == omcbsa::format::Status::Solved {
        let report = validate::<KinovaGen3, DOF>(file, &core_problem(file), &sol);
        assert!(
            report.is_valid(),
            "{planner} reported an invalid solution: {}",
            report.summary()
        );
    }
    sol
}

/// A random smooth joint path of `h` steps starting near `q0`, within position and velocity
/// limits (`dt`), made of two sine waves per joint with random amplitude and phase.
pub fn random_path(
    rng: &mut omcbsa_core::rng::Rng,
    q0: &[f64; DOF],
    spread: f64,
    h: usize,
    dt: f64,
) -> Vec<[f64; DOF]> {
    let amp: [f64; DOF] = std::array::from_fn(|_| rng.uniform(-spread, spread));
    let phase: [f64; DOF] = std::array::from_fn(|_| rng.uniform(0.0, std::f64::consts::PI));
    let vmax = KinovaGen3::VELOCITY;
    (0..h)
        .map(|t| {
            let s = t as f64 / (h.max(2) - 1) as f64;
            std::array::from_fn(|i| {
                // |d/dt| <= amp * pi / (h * dt): scaled to stay under 70 % of the limit.
                let w = std::f64::consts::PI;
                let a = amp[i].clamp(
                    -0.7 * vmax[i] * (h as f64 - 1.0) * dt / w,
                    0.7 * vmax[i] * (h as f64 - 1.0) * dt / w,
                );
                let q = q0[i] + a * ((w * s + phase[i]).sin() - phase[i].sin());
                q.clamp(KinovaGen3::LOWER[i] + 0.05, KinovaGen3::UPPER[i] - 0.05)
            })
        })
        .collect()
}

/// Whether the witness paths are collision-free (steps and motions, obstacles, self, each
/// other) and within velocity limits, by the core's own checks.
pub fn witness_is_valid(
    bases: &[Frame],
    paths: &[Vec<[f64; DOF]>],
    obstacles: &[omcbsa_core::geometry::Obstacle],
    dt: f64,
) -> bool {
    use omcbsa_core::motion::MOTION_STEP;
    use omcbsa_core::problem::Robot;
    use omcbsa_core::search::{OtherArm, OthersMode, Validity};
    (0..bases.len()).all(|i| {
        let others: Vec<OtherArm<'_, DOF>> = (0..i)
            .map(|k| OtherArm {
                model: 0,
                base: bases[k],
                tool: Tool::NONE,
                path: &paths[k],
            })
            .collect();
        let robot = Robot::at(0, bases[i]);
        let v = Validity::<KinovaGen3, DOF>::new(&robot, obstacles, dt, MOTION_STEP)
            .with_others(&others, OthersMode::Avoid);
        let p = &paths[i];
        (0..p.len()).all(|t| {
            v.state(&p[t], t).is_some()
                && (t + 1 == p.len()
                    || (v.step_within_limits(&p[t], &p[t + 1])
                        && v.motion(&p[t], &p[t + 1], t).is_some()))
        })
    })
}

/// A one-arm problem that needs a null-space elbow swing: the hand follows the witness `p0`
/// (random, from `seed`), the arm starts (`initial`) in the other elbow family (0.8 rad along
/// the null space), and a ball sits where that family's elbow is at step 8. Returns the problem
/// and the path IK tracking takes from `initial`, or `None` if this seed does not give such a
/// scene.
pub fn elbow_swing_problem(seed: u64) -> Option<(ProblemFile, Vec<[f64; DOF]>)> {
    use omcbsa_core::kinematics::null_space_basis;
    use omcbsa_core::motion::MOTION_STEP;
    use omcbsa_core::problem::Robot;
    use omcbsa_core::search::Validity;
    let mut rng = omcbsa_core::rng::Rng::new(seed);
    let base = frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    let q0: [f64; DOF] = std::array::from_fn(|i| HOME[i] + rng.uniform(-0.6, 0.6));
    let p0 = random_path(&mut rng, &q0, 0.8, 16, 0.2);
    let (_, j) = KinovaGen3::jacobian(&p0[0]);
    let n = *null_space_basis::<DOF>(&j).first()?;
    let shifted: [f64; DOF] = std::array::from_fn(|i| p0[0][i] + 0.8 * n[i]);
    let free = Validity::<KinovaGen3, DOF>::new(&Robot::at(0, base), &[], 0.2, MOTION_STEP);
    let traj: omcbsa_core::problem::Trajectory = p0.iter().map(KinovaGen3::fk).collect();
    let robot = Robot {
        model: 0,
        base,
        tcp: Frame::IDENTITY,
        initial: None,
        tool: Tool::NONE,
        start: Default::default(),
        assigned: Default::default(),
        excluded: omcbsa_core::problem::StartExclusions::NONE,
    };
    let mut alt = vec![[0.0; DOF]; p0.len()];
    omcbsa_core::tracking::track::<KinovaGen3, DOF>(
        &robot,
        &traj,
        &shifted,
        &free,
        omcbsa_core::tracking::Steps::Nearest(&Default::default()),
        &mut alt,
    )?;
    let mut f = [Frame::IDENTITY; 9];
    KinovaGen3::link_frames(&alt[8], &mut f);
    let elbow = f[4].pos;
    let ball = omcbsa_core::geometry::Obstacle {
        shape: omcbsa_core::geometry::Shape::Sphere { radius: 0.06 },
        pose: Frame {
            rot: Frame::IDENTITY.rot,
            pos: elbow,
        },
    };
    if !witness_is_valid(&[base], std::slice::from_ref(&p0), &[ball], 0.2) {
        return None;
    }
    let file = problem_json(
        &format!("elbow_swing_{seed}"),
        0.2,
        vec![robot_json("arm", &base, Some(&alt[0]))],
        vec![trajectory_json("hand", &base, &p0)],
        vec![sphere("ball", [elbow.x, elbow.y, elbow.z], 0.06)],
    );
    Some((file, alt))
}

/// Two arms facing each other `0.7..1.0` m apart, each following a random smooth witness path
/// (from `seed`); the trajectories are listed in the reverse order. `None` if the witness
/// collides.
pub fn facing_pair_problem(seed: u64) -> Option<ProblemFile> {
    let mut rng = omcbsa_core::rng::Rng::new(seed);
    let gap = rng.uniform(0.7, 1.0);
    let b0 = frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    let b1 = frame([gap, 0.0, 0.0], [0.0, 0.0, std::f64::consts::PI]);
    let q0: [f64; DOF] = std::array::from_fn(|i| HOME[i] + rng.uniform(-0.5, 0.5));
    let q1: [f64; DOF] = std::array::from_fn(|i| HOME[i] + rng.uniform(-0.5, 0.5));
    let p0 = random_path(&mut rng, &q0, 1.0, 20, 0.2);
    let p1 = random_path(&mut rng, &q1, 1.0, 20, 0.2);
    if !witness_is_valid(&[b0, b1], &[p0.clone(), p1.clone()], &[], 0.2) {
        return None;
    }
    Some(swapped_pair_problem(
        &format!("facing_pair_{seed}"),
        [b0, b1],
        [&p0, &p1],
        vec![],
    ))
}

/// The Gen3's usual "home" configuration, hand forward (Kinova's figures as published, so
/// 3.14 and 1.57 are not π and π/2).
#[allow(clippy::approx_constant)]
pub const HOME: [f64; DOF] = [0.0, 0.26, 3.14, -2.27, 0.0, 0.96, 1.57];

/// Two arms 1.4 m apart, each hand path close to one arm and out of the other's reach, listed
/// in the wrong order (trajectory 0 is robot 1's).
pub fn listed_order_wrong_problem() -> ProblemFile {
    let b0 = frame([0.0, -0.7, 0.0], [0.0, 0.0, 0.0]);
    let b1 = frame([0.0, 0.7, 0.0], [0.0, 0.0, 0.0]);
    let p0 = smooth_path(&HOME, &[0.4, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 15);
    let p1 = smooth_path(&HOME, &[-0.4, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 15);
    swapped_pair_problem("listed_order_wrong", [b0, b1], [&p0, &p1], vec![])
}

/// Two arms, two hands; no arm can track trajectory 0, whose hand passes through a ball at
/// step 5.
pub fn blocked_hand_problem() -> ProblemFile {
    let b0 = frame([0.0, -0.5, 0.0], [0.0, 0.0, 0.0]);
    let b1 = frame([0.0, 0.5, 0.0], [0.0, 0.0, 0.0]);
    let p0 = smooth_path(&HOME, &[0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 10);
    let p1 = smooth_path(&HOME, &[-0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 10);
    let hand = tool(&b0, &p0[5]).pos;
    problem_json(
        "blocked_hand",
        0.2,
        vec![
            robot_json("left", &b0, None),
            robot_json("right", &b1, None),
        ],
        vec![
            trajectory_json("blocked", &b0, &p0),
            trajectory_json("free", &b1, &p1),
        ],
        vec![sphere("ball", [hand.x, hand.y, hand.z], 0.03)],
    )
}
