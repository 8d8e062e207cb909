//! The CAN bus's wire: how many bits a classic frame takes and how long at a bitrate, how much
//! of a bus the arms on it load at a control period, and the check the executor makes with
//! it before any arm is set up ([`check`]).
//!
//! A classic CAN 2.0A data frame (11-bit identifier) with n data bytes is, on the wire:
//! start of frame 1, identifier 11, RTR 1, IDE 1, r0 1, DLC 4, data 8n and CRC 15 bits, the
//! 34 + 8n bits bit stuffing applies to (after five equal bits the sender inserts one of the
//! other value); then CRC delimiter 1, ACK slot 1, ACK delimiter 1, end of frame 7, and the
//! interframe space of 3 before the next frame may start: 13 bits never stuffed.
//!
//! - [`worst_case_bits`]: at most one stuff bit per four bits after the first (the first
//!   stuff bit after five equal bits, each later one after four more, as a stuff bit starts
//!   the next run): ⌊(34 + 8n − 1) / 4⌋, so 55 + 10n bits in all (SYNC 55, a heartbeat 65,
//!   a 6-byte PDO 115, 8 bytes 135). The load check counts these: a bound whatever the data.
//! - [`frame_bits`]: the stuff bits this frame's own bits (with its CRC) take. Typical frames
//!   stuff far less than the worst case: a 6-byte PDO of random data takes 98 bits on
//!   average (95 unstuffed, 115 at worst); a cycle of one arm (below) 1 452 bits on average
//!   with positions spread over ±3 rad, 1 514 holding at 0 rad (zeros stuff more), against
//!   1 665 counted: the worst case overstates a cycle by 10-15 %, the margin the check keeps
//!   whatever the data (`the_frames_of_a_cycle_stuffed_as_sent`). The in-process bus
//!   (`omcbsa_mock::transport::MockTransport`) delivers each frame after its own bits.
//!
//! The load of one arm of seven CiA 402 drives, per control cycle ([`ArmTraffic::cia402`],
//! from the frames the code sends and the drives answer): a SYNC (0 bytes, 55 bits), an RPDO1
//! per joint (6 bytes: target position, controlword; 115 bits), a TPDO1 per joint (6 bytes:
//! position actual, statusword; 115 bits): 15 frames, 1 665 bits; and every heartbeat
//! producer time (100 ms) a heartbeat per node (1 byte, 65 bits): 4.55 kbit/s. At 1 Mbit/s
//! and a 2 ms period that is 83.7 % of the bus, over [`MAX_LOAD`]; at 4 ms 42.1 %.
//! SDO, NMT and EMCY frames are not counted: set-up runs before streaming, a stop's frames
//! replace a cycle's, and an EMCY ends the run.
//!
//! ```
//! use omcbsa_hw::bus::{self, ArmTraffic};
//! use std::time::Duration;
//!
//! assert_eq!(bus::worst_case_bits(8), 135);
//! let arm = ArmTraffic::cia402(Duration::from_millis(100));
//! assert_eq!((arm.frames_per_cycle, arm.bits_per_cycle), (15, 1665));
//! let share = |ms| arm.bits_per_second(Duration::from_millis(ms)) / 1e6;
//! assert!(share(2) > bus::MAX_LOAD && share(4) < bus::MAX_LOAD); // one arm at 1 Mbit/s
//! ```

use crate::arm::cycle_frames;
use crate::canopen;
use crate::cia402;
use crate::frame::CanFrame;
use crate::run::{BusOverload, ExecConfig, JOINTS};
use crate::transport::Transport;
use std::time::Duration;

/// A bus's bitrate unless known otherwise (the in-process bus's default, SocketCAN's as
/// counted): 1 Mbit/s, classic CAN's (and CiA 301's) fastest.
pub const DEFAULT_BITRATE: u32 = 1_000_000;

/// The bitrates CiA 301 defines, bit/s, slowest first: the ways out a refusal looks through.
pub const BITRATES: [u32; 8] = [
    10_000, 20_000, 50_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// The share of a bus's bit time the arms' cyclic traffic may take: 70 %, counted with
/// worst-case stuffing. The rest is room for what is not counted per cycle (SDO, NMT, EMCY,
/// error frames and the retransmissions after them) and for the cycle's timing: CAN serves
/// frames by priority, so near a full bus the lowest-priority frames of a cycle (the last
/// nodes' TPDOs) wait for everything else and their latency has no useful bound; 30 % of the
/// bus left idle keeps every cycle's frames well within their period. 70 % is the usual design
/// limit for CANopen networks.
pub const MAX_LOAD: f64 = 0.70;

/// The control periods the documentation's table and the default periods choose from.
pub const PERIODS: [Duration; 5] = [
    Duration::from_millis(1),
    Duration::from_millis(2),
    Duration::from_millis(4),
    Duration::from_millis(5),
    Duration::from_millis(10),
];

/// The control period a CAN arm on a 1 Mbit/s bus runs at by default: 4 ms, the shortest of
/// [`PERIODS`] at which one arm fits under [`MAX_LOAD`] (42.1 %; at 2 ms 83.7 %):
/// [`one_arm_period`] of [`DEFAULT_BITRATE`].
pub const CAN_PERIOD: Duration = Duration::from_millis(4);

/// The shortest of [`PERIODS`] at which one arm with the default heartbeat fits alone on a
/// bus of `bitrate` under [`MAX_LOAD`] (the longest, 10 ms, if none does): an arm's default
/// period on such a bus (1 Mbit/s: 4 ms; SLCAN's 500 kbit/s: 5 ms).
pub fn one_arm_period(bitrate: u32) -> Duration {
    let heartbeat = crate::WatchSettings::default().heartbeat_ms;
    let arm = ArmTraffic::cia402(Duration::from_millis(heartbeat.into()));
    (PERIODS.into_iter())
        .find(|&p| arm.arms_that_fit(bitrate, p, MAX_LOAD) >= 1)
        .unwrap_or(PERIODS[PERIODS.len() - 1])
}

/// Bits a classic base frame with `len` data bytes puts under bit stuffing: start of frame,
/// identifier, RTR, IDE, r0, DLC, data, CRC.
const fn stuffed_field_bits(len: usize) -> u32 {
    34 + 8 * len as u32
}

/// Bits of a frame never stuffed: CRC delimiter, ACK slot and delimiter, end of frame, and the
/// interframe space before the next frame.
const UNSTUFFED_BITS: u32 = 13;

/// Bits a classic base frame with `len` data bytes takes on the wire at most (worst-case bit
/// stuffing, the interframe space included): 55 + 10 `len`.
pub const fn worst_case_bits(len: usize) -> u32 {
    let stuffed = stuffed_field_bits(len);
    stuffed + (stuffed - 1) / 4 + UNSTUFFED_BITS
}

/// Bits `frame` takes on the wire: its fields, its CRC-15, the stuff bits these take, the
/// unstuffed tail and the interframe space (at most [`worst_case_bits`]). Costs a loop over
/// its at most 98 stuffed bits, twice, and one small allocation.
pub fn frame_bits(frame: &CanFrame) -> u32 {
    let data = frame.data();
    let mut bits: Vec<bool> = Vec::with_capacity(stuffed_field_bits(data.len()) as usize);
    let push = |bits: &mut Vec<bool>, value: u32, n: u32| {
        (0..n).rev().for_each(|i| bits.push(value >> i & 1 == 1))
    };
    push(&mut bits, 0, 1); // start of frame
    push(&mut bits, u32::from(frame.id()), 11);
    push(&mut bits, 0, 3); // RTR (data frame), IDE (base format), r0
    push(&mut bits, data.len() as u32, 4);
    data.iter().for_each(|&b| push(&mut bits, u32::from(b), 8));
    // CRC-15 (x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1) over the bits so far.
    let crc = bits.iter().fold(0u32, |crc, &bit| {
        let feedback = bit ^ (crc >> 14 & 1 == 1);
        let shifted = (crc << 1) & 0x7FFF;
        if feedback {
            shifted ^ 0x4599
        } else {
            shifted
        }
    });
    push(&mut bits, crc, 15);
    let (mut stuff, mut run, mut last) = (0, 0, None);
    for &bit in &bits {
        if Some(bit) == last {
            run += 1;
        } else {
            (run, last) = (1, Some(bit));
        }
        if run == 5 {
            // The stuff bit, of the other value, starts the next run.
            stuff += 1;
            (run, last) = (1, Some(!bit));
        }
    }
    bits.len() as u32 + stuff + UNSTUFFED_BITS
}

/// How long `bits` take at `bitrate` bit/s (rounded up to the nanosecond).
pub fn wire_time(bits: u32, bitrate: u32) -> Duration {
    Duration::from_nanos((u64::from(bits) * 1_000_000_000).div_ceil(u64::from(bitrate)))
}

/// What one arm puts on its bus.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ArmTraffic {
    /// Frames each control cycle.
    pub frames_per_cycle: usize,
    /// Their bits, worst-case stuffing.
    pub bits_per_cycle: u32,
    /// Bits of the frames sent once every `heartbeat_period` (worst-case stuffing).
    pub heartbeat_bits: u32,
    /// The heartbeat producer time.
    pub heartbeat_period: Duration,
}

impl ArmTraffic {
    /// An arm of [`JOINTS`] CiA 402 drives as the executor streams to it: each cycle its
    /// frames ([`cycle_frames`]: an RPDO1 per joint, then SYNC) and every drive's TPDO1 answer
    /// ([`cia402::TPDO1_BYTES`]); a heartbeat per drive every `heartbeat` (the producer time
    /// written to 0x1017, [`crate::WatchSettings::heartbeat_ms`]).
    pub fn cia402(heartbeat: Duration) -> Self {
        let sent = cycle_frames(&[0; JOINTS], cia402::CW_ENABLE_OPERATION);
        let answers = (1..=JOINTS as u8)
            .map(|node| canopen::tpdo1(node, &cia402::tpdo1_payload(0, 0)))
            .collect::<Vec<_>>();
        let cycle = sent.iter().map(|(f, _)| *f).chain(answers);
        let heartbeats =
            (1..=JOINTS as u8).map(|node| canopen::heartbeat(node, canopen::NMT_STATE_OPERATIONAL));
        let bits = |f: CanFrame| worst_case_bits(f.data().len());
        Self {
            frames_per_cycle: cycle.clone().count(),
            bits_per_cycle: cycle.map(bits).sum(),
            heartbeat_bits: heartbeats.map(bits).sum(),
            heartbeat_period: heartbeat,
        }
    }

    /// The arm's traffic at control period `period`, bit/s.
    pub fn bits_per_second(&self, period: Duration) -> f64 {
        f64::from(self.bits_per_cycle) / period.as_secs_f64() + self.heartbeat_bits_per_second()
    }

    /// Its heartbeats' part of that, bit/s (none with no producer time).
    fn heartbeat_bits_per_second(&self) -> f64 {
        if self.heartbeat_period.is_zero() {
            0.0
        } else {
            f64::from(self.heartbeat_bits) / self.heartbeat_period.as_secs_f64()
        }
    }

    /// How many such arms fit on a bus of `bitrate` at `period` under `max_share`.
    pub fn arms_that_fit(&self, bitrate: u32, period: Duration, max_share: f64) -> usize {
        (max_share * f64::from(bitrate) / self.bits_per_second(period)).floor() as usize
    }
}

/// The load of one bus: the arms on it and what each puts on it.
#[derive(Clone, Debug, PartialEq)]
pub struct BusLoad {
    /// The bus, as its transport names it.
    pub bus: String,
    /// The arms on it.
    pub arms: Vec<String>,
    /// Its bitrate, bit/s.
    pub bitrate: u32,
    /// The control period.
    pub period: Duration,
    /// What each arm puts on it.
    pub traffic: ArmTraffic,
}

impl BusLoad {
    /// The arms' traffic, bit/s.
    pub fn bits_per_second(&self) -> f64 {
        self.arms.len() as f64 * self.traffic.bits_per_second(self.period)
    }

    /// The share of the bus's bit time it takes (1.0 = all of it).
    pub fn share(&self) -> f64 {
        self.bits_per_second() / f64::from(self.bitrate)
    }

    /// `Ok` if the load is at most `max_share`; else the refusal, with the shortest period
    /// (whole ms) and the lowest CiA 301 bitrate at which these arms would fit, and what one
    /// arm alone would load.
    pub fn check(&self, max_share: f64) -> Result<(), BusOverload> {
        if self.share() <= max_share {
            return Ok(());
        }
        let (n, t) = (self.arms.len() as f64, &self.traffic);
        let heartbeats = t.heartbeat_bits_per_second() * n;
        let room = max_share * f64::from(self.bitrate) - heartbeats;
        let fitting_period = (room > 0.0).then(|| {
            let seconds = n * f64::from(t.bits_per_cycle) / room;
            Duration::from_millis((seconds * 1e3).ceil() as u64)
        });
        let one_arm_share = t.bits_per_second(self.period) / f64::from(self.bitrate);
        let fitting_bitrate =
            (BITRATES.into_iter()).find(|&b| self.bits_per_second() <= max_share * f64::from(b));
        Err(BusOverload {
            bus: self.bus.clone(),
            arms: self.arms.clone(),
            bitrate: self.bitrate,
            period: self.period,
            bits_per_second: self.bits_per_second(),
            max_share,
            fitting_period,
            one_arm_share,
            fitting_bitrate,
        })
    }
}

/// The loads of the CAN buses at `config`'s period, from each CAN arm's name and transport:
/// arms whose transports name the same bus share it, in the order of their first arm.
///
/// Arms on one bus would today also share node ids 1 to 7 (nothing in an [`crate::port::ArmUrl`]
/// moves an arm's nodes), so only a load within [`MAX_LOAD`] makes such a configuration
/// possible, not sufficient.
pub fn loads<'a>(
    arms: impl IntoIterator<Item = (&'a str, &'a dyn Transport)>,
    config: &ExecConfig,
) -> Vec<BusLoad> {
    let traffic = ArmTraffic::cia402(Duration::from_millis(config.watch.heartbeat_ms.into()));
    let mut loads: Vec<BusLoad> = Vec::new();
    for (arm, t) in arms {
        match loads.iter_mut().find(|l| l.bus == t.name()) {
            Some(load) => load.arms.push(arm.to_string()),
            None => loads.push(BusLoad {
                bus: t.name().to_string(),
                arms: vec![arm.to_string()],
                bitrate: t.bitrate(),
                period: config.period,
                traffic,
            }),
        }
    }
    loads
}

/// Refuses a run whose CAN buses [`loads`] would carry more than [`MAX_LOAD`]: the first such
/// bus, with the numbers and the ways out.
pub fn check<'a>(
    arms: impl IntoIterator<Item = (&'a str, &'a dyn Transport)>,
    config: &ExecConfig,
) -> Result<(), Box<BusOverload>> {
    (loads(arms, config).iter()).try_for_each(|l| l.check(MAX_LOAD).map_err(Box::new))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn worst_case_bits_of_each_length() {
        // 34 + 8n stuffed bits, up to (33 + 8n) / 4 stuff bits, 13 more: 55 + 10n.
        let hand = [55, 65, 75, 85, 95, 105, 115, 125, 135];
        for (len, bits) in hand.into_iter().enumerate() {
            assert_eq!(worst_case_bits(len), bits, "{len} bytes");
        }
    }

    #[test]
    fn frame_bits_by_hand_and_within_the_worst_case() {
        // NMT "000#" with no data: 34 zeros (their CRC is 0), a stuff bit after every five:
        // 6, then 13 unstuffed.
        let zeros = CanFrame::new(0x000, &[]).unwrap();
        assert_eq!(frame_bits(&zeros), 34 + 6 + 13);
        for id in [0x080, 0x201, 0x187, 0x705, 0x7FF] {
            for data in [
                &[][..],
                &[0x05],
                &[0xA0, 0x25, 0x26, 0, 0x0F, 0],
                &[0xFF; 8],
                &[0; 8],
            ] {
                let f = CanFrame::new(id, data).unwrap();
                assert!(frame_bits(&f) <= worst_case_bits(data.len()), "{f}");
                assert!(frame_bits(&f) >= stuffed_field_bits(data.len()) + UNSTUFFED_BITS);
            }
        }
        // 1 Mbit/s: 1 µs a bit.
        assert_eq!(wire_time(115, DEFAULT_BITRATE), Duration::from_micros(115));
        assert_eq!(wire_time(3, 3_000_000), Duration::from_nanos(1000));
    }

    #[test]
    fn the_frames_of_a_cycle_stuffed_as_sent() {
        // One arm holding at 0 rad: what the module's documentation quotes.
        let sent = cycle_frames(&[0; JOINTS], cia402::CW_ENABLE_OPERATION);
        let answers =
            (1..=JOINTS as u8).map(|n| canopen::tpdo1(n, &cia402::tpdo1_payload(0, 0x0237)));
        let exact: u32 = (sent.iter().map(|(f, _)| *f).chain(answers))
            .map(|f| frame_bits(&f))
            .sum();
        assert_eq!(exact, 1514);
    }

    #[test]
    fn one_arm_at_the_default_periods() {
        let arm = ArmTraffic::cia402(Duration::from_millis(100));
        assert_eq!(arm.frames_per_cycle, 1 + 2 * JOINTS);
        assert_eq!(arm.bits_per_cycle, 55 + 2 * JOINTS as u32 * 115);
        assert_eq!(arm.heartbeat_bits, JOINTS as u32 * 65);
        let share = |ms: u64| arm.bits_per_second(Duration::from_millis(ms)) / 1e6;
        assert!((share(2) - 0.837).abs() < 1e-3, "{}", share(2));
        assert!((share(4) - 0.421).abs() < 1e-3, "{}", share(4));
        assert!(share(CAN_PERIOD.as_millis() as u64) <= MAX_LOAD);
        assert_eq!(arm.arms_that_fit(DEFAULT_BITRATE, CAN_PERIOD, MAX_LOAD), 1);
        assert_eq!(
            arm.arms_that_fit(DEFAULT_BITRATE, Duration::from_millis(10), MAX_LOAD),
            4
        );
        assert_eq!(one_arm_period(DEFAULT_BITRATE), CAN_PERIOD);
        assert_eq!(one_arm_period(500_000), Duration::from_millis(5));
    }

    #[test]
    fn an_overloaded_bus_is_refused_with_its_ways_out() {
        let load = BusLoad {
            bus: "socketcan:can0".into(),
            arms: vec!["left".into(), "right".into(), "middle".into()],
            bitrate: DEFAULT_BITRATE,
            period: Duration::from_millis(2),
            traffic: ArmTraffic::cia402(Duration::from_millis(100)),
        };
        let e = load.check(MAX_LOAD).unwrap_err();
        // 3 x 1665 bits in 0.7 x 1e6 - 3 x 4550 bit/s of room: 7.28 ms, 8 ms in whole ms.
        assert_eq!(e.fitting_period, Some(Duration::from_millis(8)));
        assert_eq!(e.fitting_bitrate, None);
        assert_eq!(
            e.to_string(),
            "CAN bus socketcan:can0 (arms left, right, middle) would be loaded 251.1 % (2511 \
             kbit/s of 1000 kbit/s) at a 2 ms control period, over the 70 % a bus may carry \
             (worst-case bit stuffing); ways out: a control period of 8 ms or longer fits; or \
             one bus per arm (one arm alone loads 83.7 %: over too); no bitrate up to CAN's 1 \
             Mbit/s fits at this period"
        );
        let fits = BusLoad {
            period: Duration::from_millis(8),
            ..load.clone()
        };
        assert_eq!(fits.check(MAX_LOAD), Ok(()));
        let slow = BusLoad {
            arms: vec!["left".into()],
            bitrate: 500_000,
            period: CAN_PERIOD,
            ..load
        };
        let e = slow.check(MAX_LOAD).unwrap_err();
        assert_eq!(e.fitting_bitrate, Some(800_000));
        assert_eq!(e.fitting_period, Some(Duration::from_millis(5)));
    }
}
