//! The watchdog's bound at the default rates (4 ms CAN, 1 ms Kortex) with the command line's
//! default watchdog: three simulated arms (`omcbsa_mock::sim`, in-process, frame level), one
//! injecting a fault; from the fault's first sign on the faulty arm to every arm's stop at
//! most 3 periods, measured on the arms' own clocks; no motion command after a stop; answers
//! late by less than the accounting's m = 2 periods are no fault (unless the loop's own jitter
//! adds the rest). `cargo run --release -p omcbsa-mock --example fault_matrix` measures the same
//! runs many times over.

use omcbsa_hw::{CycleFault, ExecConfig, Fault, STOP_BOUND_PERIODS};
use omcbsa_mock::sim::matrix::{self, Link, MatrixFault, FAULTY_ARM};
use std::sync::Mutex;

/// One run at a time: the bound is about time, and runs side by side share two cores.
static SERIAL: Mutex<()> = Mutex::new(());

fn config(link: Link, log: Option<std::path::PathBuf>) -> ExecConfig {
    ExecConfig {
        period: link.period(),
        log_path: log,
        ..ExecConfig::default()
    }
}

/// Whether `fault` is what `injected` must be detected as.
fn expected(link: Link, injected: MatrixFault, fault: &Fault) -> bool {
    let answer = |f: &Fault| {
        matches!(
            f,
            Fault::Answer {
                fault: CycleFault::Missing { .. } | CycleFault::Late { .. },
                ..
            }
        )
    };
    match (link, injected) {
        (_, MatrixFault::Silence | MatrixFault::Late(_)) => answer(fault),
        (Link::Can, MatrixFault::Emcy) => matches!(
            fault,
            Fault::Emcy {
                node: 3,
                code: 0x2310,
                ..
            }
        ),
        (Link::Can, MatrixFault::FaultBit) => matches!(fault, Fault::DriveState { node: 3, .. }),
        // The stopped node's heartbeat, or its missing TPDO, whichever shows first.
        (Link::Can, MatrixFault::LostSession) => {
            matches!(
                fault,
                Fault::NmtState {
                    node: 3,
                    state: "stopped"
                } | Fault::Answer { node: 3, .. }
            )
        }
        (Link::Kortex, MatrixFault::ErrorFrame) => {
            matches!(fault, Fault::ArmRefused(e) if e.contains("ROBOT_IN_FAULT"))
        }
        (Link::Kortex, MatrixFault::FaultBit) => {
            matches!(fault, Fault::ActuatorFault { joint: 3, .. })
        }
        (Link::Kortex, MatrixFault::LostSession) => {
            matches!(fault, Fault::ArmRefused(e) if e.contains("INVALID_SESSION"))
        }
        _ => false,
    }
}

fn check(link: Link, injected: MatrixFault) {
    let _one = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let log = std::env::temp_dir().join(format!(
        "omcbsa-bound-{link:?}-{}-{}.jsonl",
        injected.name().replace([' ', '/'], "-"),
        std::process::id()
    ));
    let cfg = config(link, Some(log.clone()));
    // A run the machine held up before the fault was injected (the watchdog stopping it, as
    // it must) says nothing about the injected fault: it is run again, at most twice.
    let mut attempts = 0;
    let out = loop {
        let out = matrix::run(link, Some(injected), &matrix::plan(0.5), &cfg)
            .unwrap_or_else(|e| panic!("{e}"));
        attempts += 1;
        if !out.stopped_before_the_fault() || attempts == 3 {
            break out;
        }
        println!("stopped before the fault, run again: {:?}", out.result);
        std::thread::sleep(std::time::Duration::from_millis(200));
    };
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    let _ = std::fs::remove_file(&log);
    assert!(
        out.faulty().first_sign.is_some(),
        "the fault was not injected: {:?}",
        out.result
    );
    let report = match &out.result {
        // Within the accounting's bound: the run may complete.
        Ok(report) if !injected.is_fault(&cfg) => {
            println!("{}: tolerated, {report}", injected.name());
            return;
        }
        Ok(report) => panic!("{}: not stopped: {report}", injected.name()),
        Err(report) if !injected.is_fault(&cfg) => {
            // The loop's own jitter took an answer past the bound: a stop by the watchdog,
            // of every arm, with nothing sent after it; its time is the jitter's, no bound's.
            assert!(
                matches!(report.fault, Fault::Answer { .. }),
                "{}: {report}",
                injected.name()
            );
            for (arm, r) in matrix::ARMS.iter().zip(&out.records) {
                assert!(r.stopped.is_some(), "{arm} was not stopped");
                assert_eq!(r.commands_after_stop, 0, "{arm}: a command after its stop");
            }
            println!(
                "{}: stopped by the loop's jitter: {report}",
                injected.name()
            );
            return;
        }
        Err(report) => report,
    };
    println!("{report}");
    assert_eq!(report.arm, FAULTY_ARM, "{report}");
    assert!(
        expected(link, injected, &report.fault),
        "{}: {}",
        injected.name(),
        report.fault
    );
    for (arm, periods) in matrix::ARMS.iter().zip(out.periods_to_stop()) {
        let periods = periods.unwrap_or_else(|| panic!("{arm} was not stopped"));
        println!("{arm}: stopped {periods:.2} periods after the fault's first sign");
        assert!(
            periods <= f64::from(STOP_BOUND_PERIODS),
            "{arm}: {periods:.2} periods after the first sign"
        );
    }
    for (arm, r) in matrix::ARMS.iter().zip(&out.records) {
        assert_eq!(r.commands_after_stop, 0, "{arm}: a command after its stop");
    }
    // An arm that has stopped answering cannot confirm its stop: it says so, in the report
    // and in the command log; the others confirm theirs.
    if injected == MatrixFault::Silence {
        for s in &report.stops {
            assert!(s.error.is_none(), "{}: {:?}", s.arm, s.error);
            if s.arm == FAULTY_ARM {
                assert!(!s.unanswered.is_empty(), "{report}");
                assert!(text.contains("no answer within"), "{text}");
            } else {
                assert!(s.unanswered.is_empty(), "{}: {:?}", s.arm, s.unanswered);
            }
        }
    }
}

#[test]
fn can_silence() {
    check(Link::Can, MatrixFault::Silence);
}

/// Within m = 2 periods: the run completes, or the loop's own jitter takes an answer past the
/// bound and the watchdog stops every arm.
#[test]
fn can_answers_1_period_late() {
    check(Link::Can, MatrixFault::Late(1));
}

#[test]
fn can_answers_20_periods_late() {
    check(Link::Can, MatrixFault::Late(20));
}

#[test]
fn can_emcy() {
    check(Link::Can, MatrixFault::Emcy);
}

#[test]
fn can_fault_bit() {
    check(Link::Can, MatrixFault::FaultBit);
}

#[test]
fn can_nmt_stop() {
    check(Link::Can, MatrixFault::LostSession);
}

#[test]
fn kortex_silence() {
    check(Link::Kortex, MatrixFault::Silence);
}

/// As for CAN, at 1 ms: a margin of one period for the loop's jitter.
#[test]
fn kortex_answers_1_period_late() {
    check(Link::Kortex, MatrixFault::Late(1));
}

#[test]
fn kortex_answers_20_periods_late() {
    check(Link::Kortex, MatrixFault::Late(20));
}

#[test]
fn kortex_error_frame() {
    check(Link::Kortex, MatrixFault::ErrorFrame);
}

#[test]
fn kortex_fault_bit() {
    check(Link::Kortex, MatrixFault::FaultBit);
}

#[test]
fn kortex_lost_session() {
    check(Link::Kortex, MatrixFault::LostSession);
}

/// The shutdown in order at 1 kHz: after a normal end and after a fault, the simulated Gen3
/// handled no Refresh after SetServoingMode(SINGLE_LEVEL_SERVOING).
#[test]
fn kortex_leaves_low_level_servoing_only_after_the_last_refresh() {
    let _one = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    for fault in [None, Some(MatrixFault::FaultBit)] {
        let cfg = config(Link::Kortex, None);
        let out = matrix::run(Link::Kortex, fault, &matrix::plan(0.5), &cfg).unwrap();
        println!("{:?}", out.result.as_ref().map(|r| r.cycles));
        for r in &out.records {
            let single = (r.sequence.iter())
                .rposition(|s| *s == "single")
                .expect("mode change");
            assert!(
                !r.sequence[single..].contains(&"refresh"),
                "{:?}",
                &r.sequence[single..]
            );
        }
    }
}
