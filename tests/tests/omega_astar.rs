//! Ω-A* on one arm, where plain IK tracking fails.

use omcbsa::format::Status;
use omcbsa::planners::DOF;
use omcbsa_core::model::KinovaGen3;
use omcbsa_core::search::{OthersMode, Validity};
use omcbsa_core::tracking::track;
use omcbsa_tests::*;

/// IK tracking keeps the elbow family of its first IK solution (the one nearest `initial`):
/// that family's elbow meets the ball at step 8. The hand path itself is feasible with the
/// elbow on the other side, which Ω-A* reaches by its ±ε null-space moves.
#[test]
fn omega_astar_swings_the_elbow_where_ik_tracking_fails() {
    let mut checked = 0;
    for seed in [42, 54, 63] {
        let Some((file, _)) = elbow_swing_problem(seed) else {
            continue;
        };
        let problem = core_problem(&file);
        let robot = problem.robots[0];
        let valid = Validity::<KinovaGen3, DOF>::new(
            robot.base,
            robot.tool,
            &problem.obstacles,
            &[],
            OthersMode::Avoid,
            &[],
            problem.dt,
            omcbsa_core::motion::MOTION_STEP,
        );
        let mut path = vec![[0.0; DOF]; problem.horizon()];
        let init = robot.initial.expect("the scene sets initial");
        assert!(
            track::<KinovaGen3, DOF>(
                &robot,
                &problem.trajectories[0],
                &init,
                &valid,
                &Default::default(),
                &mut path
            )
            .is_none(),
            "seed {seed}: IK tracking from the first IK solution should hit the ball"
        );
        // `initial` is the ball-hitting IK answer IK tracking starts from, not where the arm
        // stands: without it the plan needs no approach from there.
        let mut file = file;
        file.robots[0].initial = None;
        let sol = plan_and_validate(&file, "omega-astar", 5.0);
        assert_eq!(sol.status, Status::Solved, "seed {seed}: {}", sol.message);
        checked += 1;
    }
    assert!(checked >= 2, "the scene generator gave too few scenes");
}
