//! Motion conflicts (issue #17): two arms whose hands swap sides within one step, so that plans
//! clear at every step still collide on the way unless the arms pass each other in the right
//! way; Ω-CBSA finds it by branching on where and when the moving arms first meet.
//!
//! The scene (tests/fixtures/hands_swap_sides_2arms.json) was found by a throwaway search over
//! random facing pairs (bases 0.6-1.0 m apart, random smooth witness paths of 6 steps with
//! `dt` = 0.5 s, so that an arm moves far within a step), keeping one whose witness is
//! collision-free, whose arms planned apart are clear at every step but meet during a motion,
//! and which Ω-CBSA solves with motion branchings only. Bases 0.77 m apart, facing; from step 0
//! to 1 hand a moves 0.2 m to +y at 0.42 m height while hand b, under it and 4 cm farther out,
//! moves 0.2 m to -y and down: b's wrist passes through where a's upper arm is a third of the
//! way through the step.

use omcbsa::format::ProblemFile;
use omcbsa::load;
use omcbsa::planners::{Capacities, Outcome, Storage, DOF};
use omcbsa::validate::{validate, Rule};
use omcbsa_core::collision::ArmPose;
use omcbsa_core::model::KinovaGen3;
use omcbsa_core::motion::{motions_collide, motions_contact, near_point, ArmMotion, MOTION_STEP};
use omcbsa_core::planner::Status;
use omcbsa_core::problem::Problem;
use omcbsa_tests::*;

fn hands_swap_sides() -> ProblemFile {
    load::parse_problem(include_str!("../fixtures/hands_swap_sides_2arms.json"))
        .expect("fixture parses")
}

/// Robot `i` planned by Ω-A* on trajectory `i` as if the other arm were not there.
fn alone(file: &ProblemFile, i: usize) -> Vec<[f64; DOF]> {
    let one = problem_json(
        "alone",
        file.dt,
        vec![serde_json::to_value(&file.robots[i]).expect("robot serialises")],
        vec![serde_json::to_value(&file.trajectories[i]).expect("trajectory serialises")],
        vec![],
    );
    let problem = core_problem(&one);
    let mut storage = Storage::new(Capacities::default(), problem.horizon());
    let outcome = storage
        .solve(omcbsa::planners::PlannerKind::OmegaAstar, &problem, 5.0)
        .expect("planner");
    assert_eq!(outcome.status, Status::Solved, "robot {i} alone");
    outcome.joint_paths[0].clone()
}

/// Robot `i` following `path`, from step `t` to `t + 1`.
fn motion<'a>(
    problem: &'a Problem<DOF>,
    i: usize,
    path: &'a [[f64; DOF]],
    t: usize,
) -> ArmMotion<'a, DOF> {
    let robot = &problem.robots[i];
    ArmMotion {
        model: robot.model,
        base: &robot.base,
        tool: &robot.tool,
        from: &path[t],
        to: &path[t + 1],
    }
}

/// The arms planned apart are clear of each other at every step, so a search that looked for
/// conflicts at the steps only would return this plan; yet they collide between steps 0 and 1,
/// at an instant where a point lies inside both, and the validator rejects the plan for that
/// motion alone.
#[test]
fn arms_planned_apart_meet_only_between_steps() {
    let file = hands_swap_sides();
    let problem = core_problem(&file);
    let paths = [alone(&file, 0), alone(&file, 1)];
    let pose = |i: usize, q: &[f64; DOF]| {
        let robot = &problem.robots[i];
        ArmPose::new::<KinovaGen3, DOF>(0, &robot.base, &robot.tool, q)
    };
    for (t, (qa, qb)) in paths[0].iter().zip(&paths[1]).enumerate() {
        let (a, b) = (pose(0, qa), pose(1, qb));
        assert!(a.arm_hit(&b, 0.0).is_none(), "the arms collide at step {t}");
    }
    let (ma, mb) = (
        motion(&problem, 0, &paths[0], 0),
        motion(&problem, 1, &paths[1], 0),
    );
    assert!(motions_collide::<KinovaGen3, DOF>(&ma, &mb, MOTION_STEP));
    let (contact, exact) =
        motions_contact::<KinovaGen3, DOF>(&ma, &mb, MOTION_STEP).expect("a witness");
    assert!(exact && contact.s > 0.0 && contact.s < 1.0, "{contact:?}");
    let at = |m: &ArmMotion<'_, DOF>, i| {
        let q: [f64; DOF] = std::array::from_fn(|j| m.from[j] + contact.s * (m.to[j] - m.from[j]));
        pose(i, &q)
    };
    assert!(near_point(&at(&ma, 0), &contact.point, 0.0));
    assert!(near_point(&at(&mb, 1), &contact.point, 0.0));

    let apart = Outcome {
        status: Status::Solved,
        planning_time_s: 0.0,
        assignment: vec![Some(0), Some(1)],
        joint_paths: paths.to_vec(),
        approach: None,
        approach_info: Default::default(),
        stats: Default::default(),
    }
    .to_solution_file(&file, "planned apart");
    let report = validate::<KinovaGen3, DOF>(&file, &problem, &apart);
    assert!(!report.is_valid());
    for v in &report.violations {
        assert!(
            v.rule == Rule::Collision && v.detail.starts_with("moving from step 0 to 1"),
            "{v}"
        );
    }
}

/// Ω-CBSA's constraint tree has the motion conflict and branches on it (every branching is a
/// motion conflict, none inexact), and the plan it returns passes the validator, swept motions
/// included: with its warm start (the default) and without (root by Ω-A*, collisions counted).
#[test]
fn omcbsa_branches_on_the_motion_conflict_and_solves() {
    let file = hands_swap_sides();
    let problem = core_problem(&file);
    for warm in [true, false] {
        let mut storage = Storage::new(Capacities::default(), problem.horizon());
        if !warm {
            storage.cbs_params.warm_start_seconds = 0.0;
        }
        let outcome = storage
            .solve(omcbsa::planners::PlannerKind::OmCbsa, &problem, 10.0)
            .expect("planner");
        let s = outcome.stats;
        assert_eq!(outcome.status, Status::Solved, "warm start {warm}: {s:?}");
        assert!(s.motion_conflicts >= 1, "warm start {warm}: {s:?}");
        assert_eq!(
            s.motion_conflicts, s.conflicts_resolved,
            "warm start {warm}"
        );
        assert_eq!(
            (s.inexact_branches, s.unbranched_nodes),
            (0, 0),
            "warm start {warm}"
        );
        let sol = outcome.to_solution_file(&file, "omcbsa");
        assert_eq!(sol.stats["motion_conflicts"], s.motion_conflicts);
        let report = validate::<KinovaGen3, DOF>(&file, &problem, &sol);
        assert!(report.is_valid(), "warm start {warm}: {}", report.summary());
    }
}
