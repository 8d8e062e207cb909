//! Bad input: a plan that does not validate, a bus that cannot be opened, an arm that never
//! answers at start-up. Each gives a clear error and no motion command reaches any arm.

mod common;

use common::*;
use omcbsa_hw::plan::{Plan, PlanValidator};
use omcbsa_hw::transport;
use omcbsa_hw::ArmPorts;
use omcbsa_hw::{ExecConfig, ExecError, Executor, Transport};
use omcbsa_mock::transport::MockTransport;
use std::sync::Mutex;

static SERIAL: Mutex<()> = Mutex::new(());

struct Reject;
impl PlanValidator for Reject {
    fn validate(&self, _plan: &Plan) -> Result<(), String> {
        Err("arm \"left\" collides with arm \"right\" at step 3".into())
    }
}

#[test]
fn plan_that_does_not_validate_is_refused_before_anything_is_sent() {
    let _one = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let plan = three_arm_plan(5);
    let mocks = spawn_arms(&plan, "refused", &[]);
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let exec = Executor::new(plan, limits, open_buses(&mocks), mock_config()).unwrap();
    let e = exec.run(&Reject).unwrap_err();
    assert!(matches!(e, ExecError::Refused(_)), "{e}");
    assert!(
        e.to_string()
            .contains("does not validate: arm \"left\" collides"),
        "{e}"
    );
    for m in mocks {
        let name = m.name.clone();
        assert!(record_of(m).is_empty(), "{name} received frames");
    }
}

#[test]
fn bus_that_cannot_be_opened_is_a_clear_error() {
    let e = transport::open("slcan:/dev/ttyNOPE0")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("cannot open CAN bus slcan:/dev/ttyNOPE0"),
        "{e}"
    );
    let e = transport::open("can0").err().unwrap().to_string();
    assert!(
        e.contains("expected `slcan:/dev/ttyXXX` or `socketcan:IFACE`"),
        "{e}"
    );
    // a tty with no SLCAN adapter behind it never acknowledges the set-up commands
    let pty = nix::pty::openpty(None, None).unwrap();
    let path = nix::unistd::ttyname(&pty.slave).unwrap();
    let e = transport::open(&format!("slcan:{}", path.display()))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("did not acknowledge"), "{e}");
}

#[test]
fn arm_that_never_answers_at_start_up_gets_nothing_and_stops_the_others() {
    let _one = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let plan = three_arm_plan(5);
    let silent = vec!["--stop-after-syncs".to_string(), "0".to_string()];
    let mocks = spawn_arms(&plan, "mute", &[vec![], silent, vec![]]);
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let exec = Executor::new(plan, limits, open_buses(&mocks), mock_config()).unwrap();
    let e = exec.run(&AcceptAll).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, ExecError::Startup(_)), "{text}");
    assert!(
        text.contains("arm \"right\": node 1 did not answer SDO read 0x1000:00"),
        "{text}"
    );
    assert!(text.contains("no motion command was sent"), "{text}");
    for m in mocks {
        let name = m.name.clone();
        let record = record_of(m);
        assert_eq!(
            kinds(&record, "rpdo"),
            0,
            "{name} received a motion command"
        );
        if name != "right" {
            let last = record.last().unwrap();
            assert_eq!(
                (&last["kind"], &last["command"]),
                (&"nmt".into(), &2.into()),
                "{name}"
            );
        }
    }
}

#[test]
fn in_process_arm_that_never_answers_receives_only_the_first_sdo() {
    let plan = three_arm_plan(3);
    let (buses, devices) = MockTransport::buses(&ARMS);
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let cfg = ExecConfig {
        period: omcbsa_hw::bus::CAN_PERIOD,
        ..ExecConfig::default()
    };
    let exec = Executor::new(plan, limits, buses, cfg).unwrap();
    let e = exec.run(&AcceptAll).unwrap_err().to_string();
    for n in ARMS {
        assert!(
            e.contains(&format!(
                "arm {n:?}: node 1 did not answer SDO read 0x1000:00"
            )),
            "{e}"
        );
    }
    for mut d in devices {
        let frames = d.drain();
        assert_eq!(frames.len(), 1, "{frames:?}");
        assert_eq!(frames[0].id(), 0x601);
    }
}

#[test]
fn dry_run_logs_every_command_and_needs_no_bus() {
    let plan = three_arm_plan(4);
    let log = std::env::temp_dir().join(format!("omcbsa-hw-dry-{}.jsonl", std::process::id()));
    let cfg = ExecConfig {
        dry_run: true,
        log_path: Some(log.clone()),
        ..ExecConfig::default()
    };
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let report = Executor::new(plan, limits, ArmPorts::new(), cfg)
        .unwrap()
        .run(&AcceptAll)
        .unwrap();
    assert!(report.dry_run);
    assert_eq!(report.frames_sent, 3 * report.cycles * 8);
    let text = std::fs::read_to_string(&log).unwrap();
    assert_eq!(text.lines().count(), report.frames_sent);
    let first: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    assert!(
        first["what"]
            .as_str()
            .unwrap()
            .starts_with("RPDO1 node 1 target"),
        "{first}"
    );
    let _ = std::fs::remove_file(log);
}

#[test]
fn buses_must_match_the_plan_arms() {
    let plan = three_arm_plan(3);
    let (host, _dev) = MockTransport::pair("x");
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let e = Executor::new(
        plan,
        limits,
        vec![("left".into(), Box::new(host) as Box<dyn Transport>)],
        ExecConfig::default(),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("no bus given for arm \"right\""), "{e}");
}
