//! The mock drives' EDS (hw-adapter/mock/gen3_joint_drive.eds) loads in the `canopen` library,
//! and every object the executor touches is in it with the access it needs: each start-up write
//! (at the size written) and the controlword writes of the enable sequence writable, each
//! read-back readable, the objects the executor maps into RPDO1 writable and mappable, those of
//! TPDO1 readable and mappable, at the mapped length. Needs the mock arms' venv.

use omcbsa_hw::canopen::SdoValue;
use omcbsa_hw::cia402::{self, CONTROLWORD, RPDO1_MAPPING, TPDO1_MAPPING};
use omcbsa_mock::mock::{script_path, venv_python};
use serde_json::{json, Value};
use std::io::Write;
use std::process::{Command, Stdio};

/// Runs hw-adapter/mock/eds_access.py on `accesses`; returns (success, output).
fn check(accesses: &[Value]) -> (bool, String) {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let dir = script_path().with_file_name("");
    let mut child = Command::new(python)
        .arg(dir.join("eds_access.py"))
        .arg(dir.join("gen3_joint_drive.eds"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let input = serde_json::to_vec(accesses).unwrap();
    child.stdin.take().unwrap().write_all(&input).unwrap();
    let out = child.wait_with_output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

fn access(index: u16, sub: u8, kind: &str, bits: usize) -> Value {
    json!({"index": index, "sub": sub, "access": kind, "bits": bits})
}

/// Every object access of the executor's start-up and streaming.
fn executor_accesses() -> Vec<Value> {
    let mut out = Vec::new();
    for (index, sub, value) in cia402::startup_config(1, 100, (2, -3), (10_000, 10)) {
        out.push(access(index, sub, "write", 8 * value.size()));
        if let (RPDO1_MAPPING | TPDO1_MAPPING, 1.., SdoValue::U32(entry)) = (index, sub, value) {
            let kind = if index == RPDO1_MAPPING {
                "rpdo"
            } else {
                "tpdo"
            };
            let (object, object_sub) = ((entry >> 16) as u16, (entry >> 8) as u8);
            out.push(access(object, object_sub, kind, (entry & 0xFF) as usize));
        }
    }
    out.push(access(CONTROLWORD, 0, "write", 16));
    // The read-back before enabling (hw-adapter/src/arm/setup.rs).
    out.extend([
        access(cia402::DEVICE_TYPE, 0, "read", 32),
        access(cia402::MODES_OF_OPERATION_DISPLAY, 0, "read", 8),
        access(cia402::POSITION_ACTUAL, 0, "read", 32),
        access(cia402::SOFTWARE_POSITION_LIMIT, 1, "read", 32),
        access(cia402::SOFTWARE_POSITION_LIMIT, 2, "read", 32),
    ]);
    out
}

#[test]
fn every_object_the_executor_touches_is_in_the_eds_with_its_access() {
    let accesses = executor_accesses();
    // 2 mapped objects per PDO, besides the writes
    assert_eq!(accesses.iter().filter(|a| a["access"] == "rpdo").count(), 2);
    assert_eq!(accesses.iter().filter(|a| a["access"] == "tpdo").count(), 2);
    let (ok, out) = check(&accesses);
    assert!(ok, "{out}");
    assert!(
        out.ends_with(&format!("checked {} accesses\n", accesses.len())),
        "{out}"
    );
}

#[test]
fn the_check_refuses_what_the_eds_does_not_allow() {
    let (ok, out) = check(&[
        access(cia402::STATUSWORD, 0, "write", 16),
        access(cia402::STATUSWORD, 0, "rpdo", 16),
        access(cia402::TARGET_POSITION, 0, "rpdo", 16),
        access(cia402::DEVICE_TYPE, 0, "tpdo", 32),
        access(0x2000, 0, "read", 8),
        access(cia402::MODES_OF_OPERATION, 0, "write", 16),
        access(cia402::CONTROLWORD, 0, "rpdo", 16),
    ]);
    assert!(!ok, "{out}");
    let expected = [
        "write 0x6041:00: access type ro is not writable",
        "rpdo 0x6041:00: access type ro is not writable",
        "rpdo 0x607A:00: 16 bits accessed, the object's data type has 32",
        "tpdo 0x1000:00: not PDO-mappable",
        "read 0x2000:00: not in the object dictionary",
        "write 0x6060:00: 16 bits accessed, the object's data type has 8",
        "checked 7 accesses",
    ];
    assert_eq!(out.lines().collect::<Vec<_>>(), expected, "{out}");
}
