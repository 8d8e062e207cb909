//! The drives refuse what a real CiA 402 drive refuses, and the executor stops for it: a start-up
//! SDO write changed on purpose (`ArmPort::CanSetupOverride`) is answered by the mock drive's
//! CANopen stack with an SDO abort, and the executor refuses to start, naming the arm, the node,
//! the object and the abort code, with no drive of any arm enabled. (The hand-written mock these
//! drives replaced stored any write to any object of any size, so each of these passed.)

mod common;

use common::*;
use omcbsa_hw::arm::SetupOverride;
use omcbsa_hw::canopen::SdoValue;
use omcbsa_hw::cia402;
use omcbsa_hw::{ArmPort, ExecError, Executor};
use serde_json::Value;
use std::sync::Mutex;

/// Three mocks per test: run the tests of this file one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

/// Runs a 3-arm plan with `change` made to arm "right"'s set-up; returns the error text and
/// every mock's record.
fn refused(tag: &str, change: SetupOverride) -> (String, Vec<(String, Vec<Value>)>) {
    let _one_at_a_time = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let plan = three_arm_plan(4);
    let mocks = spawn_arms(&plan, tag, &[]);
    let ports: Vec<(String, ArmPort)> = (open_buses(&mocks).into_iter())
        .map(|(name, bus)| {
            let port = match name.as_str() {
                "right" => ArmPort::CanSetupOverride(bus, change.clone()),
                _ => ArmPort::Can(bus),
            };
            (name, port)
        })
        .collect();
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let exec = Executor::new(plan, limits, ports, mock_config()).unwrap();
    let e = exec.run(&AcceptAll).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, ExecError::Startup(_)), "{text}");
    let records = mocks
        .into_iter()
        .map(|m| (m.name.clone(), record_of(m)))
        .collect();
    (text, records)
}

/// No drive of any arm was started or enabled, none got a motion command, and the arms that did
/// not fail ended with NMT stop (the refusing arm gets nothing after the refusal).
fn assert_none_enabled(records: &[(String, Vec<Value>)]) {
    for (name, record) in records {
        assert_eq!(kinds(record, "rpdo"), 0, "{name} received a PDO");
        for e in record {
            assert!(
                !(e["kind"] == "nmt" && e["command"] == 1),
                "{name} was started: {e}"
            );
            assert!(
                !(e["kind"] == "sdo" && e["index"] == u64::from(cia402::CONTROLWORD)),
                "{name} received a controlword: {e}"
            );
        }
        let last = record.last().unwrap();
        if name == "right" {
            assert_eq!(last["kind"], "sdo", "{name}: {last}");
            continue;
        }
        assert_eq!(
            (&last["kind"], &last["command"]),
            (&"nmt".into(), &2.into()),
            "{name}: {last}"
        );
    }
}

fn change(node: u8, index: u16, sub: u8, value: SdoValue) -> SetupOverride {
    SetupOverride {
        node,
        index,
        sub,
        value,
    }
}

#[test]
fn target_position_mapped_with_the_wrong_length_is_refused() {
    // 0x607A is an INTEGER32: a 16-bit mapping entry cannot be mapped.
    let entry = cia402::mapping(cia402::TARGET_POSITION, 0, 16);
    let (text, records) = refused("map", change(2, 0x1600, 1, entry));
    assert!(
        text.contains(
            "arm \"right\": node 2 aborted SDO write 0x1600:01 = 0x607a0010 (u32) (abort code \
             0x06040041: object cannot be mapped to the PDO)"
        ),
        "{text}"
    );
    assert_none_enabled(&records);
}

#[test]
fn write_to_the_read_only_statusword_is_refused() {
    let (text, records) = refused("ro", change(4, cia402::STATUSWORD, 0, SdoValue::U16(0x27)));
    assert!(
        text.contains(
            "arm \"right\": node 4 aborted SDO write 0x6041:00 = 39 (u16) (abort code \
             0x06010002: attempt to write a read only object)"
        ),
        "{text}"
    );
    assert_none_enabled(&records);
}

#[test]
fn mode_of_operation_written_with_the_wrong_size_is_refused() {
    // 0x6060 is an INTEGER8: two bytes do not match its length.
    let wrong = SdoValue::U16(u16::from(cia402::MODE_CSP));
    let (text, records) = refused("size", change(7, cia402::MODES_OF_OPERATION, 0, wrong));
    assert!(
        text.contains(
            "arm \"right\": node 7 aborted SDO write 0x6060:00 = 8 (u16) (abort code \
             0x06070010: data type does not match, length of service parameter does not match)"
        ),
        "{text}"
    );
    assert_none_enabled(&records);
}
