//! Small exact problems that show each mechanism of Ω-CBSA and the prioritised planners.
//! Every solution any planner reports is checked by the validator (`plan_and_validate`).

use omcbsa::format::Status;
use omcbsa::planners::{Capacities, Storage, DOF};
use omcbsa::validate::validate;
use omcbsa_core::ik::{ik_multi_start, MultiStart};
use omcbsa_core::model::KinovaGen3;
use omcbsa_core::rng::Rng;
use omcbsa_tests::*;
use serde_json::json;

const PLANNERS: [&str; 3] = ["omcbsa", "pp", "pp-single"];

/// Two arms 1.4 m apart, each hand path close to one arm and out of the other's reach, listed
/// in the wrong order: robot 0 cannot even reach the first pose of trajectory 0.
#[test]
fn finds_the_assignment_the_listed_order_gets_wrong() {
    let file = listed_order_wrong_problem();
    let problem = core_problem(&file);
    let target = problem.robots[0]
        .base
        .inverse()
        .compose(&problem.trajectories[0][0]);
    let mut out = [[0.0; DOF]; 1];
    let multi = MultiStart {
        attempts: 200,
        min_separation: 0.1,
    };
    assert!(
        ik_multi_start::<KinovaGen3, DOF>(
            0,
            &target,
            &Default::default(),
            &multi,
            &mut Rng::new(1),
            &mut out
        )
        .is_err(),
        "robot 0 should not reach trajectory 0"
    );
    for planner in PLANNERS {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, Status::Solved, "{planner}: {}", sol.message);
        assert_eq!(sol.assignment, vec![Some(1), Some(0)], "{planner}");
    }
}

/// Facing arms whose hands' paths are feasible only with the right elbow postures: IK
/// tracking fails under every assignment and from every seed it tries. Ω-CBSA solves them; and
/// with its warm start off (root paths by Ω-A* with collisions only counted) it finds the arms
/// in conflict, branches on witness points, and the replanned arm moves through its null space
/// around the other.
#[test]
fn arms_pass_each_other_by_null_space_motion() {
    let mut branched = 0;
    for seed in [120, 137, 215] {
        let file = facing_pair_problem(seed).expect("witness is collision-free");
        let ik = plan_and_validate(&file, "ik-tracking", 5.0);
        assert_eq!(
            ik.status,
            Status::NoSolution,
            "seed {seed}: IK tracking should fail"
        );
        let sol = plan_and_validate(&file, "omcbsa", 5.0);
        assert_eq!(sol.status, Status::Solved, "seed {seed}: {}", sol.message);

        let problem = core_problem(&file);
        let mut storage = Storage::new(Capacities::default(), problem.horizon());
        storage.cbs_params.warm_start_seconds = 0.0;
        let outcome = storage
            .solve(omcbsa::planners::PlannerKind::OmCbsa, &problem, 5.0)
            .expect("planner");
        let cold = outcome.to_solution_file(&file, "omcbsa");
        assert_eq!(
            cold.status,
            Status::Solved,
            "seed {seed} without warm start: {}",
            cold.message
        );
        let report = validate::<KinovaGen3, DOF>(&file, &problem, &cold);
        assert!(report.is_valid(), "seed {seed}: {}", report.summary());
        if outcome.stats.conflicts_resolved > 0 {
            branched += 1;
        }
    }
    assert!(
        branched == 3,
        "Ω-CBSA without warm start should have resolved conflicts on these scenes"
    );
}

/// No arm can track trajectory 0: its hand passes through a ball at step 5. The search
/// space is small and Ω-CBSA proves there is no solution instead of running to the timeout;
/// so do the prioritised planners.
#[test]
fn proves_no_solution_before_the_timeout() {
    let file = blocked_hand_problem();
    for planner in PLANNERS {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, Status::NoSolution, "{planner}: {}", sol.message);
    }
}

/// Three arms in a row, two hand trajectories: one arm must hold its initial configuration
/// (and is an obstacle to the others); the planner picks which.
#[test]
fn fewer_trajectories_than_arms() {
    let bases = [
        frame([0.0, -0.8, 0.0], [0.0, 0.0, 0.0]),
        frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        frame([0.0, 0.8, 0.0], [0.0, 0.0, 0.0]),
    ];
    let p0 = smooth_path(&HOME, &[0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 12);
    let p2 = smooth_path(&HOME, &[-0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 12);
    let robots = (0..3)
        .map(|i| robot_json(&format!("r{i}"), &bases[i], Some(&HOME)))
        .collect();
    let file = problem_json(
        "three_arms_two_hands",
        0.2,
        robots,
        vec![
            trajectory_json("h2", &bases[2], &p2),
            trajectory_json("h0", &bases[0], &p0),
        ],
        vec![
            json!({"name": "table", "shape": "box", "half_extents": [0.4, 1.4, 0.02],
                    "pose": {"position": [0.6, 0.0, -0.03], "quat_xyzw": [0, 0, 0, 1]}}),
        ],
    );
    for planner in PLANNERS {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, Status::Solved, "{planner}: {}", sol.message);
        let holders: Vec<usize> = (0..3).filter(|&i| sol.assignment[i].is_none()).collect();
        assert_eq!(holders.len(), 1, "{planner}: {:?}", sol.assignment);
        let paths = sol.joint_paths.as_ref().expect("solved has paths");
        assert!(
            paths[holders[0]]
                .iter()
                .all(|q| q.as_slice() == HOME.as_slice()),
            "{planner}: the holder moved"
        );
    }
}

/// Restarts (a new constraint tree from another root once a tree has used its budget of Ω-A*
/// expansions, the budget doubling each time) keep Ω-CBSA complete and deterministic: from a
/// budget of one expansion, every tree but the last is cut short, and the answer is still
/// valid and the same on every run.
#[test]
fn restarts_are_complete_and_deterministic() {
    for seed in [120, 137] {
        let file = facing_pair_problem(seed).expect("witness is collision-free");
        let problem = core_problem(&file);
        let run = || {
            let mut storage = Storage::new(Capacities::default(), problem.horizon());
            storage.cbs_params.warm_start_seconds = 0.0;
            storage.cbs_params.restart_expansions = 1;
            let outcome = storage
                .solve(omcbsa::planners::PlannerKind::OmCbsa, &problem, 30.0)
                .expect("planner");
            (outcome.to_solution_file(&file, "omcbsa"), outcome.stats)
        };
        let (first, stats) = run();
        assert_eq!(
            first.status,
            Status::Solved,
            "seed {seed}: {}",
            first.message
        );
        let report = validate::<KinovaGen3, DOF>(&file, &problem, &first);
        assert!(report.is_valid(), "seed {seed}: {}", report.summary());
        // More roots were built than trees would need without restarts.
        assert!(
            stats.low_level_calls > 2 * problem.robots.len() as u32,
            "{stats:?}"
        );
        let (again, _) = run();
        assert_eq!(
            (&first.assignment, &first.joint_paths),
            (&again.assignment, &again.joint_paths),
            "seed {seed}: two runs differ"
        );
    }
}

/// Two arms 0.5 m apart, each able to reach both hands' paths, each path near one arm and the
/// paths listed in the other order. The root's warm start gives each arm, in turn, the
/// trajectory nearest its base that it can track: the root is already the plan (one
/// constraint-tree node, no conflict). Taking them in listed order would cross the arms.
#[test]
fn the_root_gives_each_arm_the_nearest_trajectory_first() {
    let b0 = frame([0.0, -0.25, 0.0], [0.0, 0.0, 0.0]);
    let b1 = frame([0.0, 0.25, 0.0], [0.0, 0.0, 0.0]);
    let p0 = smooth_path(&HOME, &[0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 15);
    let p1 = smooth_path(&HOME, &[-0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 15);
    let file = swapped_pair_problem("nearest_first", [b0, b1], [&p0, &p1], vec![]);
    let sol = plan_and_validate(&file, "omcbsa", 5.0);
    assert_eq!(sol.status, Status::Solved, "{}", sol.message);
    assert_eq!(sol.assignment, vec![Some(1), Some(0)]);
    assert_eq!(sol.stats["ct_nodes"], json!(1), "{:?}", sol.stats);
    assert_eq!(
        sol.stats["warm_start_solved"],
        json!(true),
        "{:?}",
        sol.stats
    );
}
