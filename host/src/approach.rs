//! The approach to a plan from where the arms stand (`initial`), planned by the core
//! ([`omcbsa_core::approach`]) and written into the solution's optional `approach` field.

use omcbsa_core::approach::{plan_approach, ApproachError, ApproachParams};
use omcbsa_core::model::KinovaGen3;
use omcbsa_core::problem::Problem;

use crate::planners::DOF;

/// Most configurations of an approach (at dt = 0.1 s, 100 s of motion).
pub const MAX_APPROACH: usize = 1024;

/// Robot `i`'s approach from its `initial` to `paths[i][0]` (the same length for every
/// robot), or why there is none, naming the robots. `names` are the robots' names.
pub fn approach(
    problem: &Problem<DOF>,
    paths: &[Vec<[f64; DOF]>],
    params: &ApproachParams,
    names: &[String],
) -> Result<Vec<Vec<[f64; DOF]>>, String> {
    let n = paths.len();
    let h = paths.first().map_or(0, Vec::len);
    let flat: Vec<[f64; DOF]> = paths.iter().flatten().copied().collect();
    let mut buf = vec![[0.0; DOF]; n * MAX_APPROACH];
    let a = plan_approach::<KinovaGen3, DOF>(problem, &flat, h, params, &mut buf)
        .map_err(|e| describe(e, names))?;
    Ok((0..n)
        .map(|i| buf[i * MAX_APPROACH..i * MAX_APPROACH + a].to_vec())
        .collect())
}

fn describe(e: ApproachError, names: &[String]) -> String {
    let name = |i: usize| format!("robot {i} ({:?})", names.get(i).map_or("?", |s| s.as_str()));
    match e {
        ApproachError::StartCollides { robot, other: None } => format!(
            "{} collides at its initial configuration (with an obstacle or itself)",
            name(robot)
        ),
        ApproachError::StartCollides {
            robot,
            other: Some(o),
        } => format!(
            "{} and {} collide at their initial configurations",
            name(robot),
            name(o)
        ),
        ApproachError::TooLong { needed, capacity } => {
            format!("it needs {needed} configurations per robot, more than {capacity}")
        }
        ApproachError::Blocked { robot, other } => format!(
            "the arms moving together and one at a time (every order tried) all collide; last: \
             {} with {}",
            name(robot),
            other.map_or("an obstacle or itself".to_string(), name)
        ),
        ApproachError::Invalid(why) => why.to_string(),
    }
}
