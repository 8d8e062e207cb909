//! Online execution against three Python mock arms: segments pushed while the arms move replace
//! the queue's tail with continuous commands; a late segment lets the queue run dry and the arms
//! hold within their limits (reported as an event), then go on; a segment that breaks a limit
//! is refused and none of it is sent. What every mock received is compared with a
//! [`Generator`] replaying the same pushes at the cycles the stream applied them, and re-checked
//! against the limits cycle by cycle (`record::check_followed`).

mod common;

use common::*;
use omcbsa_hw::interpolate::min_time_scale;
use omcbsa_hw::Command;
use omcbsa_hw::{Event, Executor, PushError, StreamHandle, JOINTS};
use omcbsa_mock::record::check_followed;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Three mocks per test: run the tests of this file one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

const DT: f64 = 0.1;

type Path = Vec<[f64; JOINTS]>;

struct Online {
    _one_at_a_time: MutexGuard<'static, ()>,
    handle: StreamHandle,
    mocks: Vec<omcbsa_mock::mock::MockArm>,
    starts: Vec<[f64; JOINTS]>,
    time_scale: f64,
    pushed: Vec<Pushed>,
}

/// Starts the mocks and the online stream at the first waypoints of a 3-arm plan, slowed
/// down so that its segments are within the limits; returns the plan's paths.
fn start(tag: &str) -> (Online, Vec<Path>) {
    let one_at_a_time = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let plan = three_arm_plan(40);
    let paths: Vec<Path> = plan.arms.iter().map(|a| a.joint_path.clone()).collect();
    let time_scale = scale(&paths);
    let mocks = spawn_arms(&plan, tag, &[]);
    let starts: Vec<[f64; JOINTS]> = plan.arms.iter().map(|a| a.joint_path[0]).collect();
    let arms = (open_buses(&mocks).into_iter().zip(&starts))
        .map(|((name, bus), q)| (name, *q, bus))
        .collect();
    let handle = Executor::online(
        arms,
        DT,
        time_scale,
        &omcbsa_mock::testing::fleet_limits(starts.len()),
        mock_config(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let online = Online {
        _one_at_a_time: one_at_a_time,
        handle,
        mocks,
        starts,
        time_scale,
        pushed: Vec::new(),
    };
    (online, paths)
}

impl Online {
    fn push(&mut self, start: usize, waypoints: Vec<Path>) -> Result<(), PushError> {
        let slices: Vec<&[[f64; JOINTS]]> = waypoints.iter().map(|w| w.as_slice()).collect();
        let cycle = self.handle.push(start, &slices)?;
        self.pushed.push(Pushed {
            start,
            waypoints,
            cycle,
        });
        Ok(())
    }

    /// Waits until `done` holds for the stream's progress (at most 20 s).
    fn wait(&self, what: &str, mut done: impl FnMut(&omcbsa_hw::StreamProgress) -> bool) {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let p = self.handle.progress();
            assert!(
                !self.handle.faulted(),
                "stream faulted while waiting for {what}"
            );
            if done(&p) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what}: {p:?}"
            );
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// Waits for the next events (at most 20 s).
    fn next_events(&self, what: &str) -> Vec<Event> {
        let mut events = Vec::new();
        self.wait(what, |_| {
            events = self.handle.events();
            !events.is_empty()
        });
        events
    }

    /// Finishes the stream, replays the pushes on a generator, and checks every mock's record
    /// against the replay. Returns the replayed commands per arm and the events seen.
    fn finish_and_check(self) -> (Vec<Vec<Command>>, omcbsa_hw::Report) {
        let cfg = mock_config();
        let report = self.handle.finish().unwrap_or_else(|e| panic!("{e}"));
        println!("{report}");
        let limits = omcbsa_mock::testing::arm_limits();
        let period = cfg.period.as_secs_f64();
        let fleet = vec![limits; self.starts.len()];
        let step_time = DT * self.time_scale;
        let cmds = replay(&self.starts, &fleet, period, step_time, &self.pushed);
        assert_eq!(report.cycles, cmds[0].len());
        for (mock, arm) in self.mocks.into_iter().zip(&cmds) {
            let name = mock.name.clone();
            let record = record_of(mock);
            check_followed(&record, arm, cfg.settle_cycles, &limits, period)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        (cmds, report)
    }
}

/// `n` waypoints per arm continuing from `from` (each arm's waypoint at the step before),
/// drifting by `amplitude` rad along a smooth curve.
fn continuation(from: &[[f64; JOINTS]], n: usize, amplitude: f64) -> Vec<Path> {
    from.iter()
        .map(|q| {
            (1..=n)
                .map(|i| {
                    let s = (i as f64 / n as f64 * std::f64::consts::PI).sin();
                    std::array::from_fn(|j| {
                        q[j] + amplitude * s * if j % 2 == 0 { 1.0 } else { -1.0 }
                    })
                })
                .collect()
        })
        .collect()
}

/// A slow-down at which every segment used here is within the limits, with room for the
/// tangents frozen at a junction.
fn scale(paths: &[Path]) -> f64 {
    1.5 * min_time_scale(
        paths.iter().map(|p| p.as_slice()),
        &omcbsa_mock::testing::fleet_limits(paths.len()),
        DT,
    )
}

fn at(paths: &[Path], step: usize) -> Vec<[f64; JOINTS]> {
    paths.iter().map(|p| p[step]).collect()
}

#[test]
fn pushed_segments_replace_the_tail_while_running_with_continuous_commands() {
    let (mut online, paths) = start("replace");
    let first: Vec<Path> = paths.iter().map(|p| p[1..20].to_vec()).collect();
    online.push(1, first).unwrap();
    online.wait("step 5", |p| p.step >= 5);
    // replace from the first step that is not fixed with a different continuation
    let from = online.handle.progress().fixed + 2;
    let second = continuation(&at(&paths, from - 1), 15, 0.05);
    online.push(from, second.clone()).unwrap();
    let (cmds, report) = online.finish_and_check();
    assert_eq!(report.holds, 0, "{report}");
    // the arms went through the replaced tail: they end at its last waypoint
    for (arm, c) in cmds.iter().enumerate() {
        let end = c[c.len() - 1];
        for j in 0..JOINTS {
            let want = second[arm][14][j];
            assert!((omcbsa_hw::cia402::counts_to_rad(end[j]) - want).abs() <= 1e-7);
        }
    }
}

#[test]
fn late_segment_lets_the_arms_hold_within_limits_and_is_reported() {
    let (mut online, paths) = start("late");
    online
        .push(1, paths.iter().map(|p| p[1..8].to_vec()).collect())
        .unwrap();
    let events = online.next_events("the queue to run dry");
    let dry = match events[..] {
        [Event::QueueDry { step: 7, cycle }] => cycle,
        _ => panic!("{events:?}"),
    };
    online.wait("50 cycles of hold", |p| p.cycle >= dry + 50);
    // the late segment continues from the held waypoint
    online
        .push(8, paths.iter().map(|p| p[8..16].to_vec()).collect())
        .unwrap();
    let resume = online.pushed[1].cycle;
    let events = online.next_events("the arms to move on");
    assert!(
        matches!(events[..], [Event::Resumed { step: 7, .. }]),
        "{events:?}"
    );
    let (cmds, report) = online.finish_and_check();
    assert_eq!(report.holds, 1, "{report}");
    // the hold: one unchanged command, at step 7's waypoint, from the dry cycle to the push
    for arm in &cmds {
        let held = &arm[dry as usize..resume as usize];
        assert!(held.len() >= 50 && held.iter().all(|c| *c == held[0]));
    }
}

#[test]
fn segment_breaking_a_limit_is_refused_and_none_of_it_is_sent() {
    let (mut online, paths) = start("refuse");
    // refused before anything moves: joint 2 of arm 1 beyond its limit (2.24 rad) at one
    // waypoint (a jump within the position limits is no longer refused: the time law slows
    // down to follow it within the velocity and acceleration limits)
    let mut bad: Vec<Path> = paths.iter().map(|p| p[1..10].to_vec()).collect();
    bad[1][3][1] = 2.5;
    let e = online.push(1, bad.clone()).unwrap_err();
    assert!(matches!(e, PushError::Limits { arm: 1, .. }), "{e}");
    assert!(e.to_string().contains("joint 2: position"), "{e}");
    online
        .push(1, paths.iter().map(|p| p[1..10].to_vec()).collect())
        .unwrap();
    online.wait("step 3", |p| p.step >= 3);
    // and while moving: a tail that takes joint 2 of arm 2 beyond its limit (2.24 rad)
    let from = online.handle.progress().fixed + 1;
    let mut far = continuation(&at(&paths, from - 1), 8, 0.05);
    for q in far[2].iter_mut() {
        q[1] = 3.0;
    }
    let e = online.push(from, far).unwrap_err();
    assert!(matches!(e, PushError::Limits { arm: 2, .. }), "{e}");
    // nothing of either refused segment reached an arm: the records are the accepted push alone
    let (cmds, _) = online.finish_and_check();
    let end = cmds[0][cmds[0].len() - 1];
    assert!((omcbsa_hw::cia402::counts_to_rad(end[0]) - paths[0][9][0]).abs() <= 1e-7);
}
