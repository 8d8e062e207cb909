//! Ω-A*'s start states: a first pose that no seed reaches by IK is given up after
//! `start_solutions` seeds, not tried with every seed of `start_attempts`.

use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::problem::{Robot, Trajectory};
use omcbsa_core::search::{plan, NoDeadline, OmegaParams, OthersMode, Query, SearchStats};
use omcbsa_core::search::{StartCache, StartIk, WorkspaceBuffers};

#[test]
fn an_unreachable_first_pose_is_given_up_after_start_solutions_seeds() {
    const H: usize = 3;
    let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
    let mut far = hand;
    far.pos.z += 3.0;
    let trajectories = [
        Trajectory::from_slice(&[hand; H]).unwrap(),
        Trajectory::from_slice(&[far; H]).unwrap(),
    ];
    let params = OmegaParams::default();
    // Room for 200 seeds of each trajectory: more than level 0 tries.
    let mut buf = vec![StartIk::Unknown; 400];
    let cache = StartCache::new(&mut buf, 1, 2, &params);
    let query = Query {
        robot: Robot::at(0, Frame::IDENTITY),
        trajectories: &trajectories,
        allowed: 0b11,
        hold: false,
        obstacles: &[],
        others: &[],
        others_mode: OthersMode::Avoid,
        points: &[],
        dt: 0.1,
        starts: cache.robot(0),
    };
    let mut buffers = Box::new(WorkspaceBuffers::<7, 4096, 8192>::new());
    let mut ws = buffers.workspace().unwrap();
    let (mut path, mut stats) = ([[0.0; 7]; H], SearchStats::default());
    let found = plan::<KinovaGen3, 7>(&query, &params, &mut ws, &NoDeadline, &mut path, &mut stats);
    assert_eq!(found.unwrap().trajectory, Some(0));

    let cells = cache.robot(0);
    let (near, far) = cells.split_at(cells.len() / 2);
    // The reachable pose: its start states were solved.
    assert!(near.iter().any(|c| matches!(c.get(), StartIk::Solved(_))));
    // The pose 3 m up: the first `start_solutions` seeds failed, the others were not tried.
    let n = params.start_solutions;
    assert!(params.start_attempts as usize > n);
    assert!(far[..n].iter().all(|c| c.get() == StartIk::Failed));
    assert!(far[n..].iter().all(|c| c.get() == StartIk::Unknown));
}
