//! Seven simulated CiA 402 drives (nodes 1 to 7) on the far end of an in-process CAN bus
//! ([`crate::transport::MockTransport`]), answering from their own thread: SDO reads and
//! writes (with the objects the executor's set-up reads back), NMT, the CiA 402 state machine,
//! heartbeats at the producer time written to 0x1017, and a TPDO1 per node on every SYNC while
//! operational. Each joint follows its target with a first-order lag in time
//! ([`CanSimOptions::tau`]).
//!
//! ```
//! use omcbsa_mock::sim::can::{CanSim, CanSimOptions};
//! use omcbsa_hw::{canopen, CanFrame, Transport, JOINTS};
//! use std::time::Duration;
//!
//! let (sim, mut bus) = CanSim::spawn(CanSimOptions::at([0.1; JOINTS]));
//! // Read node 2's position actual (0x6064) by SDO: 0.1 rad = 1 000 000 counts.
//! bus.send(&canopen::sdo_upload(2, 0x6064, 0), Duration::ZERO)?;
//! let answer = bus.recv(Duration::from_secs(1))?.expect("an answer");
//! assert_eq!(answer.id(), 0x582);
//! assert_eq!(answer.data()[4..], 1_000_000i32.to_le_bytes());
//! drop(bus);
//! assert!(sim.finish().commands.is_empty());
//! # Ok::<(), omcbsa_hw::TransportError>(())
//! ```

use super::{Answers, Joints, SimRecord};
use crate::transport::MockTransport;
use omcbsa_hw::canopen;
use omcbsa_hw::cia402::{self, counts_to_rad, rad_to_counts};
use omcbsa_hw::frame::CanFrame;
use omcbsa_hw::run::{Command, JOINTS};
use omcbsa_hw::transport::Transport;
use std::collections::{BTreeMap, VecDeque};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A fault the simulated drives inject from their `at`-th SYNC on (counted from 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injected {
    /// Every drive answers nothing more: no TPDO, no heartbeat.
    Silence,
    /// Every frame the drives send from then on is held back this long.
    Late(Duration),
    /// Node 3 sends EMCY 0x2310 (over-current) and faults.
    Emcy,
    /// Node 3's statusword reports a fault (no EMCY).
    FaultBit,
    /// Node 3 goes to NMT stopped (announced by its heartbeat at once; no more TPDOs).
    NmtStop,
}

/// The node a drive fault is injected on.
pub const FAULTY_NODE: u8 = 3;
/// EMCY error code of the injected fault (continuous over-current).
pub const EMCY_INJECTED: u16 = 0x2310;

/// CiA 402 states, as the statusword's bits 0-6 report them.
const SWITCH_ON_DISABLED: u16 = 0x0040;
const READY: u16 = 0x0031;
const SWITCHED_ON: u16 = 0x0033;
const OPERATION_ENABLED: u16 = 0x0037;
const QUICK_STOP_ACTIVE: u16 = 0x0017;
const FAULT: u16 = 0x0008;
/// Statusword bit 9: controlled over the bus.
const REMOTE: u16 = 0x0200;
/// CiA 402 device type: profile 402, servo drive.
const DEVICE_TYPE_402: u32 = 0x0002_0192;
/// SDO abort: attempt to write a read only object.
const ABORT_READ_ONLY: u32 = 0x0601_0002;
/// SDO abort: object does not exist in the object dictionary.
const ABORT_NO_OBJECT: u32 = 0x0602_0000;
/// How long the drives' thread waits for a frame before looking at its clocks again.
const IDLE: Duration = Duration::from_millis(5);

/// How the simulated drives start.
#[derive(Clone, Debug)]
pub struct CanSimOptions {
    /// Joint positions at power-on, rad.
    pub initial: [f64; JOINTS],
    /// Time constant of each joint's first-order lag behind its target (zero: none).
    pub tau: Duration,
    /// Software position limits (0x607D) per joint, rad (`None`: the bus's whole range).
    pub limits: Option<[(f64, f64); JOINTS]>,
    /// A fault injected at the given SYNC (counted from 1).
    pub fault: Option<(u64, Injected)>,
}

impl CanSimOptions {
    /// Drives at `initial` (rad), without lag, limits or fault.
    pub fn at(initial: [f64; JOINTS]) -> Self {
        Self {
            initial,
            tau: Duration::ZERO,
            limits: None,
            fault: None,
        }
    }
}

/// The simulated drives of one arm, running; stopped when dropped.
pub struct CanSim {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<SimRecord>>,
}

impl CanSim {
    /// Starts the drives on a new in-process bus (1 Mbit/s, named `mock:simN`, N counting the
    /// buses made); returns them and the bus's host end (hand it to the executor:
    /// `Box<dyn Transport>` is an [`omcbsa_hw::ArmPort`]).
    pub fn spawn(opts: CanSimOptions) -> (Self, Box<dyn Transport>) {
        // Each arm on a bus of its own, named apart (the load check counts arms whose buses
        // have one name as sharing it).
        static BUSES: AtomicUsize = AtomicUsize::new(0);
        let bus = format!("sim{}", BUSES.fetch_add(1, Ordering::Relaxed));
        let (host, device) = MockTransport::pair(&bus);
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            super::realtime();
            Drives::new(device, opts).run(&flag)
        });
        (
            Self {
                stop,
                thread: Some(thread),
            },
            Box::new(host),
        )
    }

    /// Stops the drives once they have handled every frame already sent (after the executor
    /// has closed the bus, that is all of them) and returns what they saw.
    pub fn finish(mut self) -> SimRecord {
        self.stop.store(true, Ordering::SeqCst);
        (self.thread.take())
            .and_then(|t| t.join().ok())
            .unwrap_or_default()
    }
}

impl Drop for CanSim {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// One drive.
#[derive(Clone, Debug)]
struct Node {
    /// Objects written (index, sub) -> value.
    od: BTreeMap<(u16, u8), u32>,
    nmt: u8,
    state: u16,
    /// The last RPDO1 (target, controlword), applied at the next SYNC.
    pending: Option<(i32, u16)>,
    /// When its next heartbeat is due.
    heartbeat: Option<Instant>,
    /// Software position limits, counts.
    limits: (i32, i32),
}

impl Node {
    fn statusword(&self) -> u16 {
        if self.state == FAULT {
            FAULT
        } else {
            self.state | REMOTE
        }
    }

    /// The CiA 402 transition the controlword commands; whether it enabled operation.
    fn controlword(&mut self, cw: u16) -> bool {
        let s = self.state;
        self.state = match cw {
            _ if s == FAULT => {
                if cw & 0x80 != 0 {
                    SWITCH_ON_DISABLED
                } else {
                    FAULT
                }
            }
            _ if cw & 0x02 == 0 => SWITCH_ON_DISABLED,
            _ if cw & 0x04 == 0 => match s {
                OPERATION_ENABLED | QUICK_STOP_ACTIVE => QUICK_STOP_ACTIVE,
                _ => SWITCH_ON_DISABLED,
            },
            _ if cw & 0x0F == 0x06 => match s {
                SWITCH_ON_DISABLED | SWITCHED_ON | OPERATION_ENABLED => READY,
                s => s,
            },
            _ if cw & 0x0F == 0x07 => match s {
                READY | OPERATION_ENABLED => SWITCHED_ON,
                s => s,
            },
            _ if cw & 0x0F == 0x0F => match s {
                SWITCHED_ON | QUICK_STOP_ACTIVE => OPERATION_ENABLED,
                s => s,
            },
            _ => s,
        };
        self.state == OPERATION_ENABLED && s != OPERATION_ENABLED
    }
}

struct Drives {
    bus: MockTransport,
    nodes: [Node; JOINTS],
    joints: Joints,
    fault: Option<(u64, Injected)>,
    syncs: u64,
    answers: Answers,
    /// Frames held back by [`Injected::Late`], with when they are due.
    delayed: VecDeque<(Instant, CanFrame)>,
    record: SimRecord,
}

impl Drives {
    fn new(bus: MockTransport, opts: CanSimOptions) -> Self {
        let counts =
            |rad: f64| rad_to_counts(rad).unwrap_or(if rad < 0.0 { -i32::MAX } else { i32::MAX });
        let node = |j: usize| Node {
            od: BTreeMap::new(),
            nmt: canopen::NMT_STATE_PRE_OPERATIONAL,
            state: SWITCH_ON_DISABLED,
            pending: None,
            heartbeat: None,
            limits: opts
                .limits
                .map_or((-i32::MAX, i32::MAX), |l| (counts(l[j].0), counts(l[j].1))),
        };
        Self {
            bus,
            nodes: std::array::from_fn(node),
            joints: Joints::new(opts.initial, opts.tau),
            fault: opts.fault,
            syncs: 0,
            answers: Answers::default(),
            delayed: VecDeque::new(),
            record: SimRecord::default(),
        }
    }

    fn run(mut self, stop: &AtomicBool) -> SimRecord {
        loop {
            self.send_due();
            let now = Instant::now();
            let next = (self.nodes.iter().filter_map(|n| n.heartbeat))
                .chain(self.delayed.front().map(|d| d.0))
                .fold(now + IDLE, Instant::min);
            // Stopping, the drives still take every frame sent to them, those on the wire too.
            let wait = if stop.load(Ordering::SeqCst) && !self.bus.in_flight() {
                Duration::ZERO
            } else {
                next.saturating_duration_since(now)
            };
            match self.bus.recv(wait) {
                Ok(Some(f)) => self.handle(&f, Instant::now()),
                Ok(None) if wait.is_zero() && stop.load(Ordering::SeqCst) => break,
                Ok(None) => {}
                Err(_) => break,
            }
        }
        self.record
    }

    /// Sends `frame` as the drives' state allows: not at all when silent, later when late.
    fn out(&mut self, frame: CanFrame) -> Instant {
        let now = Instant::now();
        if self.answers.silent {
            return now;
        }
        if !self.answers.delay.is_zero() {
            self.delayed.push_back((now + self.answers.delay, frame));
            return now;
        }
        // A host that has closed the bus hears nothing more: not the drives' concern.
        let _ = self.bus.send(&frame, Duration::ZERO);
        now
    }

    /// Sends the held-back frames and the heartbeats that are due.
    fn send_due(&mut self) {
        let now = Instant::now();
        while self.delayed.front().is_some_and(|d| d.0 <= now) {
            if let Some((_, f)) = self.delayed.pop_front() {
                let _ = self.bus.send(&f, Duration::ZERO);
            }
        }
        for j in 0..JOINTS {
            let n = &self.nodes[j];
            if let Some(due) = n.heartbeat.filter(|&d| d <= now) {
                let ms = n.od.get(&(cia402::HEARTBEAT_PRODUCER_TIME, 0)).copied();
                self.nodes[j].heartbeat = ms.map(|ms| due + Duration::from_millis(ms.into()));
                self.heartbeat(j);
            }
        }
    }

    fn heartbeat(&mut self, j: usize) -> Instant {
        self.out(canopen::heartbeat(node_id(j), self.nodes[j].nmt))
    }

    fn handle(&mut self, f: &CanFrame, now: Instant) {
        let id = f.id();
        let d = f.data();
        match id {
            canopen::NMT_ID if d.len() == 2 => {
                for j in (0..JOINTS).filter(|&j| d[1] == 0 || d[1] == node_id(j)) {
                    self.nmt(j, d[0]);
                }
            }
            canopen::SYNC_ID if d.is_empty() => self.sync(now),
            0x201..=0x207 if d.len() == 6 => {
                let j = usize::from(id - 0x201);
                if self.nodes[j].nmt == canopen::NMT_STATE_OPERATIONAL {
                    self.nodes[j].pending = cia402::parse_tpdo1(d);
                }
            }
            0x601..=0x607 if d.len() == 8 => self.sdo(usize::from(id - 0x601), d),
            _ => {}
        }
    }

    fn nmt(&mut self, j: usize, command: u8) {
        let state = match command {
            0x01 => canopen::NMT_STATE_OPERATIONAL,
            0x02 => canopen::NMT_STATE_STOPPED,
            _ => canopen::NMT_STATE_PRE_OPERATIONAL,
        };
        if self.nodes[j].nmt != state {
            self.nodes[j].nmt = state;
            // A state change is announced at once.
            self.heartbeat(j);
        }
    }

    fn sdo(&mut self, j: usize, d: &[u8]) {
        let (index, sub) = (u16::from_le_bytes([d[1], d[2]]), d[3]);
        let value = u32::from_le_bytes([d[4], d[5], d[6], d[7]]);
        let reply = if d[0] == 0x40 {
            self.read(j, index, sub)
        } else if d[0] & 0xE3 == 0x23 {
            let len = 4 - usize::from((d[0] >> 2) & 3);
            let value = value & (u32::MAX >> (32 - 8 * len));
            self.write(j, index, sub, value)
        } else {
            Err(0x0504_0001)
        };
        let i = index.to_le_bytes();
        let data = match reply {
            Ok(None) => [0x60, i[0], i[1], sub, 0, 0, 0, 0],
            Ok(Some((v, len))) => {
                let b = v.to_le_bytes();
                let cmd = 0x43 | ((4 - len) << 2);
                [cmd, i[0], i[1], sub, b[0], b[1], b[2], b[3]]
            }
            Err(code) => {
                let c = code.to_le_bytes();
                [0x80, i[0], i[1], sub, c[0], c[1], c[2], c[3]]
            }
        };
        if let Some(f) = CanFrame::new(0x580 + node_id(j) as u16, &data) {
            self.out(f);
        }
    }

    /// An object's value and size (bytes), or the SDO abort code.
    fn read(&mut self, j: usize, index: u16, sub: u8) -> Result<Option<(u32, u8)>, u32> {
        let n = &self.nodes[j];
        Ok(Some(match (index, sub) {
            (cia402::DEVICE_TYPE, 0) => (DEVICE_TYPE_402, 4),
            (cia402::STATUSWORD, 0) => (u32::from(n.statusword()), 2),
            (cia402::MODES_OF_OPERATION_DISPLAY, 0) => {
                let mode = n.od.get(&(cia402::MODES_OF_OPERATION, 0)).copied();
                (mode.unwrap_or(0), 1)
            }
            (cia402::POSITION_ACTUAL, 0) => (self.position_counts(j) as u32, 4),
            (cia402::SOFTWARE_POSITION_LIMIT, 1) => (n.limits.0 as u32, 4),
            (cia402::SOFTWARE_POSITION_LIMIT, 2) => (n.limits.1 as u32, 4),
            key => (*n.od.get(&key).ok_or(ABORT_NO_OBJECT)?, 4),
        }))
    }

    fn write(
        &mut self,
        j: usize,
        index: u16,
        sub: u8,
        value: u32,
    ) -> Result<Option<(u32, u8)>, u32> {
        match index {
            cia402::DEVICE_TYPE
            | cia402::STATUSWORD
            | cia402::MODES_OF_OPERATION_DISPLAY
            | cia402::POSITION_ACTUAL => return Err(ABORT_READ_ONLY),
            cia402::CONTROLWORD if self.nodes[j].controlword(value as u16) => self.hold(j),
            cia402::HEARTBEAT_PRODUCER_TIME => {
                self.nodes[j].heartbeat = (value > 0).then(Instant::now);
            }
            _ => {}
        }
        self.nodes[j].od.insert((index, sub), value);
        Ok(None)
    }

    /// Operation just enabled: the drive holds where the joint is.
    fn hold(&mut self, j: usize) {
        let mut q = self.joints.positions();
        q[j] = counts_to_rad(self.position_counts(j));
        self.joints.command(q);
    }

    fn position_counts(&mut self, j: usize) -> i32 {
        rad_to_counts(self.joints.positions()[j]).unwrap_or(0)
    }

    fn sync(&mut self, now: Instant) {
        self.syncs += 1;
        let injected = self.fault.filter(|&(at, _)| at == self.syncs).map(|f| f.1);
        match injected {
            Some(Injected::Silence) => self.answers.disturb(None, now, &mut self.record),
            Some(Injected::Late(d)) => self.answers.disturb(Some(d), now, &mut self.record),
            _ => {}
        }
        let mut targets = self.joints.positions();
        let mut cmd: Command = [0; JOINTS];
        let (mut moved, mut stop) = (0, false);
        for j in 0..JOINTS {
            if self.nodes[j].nmt != canopen::NMT_STATE_OPERATIONAL {
                continue;
            }
            let Some((target, cw)) = self.nodes[j].pending.take() else {
                continue;
            };
            stop |= cw == cia402::CW_QUICK_STOP;
            if self.nodes[j].controlword(cw) {
                self.hold(j);
                targets = self.joints.positions();
            }
            let n = &self.nodes[j];
            if n.state == OPERATION_ENABLED && cw == cia402::CW_ENABLE_OPERATION {
                cmd[j] = target.clamp(n.limits.0, n.limits.1);
                targets[j] = counts_to_rad(cmd[j]);
                moved += 1;
            }
        }
        if stop && self.record.stopped.is_none() {
            self.record.stopped = Some(now);
            // A quick stop halts the joints where they are.
            let here = self.joints.positions();
            self.joints.command(here);
        }
        if moved == JOINTS {
            self.joints.command(targets);
            if self.record.stopped.is_some() {
                self.record.commands_after_stop += 1;
            } else {
                self.record.commands.push(cmd);
                self.record.cycle_times.push(now);
            }
        }
        let j = usize::from(FAULTY_NODE - 1);
        match injected {
            Some(Injected::Emcy) => {
                self.nodes[j].state = FAULT;
                let code = EMCY_INJECTED.to_le_bytes();
                let emcy = CanFrame::new(
                    0x080 + u16::from(FAULTY_NODE),
                    &[code[0], code[1], 1, 0, 0, 0, 0, 0],
                );
                if let Some(f) = emcy {
                    self.record.first_sign = Some(self.out(f));
                }
            }
            Some(Injected::NmtStop) => {
                self.nodes[j].nmt = canopen::NMT_STATE_STOPPED;
                self.record.first_sign = Some(self.heartbeat(j));
            }
            Some(Injected::FaultBit) => self.nodes[j].state = FAULT,
            _ => {}
        }
        let positions = self.joints.positions();
        for (j, q) in positions.iter().enumerate() {
            let n = &self.nodes[j];
            if n.nmt != canopen::NMT_STATE_OPERATIONAL {
                continue;
            }
            let pos = rad_to_counts(*q).unwrap_or(0);
            let payload = cia402::tpdo1_payload(pos, n.statusword());
            let sent = self.out(canopen::tpdo1(node_id(j), &payload));
            if injected == Some(Injected::FaultBit) && j + 1 == usize::from(FAULTY_NODE) {
                self.record.first_sign = Some(sent);
            }
        }
    }
}

/// Node id of joint `j`.
fn node_id(j: usize) -> u8 {
    j as u8 + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use omcbsa_hw::canopen::{Message, SdoReply, SdoValue};

    /// What the executor's SDO client decodes an answer as.
    fn decode_reply(f: &CanFrame) -> Option<SdoReply> {
        match canopen::decode(f) {
            Message::SdoResponse { reply, .. } => Some(reply),
            _ => None,
        }
    }

    fn ask(bus: &mut Box<dyn Transport>, f: CanFrame) -> CanFrame {
        bus.send(&f, Duration::ZERO).unwrap();
        bus.recv(Duration::from_secs(1))
            .unwrap()
            .expect("an answer")
    }

    #[test]
    fn sdo_reads_and_writes_answer_as_a_cia402_drive() {
        let (sim, mut bus) = CanSim::spawn(CanSimOptions::at([0.0; JOINTS]));
        let r = ask(&mut bus, canopen::sdo_upload(1, cia402::DEVICE_TYPE, 0));
        assert!(matches!(
            decode_reply(&r),
            Some(SdoReply::Upload { len: 4, data, .. }) if u32::from_le_bytes(data) == DEVICE_TYPE_402
        ));
        let r = ask(
            &mut bus,
            canopen::sdo_download(4, cia402::MODES_OF_OPERATION, 0, SdoValue::U8(8)),
        );
        assert_eq!(
            decode_reply(&r),
            Some(SdoReply::DownloadAck {
                index: cia402::MODES_OF_OPERATION,
                sub: 0
            })
        );
        let r = ask(
            &mut bus,
            canopen::sdo_upload(4, cia402::MODES_OF_OPERATION_DISPLAY, 0),
        );
        assert!(matches!(
            decode_reply(&r),
            Some(SdoReply::Upload {
                len: 1,
                data: [8, ..],
                ..
            })
        ));
        let r = ask(
            &mut bus,
            canopen::sdo_download(4, cia402::STATUSWORD, 0, SdoValue::U16(0x27)),
        );
        assert!(matches!(
            decode_reply(&r),
            Some(SdoReply::Abort {
                code: ABORT_READ_ONLY,
                ..
            })
        ));
        drop(bus);
        sim.finish();
    }
}
