//! The online embodier on the scripted box-flip policy: chunks planned as they come, the
//! assignment kept, the whole sent timeline valid; clear errors for an unreachable hand pose
//! and a late chunk, with the plan left as it was.

use omcbsa::online::policy::BoxFlipPolicy;
use omcbsa::online::record::RunRecord;
use omcbsa::online::{Embodier, OnlineError, OnlineOptions};
use omcbsa::planners::DOF;
use omcbsa::validate::validate;
use omcbsa_core::model::{KinovaGen3, Model};

fn embodier(policy: &BoxFlipPolicy) -> Embodier {
    Embodier::new(&policy.setup(), OnlineOptions::default()).expect("setup is valid")
}

/// Runs chunks `chunks` just in time: everything before a chunk's first step is sent first.
fn run(
    policy: &BoxFlipPolicy,
    e: &mut Embodier,
    rec: &mut RunRecord,
    chunks: std::ops::Range<usize>,
) {
    for c in chunks {
        let chunk = policy.chunk(c);
        if let Some(index) = e.timeline_index(chunk.start_step) {
            rec.send(e, index);
            e.commit_until(index);
        }
        let report = e
            .push_chunk(chunk.start_step, &chunk.hands)
            .unwrap_or_else(|err| panic!("chunk {c}: {err}"));
        assert_eq!(Some(report.index), e.timeline_index(chunk.start_step));
    }
}

#[test]
fn box_flip_chunks_plan_keep_the_assignment_and_validate_whole() {
    let policy = BoxFlipPolicy::default();
    let mut e = embodier(&policy);
    let mut rec = RunRecord::default();
    run(&policy, &mut e, &mut rec, 0..1);
    let first = e.assignment().expect("assigned").to_vec();
    assert!(
        e.approach_len() > 0,
        "the arms start folded away from the box"
    );
    for c in 1..10 {
        run(&policy, &mut e, &mut rec, c..c + 1);
        assert_eq!(e.assignment().unwrap(), first.as_slice(), "chunk {c}");
    }
    rec.send(&e, e.end());
    let (problem, solution) = rec.files(&policy.setup(), &e).unwrap();
    let core = omcbsa::load::problem::<KinovaGen3, DOF>(&problem).unwrap();
    let report = validate::<KinovaGen3, DOF>(&problem, &core, &solution);
    assert!(report.is_valid(), "{}", report.summary());
    // The whole timeline starts where the arms stand and covers every chunk.
    let sent = &rec.sent[0];
    assert_eq!(sent[0], e.configuration(0, 0).unwrap_or(sent[0]));
    assert_eq!(sent.len(), e.approach_len() + 1 + 9 * 8 + 16);
}

#[test]
fn an_unreachable_hand_pose_is_named_and_the_plan_kept() {
    let policy = BoxFlipPolicy::default();
    let mut e = embodier(&policy);
    let mut rec = RunRecord::default();
    run(&policy, &mut e, &mut rec, 0..2);
    let before: Vec<Vec<[f64; DOF]>> = (0..3).map(|i| e.planned(i, 0).to_vec()).collect();
    let mut chunk = policy.chunk(2);
    // Hand 1's pose at the chunk's sixth step is 3 m up: out of every arm's reach.
    chunk.hands[1][5].position[2] += 3.0;
    let index = e.timeline_index(chunk.start_step).unwrap();
    e.commit_until(index);
    let err = e.push_chunk(chunk.start_step, &chunk.hands).unwrap_err();
    match err {
        OnlineError::Unreachable { hand, step, .. } => {
            assert_eq!((hand, step), (1, chunk.start_step + 5), "{err}")
        }
        other => panic!("expected an unreachable hand, got {other}"),
    }
    assert!(err.to_string().contains("hand 1"), "{err}");
    // The plan is unchanged: the arms finish it and hold at its end, within the limits.
    for (i, b) in before.iter().enumerate() {
        let now = e.planned(i, 0);
        assert_eq!(now, &b[b.len() - now.len()..]);
        for w in now.windows(2) {
            for (j, (a, b)) in w[0].iter().zip(&w[1]).enumerate() {
                assert!((b - a).abs() <= KinovaGen3::VELOCITY[j] * 0.1 + 1e-9);
            }
        }
    }
}

#[test]
fn a_late_chunk_is_refused_as_missing_its_deadline() {
    let policy = BoxFlipPolicy::default();
    let mut e = embodier(&policy);
    let mut rec = RunRecord::default();
    run(&policy, &mut e, &mut rec, 0..1);
    let chunk = policy.chunk(1);
    let index = e.timeline_index(chunk.start_step).unwrap();
    // The arms were sent three steps of what the chunk was to replace.
    e.commit_until(index + 3);
    let err = e.push_chunk(chunk.start_step, &chunk.hands).unwrap_err();
    assert!(
        matches!(
            err,
            OnlineError::DeadlineMissed {
                start_step: 8,
                committed_step: 10
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("missed its deadline"), "{err}");
    // The next chunk, in time, is planned from where the arms are.
    let next = policy.chunk(2);
    e.push_chunk(next.start_step, &next.hands).unwrap();
}

#[test]
fn bad_setups_and_chunks_name_the_field() {
    let policy = BoxFlipPolicy::default();
    let mut setup = policy.setup();
    setup.robots[1].initial = None;
    let err = Embodier::new(&setup, OnlineOptions::default())
        .err()
        .unwrap();
    assert!(err.to_string().contains("robots[1].initial"), "{err}");
    let mut e = embodier(&policy);
    let mut chunk = policy.chunk(0);
    chunk.hands[2][3].quat_xyzw = [0.0, 0.0, 0.0, 2.0];
    let err = e.push_chunk(0, &chunk.hands).unwrap_err();
    assert!(err.to_string().contains("hands[2][3].quat_xyzw"), "{err}");
    chunk.hands[2].pop();
    let err = e.push_chunk(0, &chunk.hands).unwrap_err();
    assert!(err.to_string().contains("hands[2]: 15 poses"), "{err}");
}

/// Issue 22, item 7: a chunk that comes after the plan ran out (the arms hold at its end) is
/// planned from the hold with an approach, as the first chunk is, and the whole sent timeline
/// (the hold and that approach included) validates.
#[test]
fn a_chunk_after_a_hold_is_reached_by_an_approach() {
    let policy = BoxFlipPolicy::default();
    let mut e = embodier(&policy);
    let mut rec = RunRecord::default();
    run(&policy, &mut e, &mut rec, 0..1);
    // The policy goes quiet; it comes back six chunks later, the box turned on.
    let end = e.end();
    let chunk = policy.chunk(6);
    let due = e.timeline_index(chunk.start_step).unwrap();
    assert!(due > end + 4, "the chunk starts well after the plan's end");
    rec.send(&e, end);
    e.commit_until(end);
    let hold: Vec<_> = (0..3)
        .map(|i| e.configuration(i, end - 1).unwrap())
        .collect();
    let report = e
        .push_chunk(chunk.start_step, &chunk.hands)
        .unwrap_or_else(|err| panic!("{err}"));
    assert!(report.index >= due);
    // The arms leave the hold before the chunk's first pose: an approach, not one step.
    let moved =
        (end..report.index).any(|t| (0..3).any(|i| e.configuration(i, t).unwrap() != hold[i]));
    assert!(moved, "no approach between the hold and the chunk");
    assert_eq!(report.dropped as u64, report.start_step - chunk.start_step);
    rec.send(&e, e.end());
    let (problem, solution) = rec.files(&policy.setup(), &e).unwrap();
    let core = omcbsa::load::problem::<KinovaGen3, DOF>(&problem).unwrap();
    let report = validate::<KinovaGen3, DOF>(&problem, &core, &solution);
    assert!(report.is_valid(), "{}", report.summary());
}
