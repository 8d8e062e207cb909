//! The Kortex transport against three Python mock Gen3s (hw-adapter/mock/mock_gen3.py, on
//! loopback ports; run hw-adapter/mock/setup_venv.sh first): the plan as planned, faults on one
//! arm stopping every arm within 3 cycles measured from the mocks' records, and what the mock
//! refuses as a real arm does.

mod common;

use common::{three_arm_plan, AcceptAll};
use omcbsa_hw::interpolate::interpolate;
use omcbsa_hw::kortex::channel::Channel;
use omcbsa_hw::kortex::header::{uid, Header};
use omcbsa_hw::kortex::proto::{self, base, base_cyclic};
use omcbsa_hw::watchdog::CycleFault;
use omcbsa_hw::{ExecConfig, ExecError, Executor, Fault, FaultReport, Plan};
use omcbsa_mock::arms::{MockArms, MockKind};
use omcbsa_mock::mock::{exec_config, venv_python};
use omcbsa_mock::mock_gen3::{self, MockGen3};
use prost::Message;
use serde_json::Value;
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

/// One run of mocks at a time: three Python mocks per run already take much of a 2-core
/// machine, and a starved mock answers late, which the per-cycle accounting rightly stops.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|p| p.into_inner())
}

fn record_path(tag: &str, name: &str) -> PathBuf {
    std::env::temp_dir().join(format!(
        "omcbsa-kortex-{tag}-{name}-{}.jsonl",
        std::process::id()
    ))
}

/// Mock Gen3s for the arms of `plan`, each at its start, mock i with the flags `extra[i]`.
fn spawn(plan: &Plan, tag: &str, extra: &[Vec<String>]) -> MockArms {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let arms: Vec<_> = (plan.arms.iter())
        .map(|a| (a.name.clone(), a.joint_path[0]))
        .collect();
    MockArms::spawn(
        MockKind::Kortex,
        &python,
        exec_config().period,
        &arms,
        |n| record_path(tag, n),
        extra,
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn records(mocks: MockArms) -> Vec<Vec<Value>> {
    let records = mocks.finish().unwrap_or_else(|e| panic!("{e}"));
    records.into_iter().map(|(_, r)| r).collect()
}

#[test]
fn three_gen3s_take_every_command_as_planned_and_no_log_shows_the_password() {
    let _one = serial();
    let plan = three_arm_plan(8);
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let log = record_path("ok", "log");
    let cfg = ExecConfig {
        log_path: Some(log.clone()),
        ..exec_config()
    };
    let mocks = spawn(&plan, "ok", &[]);
    let conns = mocks.ports().unwrap();
    let report = Executor::new(plan.clone(), limits.clone(), conns, cfg.clone())
        .unwrap()
        .run(&AcceptAll)
        .unwrap_or_else(|e| panic!("{e}"));
    println!("{report}");
    let period = cfg.period.as_secs_f64();
    let traj = interpolate(&plan, &limits, period).unwrap();
    for (arm, record) in records(mocks).iter().enumerate() {
        let cmds = &traj.commands[arm];
        let n = mock_gen3::check_followed(record, cmds, cfg.settle_cycles, &limits[arm], period)
            .unwrap_or_else(|e| panic!("{}: {e}", plan.arms[arm].name));
        assert_eq!(n, cmds.len() + cfg.settle_cycles);
        // One session per link, both closed at the end.
        let sessions: Vec<&Value> = record.iter().filter(|e| e["event"] == "session").collect();
        assert_eq!(sessions.len(), 2);
        assert_ne!(sessions[0]["session"], sessions[1]["session"]);
    }
    let text = std::fs::read_to_string(&log).unwrap();
    assert_eq!(text.lines().count(), report.frames_sent);
    assert!(text.contains("Session.CreateSession"));
    assert!(!text.contains(&mock_gen3::credentials().password));
    let _ = std::fs::remove_file(log);
}

/// Runs the 3-arm plan with `flags` on the second arm's mock; returns the fault report and,
/// per arm, how it was stopped, measured from the mocks' records.
fn fault_run(tag: &str, flags: &[&str]) -> (FaultReport, Vec<mock_gen3::Stop>) {
    let _one = serial();
    let plan = three_arm_plan(8);
    let cfg = exec_config();
    let extra = vec![
        vec![],
        flags.iter().map(|s| s.to_string()).collect(),
        vec![],
    ];
    let mocks = spawn(&plan, tag, &extra);
    let conns = mocks.ports().unwrap();
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let err = Executor::new(plan, limits, conns, cfg)
        .unwrap()
        .run(&AcceptAll)
        .expect_err("the run must stop on the fault");
    let ExecError::Fault(report) = err else {
        panic!("not a fault stop: {err}")
    };
    println!("{report}");
    assert_eq!(report.arm, "right", "{report}");
    let records = records(mocks);
    let sign = mock_gen3::first_sign(&records[1])
        .unwrap()
        .expect("the faulty mock records the fault's first sign");
    let stops = (records.iter())
        .map(|r| mock_gen3::stop_after(r, sign).unwrap_or_else(|e| panic!("{e}")))
        .collect();
    (*report, stops)
}

fn assert_stopped_within_3_cycles(stops: &[mock_gen3::Stop]) {
    for (arm, s) in stops.iter().enumerate() {
        println!(
            "arm {arm}: stopped {:.2} ms after the first sign, {} commands in between",
            s.after * 1e3,
            s.cycles
        );
        assert!(s.cycles <= 3, "arm {arm}: {s:?}");
        assert_eq!(s.targets_after_stop, 0, "arm {arm}: {s:?}");
    }
}

#[test]
fn a_mock_that_goes_silent_stops_every_arm_within_3_cycles() {
    let (report, stops) = fault_run("silent", &["--silent-at=100"]);
    let fault = report.fault.clone();
    assert!(
        matches!(
            fault,
            Fault::Answer {
                node: 1,
                fault: CycleFault::Missing { .. }
            }
        ),
        "{fault}"
    );
    assert_stopped_within_3_cycles(&stops);
    // The silent arm confirms none of its stop, and says so; the others confirm all of it.
    for s in &report.stops {
        let unanswered = s.unanswered.join("\n");
        if s.arm == "right" {
            for rpc in [
                "BaseCyclic.Refresh",
                "Base.ApplyEmergencyStop",
                "Base.SetServoingMode",
                "Session.CloseSession",
            ] {
                assert!(unanswered.contains(rpc), "{rpc} missing from {unanswered}");
            }
        } else {
            assert!(unanswered.is_empty(), "{}: {unanswered}", s.arm);
        }
    }
}

#[test]
fn a_mock_that_answers_5_periods_late_stops_every_arm_within_3_cycles() {
    let late = format!("--late-ms={}", 5 * exec_config().period.as_millis());
    let (report, stops) = fault_run("late", &["--late-at=100", &late]);
    let fault = report.fault;
    assert!(
        matches!(
            fault,
            Fault::Answer {
                fault: CycleFault::Missing { .. } | CycleFault::Late { .. },
                ..
            }
        ),
        "{fault}"
    );
    assert_stopped_within_3_cycles(&stops);
}

#[test]
fn an_actuator_fault_stops_every_arm_within_3_cycles() {
    let (report, stops) = fault_run("actuator", &["--fault-at=100"]);
    let fault = report.fault;
    assert_eq!(
        fault,
        Fault::ActuatorFault {
            joint: 3,
            bank_a: 1,
            bank_b: 0
        }
    );
    assert_stopped_within_3_cycles(&stops);
}

#[test]
fn a_session_lost_mid_run_stops_every_arm() {
    let (report, stops) = fault_run("session", &["--drop-session-at=100"]);
    let fault = report.fault;
    let Fault::ArmRefused(why) = &fault else {
        panic!("{fault}")
    };
    assert!(why.contains("INVALID_SESSION (12)"), "{why}");
    assert_stopped_within_3_cycles(&stops);
}

/// A link to a lone mock, at the origin.
fn lone_mock(tag: &str, extra: &[&str]) -> (MockGen3, Channel, Channel) {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let extra: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
    let mock = MockGen3::spawn(
        &python,
        "lone",
        &[0.0; 7],
        Duration::from_millis(1),
        &record_path(tag, "lone"),
        &extra,
    )
    .unwrap();
    let tcp = Channel::tcp(([127, 0, 0, 1], mock.tcp_port).into()).unwrap();
    let udp = Channel::udp(([127, 0, 0, 1], mock.udp_port).into()).unwrap();
    (mock, tcp, udp)
}

const T: Duration = Duration::from_secs(2);

fn session(link: &mut Channel, connection_timeout_ms: u32) {
    let c = mock_gen3::credentials();
    let info = proto::CreateSessionInfo {
        username: c.username,
        password: c.password,
        session_inactivity_timeout: 60000,
        connection_inactivity_timeout: connection_timeout_ms,
    }
    .encode_to_vec();
    let (h, _) = link.call(uid::CREATE_SESSION, &info, T).unwrap();
    link.session = h.session_id;
    assert_ne!(link.session, 0);
}

fn refresh(frame_id: u16, degrees: [f32; 7]) -> Vec<u8> {
    base_cyclic::Command {
        frame_id: frame_id.into(),
        actuators: (degrees.iter())
            .map(|&position| base_cyclic::ActuatorCommand {
                command_id: frame_id.into(),
                position,
                ..Default::default()
            })
            .collect(),
    }
    .encode_to_vec()
}

fn low_level(tcp: &mut Channel) {
    let mode = base::ServoingModeInformation {
        servoing_mode: base::ServoingMode::LowLevelServoing as i32,
    };
    tcp.call(uid::SET_SERVOING_MODE, &mode.encode_to_vec(), T)
        .unwrap();
}

/// The fault banks of the actuators after a RefreshFeedback.
fn fault_banks(udp: &mut Channel) -> Vec<u32> {
    let (_, p) = udp.call(uid::REFRESH_FEEDBACK, &[], T).unwrap();
    let f = base_cyclic::Feedback::decode(p.as_slice()).unwrap();
    f.actuators.iter().map(|a| a.fault_bank_a).collect()
}

#[test]
fn the_mock_refuses_what_a_real_arm_refuses_with_an_error_frame_and_an_actuator_fault() {
    let (mock, mut tcp, mut udp) = lone_mock("refusals", &[]);
    let err = |r: Result<(Header, Vec<u8>), String>| r.unwrap_err();
    // Before a session.
    let e = err(udp.call(uid::REFRESH, &refresh(1, [0.0; 7]), T));
    assert!(e.contains("INVALID_SESSION (12)"), "{e}");
    let e = err(tcp.call(uid::CLEAR_FAULTS, &[], T));
    assert!(e.contains("INVALID_SESSION (12)"), "{e}");
    // A wrong password.
    let info = proto::CreateSessionInfo {
        username: "admin".into(),
        password: "wrong".into(),
        ..Default::default()
    };
    let e = err(tcp.call(uid::CREATE_SESSION, &info.encode_to_vec(), T));
    assert!(e.contains("INVALID_PASSWORD (15)"), "{e}");
    session(&mut tcp, 2000);
    session(&mut udp, 2000);
    // Cyclic commands outside low-level servoing.
    let e = err(udp.call(uid::REFRESH, &refresh(1, [0.0; 7]), T));
    assert!(e.contains("outside low-level servoing"), "{e}");
    assert_eq!(fault_banks(&mut udp), vec![1; 7]);
    tcp.call(uid::CLEAR_FAULTS, &[], T).unwrap();
    assert_eq!(fault_banks(&mut udp), vec![0; 7]);
    low_level(&mut tcp);
    udp.call(uid::REFRESH, &refresh(10, [0.0; 7]), T).unwrap();
    udp.call(uid::REFRESH, &refresh(11, [0.0; 7]), T).unwrap();
    // A stale frame_id.
    let e = err(udp.call(uid::REFRESH, &refresh(11, [0.0; 7]), T));
    assert!(e.contains("stale frame_id 11 after 11"), "{e}");
    assert_eq!(fault_banks(&mut udp), vec![1; 7]);
    tcp.call(uid::CLEAR_FAULTS, &[], T).unwrap();
    // Too fast: 0.1 degree in 1 ms is 100 degrees/s.
    let mut step = [0.0; 7];
    step[4] = 0.1;
    let e = err(udp.call(uid::REFRESH, &refresh(12, step), T));
    assert!(e.contains("actuator 5 too fast"), "{e}");
    assert_eq!(fault_banks(&mut udp), vec![0, 0, 0, 0, 1, 0, 0]);
    tcp.call(uid::CLEAR_FAULTS, &[], T).unwrap();
    // Past joint 2's limit (128.3 degrees), seeded there after re-entering low level.
    low_level(&mut tcp);
    let mut past = [0.0; 7];
    past[1] = 360.0 - 130.0;
    let e = err(udp.call(uid::REFRESH, &refresh(1, past), T));
    assert!(
        e.contains("actuator 2 position 230.0000 past its limit"),
        "{e}"
    );
    assert_eq!(fault_banks(&mut udp), vec![0, 1, 0, 0, 0, 0, 0]);
    drop((tcp, udp));
    let record = mock.finish().unwrap();
    let refused = record.iter().filter(|e| e["event"] == "refused").count();
    assert_eq!(refused, 7, "{record:?}");
}

#[test]
fn the_mock_stops_motion_when_its_connection_inactivity_timeout_passes() {
    let (mock, mut tcp, mut udp) = lone_mock("inactive", &[]);
    session(&mut tcp, 200);
    session(&mut udp, 200);
    low_level(&mut tcp);
    udp.call(uid::REFRESH, &refresh(1, [0.0; 7]), T).unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let e = udp
        .call(uid::REFRESH, &refresh(2, [0.0; 7]), T)
        .unwrap_err();
    assert!(e.contains("ROBOT_IN_FAULT (22): no frame on"), "{e}");
    drop((tcp, udp));
    let record = mock.finish().unwrap();
    assert!(record.iter().any(|e| e["event"] == "inactivity_stop"));
}

/// The order of the leaving frames as the mock handled them: no Refresh after the last
/// SetServoingMode(SINGLE_LEVEL_SERVOING), which came after the last Refresh. Returns the
/// number of Refresh commands handled.
fn assert_no_refresh_after_the_mode_change(run: usize, record: &[Value]) -> usize {
    let single = (record.iter())
        .rposition(|e| e["event"] == "servoing" && e["mode"] == 2)
        .unwrap_or_else(|| panic!("run {run}: no SetServoingMode(SINGLE_LEVEL_SERVOING)"));
    let after: Vec<&Value> = (record[single..].iter())
        .filter(|e| e["event"] == "refresh")
        .collect();
    assert!(
        after.is_empty(),
        "run {run}: Refresh handled after the mode change: {after:?}"
    );
    record.iter().filter(|e| e["event"] == "refresh").count()
}

/// Kortex shutdown in order: 20 runs in a row on a mock Gen3 that handles every UDP request
/// after a random delay of up to 2 periods (a slow network path, so that a mode change sent on
/// TCP right after the last Refresh would overtake it). Even runs end normally, odd runs stop
/// on an actuator fault (ApplyEmergencyStop first); in every run the mock handles no Refresh
/// after the mode change.
#[test]
fn no_refresh_reaches_the_arm_after_the_mode_change_in_20_runs_with_udp_delayed_2_periods() {
    let _one = serial();
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let plan = three_arm_plan(4);
    let one_arm = Plan {
        dt: plan.dt,
        arms: vec![plan.arms[0].clone()],
    };
    let cfg = ExecConfig {
        settle_cycles: 5,
        // The mock is told to answer 2 periods late (the leaving frames' order is what this is
        // about): one more period than that before the accounting calls it a fault.
        watch: omcbsa_hw::WatchSettings {
            missed_cycles: 3,
            ..omcbsa_hw::WatchSettings::default()
        },
        ..exec_config()
    };
    let delay = format!("--udp-delay-ms={}", 2 * cfg.period.as_millis());
    let mut refreshes = 0;
    let mut ended = [0; 2];
    for run in 0..20 {
        let mut flags = vec![delay.clone(), format!("--seed={run}")];
        if run % 2 == 1 {
            flags.push("--fault-at=20".into());
        }
        let arms = vec![(one_arm.arms[0].name.clone(), one_arm.arms[0].joint_path[0])];
        let mocks = MockArms::spawn(
            MockKind::Kortex,
            &python,
            cfg.period,
            &arms,
            |n| record_path(&format!("order{run}"), n),
            &[flags],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let ports = mocks.ports().unwrap();
        let limits = omcbsa_mock::testing::fleet_limits(1);
        let result = Executor::new(one_arm.clone(), limits, ports, cfg.clone())
            .unwrap()
            .run(&AcceptAll);
        // Both ways of leaving, whichever way the run ended: a watchdog stop (the machine
        // holding a mock up) leaves by the quick stop too.
        match (run % 2, &result) {
            (0, Ok(_)) => ended[0] += 1,
            (_, Err(ExecError::Fault(r)))
                if matches!(r.fault, Fault::ActuatorFault { .. } | Fault::Answer { .. }) =>
            {
                assert!(r.stops.iter().all(|s| s.error.is_none()), "run {run}: {r}");
                ended[1] += 1;
            }
            _ => panic!("run {run}: {result:?}"),
        }
        refreshes += assert_no_refresh_after_the_mode_change(run, &records(mocks)[0]);
    }
    println!(
        "20 runs ({} ended normally, {} by a quick stop), {refreshes} Refresh commands, none \
         after the mode change",
        ended[0], ended[1]
    );
}
