use omcbsa_tests::*;

#[test]
fn two_arm_witness() {
    let home = [0.0, 0.26, 3.14, -2.27, 0.0, 0.96, 1.57];
    let b0 = frame([0.0, -0.45, 0.0], [0.0, 0.0, 0.0]);
    let b1 = frame([0.0, 0.45, 0.0], [0.0, 0.0, 0.0]);
    let p0 = smooth_path(&home, &[0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 20);
    let p1 = smooth_path(&home, &[-0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 20);
    let file = problem_json(
        "exp",
        0.2,
        vec![robot_json("a", &b0, None), robot_json("b", &b1, None)],
        vec![trajectory_json("h1", &b1, &p1), trajectory_json("h0", &b0, &p0)],
        vec![],
    );
    for planner in omcbsa::planners::PLANNERS {
        let sol = plan_and_validate(&file, planner, 5.0);
        eprintln!("{planner}: {:?} {:.1} ms {} {:?}", sol.status, sol.planning_time_s * 1e3, sol.message, sol.stats);
    }
}
