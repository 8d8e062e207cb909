//! Online embodiment at the policy's own rate (issue 26), on the long bimanual episodes of
//! `bench-online --family bimanual` at 50 Hz: a dead end recovered, a blocked chunk named, a
//! fixed assignment kept, an episode longer than a problem embodied whole.

use omcbsa::assignment::AssignmentRule;
use omcbsa::online::bench::{run_episode, Chunking};
use omcbsa::online::bimanual::{episode, Episode, Task};
use omcbsa::online::{Embodier, OnlineError, OnlineOptions};
use omcbsa::pose::to_frame;
use omcbsa_core::model::{KinovaGen3, Model};
use omcbsa_core::problem::MAX_STEPS;

mod common;
use common::on_big_stack;

const HZ: f64 = 50.0;

fn transfer(arms: usize, seed: u64) -> Episode {
    episode(Task::Transfer, arms, seed, HZ).expect("the episode is drawn")
}

/// Episode 13 of the transfer task, chunks of 16 steps every 16 sent just in time: the
/// taking arm's hand moves past where its shoulder's first and third axes nearly line up, at
/// up to 0.11 m/s, and every plan through it turns the first joint within 1 % of its 1.4
/// rad/s. Planned greedily (IK tracking, the axis cost off), the chunk before step 384 leaves
/// the arm with those axes 0.25 apart (`axis_separation`) and no plan reaches step 392 from
/// there; with the axis cost the null space keeps them apart and every chunk is planned.
#[test]
fn a_chunk_sent_just_in_time_keeps_the_arm_out_of_the_next_ones_dead_end() {
    on_big_stack(no_dead_end);
}

fn no_dead_end() {
    for arms in [2, 3] {
        let run = run_episode(
            &transfer(arms, 13),
            &OnlineOptions::default(),
            Chunking {
                len: 16,
                stride: 16,
                lead: 0,
            },
        )
        .unwrap();
        assert!(run.embodied, "{arms} arms: {:?}", run.error);
        assert_eq!((run.planned, run.recovered), (run.chunks, 0), "{arms} arms");
    }
    // A weight that is no cost is refused, naming the option.
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let options = OnlineOptions {
            axis_weight: bad,
            ..OnlineOptions::default()
        };
        match Embodier::new(&transfer(2, 13).setup, options) {
            Err(OnlineError::Input(e)) => assert!(e.has("axis_weight", "finite"), "{e}"),
            other => panic!("{bad}: {:?}", other.err()),
        }
    }
}

/// The same episode planned greedily (`axis_weight` 0): the chunk at step 384 cannot be
/// planned from where the chunk before left the taking arm (its first joint would have to
/// turn faster than 1.4 rad/s at step 392). With 8 steps of lead, the steps not yet sent
/// are planned again with it.
#[test]
fn a_dead_end_is_recovered_by_planning_again_what_was_not_sent() {
    on_big_stack(dead_end_recovered);
}

/// Chunks planned greedily, IK tracking first (the dead end of transfer 013), at the policy's
/// rate (no time scaling), and a chunk that cannot be followed an error (no catch-up).
fn greedy() -> OnlineOptions {
    OnlineOptions {
        axis_weight: 0.0,
        headroom_weight: 0.0,
        reserve_weight: 0.0,
        time_scaling: false,
        catch_up: false,
        ..OnlineOptions::default()
    }
}

fn dead_end_recovered() {
    let ep = transfer(2, 13);
    let options = greedy();
    // Just in time (everything before a chunk's first step already sent): nothing is left to
    // plan again, and the error says where the chunk is blocked and by what.
    let late = run_episode(
        &ep,
        &options,
        Chunking {
            len: 16,
            stride: 16,
            lead: 0,
        },
    )
    .unwrap();
    assert!(!late.embodied);
    let error = late.error.expect("the dead end is reported");
    for part in [
        "robot 1 (\"west\")",
        "holding hand 1",
        "cannot go on at step",
        "rad/s",
    ] {
        assert!(error.contains(part), "{part:?} not in {error:?}");
    }
    // The chunk arrives 8 steps (160 ms) before its first step is due: the steps not yet sent
    // are planned again with it, and the whole episode is embodied and valid.
    let early = run_episode(
        &ep,
        &options,
        Chunking {
            len: 16,
            stride: 16,
            lead: 8,
        },
    )
    .unwrap();
    assert!(early.embodied, "{:?}", early.error);
    assert!(early.recovered >= 1, "no chunk needed a recovery");
    assert_eq!(early.planned, early.chunks);
}

/// The chunk's error as the Embodier gives it: robot, hand and step as fields.
#[test]
fn a_blocked_chunk_names_the_robot_the_hand_and_the_step() {
    on_big_stack(blocked_named);
}

fn blocked_named() {
    let ep = transfer(2, 13);
    let mut e = Embodier::new(&ep.setup, greedy()).unwrap();
    let mut start = 0;
    let (err, kept_end, kept_last) = loop {
        let hands: Vec<_> = ep
            .hands
            .iter()
            .map(|h| h[start..start + 16].to_vec())
            .collect();
        if let Some(i) = e.timeline_index(start as u64) {
            e.commit_until(i);
        }
        let (kept_end, kept_last) = (e.end(), e.planned(1, e.end().saturating_sub(1)).to_vec());
        match e.push_chunk(start as u64, &hands) {
            Ok(_) => start += 16,
            Err(err) => break (err, kept_end, kept_last),
        }
        assert!(start + 16 <= ep.hands[0].len(), "no chunk was blocked");
    };
    match err {
        OnlineError::Blocked {
            start_step,
            robot,
            robot_index,
            hand,
            step,
            what,
        } => {
            assert_eq!(
                (start_step, robot.as_str(), robot_index, hand),
                (384, "west", 1, Some(1))
            );
            assert!((384..400).contains(&step), "step {step}");
            assert!(what.contains("joint") && what.contains("rad/s"), "{what}");
        }
        other => panic!("not a blocked chunk: {other}"),
    }
    // The plan is kept as it was: the arms finish it and hold (a later chunk, far enough
    // after, is reached from the hold by an approach: tests/online.rs).
    assert_eq!(e.end(), kept_end);
    assert_eq!(e.planned(1, kept_end - 1), kept_last.as_slice());
}

/// A fixed assignment is what the plan uses, even where the Embodier would choose another;
/// a preferred one that has no plan gives way to a free choice.
#[test]
fn a_fixed_assignment_is_kept_and_a_preferred_one_gives_way() {
    on_big_stack(fixed_kept);
}

fn fixed_kept() {
    let ep = episode(Task::Insertion, 3, 0, HZ).unwrap();
    let hands: Vec<_> = ep.hands.iter().map(|h| h[..32].to_vec()).collect();
    let chosen = {
        let mut e = Embodier::new(&ep.setup, OnlineOptions::default()).unwrap();
        e.push_chunk(0, &hands).unwrap();
        e.assignment().unwrap().to_vec()
    };
    assert_eq!(chosen, vec![Some(0), Some(1), None]);
    // The side arm takes the peg's hand instead of the arm facing it.
    let fixed = vec![None, Some(1), Some(0)];
    let options = OnlineOptions {
        assignment: AssignmentRule::Fixed(fixed.clone()),
        ..OnlineOptions::default()
    };
    let mut e = Embodier::new(&ep.setup, options).unwrap();
    e.push_chunk(0, &hands)
        .expect("the side arm can take the peg");
    assert_eq!(e.assignment().unwrap(), fixed.as_slice());
    let next: Vec<_> = ep.hands.iter().map(|h| h[32..48].to_vec()).collect();
    e.commit_until(e.timeline_index(32).unwrap());
    e.push_chunk(32, &next).unwrap();
    assert_eq!(e.assignment().unwrap(), fixed.as_slice());
    // With the side arm moved out of reach, the same assignment has no plan: preferred, it
    // gives way to the Embodier's choice; fixed, the chunk is refused naming the robot.
    let mut far = ep.setup.clone();
    far.robots[2].base.position[1] = -3.0;
    let options = OnlineOptions {
        assignment: AssignmentRule::Preferred(fixed.clone()),
        ..OnlineOptions::default()
    };
    let mut e = Embodier::new(&far, options).unwrap();
    e.push_chunk(0, &hands)
        .expect("planned with another assignment");
    assert_eq!(e.assignment().unwrap(), chosen.as_slice());
    let options = OnlineOptions {
        assignment: AssignmentRule::Fixed(fixed.clone()),
        ..OnlineOptions::default()
    };
    let mut e = Embodier::new(&far, options).unwrap();
    match e.push_chunk(0, &hands) {
        Err(OnlineError::Unreachable {
            hand: 0,
            robot: Some(2),
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // A fixed assignment that cannot be: the error, not another assignment.
    let bad = vec![Some(0), Some(1), Some(0)];
    let options = OnlineOptions {
        assignment: AssignmentRule::Fixed(bad),
        ..OnlineOptions::default()
    };
    let mut e = Embodier::new(&ep.setup, options).unwrap();
    match e.push_chunk(0, &hands) {
        Err(OnlineError::Input(err)) => assert!(err.has("assignment[2]", "already taken"), "{err}"),
        other => panic!("{other:?}"),
    }
}

/// An episode of 421 steps (8.4 s at 50 Hz, longer than a problem's MAX_STEPS) through
/// `Embodier::embody`: every step tracked by the arm holding its hand, within the joint
/// speeds.
#[test]
fn an_episode_longer_than_a_problem_is_embodied_without_splitting_it_by_hand() {
    on_big_stack(long_episode);
}

fn long_episode() {
    let ep = episode(Task::Insertion, 2, 1, HZ).unwrap();
    let steps = ep.hands[0].len();
    assert!(steps > MAX_STEPS);
    let mut e = Embodier::new(&ep.setup, OnlineOptions::default()).unwrap();
    let embodied = e.embody(&ep.hands, 64).expect("embodied");
    let timeline = embodied.timeline;
    assert_eq!(embodied.last.end, e.end());
    let a = e.approach_len();
    let assignment = e.assignment().unwrap().to_vec();
    for (i, path) in timeline.iter().enumerate() {
        assert_eq!(path.len(), 1 + a + steps);
        for w in path.windows(2) {
            for (j, limit) in KinovaGen3::VELOCITY.iter().enumerate() {
                let speed = (w[1][j] - w[0][j]).abs() / ep.setup.dt;
                assert!(speed <= limit + 1e-9, "robot {i} joint {j}: {speed}");
            }
        }
        let Some(hand) = assignment[i] else { continue };
        let base = to_frame(&ep.setup.robots[i].base).unwrap();
        let tcp = to_frame(ep.setup.robots[i].tcp.as_ref().unwrap()).unwrap();
        for (k, pose) in ep.hands[hand].iter().enumerate() {
            let reached = base
                .compose(&KinovaGen3::fk(&path[1 + a + k]))
                .compose(&tcp);
            let err = (reached.pos - to_frame(pose).unwrap().pos).norm();
            assert!(
                err <= ep.setup.tolerance.position_m + 1e-9,
                "robot {i} step {k}: {err} m"
            );
        }
    }
    // A second episode is a new run.
    assert!(matches!(
        e.embody(&ep.hands, 64),
        Err(OnlineError::Input(_))
    ));
}

/// A chunk shorter than what the policy sent before is planned with the poses sent past its
/// end (lookahead): the plan keeps reaching as far as the policy has said.
#[test]
fn a_short_chunk_is_planned_with_the_poses_sent_past_its_end() {
    on_big_stack(lookahead);
}

fn lookahead() {
    let ep = episode(Task::Insertion, 2, 2, HZ).unwrap();
    let mut e = Embodier::new(&ep.setup, OnlineOptions::default()).unwrap();
    let part =
        |a: usize, b: usize| -> Vec<_> { ep.hands.iter().map(|h| h[a..b].to_vec()).collect() };
    e.push_chunk(0, &part(0, 48)).unwrap();
    let end = e.timeline_index(47).unwrap() + 1;
    assert_eq!(e.end(), end);
    e.commit_until(e.timeline_index(16).unwrap());
    let report = e.push_chunk(16, &part(16, 32)).unwrap();
    assert_eq!(report.end, end, "the plan stops at the short chunk's end");
    assert_eq!(e.end(), end);
}
