//! Online execution on simulated CAN arms at the default rate (`omcbsa_mock::sim`, in-process):
//! what the stream says about each arm while it moves and holds, and stopping every arm at
//! once, on request or by dropping the handle.

use omcbsa_hw::interpolate::min_time_scale;
use omcbsa_hw::{ArmState, Event, ExecConfig, Executor, StreamHandle, StreamProgress, JOINTS};
use omcbsa_mock::sim::can::{CanSim, CanSimOptions};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One stream at a time: they keep time.
static SERIAL: Mutex<()> = Mutex::new(());

const DT: f64 = 0.1;
const STARTS: [[f64; JOINTS]; 2] = [[0.1; JOINTS], [-0.1; JOINTS]];

/// `n` waypoints per arm after `from`, drifting by up to 0.03 rad and back.
fn chunk(from: &[[f64; JOINTS]], n: usize) -> Vec<Vec<[f64; JOINTS]>> {
    from.iter()
        .map(|q| {
            (1..=n)
                .map(|i| {
                    let s = (i as f64 / n as f64 * std::f64::consts::PI).sin();
                    q.map(|v| v + 0.03 * s)
                })
                .collect()
        })
        .collect()
}

fn slices(w: &[Vec<[f64; JOINTS]>]) -> Vec<&[[f64; JOINTS]]> {
    w.iter().map(|p| p.as_slice()).collect()
}

fn start() -> (StreamHandle, Vec<CanSim>, f64) {
    let limits = omcbsa_mock::testing::fleet_limits(STARTS.len());
    let probe = chunk(&STARTS, 10);
    let scale = 1.5 * min_time_scale(probe.iter().map(|p| p.as_slice()), &limits, DT);
    let (sims, arms): (Vec<CanSim>, Vec<_>) = (STARTS.iter().enumerate())
        .map(|(i, q)| {
            let (sim, bus) = CanSim::spawn(CanSimOptions::at(*q));
            (sim, (format!("arm{i}"), *q, bus))
        })
        .unzip();
    let cfg = ExecConfig {
        period: omcbsa_hw::bus::CAN_PERIOD,
        ..ExecConfig::default()
    };
    let h = Executor::online(arms, DT, scale, &limits, cfg).unwrap();
    wait(&h, "start-up", |_| true);
    (h, sims, scale)
}

/// Waits (at most 10 s) for every arm to be set up and `done` to hold.
fn wait(h: &StreamHandle, what: &str, mut done: impl FnMut(&StreamProgress) -> bool) {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(!h.faulted(), "faulted while waiting for {what}");
        let starting = h.status().iter().any(|a| a.state == ArmState::Starting);
        if !starting && done(&h.progress()) {
            return;
        }
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn status_follows_each_arm_and_a_dry_queue_holds_them() {
    let _one = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let (h, sims, _) = start();
    // Nothing pushed yet: every arm holds where it starts.
    for (a, q) in h.status().iter().zip(STARTS) {
        assert_eq!(a.state, ArmState::Holding, "{a:?}");
        assert!(a.commanded.iter().zip(q).all(|(c, q)| (c - q).abs() < 1e-7));
        assert_eq!(a.queue_depth, 0);
    }
    let first = chunk(&STARTS, 10);
    h.push(1, &slices(&first)).unwrap();
    wait(&h, "step 3", |p| p.step >= 3);
    for a in h.status() {
        assert_eq!(a.state, ArmState::Moving, "{a:?}");
        assert!(a.queue_depth >= 5, "{a:?}");
        let m = a.measured.expect("feedback");
        // The simulated joints follow at once: measured is a recent command, as many
        // periods behind as the accounting allows at most.
        let lag = a.lag.expect("an answered cycle");
        assert!(lag <= omcbsa_hw::bus::CAN_PERIOD * 25, "{a:?}");
        let apart = (m.positions.iter().zip(a.commanded)).map(|(m, c)| (m - c).abs());
        assert!(apart.fold(0.0, f64::max) < 0.01, "{a:?}");
        assert!(a.following_error < 1e-6, "{a:?}");
    }
    // (The arms held at their start until the push: their motion is a resumption.)
    let mut events = Vec::new();
    wait(&h, "the queue to run dry", |_| {
        events.extend(h.events());
        events.iter().any(|e| matches!(e, Event::QueueDry { .. }))
    });
    let dry: Vec<&Event> = (events.iter())
        .filter(|e| !matches!(e, Event::Resumed { step: 0, .. }))
        .collect();
    assert!(
        matches!(dry[..], [Event::QueueDry { step: 10, .. }]),
        "{events:?}"
    );
    wait(&h, "every arm holding", |p| p.holding);
    std::thread::sleep(Duration::from_millis(20));
    let last: Vec<[f64; JOINTS]> = first.iter().map(|w| w[w.len() - 1]).collect();
    for (a, q) in h.status().iter().zip(&last) {
        assert_eq!(a.state, ArmState::Holding, "{a:?}");
        assert_eq!(a.queue_depth, 0);
        let m = a.measured.unwrap().positions;
        assert!(m.iter().zip(q).all(|(m, q)| (m - q).abs() < 1e-6), "{a:?}");
    }
    // The next push moves them on; the run ends with one hold reported.
    h.push(11, &slices(&chunk(&last, 5))).unwrap();
    let report = h.finish().unwrap();
    assert_eq!((report.holds, report.halted), (1, false), "{report}");
    for s in sims {
        let r = s.finish();
        assert!(r.stopped.is_none(), "a normal end is no quick stop");
        assert!(!r.commands.is_empty());
    }
}

#[test]
fn stop_and_drop_stop_every_arm_at_once() {
    let _one = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    for by_drop in [false, true] {
        let (h, sims, _) = start();
        h.push(1, &slices(&chunk(&STARTS, 30))).unwrap();
        wait(&h, "step 2", |p| p.step >= 2);
        let asked = Instant::now();
        if by_drop {
            drop(h);
        } else {
            let report = h.stop().unwrap();
            assert!(report.halted, "{report}");
            assert_eq!(report.arms.len(), 2, "{report}");
        }
        for s in sims {
            let r = s.finish();
            let stopped = r.stopped.expect("a quick stop");
            assert!(
                stopped >= asked && stopped - asked < Duration::from_millis(10),
                "{r:?}"
            );
            assert_eq!(r.commands_after_stop, 0);
        }
    }
}
