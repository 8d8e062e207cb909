//! The approach from where the arms stand, in words: what a robot's `initial` touches (bad
//! input) and why an approach was not found. The approach itself is planned by the core, with
//! the plan ([`omcbsa_core::embody`], called by [`crate::planners::Storage`]).

use omcbsa_core::approach::{check_starts, ApproachError, Blocked, Touch};
use omcbsa_core::model::Models;
use omcbsa_core::problem::Problem;

use crate::error::InputError;
use crate::format::{ObstacleSpec, ProblemFile, RobotSpec};

/// Most configurations of an approach per robot (at dt = 0.1 s, 100 s of motion).
pub const MAX_APPROACH: usize = 1024;

/// What capsule `c` of a robot of model `model` of `M` is: its link's name, or the tool.
fn part<M: Models<D>, const D: usize>(model: u8, c: usize) -> &'static str {
    M::capsules(model)
        .get(c)
        .and_then(|cap| M::link_names(model).get(usize::from(cap.link)))
        .copied()
        .unwrap_or("tool")
}

/// `touch` of a robot of model `model` in words, naming robots and obstacles as the lists
/// do; another robot is where it is `other_at` ("at its initial configuration").
pub fn describe_touch<M: Models<D>, const D: usize>(
    model: u8,
    robots: &[RobotSpec],
    obstacles: &[ObstacleSpec],
    touch: Touch,
    other_at: &str,
) -> String {
    match touch {
        Touch::JointLimit { joint } => format!(
            "joint {joint} ({}) is outside its limits",
            M::joint_names(model).get(joint).copied().unwrap_or("?")
        ),
        Touch::Obstacle { index } => format!(
            "collides with obstacle {index} ({:?})",
            obstacles.get(index).map_or("?", |o| o.name.as_str())
        ),
        Touch::Itself {
            capsule,
            other_capsule,
        } => format!(
            "collides with itself ({} with {})",
            part::<M, D>(model, capsule),
            part::<M, D>(model, other_capsule)
        ),
        Touch::Robot { robot } => format!(
            "collides with robot {robot} ({:?}) {other_at}",
            robots.get(robot).map_or("?", |r| r.name.as_str())
        ),
    }
}

/// Refuses a problem in which a robot's `initial` is outside its limits or collides: the error
/// names the robot and what it touches.
pub fn check_initial<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    problem: &Problem<D>,
) -> Result<(), InputError> {
    check_starts::<M, D>(problem).map_err(|Blocked { robot, touch }| {
        InputError::one(
            format!("robots[{robot}].initial"),
            format!(
                "robot {:?} cannot start here: it {}",
                file.robots.get(robot).map_or("?", |r| r.name.as_str()),
                describe_touch::<M, D>(
                    problem.robots.get(robot).map_or(0, |r| r.model),
                    &file.robots,
                    &file.obstacles,
                    touch,
                    "at its initial configuration"
                )
            ),
        )
    })
}

/// Why the last approach tried was not found, naming the robots as `names` do.
pub fn describe_miss(e: ApproachError, names: &[String]) -> String {
    let name = |i: usize| format!("robot {i} ({:?})", names.get(i).map_or("?", |s| s.as_str()));
    match e {
        ApproachError::Start(Blocked { robot, .. }) => {
            format!("{} cannot start at its initial configuration", name(robot))
        }
        ApproachError::TooLong { needed, capacity } => {
            format!("it needs {needed} configurations per robot, more than {capacity}")
        }
        ApproachError::Blocked { robot, other } => format!(
            "no approach found to the last starts tried (straight, one arm at a time, \
             RRT-Connect); the straight bridges first collide: {} with {}",
            name(robot),
            other.map_or("an obstacle or itself".to_string(), name)
        ),
        ApproachError::Timeout => "the deadline passed while planning the approach".to_string(),
        ApproachError::OutOfMemory(pool) => format!("{pool} is full"),
        ApproachError::Invalid(why) => why.to_string(),
    }
}
