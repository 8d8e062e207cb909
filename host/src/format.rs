//! The file formats `omcbsa.problem.v1` and `omcbsa.solution.v1` as serde types
//! (docs/FORMATS.md).
//!
//! These types mirror the JSON one to one and check only what the JSON shape itself says
//! (field names, types, fixed array lengths). Every rule about values (finite numbers, unit
//! quaternions, lengths that depend on the model, ...) is checked by [`crate::load`], which
//! names the field and index that breaks it.
//!
//! Unknown fields are refused everywhere except inside `stats`: a misspelt optional field
//! (`"initail"`, `"tolerence"`) would otherwise be dropped silently and change the problem.
//!
//! ```
//! use omcbsa::format::{Pose, ProblemFile, RobotSpec, TrajectorySpec, PROBLEM_FORMAT};
//! use omcbsa::load;
//!
//! let file = ProblemFile {
//!     format: PROBLEM_FORMAT.to_string(),
//!     name: "reach".to_string(),
//!     dt: 0.1,
//!     robots: vec![RobotSpec {
//!         name: "arm".to_string(),
//!         model: "kinova_gen3".to_string(),
//!         base: Pose::IDENTITY,
//!         initial: None,
//!         tcp: None,
//!         tool: None,
//!     }],
//!     trajectories: vec![TrajectorySpec {
//!         name: "hand".to_string(),
//!         poses: vec![Pose { position: [0.5, 0.0, 0.4], quat_xyzw: [1.0, 0.0, 0.0, 0.0] }],
//!     }],
//!     obstacles: Vec::new(),
//!     tolerance: Default::default(),
//! };
//! // Written and read back, it is the same file; optional fields left out stay out.
//! let text = serde_json::to_string(&file).unwrap();
//! assert!(!text.contains("initial") && !text.contains("obstacles"));
//! assert_eq!(load::parse_problem(&text).unwrap(), file);
//!
//! // A misspelt field is refused, with its path.
//! let typo = text.replace("\"dt\"", "\"dtt\"");
//! let err = load::parse_problem(&typo).unwrap_err();
//! assert!(err.to_string().contains("unknown field `dtt`"), "{err}");
//! ```

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// The `format` string of a problem file.
pub const PROBLEM_FORMAT: &str = "omcbsa.problem.v1";
/// The `format` string of a solution file.
pub const SOLUTION_FORMAT: &str = "omcbsa.solution.v1";

/// The largest joint value (rad, either sign) a file may hold, for any joint; a joint's own
/// limits may be narrower. It is the range the CAN bus encodes (`omcbsa_hw`'s i32 counts of
/// 1e-7 rad, ±214.7 rad), so that a solution that validates is one that can execute.
pub const MAX_JOINT_VALUE: f64 = omcbsa_hw::cia402::MAX_POSITION_RAD;

/// A rigid pose in the world frame: position in metres, unit quaternion in ROS order.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Position, metres.
    pub position: [f64; 3],
    /// Orientation: a unit quaternion `[x, y, z, w]` (norm within 1e-6 of 1).
    pub quat_xyzw: [f64; 4],
}

impl Pose {
    /// At the origin, not rotated.
    pub const IDENTITY: Pose = Pose {
        position: [0.0; 3],
        quat_xyzw: [0.0, 0.0, 0.0, 1.0],
    };
}

/// The `dt` a problem may have, s. Below 1 ms consecutive poses are closer together than the
/// Gen3's 1 kHz control loop can follow; above a minute between two poses a plan is no longer
/// a motion (and its execution's length in control cycles grows without bound).
pub const DT_RANGE: std::ops::RangeInclusive<f64> = 0.001..=60.0;

/// A problem file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemFile {
    /// [`PROBLEM_FORMAT`].
    pub format: String,
    /// The problem's name (solutions name it).
    pub name: String,
    /// Time between consecutive poses, s (within [`DT_RANGE`]).
    pub dt: f64,
    /// The arms (at least 1).
    pub robots: Vec<RobotSpec>,
    /// The hands' trajectories (at least 1, at most one per robot, all of one length).
    pub trajectories: Vec<TrajectorySpec>,
    /// Fixed obstacles (optional).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub obstacles: Vec<ObstacleSpec>,
    /// How closely the hands must be followed (optional).
    #[serde(default)]
    pub tolerance: ToleranceSpec,
}

/// One robot of a problem file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    /// The robot's name (unique in the problem).
    pub name: String,
    /// Its model's name (`kinova_gen3`, `franka_panda`; see [`crate::models::ModelKind`]).
    pub model: String,
    /// The pose of the model's base frame in the world.
    pub base: Pose,
    /// The arm's current configuration; its length depends on the model, so it is checked
    /// by [`crate::load`], not here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<Vec<f64>>,
    /// The tool centre point relative to the model's tool frame (default: identity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tcp: Option<Pose>,
    /// What the flange carries (default: nothing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tool: Option<ToolSpec>,
}

/// The collision shape of what a robot carries: capsules in the model's tool frame (the
/// frame `tcp` is given in).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolSpec {
    /// Named in validation messages.
    pub name: String,
    /// At most [`omcbsa_core::tool::MAX_TOOL_CAPSULES`].
    pub capsules: Vec<ToolCapsuleSpec>,
}

/// Points within `radius` (metres) of the segment `a`-`b` (tool frame, metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolCapsuleSpec {
    /// One end of the axis.
    pub a: [f64; 3],
    /// The other end.
    pub b: [f64; 3],
    /// Radius (above 0).
    pub radius: f64,
}

/// One trajectory of tool centre point poses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    /// The trajectory's name (for messages).
    pub name: String,
    /// One pose per step, `dt` apart, in the world frame.
    pub poses: Vec<Pose>,
}

/// The obstacle shapes of the format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeKind {
    /// `half_extents`.
    Box,
    /// `radius`.
    Sphere,
    /// `radius` and `half_length`, axis along local z.
    Capsule,
    /// `radius` and `half_length`, axis along local z.
    Cylinder,
}

impl ShapeKind {
    /// The name the file uses.
    pub fn as_str(self) -> &'static str {
        match self {
            ShapeKind::Box => "box",
            ShapeKind::Sphere => "sphere",
            ShapeKind::Capsule => "capsule",
            ShapeKind::Cylinder => "cylinder",
        }
    }
}

/// One obstacle. The size fields a shape needs are optional here so that a missing one is
/// reported by [`crate::load`] with the obstacle's index and the shape that needs it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleSpec {
    /// The obstacle's name (for messages).
    pub name: String,
    /// Its shape.
    pub shape: ShapeKind,
    /// A box's half size along its local axes, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_extents: Option<[f64; 3]>,
    /// A sphere's, capsule's or cylinder's radius, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Half a capsule's or cylinder's length, metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_length: Option<f64>,
    /// Where the shape's frame is in the world.
    pub pose: Pose,
}

/// Pose tolerance; each field defaults to the spec's value when left out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToleranceSpec {
    /// Position error, metres (default 0.001).
    #[serde(default = "default_position_tolerance")]
    pub position_m: f64,
    /// Angle of the relative rotation, radians (default 0.01).
    #[serde(default = "default_orientation_tolerance")]
    pub orientation_rad: f64,
}

fn default_position_tolerance() -> f64 {
    0.001
}

fn default_orientation_tolerance() -> f64 {
    0.01
}

impl Default for ToleranceSpec {
    fn default() -> Self {
        ToleranceSpec {
            position_m: default_position_tolerance(),
            orientation_rad: default_orientation_tolerance(),
        }
    }
}

/// How a planning run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// A plan, in `joint_paths`.
    Solved,
    /// The search space was exhausted (the message says why).
    NoSolution,
    /// The time limit was reached.
    Timeout,
    /// A bounded pool was exhausted (the message names it).
    OutOfMemory,
    /// The problem cannot be planned (the message says why).
    InvalidProblem,
}

impl Status {
    /// The name the file uses.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Solved => "solved",
            Status::NoSolution => "no_solution",
            Status::Timeout => "timeout",
            Status::OutOfMemory => "out_of_memory",
            Status::InvalidProblem => "invalid_problem",
        }
    }
}

/// A solution file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolutionFile {
    /// [`SOLUTION_FORMAT`].
    pub format: String,
    /// The `name` of the problem this solves.
    pub problem: String,
    /// The planner's name ([`crate::planners::PlannerKind::name`]).
    pub planner: String,
    /// How planning ended.
    pub status: Status,
    /// Why, when not solved (empty when solved).
    #[serde(default)]
    pub message: String,
    /// Wall time of planning, s.
    pub planning_time_s: f64,
    /// `assignment[i]`: the trajectory robot i tracks, `None` for a robot that holds.
    /// Planners that stop before assigning may leave it empty.
    #[serde(default)]
    pub assignment: Vec<Option<usize>>,
    /// `joint_paths[i][t]`: robot i's configuration at step t; present only when solved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint_paths: Option<Vec<Vec<Vec<f64>>>>,
    /// Optional: `approach[i]`, A configurations (the same A >= 0 for every robot) that take
    /// robot i from its `initial` to `joint_paths[i][0]`: its executed timeline is `initial`,
    /// `approach[i][0..A]`, `joint_paths[i][0..H]` at `dt` spacing. Checked like the paths
    /// (limits, velocity, collisions) but tracks no pose. Absent: the timeline starts at
    /// `joint_paths[i][0]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub approach: Option<Vec<Vec<Vec<f64>>>>,
    /// Free-form counters; any keys are accepted and kept.
    #[serde(default)]
    pub stats: Map<String, Value>,
}

/// Fixed-size joint paths (`paths[i][t]`) as the file writes them.
pub fn joint_paths_value<const D: usize>(paths: &[Vec<[f64; D]>]) -> Vec<Vec<Vec<f64>>> {
    paths
        .iter()
        .map(|p| p.iter().map(|q| q.to_vec()).collect())
        .collect()
}
