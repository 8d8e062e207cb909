//! The validator, one rule at a time: a tiny scene made by hand is valid, and breaking one
//! rule is reported as that rule, at the right robot and step.

mod common;

use common::*;
use omcbsa::format::{ObstacleSpec, Pose, ProblemFile, ShapeKind, SolutionFile, Status};
use omcbsa::load;
use omcbsa::validate::{validate, Report, Rule};
use omcbsa_core::model::KinovaGen3;

fn check(problem: &ProblemFile, solution: &SolutionFile) -> Report {
    let p = load::problem::<KinovaGen3, 7>(problem).expect("the scene is a valid problem");
    validate::<KinovaGen3, 7>(problem, &p, solution)
}

/// Every violation breaks `rule`, and one of them is at `robot`, `step` and says `text`.
#[track_caller]
fn only(report: &Report, rule: Rule, robot: Option<usize>, step: Option<usize>, text: &str) {
    assert!(
        !report.is_valid(),
        "expected a violation of {rule:?}, got a valid solution"
    );
    let all: Vec<String> = report.violations.iter().map(|v| v.to_string()).collect();
    assert!(
        report.violations.iter().all(|v| v.rule == rule),
        "expected only {rule:?}: {all:#?}"
    );
    assert!(
        (report.violations.iter())
            .any(|v| v.robot == robot && v.step == step && v.detail.contains(text)),
        "expected robot {robot:?}, step {step:?}, `{text}` in {all:#?}"
    );
}

fn sphere(name: &str, centre: [f64; 3], radius: f64) -> ObstacleSpec {
    ObstacleSpec {
        name: name.to_string(),
        shape: ShapeKind::Sphere,
        half_extents: None,
        radius: Some(radius),
        half_length: None,
        pose: at(centre),
    }
}

#[test]
fn the_hand_made_scenes_are_valid() {
    let (p, s) = tiny();
    let report = check(&p, &s);
    assert!(report.is_valid(), "{}", report.summary());
    assert_eq!(report.summary(), "valid");
}

#[test]
fn rule_1_joint_beyond_its_limit() {
    // joint_6 goes to 2.1 (limit 2.09); dt is long enough for the jump.
    let mut over = Q0;
    over[5] = 2.1;
    let (p, s) = one_robot(&[Q0, over, Q0], 2.0);
    let report = check(&p, &s);
    only(
        &report,
        Rule::JointLimits,
        Some(0),
        Some(1),
        "joint joint_6 = 2.1 is outside its limits [-2.09, 2.09]",
    );
    assert!(report
        .summary()
        .starts_with("invalid: rule 1 (joint limits), robot 0, step 1: joint joint_6"));
}

#[test]
fn rule_2_position_off_the_trajectory() {
    let (mut p, s) = tiny();
    p.trajectories[0].poses[2].position[0] += 0.002;
    only(
        &check(&p, &s),
        Rule::Tracking,
        Some(0),
        Some(2),
        "the TCP is 0.002 m from pose 2 of trajectory 0 (\"hand\"); tolerance 0.001 m",
    );
}

#[test]
fn rule_2_orientation_off_the_trajectory() {
    let (mut p, s) = tiny();
    // Turn pose 1 by 0.02 rad about the world z axis: q' = (0, 0, sin 0.01, cos 0.01) * q.
    let [x, y, z, w] = p.trajectories[0].poses[1].quat_xyzw;
    let (sz, cz) = (0.01f64.sin(), 0.01f64.cos());
    p.trajectories[0].poses[1].quat_xyzw = [
        cz * x - sz * y,
        cz * y + sz * x,
        cz * z + sz * w,
        cz * w - sz * z,
    ];
    only(
        &check(&p, &s),
        Rule::Tracking,
        Some(0),
        Some(1),
        "the TCP is rotated 0.02 rad from pose 1",
    );
}

#[test]
fn rule_2_a_tool_offset_is_part_of_the_pose() {
    let (mut p, s) = tiny();
    p.robots[0].tcp = Some(at([0.0, 0.0, 0.12]));
    only(
        &check(&p, &s),
        Rule::Tracking,
        Some(0),
        Some(0),
        "the TCP is 0.12 m from pose 0",
    );
}

/// Robot 0 tracks near `Q0`, robot 1 (2 m away) holds `Q0`, following `held`.
fn with_holder(held: Vec<Q>) -> (ProblemFile, SolutionFile) {
    let path = vec![near_q0(0.0), near_q0(1.0), near_q0(2.0)];
    let (b0, b1) = (at([0.0, 0.0, 0.0]), at([0.0, 2.0, 0.0]));
    let problem = problem(
        vec![
            robot("tracker", b0, Some(Q0)),
            robot("holder", b1, Some(Q0)),
        ],
        vec![trajectory_of("hand", &b0, &path)],
        0.1,
    );
    (problem, solution(vec![Some(0), None], vec![path, held]))
}

#[test]
fn rule_2_a_holding_robot_stays_at_initial() {
    let (p, s) = with_holder(vec![Q0, Q0, Q0]);
    assert!(check(&p, &s).is_valid());
    let mut moved = Q0;
    moved[2] += 1e-6;
    let (p, s) = with_holder(vec![Q0, moved, Q0]);
    only(
        &check(&p, &s),
        Rule::Tracking,
        Some(1),
        Some(1),
        "holds, but joint joint_3 = 0.000001 differs from its initial 0",
    );
}

#[test]
fn rule_3_joint_faster_than_its_limit() {
    // Steps of 0.05 rad in 0.01 s: joint_1's limit allows 1.3963 * 0.01 = 0.013963.
    let (p, s) = one_robot(&[near_q0(0.0), near_q0(1.0), near_q0(2.0)], 0.01);
    only(&check(&p, &s), Rule::Velocity, Some(0), Some(1), "joint joint_1 moves 0.05 between steps 1 and 2, more than its velocity limit 1.3963 * dt 0.01 = 0.013963");
}

#[test]
fn rule_3_allows_exactly_the_limit() {
    let mut next = Q0;
    next[0] += 1.3963 * 0.1;
    let (p, s) = one_robot(&[Q0, next], 0.1);
    assert!(check(&p, &s).is_valid());
}

#[test]
fn rule_4_link_in_an_obstacle_at_a_step() {
    let (mut p, s) = tiny();
    // A ball around the origin of the arm's fifth link frame at step 1.
    let path: Vec<Q> = (0..3).map(|k| near_q0(k as f64)).collect();
    p.obstacles.push(sphere("far", [3.0, 3.0, 3.0], 0.1));
    p.obstacles
        .push(sphere("ball", link_origin(&path[1], 4), 0.02));
    let report = check(&p, &s);
    only(
        &report,
        Rule::Collision,
        Some(0),
        Some(1),
        "hits obstacle 1 (\"ball\")",
    );
    assert!(report.violations.iter().all(|v| !v.detail.contains("far")));
}

#[test]
fn rule_4_the_base_link_may_touch_what_it_stands_on() {
    let (mut p, s) = tiny();
    // A table whose top is the base's mounting plane, and a ball inside the base.
    p.obstacles.push(ObstacleSpec {
        name: "table".to_string(),
        shape: ShapeKind::Box,
        half_extents: Some([0.5, 0.5, 0.02]),
        radius: None,
        half_length: None,
        pose: at([0.0, 0.0, -0.02]),
    });
    p.obstacles.push(sphere("in base", [0.0, 0.0, 0.03], 0.01));
    let report = check(&p, &s);
    assert!(report.is_valid(), "{report:#?}");
}

#[test]
fn rule_4_collision_only_between_steps() {
    // Joint 1 turns by 1.2 rad in one 1 s step; a small ball sits where the tool passes half
    // way, far from where it is at either step.
    let (a, mut b, mut mid) = (Q0, Q0, Q0);
    b[0] += 1.2;
    mid[0] += 0.6;
    let (mut p, s) = one_robot(&[a, b, b], 1.0);
    let tool = omcbsa::pose::from_frame(&<KinovaGen3 as omcbsa_core::model::Model<7>>::fk(&mid));
    p.obstacles.push(sphere("midway", tool.position, 0.01));
    only(
        &check(&p, &s),
        Rule::Collision,
        Some(0),
        Some(0),
        "moving from step 0 to 1",
    );
}

/// Robots `a` on `b0` and `b` on `b1`, both following `path`.
fn two_robots(b0: Pose, b1: Pose, path: Vec<Q>) -> (ProblemFile, SolutionFile) {
    let p = problem(
        vec![robot("a", b0, None), robot("b", b1, None)],
        vec![
            trajectory_of("ha", &b0, &path),
            trajectory_of("hb", &b1, &path),
        ],
        0.1,
    );
    (
        p,
        solution(vec![Some(0), Some(1)], vec![path.clone(), path]),
    )
}

#[test]
fn rule_4_link_of_another_robot() {
    let (p, s) = two_robots(at([0.0, 0.0, 0.0]), at([0.0, 0.05, 0.0]), vec![Q0, Q0]);
    only(
        &check(&p, &s),
        Rule::Collision,
        Some(0),
        Some(0),
        "of robot 1 (\"b\")",
    );
}

#[test]
fn rule_4_non_adjacent_links_of_its_own_arm() {
    let path = vec![FOLDED, FOLDED];
    let (p, s) = one_robot(&path, 0.1);
    only(
        &check(&p, &s),
        Rule::Collision,
        Some(0),
        Some(0),
        "hits its own link",
    );
}

#[test]
fn rule_5_trajectory_assigned_twice_and_one_untracked() {
    let path = vec![Q0, Q0];
    let (b0, b1) = (at([0.0, -1.0, 0.0]), at([0.0, 1.0, 0.0]));
    let p = problem(
        vec![robot("a", b0, None), robot("b", b1, None)],
        vec![
            trajectory_of("ha", &b0, &path),
            trajectory_of("hb", &b1, &path),
        ],
        0.1,
    );
    let s = solution(vec![Some(0), Some(1)], vec![path.clone(), path.clone()]);
    assert!(check(&p, &s).is_valid());
    let s = solution(vec![Some(0), Some(0)], vec![path.clone(), path]);
    let report = check(&p, &s);
    let rule5: Vec<_> = report
        .violations
        .iter()
        .filter(|v| v.rule == Rule::Assignment)
        .collect();
    assert!(
        rule5.iter().any(|v| v.robot == Some(1)
            && v.detail == "trajectory 0 (\"ha\") is also assigned to robot 0"),
        "{report:#?}"
    );
    assert!(
        rule5
            .iter()
            .any(|v| v.detail == "trajectory 1 (\"hb\") is tracked by no robot"),
        "{report:#?}"
    );
}

#[test]
fn rule_5_assignment_of_wrong_length_or_target() {
    let (p, mut s) = tiny();
    s.assignment = vec![Some(3)];
    let report = check(&p, &s);
    assert!(
        report.violations.iter().any(|v| v.rule == Rule::Assignment
            && v.detail
                .contains("assignment[0] = 3, but there are only 1 trajectories")),
        "{report:#?}"
    );
    s.assignment = vec![Some(0), None];
    assert!(check(&p, &s)
        .violations
        .iter()
        .any(|v| v.detail == "assignment has 2 entries for 1 robots"));
}

#[test]
fn rule_5_joint_paths_of_the_wrong_shape() {
    let (p, mut s) = tiny();
    s.joint_paths.as_mut().unwrap()[0].pop();
    only(
        &check(&p, &s),
        Rule::Assignment,
        Some(0),
        None,
        "joint_paths[0] has 2 configurations, expected H = 3",
    );
    let (p, mut s) = tiny();
    s.joint_paths.as_mut().unwrap()[0][1].pop();
    only(
        &check(&p, &s),
        Rule::Assignment,
        Some(0),
        Some(1),
        "joint_paths[0][1] has 6 joint values, model kinova_gen3 has 7",
    );
    let (p, mut s) = tiny();
    s.joint_paths.as_mut().unwrap().push(vec![]);
    only(
        &check(&p, &s),
        Rule::Assignment,
        None,
        None,
        "joint_paths has 2 paths for 1 robots",
    );
}

#[test]
fn a_solution_must_be_solved_and_name_its_problem() {
    let (p, mut s) = tiny();
    s.problem = "other".to_string();
    only(
        &check(&p, &s),
        Rule::Solution,
        None,
        None,
        "the solution is for problem \"other\", not \"tiny\"",
    );
    let (p, mut s) = tiny();
    s.status = Status::Timeout;
    s.joint_paths = None;
    let report = check(&p, &s);
    only(
        &report,
        Rule::Solution,
        None,
        None,
        "status is timeout, not solved",
    );
    assert_eq!(
        report.summary(),
        "invalid: solution: status is timeout, not solved"
    );
}

/// Two arms facing each other, their tool frames pointing at each other so that 12 cm
/// grippers reach through each other: valid for bare flanges, a collision of the two tools
/// with grippers on.
#[test]
fn rule_4_grippers_passing_through_each_other() {
    use omcbsa::demo::gripper;
    use omcbsa_core::model::Model;
    // Q0 with the wrist (joint_6) turned so that the tool points most nearly ahead.
    let ahead = (0..=40)
        .map(|k| {
            let mut q = Q0;
            q[5] = -2.0 + 0.1 * k as f64;
            q
        })
        .max_by(|p, q| {
            let ahead = |q: &Q| KinovaGen3::fk(q).rot[(0, 2)];
            ahead(p).total_cmp(&ahead(q))
        })
        .unwrap();
    let tool = KinovaGen3::fk(&ahead);
    let z = tool.rot.column(2);
    assert!(z.x > 0.7, "the tool points forward: {:?}", z.as_slice());
    // `b` is `a` turned half a turn about the vertical through the point 10 cm along `a`'s
    // tool z axis, so both grippers reach through it (they end 12 cm along z).
    let tip = tool.pos + z * 0.10;
    let (b0, b1) = (
        at([0.0, 0.0, 0.0]),
        Pose {
            position: [2.0 * tip.x, 2.0 * tip.y, 0.0],
            quat_xyzw: [0.0, 0.0, 1.0, 0.0],
        },
    );
    let (mut p, s) = two_robots(b0, b1, vec![ahead, ahead]);
    let bare = check(&p, &s);
    assert!(bare.is_valid(), "without tools: {}", bare.summary());
    for r in &mut p.robots {
        r.tool = Some(gripper());
    }
    let report = check(&p, &s);
    only(
        &report,
        Rule::Collision,
        Some(0),
        Some(0),
        "of robot 1 (\"b\")",
    );
    assert!(
        (report.violations.iter()).any(|v| v.detail.starts_with("tool \"gripper\" (capsule ")
            && v.detail.contains(" hits tool \"gripper\" (capsule ")),
        "{:#?}",
        report.violations
    );
    assert!(
        report.summary().starts_with("invalid: rule 4 (collision)"),
        "{}",
        report.summary()
    );
}

/// Issue 22: a finding in the approach is reported at its step of the approach (0 =
/// `initial`), with its phase, so that the viewer and `--json` readers can place it.
#[test]
fn a_finding_in_the_approach_names_its_approach_step() {
    use omcbsa::validate::Phase;
    let (problem, mut solution) = common::two_robots();
    // Robot 0 jumps from `initial` (Q0) to its first approach configuration.
    solution.approach = Some(vec![
        vec![near_q0(5.0).to_vec(), near_q0(0.0).to_vec()],
        vec![Q0.to_vec(), Q0.to_vec()],
    ]);
    let report = check(&problem, &solution);
    let v = report
        .violations
        .iter()
        .find(|v| v.rule == Rule::Velocity)
        .unwrap_or_else(|| panic!("{}", report.summary()));
    assert_eq!(
        (v.robot, v.step, v.phase),
        (Some(0), Some(0), Phase::Approach)
    );
    assert!(v.to_string().contains("approach step 0"), "{v}");
    let json = serde_json::to_value(v).unwrap();
    assert_eq!(json["phase"], "approach");
}
