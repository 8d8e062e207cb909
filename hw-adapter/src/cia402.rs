//! CiA 402 drive profile in cyclic synchronous position (CSP) mode: objects, controlword and
//! statusword values, PDO mapping, and the position unit.
//!
//! Position unit on the bus: **1 count = 1e-7 rad** (i32), i.e. 0.1 µrad resolution and a range
//! of ±214.7 rad (±34 turns, enough for the Gen3's continuous joints). The resolution keeps the
//! rounding error of a command (≤ 0.05 µrad) far below the 1e-6 rad tolerance of the tests, and
//! its effect on a second difference at 500 Hz (≤ 2 counts / T² = 0.05 rad/s²) inside the
//! margin the executor keeps below the acceleration limits.

use crate::canopen::{rpdo1_cob_id, tpdo1_cob_id, SdoValue};

pub const COUNTS_PER_RAD: f64 = 1e7;

/// The largest joint value (rad, either sign) the bus encodes: `i32::MAX` counts. Problem and
/// solution files are held to the same range (the host's loader and validator use this
/// constant), so that a solution that validates is one the bus can carry.
pub const MAX_POSITION_RAD: f64 = i32::MAX as f64 / COUNTS_PER_RAD;

pub const CONTROLWORD: u16 = 0x6040;
pub const STATUSWORD: u16 = 0x6041;
pub const MODES_OF_OPERATION: u16 = 0x6060;
pub const POSITION_ACTUAL: u16 = 0x6064;
pub const TARGET_POSITION: u16 = 0x607A;
pub const HEARTBEAT_PRODUCER_TIME: u16 = 0x1017;
const RPDO1_COMM: u16 = 0x1400;
const RPDO1_MAPPING: u16 = 0x1600;
const TPDO1_COMM: u16 = 0x1800;
const TPDO1_MAPPING: u16 = 0x1A00;

pub const MODE_CSP: u8 = 8;

/// Controlword commands of the CiA 402 state machine.
pub const CW_SHUTDOWN: u16 = 0x0006;
pub const CW_SWITCH_ON: u16 = 0x0007;
pub const CW_ENABLE_OPERATION: u16 = 0x000F;
/// Disable operation: the drive holds position in "switched on".
pub const CW_DISABLE_OPERATION: u16 = 0x0007;
/// Quick stop (bit 2 cleared with "enable voltage" set).
pub const CW_QUICK_STOP: u16 = 0x0002;

/// Statusword bit 3.
pub const SW_FAULT: u16 = 0x0008;
const SW_STATE_MASK: u16 = 0x006F;
const SW_OPERATION_ENABLED: u16 = 0x0027;

pub fn operation_enabled(statusword: u16) -> bool {
    statusword & SW_STATE_MASK == SW_OPERATION_ENABLED
}

/// `rad` as bus counts; `None` outside ±[`MAX_POSITION_RAD`] (and for NaN).
pub fn rad_to_counts(rad: f64) -> Option<i32> {
    // Within the range the product is at most an ulp beyond `i32::MAX`, which rounds back.
    (rad.abs() <= MAX_POSITION_RAD).then(|| (rad * COUNTS_PER_RAD).round() as i32)
}

pub fn counts_to_rad(counts: i32) -> f64 {
    f64::from(counts) / COUNTS_PER_RAD
}

/// PDO mapping entry: object index, sub-index, length in bits.
fn mapping(index: u16, sub: u8, bits: u8) -> SdoValue {
    SdoValue::U32((u32::from(index) << 16) | (u32::from(sub) << 8) | u32::from(bits))
}

/// PDO communication parameter bit 31: PDO not valid (required while changing the mapping).
const PDO_INVALID: u32 = 0x8000_0000;
/// Transmission type 1: synchronous, every SYNC.
const EVERY_SYNC: u8 = 1;

/// RPDO1 payload: target position (i32) then controlword (u16), little endian.
pub fn rpdo1_payload(target: i32, controlword: u16) -> [u8; 6] {
    let t = target.to_le_bytes();
    let c = controlword.to_le_bytes();
    [t[0], t[1], t[2], t[3], c[0], c[1]]
}

/// TPDO1 payload: position actual value (i32) then statusword (u16).
pub fn parse_tpdo1(data: &[u8]) -> Option<(i32, u16)> {
    match data {
        [a, b, c, d, s0, s1, ..] => Some((
            i32::from_le_bytes([*a, *b, *c, *d]),
            u16::from_le_bytes([*s0, *s1]),
        )),
        _ => None,
    }
}

/// The SDO writes that configure one drive for CSP streaming, in order (CiA 301 §7.5.2.35
/// procedure for changing a PDO mapping: invalidate, clear, map, set count, validate).
pub fn startup_config(node: u8, heartbeat_ms: u16) -> Vec<(u16, u8, SdoValue)> {
    vec![
        (MODES_OF_OPERATION, 0, SdoValue::U8(MODE_CSP)),
        (
            RPDO1_COMM,
            1,
            SdoValue::U32(PDO_INVALID | rpdo1_cob_id(node)),
        ),
        (RPDO1_MAPPING, 0, SdoValue::U8(0)),
        (RPDO1_MAPPING, 1, mapping(TARGET_POSITION, 0, 32)),
        (RPDO1_MAPPING, 2, mapping(CONTROLWORD, 0, 16)),
        (RPDO1_MAPPING, 0, SdoValue::U8(2)),
        (RPDO1_COMM, 2, SdoValue::U8(EVERY_SYNC)),
        (RPDO1_COMM, 1, SdoValue::U32(rpdo1_cob_id(node))),
        (
            TPDO1_COMM,
            1,
            SdoValue::U32(PDO_INVALID | tpdo1_cob_id(node)),
        ),
        (TPDO1_MAPPING, 0, SdoValue::U8(0)),
        (TPDO1_MAPPING, 1, mapping(POSITION_ACTUAL, 0, 32)),
        (TPDO1_MAPPING, 2, mapping(STATUSWORD, 0, 16)),
        (TPDO1_MAPPING, 0, SdoValue::U8(2)),
        (TPDO1_COMM, 2, SdoValue::U8(EVERY_SYNC)),
        (TPDO1_COMM, 1, SdoValue::U32(tpdo1_cob_id(node))),
        (HEARTBEAT_PRODUCER_TIME, 0, SdoValue::U16(heartbeat_ms)),
    ]
}

/// Controlword writes that bring a drive from "switch on disabled" to "operation enabled".
pub const ENABLE_SEQUENCE: [u16; 3] = [CW_SHUTDOWN, CW_SWITCH_ON, CW_ENABLE_OPERATION];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn position_unit_round_trips_and_saturates() {
        assert_eq!(rad_to_counts(1.0), Some(10_000_000));
        assert_eq!(rad_to_counts(-2.5e-7), Some(-3));
        assert_eq!(
            counts_to_rad(rad_to_counts(0.123_456_78).unwrap()),
            0.123_456_8
        );
        assert_eq!(rad_to_counts(300.0), None);
        assert_eq!(rad_to_counts(MAX_POSITION_RAD), Some(i32::MAX));
        assert_eq!(rad_to_counts(-MAX_POSITION_RAD), Some(-i32::MAX));
        assert_eq!(rad_to_counts(MAX_POSITION_RAD * (1.0 + f64::EPSILON)), None);
        assert_eq!(rad_to_counts(f64::NAN), None);
    }

    #[test]
    fn pdo_payloads() {
        let p = rpdo1_payload(-2, CW_ENABLE_OPERATION);
        assert_eq!(p, [0xFE, 0xFF, 0xFF, 0xFF, 0x0F, 0x00]);
        assert_eq!(parse_tpdo1(&[1, 0, 0, 0, 0x27, 0, 0, 0]), Some((1, 0x27)));
        assert_eq!(parse_tpdo1(&[1, 0, 0]), None);
        assert!(operation_enabled(0x0637));
        assert!(!operation_enabled(0x0008));
    }

    #[test]
    fn mapping_entries() {
        assert_eq!(mapping(TARGET_POSITION, 0, 32), SdoValue::U32(0x607A_0020));
    }
}
