//! Scenes for the approach's tests (issue 22), drawn from seeds and kept only when they have
//! the property a test is about.

use omcbsa::format::ProblemFile;
use omcbsa::planners::DOF;
use omcbsa_core::approach::{
    check_starts, plan_approach, ApproachError, ApproachParams, ApproachQuery, ApproachStorage,
    Method,
};
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::problem::Problem;
use omcbsa_core::rng::Rng;
use omcbsa_core::search::NoDeadline;
use serde_json::Value;

use crate::{cuboid, frame, problem_json, robot_json, tool, trajectory_json};

/// Kinova's retract configuration, the arms' usual resting pose.
pub use omcbsa::online::policy::RETRACT as TUCKED;

/// Per robot, its approach.
pub type Paths = Vec<Vec<[f64; DOF]>>;

/// Plans the approach of `problem` from `initial` to `goals` with the core's planner:
/// `rrt_samples` 0 keeps it to the straight bridges (together, then one at a time) and the
/// detours through one via configuration.
pub fn approach(
    problem: &Problem<DOF>,
    goals: &[[f64; DOF]],
    rrt_samples: u32,
) -> Result<(Method, Paths), ApproachError> {
    let n = goals.len();
    let (mut tree, mut parent, mut waypoints) = (
        vec![[0.0; DOF]; 4096 * n],
        vec![0u32; 4096],
        vec![[0.0; DOF]; 512 * n],
    );
    let mut storage = ApproachStorage {
        tree: &mut tree,
        parent: &mut parent,
        waypoints: &mut waypoints,
    };
    let cap = 1024;
    let mut out = vec![[0.0; DOF]; cap * n];
    let q = ApproachQuery {
        problem,
        plan: goals,
        horizon: 1,
        params: ApproachParams {
            rrt_samples,
            ..ApproachParams::default()
        },
        deadline: &NoDeadline,
    };
    let a = plan_approach::<KinovaGen3, DOF>(&q, &mut storage, &mut out)?;
    Ok((
        a.method,
        (0..n)
            .map(|i| out[i * cap..i * cap + a.len].to_vec())
            .collect(),
    ))
}

/// A configuration with joint 1 within `yaw ± 0.8` and the rest uniform within limits.
fn draw(rng: &mut Rng, yaw: f64) -> [f64; DOF] {
    let mut q = rng.configuration(&KinovaGen3::LOWER, &KinovaGen3::UPPER);
    q[0] = yaw + rng.uniform(-0.8, 0.8);
    q
}

/// One-pose problem: each robot's hand stays where `goals` put its tool, for 3 steps.
pub fn hold_problem(
    name: &str,
    bases: &[Frame],
    initial: &[[f64; DOF]],
    goals: &[[f64; DOF]],
    obstacles: Vec<Value>,
) -> ProblemFile {
    let robots = (0..bases.len())
        .map(|i| robot_json(&format!("arm{i}"), &bases[i], Some(&initial[i])))
        .collect();
    let trajectories = (0..bases.len())
        .map(|i| trajectory_json(&format!("hand{i}"), &bases[i], &[goals[i]; 3]))
        .collect();
    problem_json(name, 0.1, robots, trajectories, obstacles)
}

/// Two arms side by side, each standing reached over into the other's side; their goals are
/// swapped sides: moving together or one at a time along straight bridges collides, so one
/// arm must swing past the other.
pub fn crossing_scene(seed: u64) -> Option<(ProblemFile, [[f64; DOF]; 2])> {
    use std::f64::consts::FRAC_PI_2;
    let bases = [
        frame([0.0, 0.3, 0.0], [0.0; 3]),
        frame([0.0, -0.3, 0.0], [0.0; 3]),
    ];
    let mut rng = Rng::new(seed);
    let initial = [draw(&mut rng, -FRAC_PI_2), draw(&mut rng, FRAC_PI_2)];
    let goals = [draw(&mut rng, FRAC_PI_2), draw(&mut rng, -FRAC_PI_2)];
    let file = hold_problem(
        &format!("crossing_{seed}"),
        &bases,
        &initial,
        &goals,
        Vec::new(),
    );
    let problem = omcbsa::load::problem::<KinovaGen3, DOF>(&file).ok()?;
    check_starts::<KinovaGen3, DOF>(&problem).ok()?;
    let mut at_goals = problem.clone();
    for (r, g) in at_goals.robots.iter_mut().zip(&goals) {
        r.initial = Some(*g);
    }
    check_starts::<KinovaGen3, DOF>(&at_goals).ok()?;
    // Straight bridges, together and in both orders, and the detours through a via all
    // collide.
    matches!(
        approach(&problem, &goals, 0),
        Err(ApproachError::Blocked { .. })
    )
    .then_some((file, goals))
}

/// One arm tucked at Kinova's retract pose, its hand behind a post: the straight bridge to
/// the hand's first configuration runs through the post (and so do both via detours).
pub fn post_scene(seed: u64) -> Option<(ProblemFile, [f64; DOF])> {
    let base = frame([0.0; 3], [0.0; 3]);
    let mut rng = Rng::new(seed);
    let goal = draw(&mut rng, 0.0);
    let hand = tool(&base, &goal).pos;
    let reach = (hand.x * hand.x + hand.y * hand.y).sqrt();
    if !(0.45..0.8).contains(&reach) || !(0.05..0.6).contains(&hand.z) || hand.x < 0.3 {
        return None;
    }
    // A post halfway to the hand, up to the hand's height.
    let post = cuboid(
        "post",
        [0.55 * hand.x, 0.55 * hand.y, 0.5 * hand.z],
        [0.03, 0.03, 0.5 * hand.z],
    );
    let file = hold_problem(
        &format!("post_{seed}"),
        &[base],
        &[TUCKED],
        &[goal],
        vec![post],
    );
    let problem = omcbsa::load::problem::<KinovaGen3, DOF>(&file).ok()?;
    check_starts::<KinovaGen3, DOF>(&problem).ok()?;
    let mut at_goal = problem.clone();
    at_goal.robots[0].initial = Some(goal);
    check_starts::<KinovaGen3, DOF>(&at_goal).ok()?;
    matches!(
        approach(&problem, &[goal], 0),
        Err(ApproachError::Blocked { .. })
    )
    .then_some((file, goal))
}
