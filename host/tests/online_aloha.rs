//! Online embodiment of the recorded ALOHA episodes (`data/aloha_sim`, the scripted policies
//! in MuJoCo) at the policy's 50 Hz: the wrist-turn dead end that chunks planned without
//! speed headroom walk into is
//! avoided by the speed headroom, recovered by a catch-up, or slowed by time scaling; and a
//! new chunk every step never changes what the arms were sent.

use std::path::Path;

use omcbsa::online::aloha::{read_family, Cell, FleetKind, Layout};
use omcbsa::online::bench::{run_altered, run_episode, Chunking, EpisodeRun};
use omcbsa::online::bimanual::Episode;
use omcbsa::online::{OnlineOptions, Recovery};
use omcbsa_core::model::{KinovaGen3, Model};

mod common;
use common::on_big_stack;

/// A recorded transfer episode on two Gen3s at the table's corners. Transfer 100: the arm
/// that takes the cube turns its last joint past 1.22 rad/s at step ~320 when its chunks
/// were planned without regard for what comes next.
fn transfer(seed: u32) -> Episode {
    transfer_on(seed, 2)
}

/// A recorded transfer episode on `arms` Gen3s at the table's corners.
fn transfer_on(seed: u32, arms: usize) -> Episode {
    let family = read_family(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/aloha_sim"))
        .expect("the committed family reads");
    let i = (family.episodes.iter())
        .position(|e| e.entry.task == "transfer" && e.entry.seed == u64::from(seed))
        .expect("the episode is in the family");
    let cell = Cell {
        layout: Layout::Corners,
        fleet: FleetKind::Gen3,
        arms,
    };
    family.episode(i, &cell)
}

/// The Embodier as it was before the speed headroom: the axis cost tuned on the synthetic
/// bimanual family (weight 4), no speed headroom, no reserve, no time scaling. It fails 49
/// of the 50 recorded transfer episodes on two Gen3s with 16-step chunks.
fn before_headroom() -> OnlineOptions {
    OnlineOptions {
        axis_weight: 4.0,
        headroom_weight: 0.0,
        reserve_weight: 0.0,
        time_scaling: false,
        ..OnlineOptions::default()
    }
}

/// The defaults at the policy's rate: time scaling off, so a dead end is not slowed away.
fn at_rate() -> OnlineOptions {
    OnlineOptions {
        time_scaling: false,
        ..OnlineOptions::default()
    }
}

/// [`at_rate`] with room for ACT's 100-step chunks.
fn at_rate_100() -> OnlineOptions {
    OnlineOptions {
        max_chunk_len: 100,
        ..at_rate()
    }
}

/// ACT's 100-step chunks, one every `stride` steps, arriving `lead` steps early.
fn hundred(stride: usize, lead: usize) -> Chunking {
    Chunking {
        len: 100,
        stride,
        lead,
    }
}

const JUST_IN_TIME: Chunking = Chunking {
    len: 16,
    stride: 16,
    lead: 0,
};

/// The first chunk that could not be planned from where the last one left the arms because
/// a joint would turn too fast, and that error.
fn first_speed_failure(run: &EpisodeRun) -> Option<(u64, String)> {
    run.outcomes.iter().find_map(|o| {
        let error = o.result.as_ref().err().or(o.blocked.as_ref())?;
        error.contains("rad/s").then(|| (o.start, error.clone()))
    })
}

#[test]
fn a_recorded_episode_that_failed_on_joint_speed_is_embodied() {
    on_big_stack(|| {
        let ep = transfer(100);
        let before = run_episode(&ep, &before_headroom(), JUST_IN_TIME).unwrap();
        assert!(!before.embodied);
        let (step, error) = first_speed_failure(&before).expect("a chunk fails on a joint's speed");
        assert_eq!(step, 320);
        for part in [
            "robot",
            "holding hand",
            "cannot go on at step",
            "above its limit",
        ] {
            assert!(error.contains(part), "{part:?} not in {error:?}");
        }
        let run = run_episode(&ep, &at_rate(), JUST_IN_TIME).unwrap();
        assert!(run.embodied, "{:?}", run.error);
        assert_eq!((run.planned, run.recovered), (run.chunks, 0));
        assert_eq!(run.lag_s, 0.0);
    });
}

/// Transfer 113 on four Gen3s, 100-step chunks every 100 steps (ACT's default) at the rate.
/// Started from the first pose's IK answer nearest where it stood, the arm that takes the
/// cube tracked the first chunk in a self-motion family whose joints had no room for the
/// lift at step ~180 (joint 6 past its limit), and the null space offered no way out of it
/// in the 80 steps the second chunk gave: that chunk was caught up, 99 poses dropped. With
/// `rank_starts`, a first chunk this long starts where the joints' reserve is largest.
#[test]
fn a_first_chunk_starts_where_the_later_motions_can_be_followed() {
    on_big_stack(|| {
        let options = OnlineOptions {
            rank_starts: true,
            ..at_rate_100()
        };
        let run = run_episode(&transfer_on(113, 4), &options, hundred(100, 0)).unwrap();
        assert!(run.embodied, "{:?}", run.error);
        assert_eq!((run.planned, run.recovered), (run.chunks, 0));
    });
}

/// The policy glitches once: the chunk at step 160 puts the hands 3 m up, out of every
/// arm's reach. That chunk fails, naming the pose; the arms hold at the end of the plan,
/// and the next chunk catches up with the hands (dropping the poses the approach cannot
/// reach in time). Every later chunk is planned, and what was sent is one valid timeline.
#[test]
fn a_failed_chunk_is_followed_by_a_recovered_one() {
    on_big_stack(|| {
        const GLITCH: u64 = 160;
        let mut glitch = |start: u64, hands: &mut [Vec<omcbsa::format::Pose>]| {
            if start == GLITCH {
                hands
                    .iter_mut()
                    .flatten()
                    .for_each(|p| p.position[2] += 3.0);
            }
        };
        let run = run_altered(&transfer(100), &at_rate(), JUST_IN_TIME, &mut glitch).unwrap();
        let failed = (run.outcomes.iter())
            .position(|o| o.result.is_err())
            .expect("the glitch fails");
        assert_eq!(run.outcomes[failed].start, GLITCH);
        let error = run.outcomes[failed].result.as_ref().unwrap_err();
        assert!(error.contains("reach"), "{error}");
        let next = &run.outcomes[failed + 1];
        assert_eq!(next.result, Ok(Some(Recovery::CaughtUp)), "{next:?}");
        let later = &run.outcomes[failed + 2..];
        assert!(later.iter().all(|o| o.result == Ok(None)), "{later:?}");
        // The glitch, and the catch-up that dropped poses, are not counted as planned.
        assert_eq!(run.planned, run.chunks - 2);
        assert_eq!(run.broken_commitments, 0);
        // Valid but for the poses skipped: the glitch's and those the approach dropped.
        let order = run.record.check_order().unwrap();
        assert!(order.dropped >= 16, "{order:?}");
        assert_eq!(order.reached + order.dropped, transfer(100).hands[0].len());
        assert!(!run.embodied);
    });
}

#[test]
fn a_time_scaled_timeline_is_valid_and_within_every_speed_limit() {
    on_big_stack(|| {
        let ep = transfer(100);
        let options = OnlineOptions {
            time_scaling: true,
            ..before_headroom()
        };
        let run = run_episode(&ep, &options, JUST_IN_TIME).unwrap();
        assert!(run.scaled >= 1, "no chunk was slowed: {:?}", run.outcomes);
        // Valid under the validator, every pose tracked in order, none dropped.
        assert!(run.embodied, "{:?}", run.error);
        assert!(run.lag_s > 0.0);
        let order = run.record.check_order().unwrap();
        assert_eq!(order.dropped, 0);
        let steps = ep.hands[0].len();
        assert_eq!(order.reached, steps);
        // And, from the configurations sent, no joint faster than its limit.
        let vmax = KinovaGen3::VELOCITY;
        for (robot, path) in run.record.sent.iter().enumerate() {
            assert!(path.len() > steps, "robot {robot}: {} sent", path.len());
            for (k, w) in path.windows(2).enumerate() {
                for j in 0..7 {
                    let speed = (w[1][j] - w[0][j]).abs() / ep.setup.dt;
                    assert!(
                        speed <= vmax[j] + 1e-9,
                        "robot {robot} joint {j} at index {k}: {speed} rad/s over {}",
                        vmax[j]
                    );
                }
            }
        }
    });
}

#[test]
fn a_chunk_every_step_keeps_what_the_arms_were_sent() {
    on_big_stack(|| {
        let ep = transfer(100);
        let run = run_episode(&ep, &at_rate_100(), hundred(1, 4)).unwrap();
        assert_eq!(run.chunks, ep.hands[0].len() - 100 + 1);
        // After every chunk the plan still starts from the last configuration sent
        // (`broken_commitments`), and what was sent is one valid timeline.
        assert_eq!(run.broken_commitments, 0, "{:?}", run.error);
        assert!(run.embodied, "{:?}", run.error);
        assert_eq!(run.record.check_order().unwrap().dropped, 0);
    });
}
