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
    pub position: [f64; 3],
    pub quat_xyzw: [f64; 4],
}

impl Pose {
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
    pub format: String,
    pub name: String,
    pub dt: f64,
    pub robots: Vec<RobotSpec>,
    pub trajectories: Vec<TrajectorySpec>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub obstacles: Vec<ObstacleSpec>,
    #[serde(default)]
    pub tolerance: ToleranceSpec,
}

/// One robot of a problem file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSpec {
    pub name: String,
    pub model: String,
    pub base: Pose,
    /// The arm's current configuration; its length depends on the model, so it is checked
    /// by [`crate::load`], not here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<Vec<f64>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tcp: Option<Pose>,
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
    pub capsules: Vec<ToolCapsuleSpec>,
}

/// Points within `radius` (metres) of the segment `a`-`b` (tool frame, metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolCapsuleSpec {
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub radius: f64,
}

/// One trajectory of tool centre point poses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    pub name: String,
    pub poses: Vec<Pose>,
}

/// The obstacle shapes of the format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeKind {
    Box,
    Sphere,
    Capsule,
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
    pub name: String,
    pub shape: ShapeKind,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_extents: Option<[f64; 3]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_length: Option<f64>,
    pub pose: Pose,
}

/// Pose tolerance; each field defaults to the spec's value when left out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToleranceSpec {
    #[serde(default = "default_position_tolerance")]
    pub position_m: f64,
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
    Solved,
    NoSolution,
    Timeout,
    OutOfMemory,
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
    pub format: String,
    /// The `name` of the problem this solves.
    pub problem: String,
    pub planner: String,
    pub status: Status,
    #[serde(default)]
    pub message: String,
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
