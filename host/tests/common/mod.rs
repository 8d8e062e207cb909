//! Small scenes built by hand: trajectories made by forward kinematics of given joint paths,
//! so that a scene is valid until a test breaks one rule.
#![allow(dead_code)] // Each test file uses a different part of this module.

use omcbsa::format::{
    joint_paths_value, Pose, ProblemFile, RobotSpec, SolutionFile, Status, ToleranceSpec,
    TrajectorySpec, PROBLEM_FORMAT, SOLUTION_FORMAT,
};
use omcbsa::pose;
use omcbsa_core::model::{KinovaGen3, Model};
use serde_json::Map;

pub type Q = [f64; 7];

/// A collision-free configuration of the Gen3 (elbow bent, tool pointing forward and down).
pub const Q0: Q = [0.0, 0.35, 0.0, 1.8, 0.0, 1.0, 0.0];

/// The arm folded onto itself: the wrist against the upper arm.
pub const FOLDED: Q = [0.0, 0.0, 0.0, 2.57, 0.0, 2.09, 0.0];

/// `Q0` moved by `k * 0.05` rad on every joint: a path well within the velocity limits at
/// `dt = 0.1`.
pub fn near_q0(k: f64) -> Q {
    Q0.map(|v| v + 0.05 * k)
}

pub fn at(position: [f64; 3]) -> Pose {
    Pose {
        position,
        quat_xyzw: [0.0, 0.0, 0.0, 1.0],
    }
}

pub fn robot(name: &str, base: Pose, initial: Option<Q>) -> RobotSpec {
    RobotSpec {
        name: name.to_string(),
        model: "kinova_gen3".to_string(),
        base,
        initial: initial.map(|q| q.to_vec()),
        tcp: None,
        tool: None,
    }
}

/// The trajectory a robot based at `base` (identity tcp) follows along `path`.
pub fn trajectory_of(name: &str, base: &Pose, path: &[Q]) -> TrajectorySpec {
    let base = pose::to_frame(base).unwrap();
    let poses = path
        .iter()
        .map(|q| pose::from_frame(&base.compose(&KinovaGen3::fk(q))))
        .collect();
    TrajectorySpec {
        name: name.to_string(),
        poses,
    }
}

pub fn problem(robots: Vec<RobotSpec>, trajectories: Vec<TrajectorySpec>, dt: f64) -> ProblemFile {
    ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: "tiny".to_string(),
        dt,
        robots,
        trajectories,
        obstacles: Vec::new(),
        tolerance: ToleranceSpec::default(),
    }
}

pub fn solution(assignment: Vec<Option<usize>>, paths: Vec<Vec<Q>>) -> SolutionFile {
    SolutionFile {
        approach: None,
        format: SOLUTION_FORMAT.to_string(),
        problem: "tiny".to_string(),
        planner: "by hand".to_string(),
        status: Status::Solved,
        message: String::new(),
        planning_time_s: 0.0,
        assignment,
        joint_paths: Some(joint_paths_value(&paths)),
        stats: Map::new(),
    }
}

/// One robot at the origin tracking `path`: the smallest valid scene.
pub fn one_robot(path: &[Q], dt: f64) -> (ProblemFile, SolutionFile) {
    let base = at([0.0; 3]);
    let problem = problem(
        vec![robot("solo", base, None)],
        vec![trajectory_of("hand", &base, path)],
        dt,
    );
    (problem, solution(vec![Some(0)], vec![path.to_vec()]))
}

/// The default one-robot scene: H = 3 steps near `Q0`.
pub fn tiny() -> (ProblemFile, SolutionFile) {
    one_robot(&[near_q0(0.0), near_q0(1.0), near_q0(2.0)], 0.1)
}

/// World position of the origin of link `link` of a robot at the origin at `q`.
pub fn link_origin(q: &Q, link: usize) -> [f64; 3] {
    let mut frames = [omcbsa_core::model::Frame::IDENTITY; 32];
    KinovaGen3::link_frames(q, &mut frames);
    frames[link].pos.into()
}

/// Two robots 2 m apart: the first tracks, the second holds.
pub fn two_robots() -> (ProblemFile, SolutionFile) {
    let path = [near_q0(0.0), near_q0(1.0), near_q0(2.0)];
    let (a, b) = (at([0.0; 3]), at([2.0, 0.0, 0.0]));
    let problem = problem(
        vec![robot("left", a, Some(Q0)), robot("right", b, Some(Q0))],
        vec![trajectory_of("hand", &a, &path)],
        0.1,
    );
    let solution = solution(vec![Some(0), None], vec![path.to_vec(), vec![Q0; 3]]);
    (problem, solution)
}

/// Runs `f` on a thread with a main thread's stack: the loader's and the validator's core
/// problems (200 kB each) live on the stack.
pub fn on_big_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(8 << 20)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap();
}
