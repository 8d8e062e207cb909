//! Issue 22: the approach from where the arms stand is planned inside the search.
//!
//! Scenes are drawn from seeds and kept only when they have the property a test is about (the
//! straight bridge collides, every one-at-a-time order collides too): the tests assert that
//! such scenes exist among the first seeds and that every one found is solved.

use omcbsa::format::Status as FileStatus;
use omcbsa::plan::plan_file;
use omcbsa_core::approach::{ApproachParams, Method};
use omcbsa_tests::approach_scenes::{approach, crossing_scene, hold_problem, post_scene, TUCKED};
use omcbsa_tests::{core_problem, frame, plan_and_validate, tool};

#[test]
fn arms_whose_hands_cross_swing_past_each_other() {
    let scenes: Vec<_> = (0..400).filter_map(crossing_scene).take(3).collect();
    assert!(
        !scenes.is_empty(),
        "no crossing scene among the first 400 seeds: the generator is broken"
    );
    for (file, goals) in &scenes {
        let problem = core_problem(file);
        // The core's planner joins exactly these configurations with RRT-Connect.
        let (method, paths) = approach(&problem, goals, ApproachParams::default().rrt_samples * 64)
            .unwrap_or_else(|e| panic!("{}: {e:?}", file.name));
        assert!(
            matches!(method, Method::OrderedRrt | Method::Rrt),
            "{}: {method:?}",
            file.name
        );
        assert!(paths[0].len() > 1);
        // Through `plan`, the approach is part of the plan and the validator accepts the whole.
        let sol = plan_and_validate(file, "omcbsa", 10.0);
        assert_eq!(
            sol.status,
            FileStatus::Solved,
            "{}: {}",
            file.name,
            sol.message
        );
        let a = sol.approach.as_ref().expect("an approach");
        assert!(!a[0].is_empty(), "{}: the arms must move", file.name);
    }
}

#[test]
fn a_tucked_arm_reaches_a_hand_behind_a_post() {
    let scenes: Vec<_> = (0..2000).filter_map(post_scene).take(3).collect();
    assert!(
        !scenes.is_empty(),
        "no post scene among the first 2000 seeds: the generator is broken"
    );
    for (file, goal) in &scenes {
        // The core's planner goes around the post to the very configuration drawn.
        let problem = core_problem(file);
        let (method, _) = approach(
            &problem,
            &[*goal],
            ApproachParams::default().rrt_samples * 64,
        )
        .unwrap_or_else(|e| panic!("{}: {e:?}", file.name));
        assert!(
            matches!(method, Method::OrderedRrt | Method::Rrt),
            "{}: {method:?}",
            file.name
        );
        // Through `plan`: solved and valid, whichever start the search settles on.
        let sol = plan_and_validate(file, "omcbsa", 10.0);
        assert_eq!(
            sol.status,
            FileStatus::Solved,
            "{}: {}",
            file.name,
            sol.message
        );
        assert!(sol.approach.is_some(), "{}", file.name);
    }
}

#[test]
fn a_start_in_collision_is_bad_input_naming_the_robot_and_what_it_touches() {
    let base = frame([0.0; 3], [0.0; 3]);
    let ball_at = tool(&base, &TUCKED).pos;
    let file = hold_problem(
        "start_in_ball",
        &[base],
        &[TUCKED],
        &[TUCKED],
        vec![omcbsa_tests::sphere(
            "ball",
            [ball_at.x, ball_at.y, ball_at.z],
            0.08,
        )],
    );
    let err = match plan_file(&file, omcbsa::planners::PlannerKind::OmCbsa, 5.0) {
        Err(omcbsa::plan::InputOrPlanError::Input(e)) => e.to_string(),
        other => panic!("expected an input error, got {other:?}"),
    };
    assert!(err.contains("robots[0].initial"), "{err}");
    assert!(err.contains("arm0"), "{err}");
    assert!(err.contains("obstacle 0") && err.contains("ball"), "{err}");
}

#[test]
fn the_approach_does_not_depend_on_the_clock() {
    let (file, _) = (0..400).find_map(crossing_scene).expect("a crossing scene");
    let a = plan_file(&file, omcbsa::planners::PlannerKind::OmCbsa, 10.0).expect("plans");
    let b = plan_file(&file, omcbsa::planners::PlannerKind::OmCbsa, 30.0).expect("plans");
    assert_eq!(a.status, FileStatus::Solved);
    assert_eq!(a.approach, b.approach);
    assert_eq!(a.joint_paths, b.joint_paths);
}

/// A problem of the default suite (`gen-bench`, bimanual_torso_3arms_016) on which planning
/// then joining the plan with straight bridges answered `no_solution` ("the arms moving
/// together and one at a time all collide"): it is solved now, and its approach is not the
/// straight bridge.
#[test]
fn a_suite_problem_the_straight_bridge_failed_is_solved() {
    let text = include_str!("../fixtures/straight_bridge_fails_3arms.json");
    let file = omcbsa::load::parse_problem(text).expect("fixture parses");
    let sol = plan_and_validate(&file, "omcbsa", 10.0);
    assert_eq!(sol.status, FileStatus::Solved, "{}", sol.message);
    let method = sol.stats.get("approach_method").and_then(|v| v.as_str());
    assert!(
        matches!(method, Some("ordered" | "ordered-rrt" | "rrt-connect")),
        "{method:?}"
    );
    assert!(sol.approach.as_ref().is_some_and(|a| !a[0].is_empty()));
}
