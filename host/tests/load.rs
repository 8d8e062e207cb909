//! Reading problem and solution files: every class of malformed input is refused with the
//! exact path of the field at fault.

mod common;

use omcbsa::error::InputError;
use omcbsa::format::{ProblemFile, Status};
use omcbsa::load;
use omcbsa_core::geometry::Shape;
use omcbsa_core::model::KinovaGen3;
use omcbsa_core::problem::{MAX_OBSTACLES, MAX_ROBOTS, MAX_STEPS};
use serde_json::{json, Value};

/// A valid problem: two robots, one trajectory (so both robots need `initial`), one obstacle of
/// each shape.
fn valid() -> Value {
    let q = [0.0, 0.35, 0.0, 1.8, 0.0, 1.0, 0.0];
    let pose = json!({"position": [0.5, 0.0, 0.3], "quat_xyzw": [1, 0, 0, 0]});
    let identity = json!({"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]});
    json!({
        "format": "omcbsa.problem.v1",
        "name": "two_arms",
        "dt": 0.1,
        "robots": [
            {"name": "left", "model": "kinova_gen3", "base": identity, "initial": q},
            {"name": "right", "model": "kinova_gen3",
             "base": {"position": [0, 1, 0], "quat_xyzw": [0, 0, 0, 1]}, "initial": q,
             "tcp": {"position": [0, 0, 0.12], "quat_xyzw": [0, 0, 0, 1]}}
        ],
        "trajectories": [{"name": "hand_0", "poses": [pose, pose]}],
        "obstacles": [
            {"name": "table", "shape": "box", "half_extents": [0.6, 1.2, 0.02], "pose": identity},
            {"name": "ball", "shape": "sphere", "radius": 0.05, "pose": identity},
            {"name": "post", "shape": "capsule", "radius": 0.03, "half_length": 0.2, "pose": identity},
            {"name": "pipe", "shape": "cylinder", "radius": 0.03, "half_length": 0.2, "pose": identity}
        ],
        "tolerance": {"position_m": 0.001, "orientation_rad": 0.01}
    })
}

fn load(v: &Value) -> Result<omcbsa_core::problem::Problem<7>, InputError> {
    let file = load::parse_problem(&v.to_string())?;
    load::problem::<KinovaGen3, 7>(&file)
}

/// `valid()` with the value at JSON pointer `at` replaced (or removed when `new` is null).
fn with(at: &str, new: Value) -> Value {
    let mut v = valid();
    let (parent, key) = at.rsplit_once('/').unwrap();
    match v.pointer_mut(parent).unwrap() {
        Value::Object(m) if new.is_null() => {
            m.remove(key);
        }
        Value::Object(m) => {
            m.insert(key.to_string(), new);
        }
        Value::Array(a) => a[key.parse::<usize>().unwrap()] = new,
        _ => panic!("{at} is not in an object or array"),
    }
    v
}

#[track_caller]
fn refused(v: &Value, path: &str, text: &str) {
    match load(v) {
        Ok(_) => panic!("accepted; expected `{path}: ...{text}...`"),
        Err(e) => assert!(
            e.has(path, text),
            "expected `{path}: ...{text}...`, got:\n{e}"
        ),
    }
}

#[test]
fn a_valid_problem_loads_with_its_values() {
    let p = load(&valid()).unwrap();
    assert_eq!(
        (p.dt, p.robots.len(), p.horizon(), p.obstacles.len()),
        (0.1, 2, 2, 4)
    );
    // quat_xyzw [1, 0, 0, 0] is a half turn about x.
    let rot = p.trajectories[0][0].rot;
    assert!(
        (rot - omcbsa_core::nalgebra::Matrix3::from_diagonal(&[1.0, -1.0, -1.0].into())).amax()
            < 1e-15
    );
    assert_eq!(p.robots[1].base.pos.y, 1.0);
    assert_eq!(p.robots[1].tcp.pos.z, 0.12);
    assert_eq!(
        p.obstacles[2].shape,
        Shape::Capsule {
            radius: 0.03,
            half_length: 0.2
        }
    );
}

#[test]
fn optional_fields_take_their_defaults() {
    let mut v = valid();
    let o = v.as_object_mut().unwrap();
    o.remove("obstacles");
    o.insert("tolerance".into(), json!({"orientation_rad": 0.02}));
    let p = load(&v).unwrap();
    assert_eq!(
        (p.tolerance.position, p.tolerance.orientation),
        (0.001, 0.02)
    );
    assert!(p.obstacles.is_empty());
    assert_eq!(p.robots[0].tcp, omcbsa_core::model::Frame::IDENTITY);
}

#[test]
fn syntax_format_and_type_errors_name_the_field() {
    let e = load::parse_problem("{\"format\": ").unwrap_err();
    assert!(e.has("", "not valid JSON"), "{e}");
    refused(
        &with("/format", json!("omcbsa.problem.v2")),
        "format",
        "expected \"omcbsa.problem.v1\"",
    );
    refused(&with("/format", Value::Null), "format", "missing");
    refused(&with("/dt", json!("0.1")), "dt", "invalid type: string");
    refused(&with("/name", Value::Null), "", "missing field `name`");
    refused(
        &with("/robots/0/base/position", json!([0, 0])),
        "robots[0].base.position",
        "invalid length 2",
    );
    refused(
        &with("/obstacles/0/shape", json!("cone")),
        "obstacles[0].shape",
        "unknown variant `cone`",
    );
}

#[test]
fn unknown_fields_are_refused_outside_stats() {
    refused(
        &with("/robots/0/initail", json!([0.0])),
        "robots[0].initail",
        "unknown field `initail`",
    );
    refused(
        &with("/tolerance/position", json!(0.1)),
        "tolerance.position",
        "unknown field `position`",
    );
}

#[test]
fn numbers_beyond_a_double_are_refused() {
    let text = valid().to_string().replace("\"dt\":0.1", "\"dt\":1e999");
    let e = load::parse_problem(&text).unwrap_err();
    assert!(e.has("dt", "number out of range"), "{e}");
}

#[test]
fn non_finite_values_are_refused_where_they_are() {
    // JSON cannot hold NaN or infinity, but a problem built in code can.
    let mut file: ProblemFile = serde_json::from_value(valid()).unwrap();
    file.dt = f64::NAN;
    file.robots[1].base.position[1] = f64::INFINITY;
    file.robots[0].initial.as_mut().unwrap()[2] = f64::NAN;
    file.trajectories[0].poses[1].quat_xyzw[3] = f64::NAN;
    let e = load::problem::<KinovaGen3, 7>(&file).unwrap_err();
    assert!(e.has("dt", "must be > 0, got NaN"), "{e}");
    assert!(
        e.has("robots[1].base.position[1]", "inf is not a finite number"),
        "{e}"
    );
    assert!(
        e.has("robots[0].initial[2]", "NaN is not a finite number"),
        "{e}"
    );
    assert!(
        e.has(
            "trajectories[0].poses[1].quat_xyzw[3]",
            "not a finite number"
        ),
        "{e}"
    );
    assert_eq!(e.errors.len(), 4, "{e}");
}

#[test]
fn value_rules_name_field_and_index() {
    refused(&with("/dt", json!(0)), "dt", "must be > 0, got 0");
    refused(&with("/dt", json!(-0.1)), "dt", "must be > 0");
    refused(
        &with("/robots/0/model", json!("ur5")),
        "robots[0].model",
        "unknown model \"ur5\" (compiled in: kinova_gen3, franka_panda; aliases: panda for franka_panda)",
    );
    refused(
        &with("/robots/1/initial", json!([0, 0, 0, 0, 0, 0])),
        "robots[1].initial",
        "expected 7 joint values for model kinova_gen3, got 6",
    );
    refused(
        &with("/robots/0/initial/3", json!(3.5)),
        "robots[0].initial[3]",
        "3.5 is outside the limits [-2.57, 2.57] of joint joint_4",
    );
    refused(
        &with("/trajectories/0/poses/1/quat_xyzw", json!([0, 0, 0, 0.98])),
        "trajectories[0].poses[1].quat_xyzw",
        "norm 0.98 is more than 1e-6 away from 1",
    );
    refused(
        &with("/robots/1/tcp/quat_xyzw", json!([0, 0, 0, 1.00001])),
        "robots[1].tcp.quat_xyzw",
        "norm 1.00001 is more than 1e-6",
    );
    refused(
        &with("/tolerance/position_m", json!(0)),
        "tolerance.position_m",
        "must be > 0",
    );
    refused(
        &with("/tolerance/orientation_rad", json!(-1)),
        "tolerance.orientation_rad",
        "must be > 0",
    );
}

#[test]
fn a_quaternion_within_1e6_of_unit_norm_is_accepted() {
    assert!(load(&with(
        "/robots/1/tcp/quat_xyzw",
        json!([0, 0, 0, 1.0000009])
    ))
    .is_ok());
}

#[test]
fn obstacle_shapes_need_their_fields_and_only_theirs() {
    refused(
        &with("/obstacles/1/radius", json!(-0.05)),
        "obstacles[1].radius",
        "must be > 0, got -0.05",
    );
    refused(
        &with("/obstacles/0/half_extents", json!([0.6, 1.2, -0.02])),
        "obstacles[0].half_extents[2]",
        "must be > 0",
    );
    refused(
        &with("/obstacles/3/half_length", json!(-1)),
        "obstacles[3].half_length",
        "must be >= 0",
    );
    refused(
        &with("/obstacles/2/half_length", Value::Null),
        "obstacles[2].half_length",
        "missing (shape capsule needs it)",
    );
    refused(
        &with("/obstacles/0/half_extents", Value::Null),
        "obstacles[0].half_extents",
        "missing (shape box needs it)",
    );
    refused(
        &with("/obstacles/1/half_extents", json!([1, 1, 1])),
        "obstacles[1].half_extents",
        "not a field of shape sphere",
    );
    refused(
        &with("/obstacles/2/pose/quat_xyzw", json!([0, 0, 1, 1])),
        "obstacles[2].pose.quat_xyzw",
        "norm 1.414213562",
    );
}

#[test]
fn robots_and_trajectories_must_fit_together() {
    refused(&with("/robots", json!([])), "robots", "at least 1 robot");
    refused(
        &with("/trajectories", json!([])),
        "trajectories",
        "at least 1 trajectory",
    );
    let pose = json!({"position": [0.5, 0.0, 0.3], "quat_xyzw": [0, 0, 0, 1]});
    let three = json!([
        {"name": "a", "poses": [pose, pose]},
        {"name": "b", "poses": [pose, pose]},
        {"name": "c", "poses": [pose, pose]}
    ]);
    refused(
        &with("/trajectories", three),
        "trajectories",
        "3 trajectories but only 2 robots",
    );
    let uneven =
        json!([{"name": "a", "poses": [pose, pose]}, {"name": "b", "poses": [pose, pose, pose]}]);
    refused(
        &with("/trajectories", uneven),
        "trajectories[1].poses",
        "3 poses, but trajectories[0] has 2",
    );
    refused(
        &with("/trajectories/0/poses", json!([])),
        "trajectories[0].poses",
        "empty",
    );
}

#[test]
fn initial_is_required_only_when_some_robot_must_hold() {
    // One trajectory for two robots: either may hold.
    refused(
        &with("/robots/1/initial", Value::Null),
        "robots[1].initial",
        "missing: with fewer trajectories than robots",
    );
    // One trajectory per robot: nobody holds.
    let mut v = with("/robots/1/initial", Value::Null);
    let t = v["trajectories"][0].clone();
    v["trajectories"].as_array_mut().unwrap().push(t);
    assert!(load(&v).is_ok());
}

#[test]
fn capacities_are_refused_by_name_not_truncated() {
    let robot = valid()["robots"][0].clone();
    refused(
        &with("/robots", Value::Array(vec![robot; MAX_ROBOTS + 1])),
        "robots",
        "9 entries exceed the capacity MAX_ROBOTS = 8",
    );
    let pose = valid()["trajectories"][0]["poses"][0].clone();
    refused(
        &with(
            "/trajectories/0/poses",
            Value::Array(vec![pose; MAX_STEPS + 1]),
        ),
        "trajectories[0].poses",
        "capacity MAX_STEPS = 256",
    );
    let ball = valid()["obstacles"][1].clone();
    refused(
        &with("/obstacles", Value::Array(vec![ball; MAX_OBSTACLES + 1])),
        "obstacles",
        "capacity MAX_OBSTACLES = 64",
    );
    let pose = valid()["trajectories"][0]["poses"][0].clone();
    assert!(load(&with(
        "/trajectories/0/poses",
        Value::Array(vec![pose; MAX_STEPS])
    ))
    .is_ok());
}

#[test]
fn every_error_is_reported_at_once() {
    let mut v = with("/dt", json!(0));
    v["robots"][0]["model"] = json!("ur5");
    let e = load(&v).unwrap_err();
    assert!(
        e.has("dt", "must be > 0") && e.has("robots[0].model", "unknown model"),
        "{e}"
    );
    assert_eq!(e.to_string().lines().count(), 2, "{e}");
}

fn solution() -> Value {
    json!({
        "format": "omcbsa.solution.v1",
        "problem": "two_arms",
        "planner": "omcbsa",
        "status": "solved",
        "message": "",
        "planning_time_s": 0.0123,
        "assignment": [0, null],
        "joint_paths": [[[0, 0, 0, 0, 0, 0, 0]], [[0, 0, 0, 0, 0, 0, 0]]],
        "stats": {"nodes_expanded": 12, "anything": {"goes": ["here"]}}
    })
}

#[test]
fn a_valid_solution_loads_with_free_form_stats() {
    let s = load::parse_solution(&solution().to_string()).unwrap();
    assert_eq!(
        (s.status, s.assignment.as_slice()),
        (Status::Solved, [Some(0), None].as_slice())
    );
    assert_eq!(s.stats["anything"]["goes"][0], "here");
}

#[track_caller]
fn solution_refused(v: Value, path: &str, text: &str) {
    match load::parse_solution(&v.to_string()) {
        Ok(_) => panic!("accepted; expected `{path}: ...{text}...`"),
        Err(e) => assert!(
            e.has(path, text),
            "expected `{path}: ...{text}...`, got:\n{e}"
        ),
    }
}

#[test]
fn malformed_solutions_are_refused_with_the_field() {
    let set = |key: &str, value: Value| {
        let mut v = solution();
        if value.is_null() {
            v.as_object_mut().unwrap().remove(key);
        } else {
            v[key] = value;
        }
        v
    };
    solution_refused(
        set("format", json!("omcbsa.problem.v1")),
        "format",
        "expected \"omcbsa.solution.v1\"",
    );
    solution_refused(
        set("status", json!("done")),
        "status",
        "unknown variant `done`",
    );
    solution_refused(
        set("joint_paths", Value::Null),
        "joint_paths",
        "missing, but status is solved",
    );
    let mut timeout = set("status", json!("timeout"));
    solution_refused(
        timeout.clone(),
        "joint_paths",
        "present, but status is timeout",
    );
    timeout.as_object_mut().unwrap().remove("joint_paths");
    assert!(load::parse_solution(&timeout.to_string()).is_ok());
    let mut invalid = set("status", json!("invalid_problem"));
    invalid.as_object_mut().unwrap().remove("joint_paths");
    solution_refused(invalid, "message", "needs a message");
    solution_refused(
        set("planning_time_s", json!(-1)),
        "planning_time_s",
        "must be a finite number >= 0",
    );
    solution_refused(
        set("assignment", json!([0, -1])),
        "assignment[1]",
        "invalid value",
    );
    solution_refused(
        set("joint_paths", json!([[[0, "x"]]])),
        "joint_paths[0][0][1]",
        "invalid type",
    );
    solution_refused(set("extra", json!(1)), "extra", "unknown field `extra`");
}

#[test]
fn a_tool_loads_and_bad_tool_capsules_are_named() {
    let capsule = |radius: f64| json!({"a": [0, 0, 0.01], "b": [0, 0, 0.1], "radius": radius});
    let tool = |capsules: Vec<Value>| json!({"name": "gripper", "capsules": capsules});
    let p = load(&with("/robots/1/tool", tool(vec![capsule(0.04)]))).unwrap();
    assert_eq!(p.robots[1].tool.capsules().len(), 1);
    assert_eq!(p.robots[1].tool.capsules()[0].b, [0.0, 0.0, 0.1]);
    assert!(p.robots[0].tool.capsules().is_empty());
    refused(
        &with("/robots/1/tool", tool(vec![capsule(0.04), capsule(0.0)])),
        "robots[1].tool.capsules[1].radius",
        "must be > 0, got 0",
    );
    let many = vec![capsule(0.04); omcbsa_core::tool::MAX_TOOL_CAPSULES + 1];
    refused(
        &with("/robots/1/tool", tool(many)),
        "robots[1].tool.capsules",
        "exceed the capacity MAX_TOOL_CAPSULES = 4",
    );
    refused(
        &with("/robots/1/tool", json!({"capsules": []})),
        "robots[1].tool",
        "missing field `name`",
    );
}
