//! Reading problem and solution files.
//!
//! Every rule of docs/FORMATS.md that a file alone can break is checked here, and every
//! broken rule is reported (not only the first) with the path of the field and index, e.g.
//! `robots[2].initial: expected 7 joint values for model kinova_gen3, got 6`. Input beyond
//! the core's capacities is refused with the capacity's name, never truncated. Rules that
//! need a problem and a solution together are the validator's ([`crate::validate`]).
//!
//! ```
//! use omcbsa::load;
//! use omcbsa::models::{Fleet, DOF};
//!
//! // Four rules broken at once: a negative dt, an unknown model, an initial configuration
//! // of the wrong length, and one missing (with two robots and one hand, either may have to
//! // hold where it stands). All four are reported, each at its field.
//! let text = r#"{
//!   "format": "omcbsa.problem.v1", "name": "bad", "dt": -0.1,
//!   "robots": [
//!     {"name": "a", "model": "ur5", "base": {"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]}},
//!     {"name": "b", "model": "kinova_gen3", "initial": [0, 0, 0],
//!      "base": {"position": [1, 0, 0], "quat_xyzw": [0, 0, 0, 1]}}],
//!   "trajectories": [{"name": "hand", "poses": [
//!     {"position": [0.5, 0, 0.4], "quat_xyzw": [1, 0, 0, 0]}]}]
//! }"#;
//! let file = load::parse_problem(text).unwrap(); // the JSON's shape is right
//! let err = load::problem::<Fleet, DOF>(&file).unwrap_err();
//! assert!(err.has("dt", "must be > 0"));
//! assert!(err.has("robots[0].model", "unknown model \"ur5\""));
//! assert!(err.has("robots[1].initial", "expected 7"));
//! assert!(err.has("robots[0].initial", "missing"));
//! assert_eq!(err.errors.len(), 4, "{err}");
//! ```

use std::collections::hash_map::{Entry, HashMap};
use std::io::Read;
use std::path::Path;

use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::problem::{
    Problem, Robot, Tolerance, Trajectory, MAX_OBSTACLES, MAX_ROBOTS, MAX_STEPS,
};
use omcbsa_core::tool::{Tool, ToolCapsule, ToolError, MAX_TOOL_CAPSULES};
use serde::de::DeserializeOwned;
use serde_json::error::Category;
use serde_json::value::RawValue;

use crate::error::{quoted, Errors, InputError};
use crate::format::DT_RANGE;
use crate::format::{
    ObstacleSpec, ProblemFile, RobotSpec, ShapeKind, SolutionFile, Status, ToolSpec,
    MAX_JOINT_VALUE, PROBLEM_FORMAT, SOLUTION_FORMAT,
};
use crate::models::ModelKind;
use crate::pose::{self, short};

/// Default cap on the size of a problem or solution file (16 MiB): more than 10 times the
/// largest file the core's capacities admit (8 robots x 256 steps), small enough that reading
/// (`omcbsa plan /dev/zero`) ends with an error instead of exhausting memory, and that the
/// costliest JSON (a free-form `stats` array of zeros) stays within about 300 MB.
/// `--max-input-mib` raises it.
pub const DEFAULT_MAX_INPUT_BYTES: u64 = 16 << 20;

/// Reads a whole file of at most [`DEFAULT_MAX_INPUT_BYTES`] as text ([`decode_text`]).
pub fn read_text(path: &Path) -> Result<String, InputError> {
    read_text_within(path, DEFAULT_MAX_INPUT_BYTES)
}

/// Reads a whole file of at most `max_bytes` as text ([`decode_text`]).
pub fn read_text_within(path: &Path, max_bytes: u64) -> Result<String, InputError> {
    let cannot =
        |e: std::io::Error| InputError::one("", format!("cannot read {}: {e}", path.display()));
    let file = std::fs::File::open(path).map_err(cannot)?;
    // `take` bounds the read even where the size is unknown (a pipe, /dev/zero).
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > max_bytes {
        return Err(InputError::one(
            "",
            format!(
                "larger than the input limit of {max_bytes} bytes (refused, not truncated; \
                 --max-input-mib raises the limit)"
            ),
        ));
    }
    decode_text(bytes)
}

/// File bytes as text: UTF-8, with a leading byte order mark (which some editors write)
/// accepted and dropped.
pub fn decode_text(mut bytes: Vec<u8>) -> Result<String, InputError> {
    const BOM: &[u8] = "\u{feff}".as_bytes();
    if bytes.starts_with(BOM) {
        bytes.drain(..BOM.len());
    }
    String::from_utf8(bytes).map_err(|e| {
        let e = e.utf8_error();
        InputError::one(
            "",
            format!(
                "not UTF-8 text: invalid byte at offset {} (files must be UTF-8 JSON)",
                e.valid_up_to()
            ),
        )
    })
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

/// JSON text -> `format` check -> typed value (errors carry the field path). Checking
/// `format` first means a file of another format is reported as such, not as a list of
/// unexpected fields. Neither pass builds a generic JSON tree: a tree costs up to 16 times
/// the text's size, the typed value about as much as the text.
pub(crate) fn parse<T: DeserializeOwned>(text: &str, format: &str) -> Result<T, InputError> {
    /// Only `format`, borrowed unparsed; every other field is skipped.
    #[derive(serde::Deserialize)]
    #[serde(rename = "JSON object")]
    struct Probe<'a> {
        #[serde(borrow, default)]
        format: Option<&'a RawValue>,
    }
    let probe: Probe = serde_json::from_str(text).map_err(|e| match e.classify() {
        Category::Data => InputError::one("", format!("not a {format} document: {e}")),
        _ => InputError::one("", format!("not valid JSON: {e}")),
    })?;
    match probe
        .format
        .map(|raw| (raw, serde_json::from_str::<String>(raw.get())))
    {
        Some((_, Ok(f))) if f == format => {}
        Some((raw, _)) => {
            return Err(InputError::one(
                "format",
                format!("expected {format:?}, got {}", raw.get()),
            ))
        }
        None => {
            return Err(InputError::one(
                "format",
                format!("missing (expected {format:?})"),
            ))
        }
    }
    let mut json = serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(&mut json).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        InputError::one(path, e.into_inner().to_string())
    })
}

/// Each robot's model; every unknown name is reported.
pub fn models(file: &ProblemFile) -> Result<Vec<ModelKind>, InputError> {
    let mut errors = Errors::default();
    let kinds: Vec<_> = (file.robots.iter().enumerate())
        .filter_map(|(i, robot)| {
            ModelKind::parse(&robot.model)
                .map_err(|e| errors.push(format!("robots[{i}].model"), e))
                .ok()
        })
        .collect();
    errors.finish()?;
    Ok(kinds)
}

/// Robot `i`'s model as an index into `M` (robots may use different models).
fn model_id<M: Models<D>, const D: usize>(
    i: usize,
    spec: &RobotSpec,
    errors: &mut Errors,
) -> Option<u8> {
    let path = format!("robots[{i}].model");
    let kind = ModelKind::parse(&spec.model)
        .map_err(|e| errors.push(&path, e))
        .ok()?;
    let id = M::find(kind.name());
    if id.is_none() {
        let loaded: Vec<&str> = (0..M::COUNT)
            .filter_map(|m| u8::try_from(m).ok().map(M::name))
            .collect();
        errors.push(
            path,
            format!(
                "{kind}, but the problem was loaded for {}",
                loaded.join(", ")
            ),
        );
    }
    id
}

/// Checks every value of a problem file whose robots use models of `M` and converts it into
/// the core's fixed-capacity problem, each robot's model an index into `M`. Every broken rule
/// is reported at its field (the module's example); input beyond a capacity
/// ([`MAX_ROBOTS`], [`MAX_STEPS`], [`MAX_OBSTACLES`], [`MAX_TOOL_CAPSULES`]) is refused with
/// the capacity's name, never truncated.
///
/// ```
/// use omcbsa::load;
/// use omcbsa::models::{Fleet, DOF};
///
/// let text = r#"{
///   "format": "omcbsa.problem.v1", "name": "one", "dt": 0.1,
///   "robots": [{"name": "arm", "model": "panda",
///               "base": {"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]}}],
///   "trajectories": [{"name": "hand", "poses": [
///     {"position": [0.5, 0, 0.4], "quat_xyzw": [1, 0, 0, 0]},
///     {"position": [0.5, 0, 0.41], "quat_xyzw": [1, 0, 0, 0]}]}]
/// }"#;
/// let problem = load::problem::<Fleet, DOF>(&load::parse_problem(text).unwrap()).unwrap();
/// assert_eq!(problem.horizon(), 2);
/// // `panda` is an alias of `franka_panda`, model 1 of the fleet.
/// assert_eq!(problem.robots[0].model, 1);
/// assert!((problem.trajectories[0][1].pos.z - 0.41).abs() < 1e-12);
/// ```
pub fn problem<M: Models<D>, const D: usize>(file: &ProblemFile) -> Result<Problem<D>, InputError> {
    let mut errors = Errors::default();

    if file.robots.is_empty() {
        errors.push("robots", "at least 1 robot is required");
    }
    if !(file.dt.is_finite() && file.dt > 0.0) {
        errors.push("dt", format!("must be > 0, got {}", file.dt));
    } else if !DT_RANGE.contains(&file.dt) {
        errors.push(
            "dt",
            format!(
                "must be within [{}, {}] s, got {}",
                DT_RANGE.start(),
                DT_RANGE.end(),
                file.dt
            ),
        );
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
    check_robot_names(&file.robots, &mut errors);

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

/// Robot names address the arms (`execute --arm NAME=BUS`): each must be unique, non-empty
/// and free of `=`.
fn check_robot_names(robots: &[RobotSpec], errors: &mut Errors) {
    let mut first_of: HashMap<&str, usize> = HashMap::with_capacity(robots.len());
    for (i, robot) in robots.iter().enumerate() {
        let path = format!("robots[{i}].name");
        let name = robot.name.as_str();
        if name.is_empty() {
            errors.push(
                path,
                "empty: a robot needs a name (execute's --arm NAME=BUS uses it)",
            );
        } else if name.contains('=') {
            errors.push(
                path,
                format!(
                    "{} contains '=', so execute's --arm NAME=BUS cannot name it",
                    quoted(name)
                ),
            );
        } else {
            match first_of.entry(name) {
                Entry::Vacant(slot) => {
                    slot.insert(i);
                }
                Entry::Occupied(first) => errors.push(
                    path,
                    format!(
                        "{} is also the name of robots[{}]: robot names must be unique",
                        quoted(name),
                        first.get()
                    ),
                ),
            }
        }
    }
}

fn robot<M: Models<D>, const D: usize>(
    i: usize,
    spec: &RobotSpec,
    needs_initial: bool,
    errors: &mut Errors,
) -> Option<Robot<D>> {
    let path = format!("robots[{i}]");
    let model = model_id::<M, D>(i, spec, errors);
    let base = checked(pose::to_frame(&spec.base), &format!("{path}.base"), errors);
    let tcp = match &spec.tcp {
        Some(p) => checked(pose::to_frame(p), &format!("{path}.tcp"), errors),
        None => Some(Frame::IDENTITY),
    };
    let initial = match &spec.initial {
        // Without a model its joint values cannot be checked (the model's error is reported).
        Some(q) => model
            .and_then(|m| joint_values::<M, D>(m, q, &format!("{path}.initial"), errors).map(Some)),
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
    let tool = match &spec.tool {
        Some(t) => tool(t, &format!("{path}.tool"), errors),
        None => Some(Tool::NONE),
    };
    Some(Robot {
        model: model?,
        base: base?,
        tcp: tcp?,
        initial: initial?,
        tool: tool?,
        start: Default::default(),
        assigned: Default::default(),
        excluded: omcbsa_core::problem::StartExclusions::NONE,
    })
}

/// The values joint `j` of model `model` of `M` may take in a file: its limits, within
/// ±[`MAX_JOINT_VALUE`] (which bounds the continuous joints).
pub fn joint_range<M: Models<D>, const D: usize>(model: u8, j: usize) -> (f64, f64) {
    (
        M::lower(model)[j].max(-MAX_JOINT_VALUE),
        M::upper(model)[j].min(MAX_JOINT_VALUE),
    )
}

/// Checks a tool's capsules (finite points, radii > 0, at most [`MAX_TOOL_CAPSULES`]).
fn tool(spec: &ToolSpec, path: &str, errors: &mut Errors) -> Option<Tool> {
    let capsules: Vec<ToolCapsule> = (spec.capsules.iter())
        .map(|c| ToolCapsule {
            a: c.a,
            b: c.b,
            radius: c.radius,
        })
        .collect();
    match Tool::new(&capsules) {
        Ok(tool) => Some(tool),
        Err(ToolError::TooMany) => {
            errors.push(
                format!("{path}.capsules"),
                format!(
                    "{} entries exceed the capacity MAX_TOOL_CAPSULES = {MAX_TOOL_CAPSULES} of this build (refused, not truncated)",
                    capsules.len()
                ),
            );
            None
        }
        Err(ToolError::BadCapsule(_)) => {
            // Every bad capsule is named, not only the first.
            for (k, c) in capsules.iter().enumerate() {
                let at = format!("{path}.capsules[{k}]");
                for (field, p) in [("a", c.a), ("b", c.b)] {
                    if let Err(e) = pose::finite(&p) {
                        errors.add(e.within(&format!("{at}.{field}")));
                    }
                }
                positive(c.radius, &format!("{at}.radius"), errors);
            }
            None
        }
    }
}

/// Checks a configuration of model `model` of `M` (length, finite values, [`joint_range`]).
pub fn joint_values<M: Models<D>, const D: usize>(
    model: u8,
    q: &[f64],
    path: &str,
    errors: &mut Errors,
) -> Option<[f64; D]> {
    let Ok(q) = <[f64; D]>::try_from(q) else {
        errors.push(
            path,
            format!(
                "expected {D} joint values for model {}, got {}",
                M::name(model),
                q.len()
            ),
        );
        return None;
    };
    let mut ok = true;
    for (j, &v) in q.iter().enumerate() {
        let (lower, upper) = joint_range::<M, D>(model, j);
        if !v.is_finite() {
            errors.push(
                format!("{path}[{j}]"),
                format!("{v} is not a finite number"),
            );
            ok = false;
        } else if v < lower || v > upper {
            errors.push(
                format!("{path}[{j}]"),
                format!(
                    "{} is outside the limits [{}, {}] of joint {}",
                    short(v),
                    short(lower),
                    short(upper),
                    M::joint_names(model)[j]
                ),
            );
            ok = false;
        }
    }
    ok.then_some(q)
}

/// Checks obstacle `i` of a file (the fields its shape needs, sizes, pose) and converts it.
pub fn obstacle(i: usize, spec: &ObstacleSpec, errors: &mut Errors) -> Option<Obstacle> {
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
    if file.approach.is_some() && file.status != Status::Solved {
        errors.push(
            "approach",
            format!(
                "present, but status is {} (only solved solutions carry an approach)",
                file.status.as_str()
            ),
        );
    }
    for (i, path) in file.approach.iter().flatten().enumerate() {
        for (k, q) in path.iter().enumerate() {
            if let Err(e) = pose::finite(q) {
                errors.add(e.within(&format!("approach[{i}][{k}]")));
            }
        }
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
