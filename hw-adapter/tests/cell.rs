//! A cell of Python mock arms (hw-adapter/mock; run hw-adapter/mock/setup_venv.sh first):
//! two Gen3s on Kortex and two arms on CAN, started by their URLs, driven by pushed chunks; a
//! queue that runs dry holds them; what every mock received is the stream a generator given the
//! same pushes computes; a fault on one arm stops every arm and the next call reports it;
//! dropping the cell stops every arm.

mod common;

use common::{replay, Pushed};
use omcbsa_hw::cell::{Cell, CellArm, CellError, CellOptions};
use omcbsa_hw::cia402::CW_QUICK_STOP;
use omcbsa_hw::connect::RealArms;
use omcbsa_hw::interpolate::min_time_scale;
use omcbsa_hw::{ArmState, Event, Fault, JOINTS};
use omcbsa_mock::arms::MockKind;
use omcbsa_mock::connect::{ArmOrMockUrl, MockConnector};
use serde_json::Value;
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// Up to four Python mocks per test: one test at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|p| p.into_inner())
}

const DT: f64 = 0.1;

type Path = Vec<[f64; JOINTS]>;

fn records_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("omcbsa-cell-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

type MockArm = CellArm<ArmOrMockUrl>;

fn arms(urls: &[&str]) -> Vec<MockArm> {
    (urls.iter().enumerate())
        .map(|(i, url)| CellArm {
            name: format!("arm{i}"),
            url: ArmOrMockUrl::parse(url).unwrap(),
            start: [0.1 * i as f64 - 0.15; JOINTS],
            limits: omcbsa_mock::testing::arm_limits(),
        })
        .collect()
}

/// `n` waypoints per arm after `from`, drifting by up to 0.05 rad and back.
fn chunk(from: &[[f64; JOINTS]], n: usize) -> Vec<Path> {
    from.iter()
        .map(|q| {
            (1..=n)
                .map(|i| {
                    let s = (i as f64 / n as f64 * std::f64::consts::PI).sin();
                    std::array::from_fn(|j| q[j] + 0.05 * s * if j % 2 == 0 { 1.0 } else { -1.0 })
                })
                .collect()
        })
        .collect()
}

fn slices(w: &[Path]) -> Vec<&[[f64; JOINTS]]> {
    w.iter().map(|p| p.as_slice()).collect()
}

/// Mocks recording to `dir`.
fn connector(dir: &std::path::Path) -> MockConnector {
    MockConnector::new(RealArms::default(), Some(dir.to_path_buf()))
}

fn options(arms: &[MockArm], dir: &std::path::Path) -> CellOptions {
    let mut o = CellOptions::new(DT, arms, &connector(dir));
    let probe = chunk(&arms.iter().map(|a| a.start).collect::<Vec<_>>(), 10);
    let limits = omcbsa_mock::testing::fleet_limits(arms.len());
    o.time_scale = 1.5 * min_time_scale(probe.iter().map(|p| p.as_slice()), &limits, DT);
    o
}

/// Calls `status` until `done` holds for it (at most 20 s).
fn wait_for(
    cell: &mut Cell,
    what: &str,
    mut done: impl FnMut(&omcbsa_hw::cell::CellStatus) -> bool,
) {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let s = cell
            .status()
            .unwrap_or_else(|e| panic!("waiting for {what}: {e}"));
        if done(&s) {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "timed out waiting for {what}: {s:?}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn two_kortex_and_two_can_mocks_follow_pushed_chunks_hold_when_dry_and_finish() {
    let _one = serial();
    let dir = records_dir("follow");
    let arms = arms(&[
        "mock-kortex",
        "mock-can",
        "mock-kortex?tau-ms=20",
        "mock-can?tau=0.02",
    ]);
    let opts = options(&arms, &dir);
    let (period, step_time) = (opts.config.period, DT * opts.time_scale);
    let settle = opts.config.settle_cycles;
    let starts: Vec<[f64; JOINTS]> = arms.iter().map(|a| a.start).collect();
    let limits: Vec<_> = arms.iter().map(|a| a.limits).collect();
    let mut cell = Cell::start(arms, opts, &connector(&dir)).unwrap_or_else(|e| panic!("{e}"));
    let s = cell.status().unwrap();
    assert!(s.arms.iter().all(|a| a.state == ArmState::Holding), "{s:?}");
    let first = chunk(&starts, 12);
    let cycle = cell.push(1, &slices(&first)).unwrap();
    let mut pushes = vec![Pushed {
        start: 1,
        waypoints: first.clone(),
        cycle,
    }];
    wait_for(&mut cell, "motion", |s| {
        s.arms.iter().all(|a| a.state == ArmState::Moving)
    });
    let mut dry = false;
    wait_for(&mut cell, "the queue to run dry", |s| {
        dry |= s
            .events
            .iter()
            .any(|e| matches!(e, Event::QueueDry { step: 12, .. }));
        dry && s
            .arms
            .iter()
            .all(|a| a.state == ArmState::Holding && a.queue_depth == 0)
    });
    let last: Vec<[f64; JOINTS]> = first.iter().map(|w| w[w.len() - 1]).collect();
    let second = chunk(&last, 8);
    let cycle = cell.push(13, &slices(&second)).unwrap();
    pushes.push(Pushed {
        start: 13,
        waypoints: second,
        cycle,
    });
    let end = cell.finish().unwrap_or_else(|e| panic!("{e}"));
    println!("{}", end.report);
    assert_eq!(end.report.holds, 1);
    // What each mock received is the stream a generator replaying the pushes computes.
    let cmds = replay(&starts, &limits, period.as_secs_f64(), step_time, &pushes);
    assert_eq!(end.records.len(), 4);
    for (i, (name, record)) in end.records.iter().enumerate() {
        let kind = if i % 2 == 0 {
            MockKind::Kortex
        } else {
            MockKind::Can
        };
        kind.check_followed(record, &cmds[i], settle, &limits[i], period.as_secs_f64())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    let _ = std::fs::remove_dir_all(dir);
}

fn quick_stopped(record: &[Value]) -> bool {
    let can = record
        .iter()
        .any(|e| e["kind"] == "rpdo" && e["cw"] == u64::from(CW_QUICK_STOP));
    let kortex = record.iter().any(|e| e["event"] == "estop");
    can || kortex
}

#[test]
fn a_fault_on_one_arm_stops_every_arm_and_the_next_call_reports_it() {
    let _one = serial();
    let dir = records_dir("fault");
    let arms = arms(&["mock-can", "mock-can?emcy-at-sync=60", "mock-kortex"]);
    let opts = options(&arms, &dir);
    let starts: Vec<[f64; JOINTS]> = arms.iter().map(|a| a.start).collect();
    let mut cell = Cell::start(arms, opts, &connector(&dir)).unwrap_or_else(|e| panic!("{e}"));
    cell.push(1, &slices(&chunk(&starts, 40))).unwrap();
    let deadline = Instant::now() + Duration::from_secs(20);
    let report = loop {
        match cell.status() {
            Ok(_) => {}
            Err(CellError::Fault(r)) => break r,
            Err(e) => panic!("{e}"),
        }
        assert!(Instant::now() < deadline, "no fault");
        std::thread::sleep(Duration::from_millis(5));
    };
    println!("{report}");
    assert_eq!(report.arm, "arm1");
    assert!(
        matches!(
            report.fault,
            Fault::Emcy {
                node: 3,
                code: 0x2310,
                ..
            }
        ),
        "{report}"
    );
    assert_eq!(report.stops.len(), 3);
    // Reported once; afterwards the cell has ended, for a push as for a status.
    assert!(matches!(cell.status(), Err(CellError::Ended(_))));
    let e = cell.push(50, &slices(&chunk(&starts, 2))).unwrap_err();
    assert!(matches!(e, CellError::Ended(_)), "{e}");
    drop(cell);
    for i in 0..3 {
        let record = omcbsa_mock::record::read(&dir.join(format!("arm{i}.jsonl"))).unwrap();
        assert!(quick_stopped(&record), "arm{i} was not quick-stopped");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn dropping_the_cell_stops_every_arm_and_bad_cells_are_refused_before_anything_starts() {
    let _one = serial();
    let dir = records_dir("drop");
    let arms = arms(&["mock-can", "mock-kortex"]);
    let opts = options(&arms, &dir);
    let starts: Vec<[f64; JOINTS]> = arms.iter().map(|a| a.start).collect();
    let mut cell =
        Cell::start(arms.clone(), opts.clone(), &connector(&dir)).unwrap_or_else(|e| panic!("{e}"));
    cell.push(1, &slices(&chunk(&starts, 40))).unwrap();
    wait_for(&mut cell, "motion", |s| s.progress.step >= 2);
    drop(cell);
    for i in 0..2 {
        let record = omcbsa_mock::record::read(&dir.join(format!("arm{i}.jsonl"))).unwrap();
        assert!(quick_stopped(&record), "arm{i} was not quick-stopped");
    }
    let _ = std::fs::remove_dir_all(&dir);
    // A mock faster than it can run, and a name given twice: refused, nothing started.
    let mut fast = opts.clone();
    fast.config.period = Duration::from_millis(2);
    let e = Cell::start(arms.clone(), fast, &connector(&dir))
        .err()
        .unwrap();
    assert!(
        e.to_string()
            .contains("a Python mock runs at a period of 10ms at the fastest"),
        "{e}"
    );
    let mut twice = arms.clone();
    twice[1].name = "arm0".into();
    let e = Cell::start(twice, opts, &connector(&dir)).err().unwrap();
    assert!(e.to_string().contains("\"arm0\" is given twice"), "{e}");
    assert!(!dir.exists(), "a refused cell started a mock");
}
