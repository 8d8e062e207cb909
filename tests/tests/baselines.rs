//! The paper's baselines (IK tracking, PP-Descartes, composite A*) on small problems, through
//! the same interface and validator as Ω-CBSA.

use omcbsa::format::Status;
use omcbsa_tests::*;

const BASELINES: [&str; 3] = ["ik-tracking", "descartes", "composite-astar"];

/// Two arms tracing easy, well separated hand paths: every planner solves it, and every answer
/// validates.
#[test]
fn every_planner_solves_an_easy_two_arm_problem() {
    let b0 = frame([0.0, -0.45, 0.0], [0.0, 0.0, 0.0]);
    let b1 = frame([0.0, 0.45, 0.0], [0.0, 0.0, 0.0]);
    let p0 = smooth_path(&HOME, &[0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 20);
    let p1 = smooth_path(&HOME, &[-0.3, 0.1, 0.0, 0.2, 0.0, 0.1, 0.0], 20);
    let file = swapped_pair_problem("easy_pair", [b0, b1], [&p0, &p1], vec![]);
    for planner in omcbsa::planners::PlannerKind::BENCH.map(|p| p.name()) {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, Status::Solved, "{planner}: {}", sol.message);
        assert_eq!(sol.assignment, vec![Some(1), Some(0)], "{planner}");
    }
}

/// The baselines enumerate assignments (IK tracking and PP-Descartes explicitly, composite A*
/// by seeding every assignment), so they find the one the listed order gets wrong.
#[test]
fn baselines_search_the_assignments() {
    let file = listed_order_wrong_problem();
    for planner in BASELINES {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, Status::Solved, "{planner}: {}", sol.message);
        assert_eq!(sol.assignment, vec![Some(1), Some(0)], "{planner}");
    }
}

/// With a hand that no arm can follow, each baseline runs out of options and says so.
#[test]
fn baselines_report_no_solution_when_none_exists() {
    let file = blocked_hand_problem();
    for planner in BASELINES {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, Status::NoSolution, "{planner}: {}", sol.message);
    }
}
