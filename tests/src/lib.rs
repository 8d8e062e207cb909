//! Fixtures for the cross-crate tests: problems built from witnesses (joint paths mapped by
//! forward kinematics), written as problem files and read back through the host's loader, so
//! every test exercises the same path a user's file takes.

use omcbsa::format::{ProblemFile, SolutionFile};
use omcbsa::load;
use omcbsa::planners::{plan_file, DOF};
use omcbsa::validate::validate;
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::nalgebra::{Rotation3, Vector3};
use omcbsa_core::problem::Problem;
use serde_json::{json, Value};

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
pub fn problem_json(name: &str, dt: f64, robots: Vec<Value>, trajectories: Vec<Value>, obstacles: Vec<Value>) -> ProblemFile {
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
    let sol = plan_file(file, planner, timeout).expect("problem plans");
    assert!(!sol.message.contains("failed validation"), "{planner}: {}", sol.message);
    if sol.status == omcbsa::format::Status::Solved {
        let report = validate::<KinovaGen3, DOF>(file, &core_problem(file), &sol);
        assert!(report.is_valid(), "{planner} reported an invalid solution: {}", report.summary());
    }
    sol
}
