//! CiA 402 drive profile in cyclic synchronous position (CSP) mode: objects, controlword and
//! statusword values, PDO mapping, and the position unit.
//!
//! Position unit on the bus: **1 count = 1e-7 rad** (i32), i.e. 0.1 µrad resolution and a range
//! of ±214.7 rad (±34 turns, enough for the Gen3's continuous joints). The resolution keeps the
//! rounding error of a command (≤ 0.05 µrad) far below the 1e-6 rad tolerance of the tests, and
//! its effect on a second difference at 500 Hz (≤ 2 counts / T² = 0.05 rad/s²) inside the
//! margin the executor keeps below the acceleration limits.
//!
//! ```
//! use omcbsa_hw::cia402::{self, counts_to_rad, rad_to_counts};
//!
//! assert_eq!(rad_to_counts(0.25), Some(2_500_000));
//! assert_eq!(counts_to_rad(-10), -1e-6);
//! assert_eq!(rad_to_counts(300.0), None); // beyond ±214.7 rad: not on the bus
//! // RPDO1: target position, then the controlword, little endian.
//! let payload = cia402::rpdo1_payload(2_500_000, cia402::CW_ENABLE_OPERATION);
//! assert_eq!(payload, [0xA0, 0x25, 0x26, 0x00, 0x0F, 0x00]);
//! assert_eq!(cia402::parse_tpdo1(&payload), Some((2_500_000, 0x000F)));
//! // 2 ms as the interpolation time period 0x60C2: 2 x 10^-3 s.
//! let period = std::time::Duration::from_millis(2);
//! assert_eq!(cia402::interpolation_time_period(period), Some((2, -3)));
//! ```

use crate::canopen::{rpdo1_cob_id, tpdo1_cob_id, SdoValue, SYNC_ID};
use std::time::Duration;

/// Bus counts per radian.
pub const COUNTS_PER_RAD: f64 = 1e7;

/// The largest joint value (rad, either sign) the bus encodes: `i32::MAX` counts. Problem and
/// solution files are held to the same range (the host's loader and validator use this
/// constant), so that a solution that validates is one the bus can carry.
pub const MAX_POSITION_RAD: f64 = i32::MAX as f64 / COUNTS_PER_RAD;

/// Device type (CiA 301): the profile number in the low 16 bits.
pub const DEVICE_TYPE: u16 = 0x1000;
/// COB-ID of the SYNC the drive consumes (CiA 301).
pub const COB_ID_SYNC: u16 = 0x1005;
/// Controlword.
pub const CONTROLWORD: u16 = 0x6040;
/// Statusword.
pub const STATUSWORD: u16 = 0x6041;
/// Mode of operation asked for.
pub const MODES_OF_OPERATION: u16 = 0x6060;
/// Mode of operation in effect.
pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// Position actual value (counts).
pub const POSITION_ACTUAL: u16 = 0x6064;
/// Target position (counts).
pub const TARGET_POSITION: u16 = 0x607A;
/// Software position limit: sub 1 minimum, sub 2 maximum (counts).
pub const SOFTWARE_POSITION_LIMIT: u16 = 0x607D;
/// Following error window (counts, u32; 0xFFFFFFFF switches the check off) and time-out (ms,
/// u16): the drive faults once |target - actual| has stayed beyond the window that long.
pub const FOLLOWING_ERROR_WINDOW: u16 = 0x6065;
/// Following error time-out (ms): see [`FOLLOWING_ERROR_WINDOW`].
pub const FOLLOWING_ERROR_TIME_OUT: u16 = 0x6066;
pub use crate::run::EMCY_FOLLOWING_ERROR;
/// Interpolation time period: sub 1 value, sub 2 index (the period is value * 10^index s).
pub const INTERPOLATION_TIME_PERIOD: u16 = 0x60C2;
/// Heartbeat producer time, ms (CiA 301).
pub const HEARTBEAT_PRODUCER_TIME: u16 = 0x1017;
const RPDO1_COMM: u16 = 0x1400;
/// RPDO1 mapping parameter (CiA 301).
pub const RPDO1_MAPPING: u16 = 0x1600;
const TPDO1_COMM: u16 = 0x1800;
/// TPDO1 mapping parameter (CiA 301).
pub const TPDO1_MAPPING: u16 = 0x1A00;

/// Mode of operation: cyclic synchronous position.
pub const MODE_CSP: u8 = 8;

/// The device profile number in the low 16 bits of the device type (0x1000).
const DEVICE_PROFILE_402: u32 = 402;

/// Whether a device type (0x1000) names a CiA 402 drive.
pub fn is_cia402_device(device_type: u32) -> bool {
    device_type & 0xFFFF == DEVICE_PROFILE_402
}

/// `period` as the interpolation time period (0x60C2): value and index with
/// `period = value * 10^index s`, index from -6 (µs) to 0; `None` if it cannot be written so.
pub fn interpolation_time_period(period: Duration) -> Option<(u8, i8)> {
    let nanos = period.as_nanos();
    (-6i8..=0).rev().find_map(|index| {
        let unit = 10u128.pow((9 + i32::from(index)).unsigned_abs());
        let value = u8::try_from(nanos / unit).ok()?;
        (nanos.is_multiple_of(unit) && value > 0).then_some((value, index))
    })
}

/// Controlword: shutdown (to "ready to switch on").
pub const CW_SHUTDOWN: u16 = 0x0006;
/// Controlword: switch on (to "switched on").
pub const CW_SWITCH_ON: u16 = 0x0007;
/// Controlword: enable operation (the drive follows its targets).
pub const CW_ENABLE_OPERATION: u16 = 0x000F;
/// Disable operation: the drive holds position in "switched on".
pub const CW_DISABLE_OPERATION: u16 = 0x0007;
/// Quick stop (bit 2 cleared with "enable voltage" set).
pub const CW_QUICK_STOP: u16 = 0x0002;

/// Statusword bit 3.
pub const SW_FAULT: u16 = 0x0008;
/// Statusword bit 13 in cyclic synchronous position mode: following error.
pub const SW_FOLLOWING_ERROR: u16 = 0x2000;
const SW_STATE_MASK: u16 = 0x006F;
const SW_OPERATION_ENABLED: u16 = 0x0027;

/// Whether a statusword says "operation enabled".
pub fn operation_enabled(statusword: u16) -> bool {
    statusword & SW_STATE_MASK == SW_OPERATION_ENABLED
}

/// `rad` as bus counts; `None` outside ±[`MAX_POSITION_RAD`] (and for NaN).
pub fn rad_to_counts(rad: f64) -> Option<i32> {
    // Within the range the product is at most an ulp beyond `i32::MAX`, which rounds back.
    (rad.abs() <= MAX_POSITION_RAD).then(|| (rad * COUNTS_PER_RAD).round() as i32)
}

/// Bus counts as rad.
pub fn counts_to_rad(counts: i32) -> f64 {
    f64::from(counts) / COUNTS_PER_RAD
}

/// A following-error window of `rad` as written to 0x6065: counts, rounded up (below
/// 0xFFFFFFFF, which would switch the drive's check off).
pub fn window_counts(rad: f64) -> u32 {
    // Far below u32::MAX counts for any joint speed within the limits.
    (rad * COUNTS_PER_RAD).ceil().min(f64::from(u32::MAX - 1)) as u32
}

/// PDO mapping entry: object index, sub-index, length in bits.
pub fn mapping(index: u16, sub: u8, bits: u8) -> SdoValue {
    SdoValue::U32((u32::from(index) << 16) | (u32::from(sub) << 8) | u32::from(bits))
}

/// PDO communication parameter bit 31: PDO not valid (required while changing the mapping).
const PDO_INVALID: u32 = 0x8000_0000;
/// Transmission type 1: synchronous, every SYNC.
const EVERY_SYNC: u8 = 1;

/// RPDO1's mapping (object, sub-index, bits): target position, then controlword.
const RPDO1_MAP: [(u16, u8, u8); 2] = [(TARGET_POSITION, 0, 32), (CONTROLWORD, 0, 16)];
/// TPDO1's mapping (object, sub-index, bits): position actual value, then statusword.
const TPDO1_MAP: [(u16, u8, u8); 2] = [(POSITION_ACTUAL, 0, 32), (STATUSWORD, 0, 16)];

/// Bytes of a PDO with this mapping.
const fn pdo_bytes(map: &[(u16, u8, u8)]) -> usize {
    let (mut bits, mut i) = (0, 0);
    while i < map.len() {
        bits += map[i].2 as usize;
        i += 1;
    }
    bits.div_ceil(8)
}

/// Bytes of an RPDO1 on the bus (its mapping: target position, controlword): 6.
pub const RPDO1_BYTES: usize = pdo_bytes(&RPDO1_MAP);
/// Bytes of a TPDO1 on the bus (its mapping: position actual value, statusword): 6.
pub const TPDO1_BYTES: usize = pdo_bytes(&TPDO1_MAP);

/// The SDO writes that map `map` into the PDO whose mapping parameter is `mapping_index`
/// (clear, map each entry, set the count).
fn map_pdo(mapping_index: u16, map: &[(u16, u8, u8)]) -> Vec<(u16, u8, SdoValue)> {
    let entries = (1u8..)
        .zip(map)
        .map(|(sub, &(index, s, bits))| (mapping_index, sub, mapping(index, s, bits)));
    std::iter::once((mapping_index, 0, SdoValue::U8(0)))
        .chain(entries)
        .chain(std::iter::once((
            mapping_index,
            0,
            SdoValue::U8(map.len() as u8),
        )))
        .collect()
}

/// RPDO1 payload: target position (i32) then controlword (u16), little endian.
pub fn rpdo1_payload(target: i32, controlword: u16) -> [u8; RPDO1_BYTES] {
    let t = target.to_le_bytes();
    let c = controlword.to_le_bytes();
    [t[0], t[1], t[2], t[3], c[0], c[1]]
}

/// TPDO1 payload (a drive's answer): position actual value (i32) then statusword (u16), little
/// endian: the layout of RPDO1's.
pub fn tpdo1_payload(position: i32, statusword: u16) -> [u8; TPDO1_BYTES] {
    rpdo1_payload(position, statusword)
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
/// procedure for changing a PDO mapping: invalidate, clear, map, set count, validate);
/// `period` is the interpolation time period ([`interpolation_time_period`]), `following` the
/// following error window (counts) and time-out (ms).
pub fn startup_config(
    node: u8,
    heartbeat_ms: u16,
    period: (u8, i8),
    following: (u32, u16),
) -> Vec<(u16, u8, SdoValue)> {
    let mut writes = vec![
        (MODES_OF_OPERATION, 0, SdoValue::U8(MODE_CSP)),
        (COB_ID_SYNC, 0, SdoValue::U32(u32::from(SYNC_ID))),
        (INTERPOLATION_TIME_PERIOD, 1, SdoValue::U8(period.0)),
        (INTERPOLATION_TIME_PERIOD, 2, SdoValue::I8(period.1)),
        (
            RPDO1_COMM,
            1,
            SdoValue::U32(PDO_INVALID | rpdo1_cob_id(node)),
        ),
    ];
    writes.extend(map_pdo(RPDO1_MAPPING, &RPDO1_MAP));
    writes.extend([
        (RPDO1_COMM, 2, SdoValue::U8(EVERY_SYNC)),
        (RPDO1_COMM, 1, SdoValue::U32(rpdo1_cob_id(node))),
        (
            TPDO1_COMM,
            1,
            SdoValue::U32(PDO_INVALID | tpdo1_cob_id(node)),
        ),
    ]);
    writes.extend(map_pdo(TPDO1_MAPPING, &TPDO1_MAP));
    writes.extend([
        (TPDO1_COMM, 2, SdoValue::U8(EVERY_SYNC)),
        (TPDO1_COMM, 1, SdoValue::U32(tpdo1_cob_id(node))),
        (FOLLOWING_ERROR_WINDOW, 0, SdoValue::U32(following.0)),
        (FOLLOWING_ERROR_TIME_OUT, 0, SdoValue::U16(following.1)),
        (HEARTBEAT_PRODUCER_TIME, 0, SdoValue::U16(heartbeat_ms)),
    ]);
    writes
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
    fn interpolation_period_in_powers_of_ten() {
        let p = |us| interpolation_time_period(Duration::from_micros(us));
        assert_eq!(p(2000), Some((2, -3)));
        assert_eq!(p(500), Some((5, -4)));
        assert_eq!(p(250), Some((25, -5)));
        assert_eq!(p(255), Some((255, -6)));
        assert_eq!(p(1_000_000), Some((1, 0)));
        assert_eq!(p(1001), None);
        assert_eq!(interpolation_time_period(Duration::ZERO), None);
        assert!(is_cia402_device(0x0002_0192));
        assert!(!is_cia402_device(0x0000_0191));
    }

    #[test]
    fn following_error_windows_in_counts() {
        let w = crate::WatchSettings::default();
        // 0.5 rad/s x 2 x 14 ms = 14 mrad; a joint at rest gets the smallest window, 1 mrad
        let period = Duration::from_millis(4);
        assert_eq!(
            window_counts(w.following_error_window(0.5, period)),
            140_000
        );
        assert_eq!(window_counts(w.following_error_window(0.0, period)), 10_000);
        assert_eq!(window_counts(1e9), u32::MAX - 1);
    }

    #[test]
    fn mapping_entries() {
        assert_eq!(mapping(TARGET_POSITION, 0, 32), SdoValue::U32(0x607A_0020));
    }
}
