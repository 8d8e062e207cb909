//! Reading problem and solution files.
//!
//! Every rule of docs/FORMATS.md that a file alone can break is checked here, and every
//! broken rule is reported (not only the first) with the path of the field and index, e.g.
//! `robots[2].initial: expected 7 joint values for model kinova_gen3, got 6`. Input beyond
//! the core's capacities is refused with the capacity's name, never truncated. Rules that
//! need a problem and a solution together are the validator's ([`crate::validate`]).

use std::path::Path;

use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::model::{Frame, Model};
use omcbsa_core::problem::{
    Problem, Robot, Tolerance, Trajectory, MAX_OBSTACLES, MAX_ROBOTS, MAX_STEPS,
};
use serde::de::DeserializeOwned;
use serde_json::Value;

use crate::error::{Errors, InputError};
use crate::format::{
    ObstacleSpec, ProblemFile, RobotSpec, ShapeKind, SolutionFile, Status, PROBLEM_FORMAT,
    SOLUTION_FORMAT,
};
use crate::models::ModelKind;
use crate::pose::{self, short};

/// Reads a whole file, with an error naming it.
pub fn read_text(path: &Path) -> Result<String, InputError> {
    std::fs::read_to_string(path)
        .map_err(|e| InputError::one("", format!("cannot read {}: {e}", path.display())))
}

/// Parses a problem file (JSON syntax, `format`, field names and types). The values are
/// checked by [`problem`].
pub fn parse_problem(text: &str) -> Result<ProblemFile, InputError> {
    parse(text, PROBLEM_FORMAT)
}

/// Parses a solution file and checks it on its own ([`check_solution`]).
pub fn parse_solution(text: &str) -> Result<SolutionFile, InputError> {
    let file = parse(text, SOLUTION_FORMAT)?;
    check_solution(&file)?;
    Ok(file)
}

/// JSON text -> value (syntax errors carry line and column) -> `format` check -> typed value
/// (errors carry the field path). Checking `format` first means a file of another format is
/// reported as such, not as a list of unexpected fields.
fn parse<T: DeserializeOwned>(text: &str, format: &str) -> Result<T, InputError> {
    let value: Value = serde_json::from_str(text)
        .map_err(|e| InputError::one("", format!("not valid JSON: {e}")))?;
    match value.get("format") {
        Some(Value::String(f)) if f == format => {}
        Some(other) => {
            return Err(InputError::one(
                "format",
                format!("expected {format:?}, got {other}"),
            ))
        }
        None => {
            return Err(InputError::one(
                "format",
                format!("missing (expected {format:?})"),
            ))
        }
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        InputError::one(path, e.into_inner().to_string())
    })
}

/// The one model all robots of the problem use.
pub fn model_of(file: &ProblemFile) -> Result<ModelKind, InputError> {
    let mut errors = Errors::default();
    let model = check_models(file, &mut errors);
    errors.finish()?;
    model.ok_or_else(|| InputError::one("robots", "at least 1 robot is required"))
}

fn check_models(file: &ProblemFile, errors: &mut Errors) -> Option<ModelKind> {
    let mut first: Option<(usize, ModelKind)> = None;
    for (i, robot) in file.robots.iter().enumerate() {
        match (ModelKind::parse(&robot.model), first) {
            (Err(e), _) => errors.push(format!("robots[{i}].model"), e),
            (Ok(m), None) => first = Some((i, m)),
            (Ok(m), Some((f, fm))) if m != fm => errors.push(
                format!("robots[{i}].model"),
                format!(
                    "{m}, but robots[{f}].model is {fm}: all robots of a problem must use \
                     the same model for now"
                ),
            ),
            (Ok(_), Some(_)) => {}
        }
    }
    first.map(|(_, m)| m)
}

/// Checks every value of a problem file whose robots use model `M` and converts it into the
/// core's fixed-capacity problem.
pub fn problem<M: Model<D>, const D: usize>(file: &ProblemFile) -> Result<Problem<D>, InputError> {
    let mut errors = Errors::default();

    if file.robots.is_empty() {
        errors.push("robots", "at least 1 robot is required");
    }
    if let Some(model) = check_models(file, &mut errors) {
        if model.name() != M::NAME {
            errors.push(
                "robots",
                format!("the problem uses {model}, but was loaded for {}", M::NAME),
            );
        }
    }
    if !(file.dt.is_finite() && file.dt > 0.0) {
        errors.push("dt", format!("must be > 0, got {}", file.dt));
    }
    for (field, value) in [
        ("tolerance.position_m", file.tolerance.position_m),
        ("tolerance.orientation_rad", file.tolerance.orientation_rad),
    ] {
        if !(value.is_finite() && value > 0.0) {
            errors.push(field, format!("must be > 0, got {value}"));
        }
    }

    let (n_robots, n_traj) = (file.robots.len(), file.trajectories.len());
    if file.trajectories.is_empty() {
        errors.push("trajectories", "at least 1 trajectory is required");
    }
    if n_traj > n_robots {
        errors.push(
            "trajectories",
            format!("{n_traj} trajectories but only {n_robots} robots (at most one trajectory per robot)"),
        );
    }
    // Which robots hold is the planner's choice, so when some must, every robot may.
    let all_need_initial = n_traj < n_robots;
    let robots: Vec<_> = (file.robots.iter().enumerate())
        .map(|(i, r)| robot::<M, D>(i, r, all_need_initial, &mut errors))
        .collect();

    let horizon = file.trajectories.first().map_or(0, |t| t.poses.len());
    let trajectories: Vec<_> = (file.trajectories.iter().enumerate())
        .map(|(j, traj)| {
            let path = format!("trajectories[{j}].poses");
            if traj.poses.is_empty() {
                errors.push(&path, "empty: every trajectory needs at least 1 pose");
            } else if traj.poses.len() != horizon {
                errors.push(
                    &path,
                    format!(
                        "{} poses, but trajectories[0] has {horizon}: all trajectories must \
                         have the same length",
                        traj.poses.len()
                    ),
                );
            }
            let frames: Vec<_> = (traj.poses.iter().enumerate())
                .map(|(t, p)| checked(pose::to_frame(p), &format!("{path}[{t}]"), &mut errors))
                .collect();
            bounded::<Frame, MAX_STEPS>(&path, "MAX_STEPS", frames, &mut errors)
        })
        .collect();

    let obstacles: Vec<_> = (file.obstacles.iter().enumerate())
        .map(|(i, o)| obstacle(i, o, &mut errors))
        .collect();

    let robots = bounded::<Robot<D>, MAX_ROBOTS>("robots", "MAX_ROBOTS", robots, &mut errors);
    let trajectories =
        bounded::<Trajectory, MAX_ROBOTS>("trajectories", "MAX_ROBOTS", trajectories, &mut errors);
    let obstacles =
        bounded::<Obstacle, MAX_OBSTACLES>("obstacles", "MAX_OBSTACLES", obstacles, &mut errors);
    errors.finish()?;
    match (robots, trajectories, obstacles) {
        (Some(robots), Some(trajectories), Some(obstacles)) => Ok(Problem {
            dt: file.dt,
            robots,
            trajectories,
            obstacles,
            tolerance: Tolerance {
                position: file.tolerance.position_m,
                orientation: file.tolerance.orientation_rad,
            },
        }),
        // Every `None` above has recorded an error.
        _ => Err(InputError::one("", "invalid problem")),
    }
}

fn robot<M: Model<D>, const D: usize>(
    i: usize,
    spec: &RobotSpec,
    needs_initial: bool,
    errors: &mut Errors,
) -> Option<Robot<D>> {
    let path = format!("robots[{i}]");
    let base = checked(pose::to_frame(&spec.base), &format!("{path}.base"), errors);
    let tcp = match &spec.tcp {
        Some(p) => checked(pose::to_frame(p), &format!("{path}.tcp"), errors),
        None => Some(Frame::IDENTITY),
    };
    let initial = match &spec.initial {
        Some(q) => joint_values::<M, D>(q, &format!("{path}.initial"), errors).map(Some),
        None if needs_initial => {
            errors.push(
                format!("{path}.initial"),
                "missing: with fewer trajectories than robots some robots hold their initial \
                 configuration, and which ones is the planner's choice, so every robot needs one",
            );
            None
        }
        None => Some(None),
    };
    Some(Robot {
        base: base?,
        tcp: tcp?,
        initial: initial?,
        start: Default::default(),
        assigned: Default::default(),
    })
}

/// Checks a configuration of model `M` (length, finite values, joint limits).
pub fn joint_values<M: Model<D>, const D: usize>(
    q: &[f64],
    path: &str,
    errors: &mut Errors,
) -> Option<[f64; D]> {
    let Ok(q) = <[f64; D]>::try_from(q) else {
        errors.push(
            path,
            format!(
                "expected {D} joint values for model {}, got {}",
                M::NAME,
                q.len()
            ),
        );
        return None;
    };
    let mut ok = true;
    for (j, &v) in q.iter().enumerate() {
        if !v.is_finite() {
            errors.push(
                format!("{path}[{j}]"),
                format!("{v} is not a finite number"),
            );
            ok = false;
        } else if v < M::LOWER[j] || v > M::UPPER[j] {
            errors.push(
                format!("{path}[{j}]"),
                format!(
                    "{} is outside the limits [{}, {}] of joint {}",
                    short(v),
                    short(M::LOWER[j]),
                    short(M::UPPER[j]),
                    M::JOINT_NAMES[j]
                ),
            );
            ok = false;
        }
    }
    ok.then_some(q)
}

fn obstacle(i: usize, spec: &ObstacleSpec, errors: &mut Errors) -> Option<Obstacle> {
    let path = format!("obstacles[{i}]");
    let shape_name = spec.shape.as_str();
    let needs: &[&str] = match spec.shape {
        ShapeKind::Box => &["half_extents"],
        ShapeKind::Sphere => &["radius"],
        ShapeKind::Capsule | ShapeKind::Cylinder => &["radius", "half_length"],
    };
    let given = [
        ("half_extents", spec.half_extents.is_some()),
        ("radius", spec.radius.is_some()),
        ("half_length", spec.half_length.is_some()),
    ];
    for (field, present) in given {
        match (present, needs.contains(&field)) {
            (false, true) => errors.push(
                format!("{path}.{field}"),
                format!("missing (shape {shape_name} needs it)"),
            ),
            (true, false) => errors.push(
                format!("{path}.{field}"),
                format!("not a field of shape {shape_name}"),
            ),
            _ => {}
        }
    }
    let radius = spec
        .radius
        .and_then(|r| positive(r, &format!("{path}.radius"), errors));
    let half_length = spec.half_length.and_then(|h| {
        let ok = h.is_finite() && h >= 0.0;
        if !ok {
            errors.push(
                format!("{path}.half_length"),
                format!("must be >= 0, got {h}"),
            );
        }
        ok.then_some(h)
    });
    let half_extents = spec.half_extents.and_then(|e| {
        let ok = (e.iter().enumerate())
            .all(|(k, &v)| positive(v, &format!("{path}.half_extents[{k}]"), errors).is_some());
        ok.then_some(e)
    });
    let pose = checked(pose::to_frame(&spec.pose), &format!("{path}.pose"), errors);
    let shape = match spec.shape {
        ShapeKind::Box => Shape::Box {
            half_extents: half_extents?,
        },
        ShapeKind::Sphere => Shape::Sphere { radius: radius? },
        ShapeKind::Capsule => Shape::Capsule {
            radius: radius?,
            half_length: half_length?,
        },
        ShapeKind::Cylinder => Shape::Cylinder {
            radius: radius?,
            half_length: half_length?,
        },
    };
    Some(Obstacle { shape, pose: pose? })
}

fn positive(v: f64, path: &str, errors: &mut Errors) -> Option<f64> {
    let ok = v.is_finite() && v > 0.0;
    if !ok {
        errors.push(path, format!("must be > 0, got {v}"));
    }
    ok.then_some(v)
}

fn checked<T>(
    r: Result<T, crate::error::FieldError>,
    path: &str,
    errors: &mut Errors,
) -> Option<T> {
    r.map_err(|e| errors.add(e.within(path))).ok()
}

/// Moves checked items into a fixed-capacity vector. More than `N` items is an error naming
/// the capacity; `None` if so or if any item failed its checks (already reported).
fn bounded<T, const N: usize>(
    path: &str,
    capacity: &str,
    items: Vec<Option<T>>,
    errors: &mut Errors,
) -> Option<heapless::Vec<T, N>> {
    if items.len() > N {
        errors.push(
            path,
            format!(
                "{} entries exceed the capacity {capacity} = {N} of this build (refused, not \
                 truncated)",
                items.len()
            ),
        );
        return None;
    }
    let mut out = heapless::Vec::new();
    for item in items {
        // Cannot overflow: the length was checked above.
        out.push(item?).ok()?;
    }
    Some(out)
}

/// Checks a solution file on its own: numbers, and which fields its status requires.
pub fn check_solution(file: &SolutionFile) -> Result<(), InputError> {
    let mut errors = Errors::default();
    let t = file.planning_time_s;
    if !(t.is_finite() && t >= 0.0) {
        errors.push(
            "planning_time_s",
            format!("must be a finite number >= 0, got {t}"),
        );
    }
    match (&file.joint_paths, file.status) {
        (None, Status::Solved) => errors.push("joint_paths", "missing, but status is solved"),
        (Some(_), status) if status != Status::Solved => errors.push(
            "joint_paths",
            format!(
                "present, but status is {} (only solved solutions carry paths)",
                status.as_str()
            ),
        ),
        _ => {}
    }
    if file.status == Status::InvalidProblem && file.message.trim().is_empty() {
        errors.push(
            "message",
            "empty, but status invalid_problem needs a message saying what is wrong",
        );
    }
    for (i, path) in file.joint_paths.iter().flatten().enumerate() {
        for (t, q) in path.iter().enumerate() {
            if let Err(e) = pose::finite(q) {
                errors.add(e.within(&format!("joint_paths[{i}][{t}]")));
            }
        }
    }
    errors.finish()
}
