//! Ω-A* keeps each joint's acceleration at the hands' timing, and says where and how much
//! slower hands it cannot follow would have to move.

use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::motion::MOTION_STEP;
use omcbsa_core::pace::{plan_too_fast, TooFast};
use omcbsa_core::problem::{Robot, Start, Trajectory, MAX_ROBOTS};
use omcbsa_core::search::{plan, NoDeadline, OmegaParams, OthersMode, PointConstraint, Query};
use omcbsa_core::search::{Node, OpenEntry, SearchStats, Slot, Workspace};
use omcbsa_core::search::{SearchError, Validity};

const H: usize = 12;

/// A hand pointing down that shakes along y by `amp` m every step (then rests), in front of a
/// Gen3 at the origin.
fn shaking(amp: f64) -> Trajectory {
    let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
    (0..H)
        .map(|t| {
            let mut x = hand;
            x.pos.y += if t % 2 == 0 { 0.0 } else { amp };
            x
        })
        .collect()
}

/// Ω-A* with the defaults for `robot` on `traj` (steps `dt` apart) under `points`.
fn search(
    robot: Robot<7>,
    traj: &Trajectory,
    points: &[PointConstraint],
    dt: f64,
) -> (Result<Option<u8>, SearchError>, [[f64; 7]; H], SearchStats) {
    let trajectories = [traj.clone()];
    let query = Query {
        robot,
        trajectories: &trajectories,
        allowed: 1,
        hold: false,
        obstacles: &[],
        others: &[],
        others_mode: OthersMode::Avoid,
        points,
        dt,
        starts: &[],
    };
    let (mut nodes, mut open, mut table) = (
        vec![Node::<7>::default(); 1 << 16],
        vec![OpenEntry::default(); 1 << 17],
        vec![Slot::default(); 1 << 17],
    );
    let mut ws = Workspace::new(&mut nodes, &mut open, &mut table).unwrap();
    let (mut path, mut stats) = ([[0.0; 7]; H], SearchStats::default());
    let p = OmegaParams::default();
    let found = plan::<KinovaGen3, 7>(&query, &p, &mut ws, &NoDeadline, &mut path, &mut stats);
    (found.map(|f| f.trajectory), path, stats)
}

/// Where `path` (robot 0 tracking trajectory 0, steps `dt` apart) breaks an acceleration
/// limit, as the planners' last check and `validate` compute it.
fn too_fast(path: &[[f64; 7]; H], dt: f64) -> Option<TooFast> {
    let mut assignment = [None; MAX_ROBOTS];
    assignment[0] = Some(0);
    plan_too_fast::<KinovaGen3, 7>(&[0], &assignment, path, H, dt)
}

#[test]
fn an_arm_clears_a_point_along_its_null_space_within_its_accelerations() {
    // The hand stays where it is; at step 8 the elbow may not be where it starts, so the arm
    // must turn along its null space, from rest, within 5.2 rad/s^2 at 10 Hz: 0.052 rad of
    // change a step, where the paper's null-space moves at this rate are 0.1 rad.
    let q0 = [0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0];
    let mut robot = Robot::at(0, Frame::IDENTITY);
    (robot.initial, robot.start) = (Some(q0), Start::AtInitial);
    let (dt, p) = (0.1, [0.2, 0.0, 0.6]);
    let keep_off = [PointConstraint {
        t: 8,
        segment: false,
        s: 0.0,
        p,
        margin: 0.0,
    }];
    let valid = Validity::<KinovaGen3, 7>::new(&robot, &[], dt, MOTION_STEP).with_points(&keep_off);
    assert_eq!(
        valid.state(&q0, 8),
        None,
        "the arm at its start holds the point"
    );
    let still = Trajectory::from_slice(&[KinovaGen3::fk(&q0); H]).unwrap();
    let (found, path, _) = search(robot, &still, &keep_off, dt);
    assert_eq!(found, Ok(Some(0)));
    assert!(valid.state(&path[8], 8).is_some());
    assert_eq!(too_fast(&path, dt), None);
}

#[test]
fn a_hand_too_fast_for_the_arm_says_where_and_slower_steps_plan_it() {
    // 2 cm back and forth every 0.1 s: 4 m/s^2 at the hand.
    let robot = Robot::at(0, Frame::IDENTITY);
    let (found, _, stats) = search(robot, &shaking(0.02), &[], 0.1);
    assert_eq!(found, Err(SearchError::NoSolution));
    let cut = stats.too_fast.expect("the joints' limits cut the search");
    assert_eq!((cut.robot, cut.trajectory), (0, 0));
    assert!((1..H as u16 - 1).contains(&cut.step), "{cut:?}");
    assert!(cut.joint < 7 && cut.time_scale > 1.0, "{cut:?}");
    // Steps twice as long: planned, within every acceleration.
    let (found, path, stats) = search(robot, &shaking(0.02), &[], 0.2);
    assert_eq!(found, Ok(Some(0)));
    assert_eq!(stats.too_fast, None);
    assert_eq!(too_fast(&path, 0.2), None);
}

#[test]
fn the_searches_under_acceleration_are_deterministic() {
    let robot = Robot::at(0, Frame::IDENTITY);
    for (amp, dt) in [(0.02, 0.1), (0.01, 0.1)] {
        let (a, b) = (
            search(robot, &shaking(amp), &[], dt),
            search(robot, &shaking(amp), &[], dt),
        );
        assert_eq!(a.0, b.0);
        assert_eq!(
            a.1.map(|q| q.map(f64::to_bits)),
            b.1.map(|q| q.map(f64::to_bits))
        );
        assert_eq!(a.2, b.2);
    }
}
