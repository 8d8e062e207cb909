//! The built-in problem of `omcbsa demo`: three Kinova Gen3 arms on a ring around a box, each
//! hand on one of the box's side faces while the box is lifted and flipped about a horizontal
//! axis.
//!
//! The problem is made from a witness, so it is solvable by construction: each arm's hand is
//! placed on its face by IK with the box at rest and again with the box flipped, the arm moves
//! between the two in joint space with a smooth start and stop, within the velocity limits,
//! and that motion's tool poses (forward kinematics) are the arm's trajectory. The witness is
//! confirmed by the host validator (no collision, every rule met). The trajectories are listed
//! in shuffled order, so the listed order is not the assignment.
//!
//! [`run_on_mock_arms`] streams a plan to Python mock arms and checks what they received.

use std::f64::consts::{PI, TAU};
use std::fmt;
use std::path::Path;

use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::nalgebra::{Matrix3, Rotation3, Vector3};
use omcbsa_hw::interpolate::interpolate;
use omcbsa_hw::Progress;
use omcbsa_hw::{ExecConfig, ExecError, Executor, Plan, PlanValidator, Report, WatchSettings};
use omcbsa_mock::arms::{MockArms, MockKind};
use omcbsa_mock::mock::exec_config;
use serde_json::Map;

use crate::execute::{joint_limits, CheckedSolution, CAUTIOUS_SPEED};
use crate::format::{
    joint_paths_value, Pose, ProblemFile, RobotSpec, SolutionFile, Status, ToleranceSpec,
    ToolCapsuleSpec, ToolSpec, TrajectorySpec, PROBLEM_FORMAT, SOLUTION_FORMAT,
};
use crate::models::{self, ModelKind, DOF};
use crate::pose::from_frame;

/// The demo problem's name.
pub const NAME: &str = "demo_box_flip_3arms";
/// The robots, on the ring at 0, 120 and 240 degrees.
pub const ROBOTS: [&str; 3] = ["north", "south_west", "south_east"];
/// Time between steps, s.
pub const DT: f64 = 0.1;
/// Steps of the motion (3 s).
pub const STEPS: usize = 31;
/// `ORDER[j]`: the robot whose hand trajectory `j` is.
pub(crate) const ORDER: [usize; 3] = [2, 0, 1];

const RING_RADIUS: f64 = 0.75;
const BOX_HEIGHT: f64 = 0.35;
const BOX_HALF: f64 = 0.1;
/// Flip of the box about its horizontal y axis, and how far it is lifted meanwhile.
const FLIP: f64 = 0.5;
const LIFT: f64 = 0.1;
/// The tool centre point beyond Kinova's tool frame (the fingertips of a gripper).
const TCP_LENGTH: f64 = 0.12;
/// IK seed: the arm reaching forward, elbow up, tool pointing ahead.
const SEED: [f64; 7] = [0.0, 0.6, 0.0, 1.8, 0.0, 0.7, PI / 2.0];

/// The demo problem and the witness it was made from.
pub struct Demo {
    /// The problem: three arms flipping a box.
    pub problem: ProblemFile,
    /// The solution it was built from (IK from a known pose), which shows it solvable.
    pub witness: SolutionFile,
}

fn heading(k: usize) -> f64 {
    TAU * k as f64 / ROBOTS.len() as f64
}

fn frame(rot: Matrix3<f64>, pos: Vector3<f64>) -> Frame {
    Frame { rot, pos }
}

pub(crate) fn base(k: usize) -> Frame {
    let a = heading(k);
    // The arm faces the box: its x axis points at the ring's centre.
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), a + PI).into_inner();
    frame(rot, RING_RADIUS * Vector3::new(a.cos(), a.sin(), 0.0))
}

pub(crate) fn tcp() -> Frame {
    frame(Matrix3::identity(), Vector3::new(0.0, 0.0, TCP_LENGTH))
}

/// A two-finger gripper's collision shape in Kinova's tool frame (z out of the flange): a
/// palm 9 cm across and fingers reaching the tool centre point.
pub fn gripper() -> ToolSpec {
    let along = |z0: f64, z1: f64, radius: f64| ToolCapsuleSpec {
        a: [0.0, 0.0, z0],
        b: [0.0, 0.0, z1],
        radius,
    };
    ToolSpec {
        name: "gripper".to_string(),
        capsules: vec![
            along(0.01, 0.06, 0.045),
            along(0.06, TCP_LENGTH - 0.03, 0.03),
        ],
    }
}

/// Hand `k` on its face of the box flipped by `s` (0 at rest, 1 fully flipped): at the face's
/// centre, tool z into the face, tool x up the face.
pub(crate) fn hand(k: usize, s: f64) -> Frame {
    let flip = Rotation3::from_axis_angle(&Vector3::y_axis(), FLIP * s).into_inner();
    let centre = Vector3::new(0.0, 0.0, BOX_HEIGHT + LIFT * s);
    let a = heading(k);
    let normal = flip * Vector3::new(a.cos(), a.sin(), 0.0);
    let z = -normal;
    let up = flip * Vector3::z();
    let x = (up - z * up.dot(&z)).normalize();
    frame(
        Matrix3::from_columns(&[x, z.cross(&x), z]),
        centre + BOX_HALF * normal,
    )
}

/// The demo's arms' model: the default one (the Gen3, which the mock drives and the Kortex
/// transport stand in for).
fn model() -> ModelKind {
    ModelKind::default()
}

/// Arm `k`'s configuration with its hand at `hand`, by IK from `seed`.
fn reach(k: usize, hand: &Frame, seed: &[f64; 7]) -> Result<[f64; 7], String> {
    let target = base(k).inverse().compose(hand).compose(&tcp().inverse());
    ik::<models::Fleet, DOF>(model().id(), &target, seed, &IkParams::default())
        .map_err(|e| format!("demo arm {:?} cannot reach its face: {e}", ROBOTS[k]))
}

/// `0 -> 0`, `1 -> 1` with zero speed at both ends.
fn ease(s: f64) -> f64 {
    0.5 - 0.5 * (PI * s).cos()
}

/// Arm `k`'s witness motion.
fn motion(k: usize) -> Result<Vec<[f64; 7]>, String> {
    let start = reach(k, &hand(k, 0.0), &SEED)?;
    let end = reach(k, &hand(k, 1.0), &start)?;
    Ok((0..STEPS)
        .map(|t| {
            let s = ease(t as f64 / (STEPS - 1) as f64);
            std::array::from_fn(|j| start[j] + s * (end[j] - start[j]))
        })
        .collect())
}

/// Builds the demo problem and its witness, checked by the validator.
pub fn box_flip() -> Result<Demo, String> {
    let paths = (0..ROBOTS.len())
        .map(motion)
        .collect::<Result<Vec<_>, _>>()?;
    let robots = (ROBOTS.iter().enumerate())
        .map(|(k, name)| RobotSpec {
            name: name.to_string(),
            model: model().name().to_string(),
            base: from_frame(&base(k)),
            initial: None,
            tcp: Some(from_frame(&tcp())),
            tool: Some(gripper()),
        })
        .collect();
    let trajectories = (ORDER.iter().enumerate())
        .map(|(j, &k)| TrajectorySpec {
            name: format!("hand_{j}"),
            poses: (paths[k].iter())
                .map(|q| {
                    from_frame(
                        &base(k)
                            .compose(&models::Fleet::fk(model().id(), q))
                            .compose(&tcp()),
                    )
                })
                .collect::<Vec<Pose>>(),
        })
        .collect();
    let problem = ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: NAME.to_string(),
        dt: DT,
        robots,
        trajectories,
        obstacles: Vec::new(),
        tolerance: ToleranceSpec::default(),
    };
    let witness = SolutionFile {
        approach: None,
        format: SOLUTION_FORMAT.to_string(),
        problem: NAME.to_string(),
        planner: "witness".to_string(),
        status: Status::Solved,
        message: String::new(),
        planning_time_s: 0.0,
        assignment: (0..ROBOTS.len())
            .map(|k| ORDER.iter().position(|&o| o == k))
            .collect(),
        joint_paths: Some(joint_paths_value(&paths)),
        stats: Map::new(),
    };
    let checked = CheckedSolution::new(problem, witness).map_err(|e| e.to_string())?;
    if !checked.report().is_valid() {
        return Err(format!(
            "the demo's witness does not validate: {}",
            checked.report().summary()
        ));
    }
    let (problem, witness) = checked.into_parts();
    Ok(Demo { problem, witness })
}

/// Why [`run_on_mock_arms`] failed.
#[derive(Debug)]
pub enum MockRunError {
    /// The mock arms could not be started or their buses opened.
    Mocks(String),
    /// The executor refused to start or was stopped by a fault.
    Exec(ExecError),
    /// What a mock arm received is not the interpolated plan.
    Record {
        /// The arm's name.
        arm: String,
        /// What differs.
        error: String,
    },
}

impl fmt::Display for MockRunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MockRunError::Mocks(e) => write!(f, "mock arms: {e}"),
            MockRunError::Exec(e) => write!(f, "{e}"),
            MockRunError::Record { arm, error } => {
                write!(f, "mock arm {arm:?} did not receive the plan: {error}")
            }
        }
    }
}

/// Streams `plan` to one Python mock arm of `kind` per arm (`python` from the mocks' venv),
/// each started at its arm's first configuration and recording to `record_dir/mock-NAME.jsonl`,
/// then checks that every mock received exactly the interpolated plan and nothing that breaks
/// a limit.
pub fn run_on_mock_arms(
    python: &Path,
    kind: MockKind,
    plan: Plan,
    validator: &dyn PlanValidator,
    record_dir: &Path,
    progress: impl Fn(Progress) + Send + Sync + 'static,
) -> Result<Report, MockRunError> {
    let watch = WatchSettings::default();
    run_on_mock_arms_watched(python, kind, plan, validator, record_dir, &watch, progress)
}

/// [`run_on_mock_arms`] with the fault detection `watch` (the command line's options).
pub fn run_on_mock_arms_watched(
    python: &Path,
    kind: MockKind,
    plan: Plan,
    validator: &dyn PlanValidator,
    record_dir: &Path,
    watch: &WatchSettings,
    progress: impl Fn(Progress) + Send + Sync + 'static,
) -> Result<Report, MockRunError> {
    let record = |name: &str| record_dir.join(format!("mock-{name}.jsonl"));
    let starts: Vec<_> = (plan.arms.iter())
        .map(|a| (a.name.clone(), a.joint_path[0]))
        .collect();
    let config = ExecConfig {
        watch: watch.clone(),
        ..exec_config()
    };
    let mocks = MockArms::spawn(kind, python, config.period, &starts, record, &[])
        .map_err(MockRunError::Mocks)?;
    let ports = mocks.ports().map_err(MockRunError::Mocks)?;
    // The demo's arms are all of its one model.
    let limits = vec![joint_limits(model(), CAUTIOUS_SPEED); plan.arms.len()];
    let period = config.period.as_secs_f64();
    let traj = interpolate(&plan, &limits, period)
        .map_err(|e| MockRunError::Exec(ExecError::Limits(e)))?;
    let settle = config.settle_cycles;
    let run = Executor::new(plan, limits.clone(), ports, config)
        .and_then(|e| e.on_progress(progress).run(validator));
    let report = match run {
        Ok(report) => report,
        Err(e) => {
            // The buses are closed: let the mocks exit and write their records and bus logs
            // (the evidence of a fault), rather than kill them.
            let _ = mocks.finish();
            return Err(MockRunError::Exec(e));
        }
    };
    let records = mocks.finish().map_err(MockRunError::Mocks)?;
    for (((arm, record), cmds), limits) in records.into_iter().zip(&traj.commands).zip(&limits) {
        kind.check_followed(&record, cmds, settle, limits, period)
            .map_err(|error| MockRunError::Record { arm, error })?;
    }
    Ok(report)
}
