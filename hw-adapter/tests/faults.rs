//! Fault injection against three Python mock arms: each fault on one arm quick-stops every arm
//! within the stated bound (no arm streams more than one cycle past the cycle in which the fault
//! was detected), the report says what happened, and no arm receives anything after its stop.

mod common;

use common::*;
use omcbsa_hw::cia402::CW_QUICK_STOP;
use omcbsa_hw::executor::STOP_BOUND_PERIODS;
use omcbsa_hw::{ExecError, Executor, Fault, FaultReport, JointLimits};
use serde_json::Value;
use std::sync::Mutex;

/// Three mocks per test: run the tests of this file one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Runs the plan with `flags` injected into arm "right"; returns the fault report and records.
fn run_with_fault(tag: &str, flags: &[&str]) -> (FaultReport, Vec<(String, Vec<Value>)>) {
    let _one_at_a_time = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let plan = three_arm_plan(8);
    let extra = vec![
        vec![],
        flags.iter().map(|s| s.to_string()).collect(),
        vec![],
    ];
    let mocks = spawn_arms(&plan, tag, &extra);
    let exec = Executor::new(
        plan,
        JointLimits::kinova_gen3(),
        open_buses(&mocks),
        mock_config(),
    )
    .unwrap();
    let report = match exec.run(&AcceptAll) {
        Err(ExecError::Fault(r)) => *r,
        other => panic!("expected a fault, got {other:?}"),
    };
    println!("{report}");
    let records = mocks
        .into_iter()
        .map(|m| (m.name.clone(), record_of(m)))
        .collect();
    (report, records)
}

/// Every arm was stopped within the bound, and its mock received nothing after the stop: the
/// last frames it got are the quick stop of each node, the SYNC applying it, and NMT stop.
fn assert_all_stopped(report: &FaultReport, records: &[(String, Vec<Value>)]) {
    assert_eq!(report.arm, "right");
    assert_eq!(report.stops.len(), 3);
    for s in &report.stops {
        assert!(s.error.is_none(), "{}: {:?}", s.arm, s.error);
        // lockstep: at most one more cycle than the faulty arm had streamed
        assert!(
            s.cycles_sent <= report.cycle + 1,
            "{}: {} cycles after detection at {}",
            s.arm,
            s.cycles_sent,
            report.cycle
        );
        // Wall clock: the executor aims at `bound` (3 periods; typically well under 1 ms here),
        // but on a shared 2-core machine running three Python mocks a thread can be preempted
        // for several ms, so only a gross miss (such as waiting for a feedback timeout) fails.
        assert!(
            s.latency <= report.bound * 10,
            "{}: stopped {:?} after detection, bound {:?}",
            s.arm,
            s.latency,
            report.bound
        );
    }
    assert_eq!(report.bound, mock_config().period * STOP_BOUND_PERIODS);
    for (name, record) in records {
        assert_eq!(kinds(record, "violation"), 0, "{name}");
        let n = record.len();
        assert!(n > 9, "{name}: record too short");
        let last = &record[n - 1];
        assert_eq!(last["kind"], "nmt", "{name}: last frame {last}");
        assert_eq!(last["command"], 2, "{name}: last frame is not NMT stop");
        assert_eq!(last["node"], 0);
        assert_eq!(record[n - 2]["kind"], "sync", "{name}");
        let stop: Vec<&Value> = record[n - 9..n - 2].iter().collect();
        for (j, e) in stop.iter().enumerate() {
            assert_eq!(e["kind"], "rpdo", "{name}");
            assert_eq!(e["node"], j as u64 + 1, "{name}");
            assert_eq!(e["cw"], u64::from(CW_QUICK_STOP), "{name}: {e}");
        }
        // and no quick stop anywhere before: the stop is the end of the stream
        assert_eq!(
            record
                .iter()
                .filter(|e| e["kind"] == "rpdo" && e["cw"] == u64::from(CW_QUICK_STOP))
                .count(),
            7,
            "{name}"
        );
    }
}

#[test]
fn arm_that_stops_answering_stops_every_arm() {
    let (report, records) = run_with_fault("silent", &["--stop-after-syncs", "300"]);
    assert!(
        matches!(
            report.fault,
            Fault::FeedbackLost { .. } | Fault::HeartbeatLost { .. }
        ),
        "{}",
        report.fault
    );
    assert_all_stopped(&report, &records);
}

#[test]
fn arm_that_answers_late_stops_every_arm() {
    let (report, records) =
        run_with_fault("late", &["--late-after-syncs", "300", "--late-ms", "600"]);
    assert!(
        matches!(report.fault, Fault::FeedbackLost { .. }),
        "{}",
        report.fault
    );
    assert_all_stopped(&report, &records);
}

#[test]
fn emcy_stops_every_arm() {
    let (report, records) = run_with_fault("emcy", &["--emcy-at-sync", "300"]);
    assert_eq!(
        report.fault,
        Fault::Emcy {
            node: 3,
            code: 0x2310,
            register: 1
        },
        "{}",
        report.fault
    );
    assert_all_stopped(&report, &records);
}

#[test]
fn lagging_arm_stops_every_arm() {
    let (report, records) = run_with_fault("lag", &["--lag-after-syncs", "300"]);
    assert!(
        matches!(report.fault, Fault::FollowingError { .. }),
        "{}",
        report.fault
    );
    assert_all_stopped(&report, &records);
}
