//! Hands that move faster than any arm can follow at their timing: `omcbsa plan`'s answer is
//! not solved, names the robot, trajectory, step and joint, and offers a time scaling that
//! plans; with `dt` scaled by it the problem plans and the plan passes validation, its
//! accelerations within the limits.

use omcbsa::format::Status;
use omcbsa::load::parse_problem;
use omcbsa::models::{Fleet, DOF};
use omcbsa::plan::plan_file;
use omcbsa::planners::PlannerKind;
use omcbsa::validate::validate;
use omcbsa_core::model::Models;

/// One Gen3; its hand, pointing down, shakes 5 cm along y every step (0.1 s): 10 m/s^2.
fn shaking(dt: f64) -> String {
    let poses: Vec<String> = (0..10)
        .map(|t| {
            let y = if t % 2 == 0 { 0.0 } else { 0.05 };
            format!(r#"{{"position": [0.5, {y}, 0.4], "quat_xyzw": [1, 0, 0, 0]}}"#)
        })
        .collect();
    format!(
        r#"{{"format": "omcbsa.problem.v1", "name": "shake", "dt": {dt},
  "robots": [{{"name": "arm", "model": "kinova_gen3",
              "base": {{"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]}}}}],
  "trajectories": [{{"name": "hand", "poses": [{}]}}]}}"#,
        poses.join(", ")
    )
}

#[test]
fn too_fast_hands_get_where_and_a_time_scaling_that_plans() {
    let file = parse_problem(&shaking(0.1)).unwrap();
    let refused = plan_file(&file, PlannerKind::OmCbsa, 5.0).unwrap();
    assert_eq!(refused.status, Status::NoSolution, "{}", refused.message);
    let cut = &refused.stats["too_fast"];
    assert_eq!(
        (cut["robot"].as_u64(), cut["trajectory"].as_u64()),
        (Some(0), Some(0))
    );
    let (step, joint) = (
        cut["step"].as_u64().unwrap(),
        cut["joint"].as_u64().unwrap(),
    );
    assert!((1..9).contains(&step) && joint < 7, "{cut}");
    assert!(
        refused.message.contains("too fast for robot arm"),
        "{}",
        refused.message
    );
    let k = refused.stats["time_scale"]
        .as_f64()
        .expect("a scaling that plans");
    let below = refused.stats["time_scale_refused_below"].as_f64().unwrap();
    assert!(k > 1.0 && below >= 1.0 && below < k, "{k} {below}");

    let slower = parse_problem(&shaking(0.1 * k)).unwrap();
    let planned = plan_file(&slower, PlannerKind::OmCbsa, 5.0).unwrap();
    assert_eq!(planned.status, Status::Solved, "{}", planned.message);
    let problem = omcbsa::load::problem::<Fleet, DOF>(&slower).unwrap();
    let report = validate::<Fleet, DOF>(&slower, &problem, &planned);
    assert!(report.is_valid(), "{}", report.summary());
    // The plan's accelerations (finite differences at its steps) within the Gen3's limits.
    let a = Fleet::acceleration(problem.robots[0].model);
    let path = &planned.joint_paths.as_ref().unwrap()[0];
    let dt = problem.dt;
    for w in path.windows(3) {
        for j in 0..DOF {
            let acc = (w[2][j] - 2.0 * w[1][j] + w[0][j]).abs() / (dt * dt);
            assert!(acc <= a[j], "joint {j}: {acc} > {}", a[j]);
        }
    }
}
