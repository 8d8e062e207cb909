//! Ω-A* on one arm, where plain IK tracking fails.

use omcbsa::format::Status;
use omcbsa::planners::DOF;
use omcbsa_core::model::KinovaGen3;
use omcbsa_core::search::Validity;
use omcbsa_core::tracking::{track, Steps};
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
            &robot,
            &problem.obstacles,
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
                Steps::Nearest(&Default::default()),
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

/// `file` at `k` times the rate: `dt / k`, with `k - 1` poses between consecutive ones
/// (position along the segment, orientation along the shortest rotation).
fn resample(file: &omcbsa::format::ProblemFile, k: usize) -> omcbsa::format::ProblemFile {
    use omcbsa_core::nalgebra::{Rotation3, UnitQuaternion};
    let mut fine = file.clone();
    fine.dt = file.dt / k as f64;
    for t in &mut fine.trajectories {
        let frames: Vec<_> = t
            .poses
            .iter()
            .map(|p| omcbsa::pose::to_frame(p).unwrap())
            .collect();
        let mut poses = Vec::new();
        for w in frames.windows(2) {
            let (qa, qb) = (
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(w[0].rot)),
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(w[1].rot)),
            );
            for i in 0..k {
                let s = i as f64 / k as f64;
                let f = omcbsa_core::model::Frame {
                    rot: *qa.slerp(&qb, s).to_rotation_matrix().matrix(),
                    pos: w[0].pos + s * (w[1].pos - w[0].pos),
                };
                poses.push(omcbsa::pose::from_frame(&f));
            }
        }
        poses.push(*t.poses.last().unwrap());
        t.poses = poses;
    }
    fine
}

/// Issue 26: the null-space step and the duplicate grid follow the step's length. The arm
/// stands in the elbow family that meets the ball and must swing out of it while its hand
/// moves (it starts exactly where it stands, as online chunks do). Ω-A* does it at 5 Hz; at
/// 50 Hz (the same hand path, ten times as many poses) a 0.2 rad null-space move would be
/// seven times what a joint may move in a step, leaving only IK tracking, which hits the ball.
#[test]
fn fifty_hz_swings_the_elbow_as_five_hz_does() {
    use omcbsa::planners::{Capacities, Storage, WallClock};
    use omcbsa_core::planner::{Status as CoreStatus, Until};
    use omcbsa_core::problem::Start;
    let solve = |file: &omcbsa::format::ProblemFile, initial: [f64; DOF]| {
        let mut problem = core_problem(file);
        problem.robots[0].initial = Some(initial);
        problem.robots[0].start = Start::AtInitial;
        let mut storage = Storage::new(Capacities::default(), problem.horizon());
        let clock = WallClock::start();
        let kind = omcbsa::planners::PlannerKind::OmegaAstar;
        let ran = storage
            .solve_core(kind, &problem, Until::new(&clock, 10.0))
            .unwrap();
        (ran.status, ran.stats)
    };
    let mut checked = 0;
    for seed in [42, 54, 63, 71, 88] {
        let Some((file, alt)) = elbow_swing_problem(seed) else {
            continue;
        };
        // Scenes where the swing fits in time at 5 Hz (not every one does: the ball may be
        // met before the elbow can leave).
        if solve(&file, alt[0]).0 != CoreStatus::Solved {
            continue;
        }
        let (status, stats) = solve(&resample(&file, 10), alt[0]);
        assert_eq!(
            status,
            CoreStatus::Solved,
            "seed {seed} at 50 Hz: {stats:?}"
        );
        checked += 1;
    }
    assert!(checked >= 1, "the scene generator gave no scene");
}
