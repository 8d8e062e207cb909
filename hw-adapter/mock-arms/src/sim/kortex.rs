//! A simulated Gen3 on Kortex, served on loopback TCP and UDP ports by two threads of this
//! process: sessions, ClearFaults, SetServoingMode, ApplyEmergencyStop, RefreshFeedback and
//! Refresh, with error frames where a real arm refuses (no session, a Refresh outside low-level
//! servoing or after an emergency stop). Each actuator follows its command with a first-order
//! lag in time ([`KortexSimOptions::tau`]).
//!
//! ```
//! use omcbsa_mock::sim::kortex::{KortexSim, KortexSimOptions};
//! use omcbsa_hw::JOINTS;
//!
//! let (sim, connection) = KortexSim::spawn(KortexSimOptions::at([0.0; JOINTS]))?;
//! assert_eq!(connection.spec.host, "127.0.0.1");
//! // `connection` is an ArmPort for the executor; here it is dropped unused.
//! drop(connection);
//! assert!(sim.finish().commands.is_empty());
//! # Ok::<(), String>(())
//! ```

use super::{Answers, Joints, SimRecord};
use omcbsa_hw::cia402::rad_to_counts;
use omcbsa_hw::kortex::arm::{from_wire, wire_degrees};
use omcbsa_hw::kortex::codec::{self, error_frame, Frame, TcpDecoder};
use omcbsa_hw::kortex::header::{uid, FrameType};
use omcbsa_hw::kortex::proto::{base, base_cyclic};
use omcbsa_hw::kortex::{Connection, Credentials, KortexSpec};
use omcbsa_hw::run::{Command, JOINTS};
use prost::Message;
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// The actuator a fault is injected on.
pub const FAULTY_ACTUATOR: usize = 3;
/// How long a thread waits for a frame before looking at its clocks and the stop flag.
const IDLE: Duration = Duration::from_millis(2);
/// Kinova.Api.ErrorCodes / SubErrorCodes the simulator answers with.
const ERROR_PROTOCOL_SERVER: u32 = 1;
const ERROR_DEVICE: u32 = 3;
const INVALID_SESSION: u32 = 12;
const INVALID_PASSWORD: u32 = 15;
const ROBOT_IN_FAULT: u32 = 22;
const ROBOT_IN_EMERGENCY_STOP: u32 = 25;
const METHOD_FAILED: u32 = 1;

/// A fault the simulated Gen3 injects from its `at`-th Refresh in low-level servoing on
/// (counted from 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injected {
    /// The arm answers nothing more, on either link.
    Silence,
    /// Every UDP answer from then on is held back this long.
    Late(Duration),
    /// Actuator 3 reports a fault (fault bank A bit 0) in every feedback.
    FaultBit,
    /// Every Refresh is answered with an error frame (ERROR_DEVICE, ROBOT_IN_FAULT).
    ErrorFrame,
    /// The arm forgets both sessions: every request is answered with INVALID_SESSION.
    LostSession,
}

/// How the simulated Gen3 starts.
#[derive(Clone, Debug)]
pub struct KortexSimOptions {
    /// Joint positions at power-on, rad.
    pub initial: [f64; JOINTS],
    /// Time constant of each actuator's first-order lag behind its command (zero: none).
    pub tau: Duration,
    /// A fault injected at the given Refresh in low-level servoing (counted from 1).
    pub fault: Option<(u64, Injected)>,
}

impl KortexSimOptions {
    /// A Gen3 at `initial` (rad), without lag or fault.
    pub fn at(initial: [f64; JOINTS]) -> Self {
        Self {
            initial,
            tau: Duration::ZERO,
            fault: None,
        }
    }
}

/// The user and password the simulator accepts (any other is refused).
pub fn credentials() -> Credentials {
    Credentials {
        username: "admin".into(),
        password: "sim".into(),
    }
}

/// A simulated Gen3, serving; stopped when dropped.
pub struct KortexSim {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    arm: Arc<Mutex<Arm>>,
}

impl KortexSim {
    /// Starts the arm on free loopback ports; returns it and a connection to it (hand it to
    /// the executor: a [`omcbsa_hw::kortex::Connection`] is an [`omcbsa_hw::ArmPort`]).
    pub fn spawn(opts: KortexSimOptions) -> Result<(Self, Connection), String> {
        let io = |e: std::io::Error| format!("simulated Gen3: {e}");
        let listener = TcpListener::bind("127.0.0.1:0").map_err(io)?;
        let udp = UdpSocket::bind("127.0.0.1:0").map_err(io)?;
        let spec = KortexSpec {
            host: "127.0.0.1".into(),
            tcp_port: listener.local_addr().map_err(io)?.port(),
            udp_port: udp.local_addr().map_err(io)?.port(),
        };
        listener.set_nonblocking(true).map_err(io)?;
        udp.set_read_timeout(Some(IDLE)).map_err(io)?;
        let arm = Arc::new(Mutex::new(Arm::new(&opts)));
        let stop = Arc::new(AtomicBool::new(false));
        let fence = (UdpSocket::bind("127.0.0.1:0"))
            .and_then(|f| f.connect(("127.0.0.1", spec.udp_port)).map(|()| f))
            .map_err(io)?;
        let tcp_thread = {
            let (arm, stop) = (arm.clone(), stop.clone());
            std::thread::spawn(move || serve_tcp(&listener, &fence, &arm, &stop))
        };
        let udp_thread = {
            let (arm, stop) = (arm.clone(), stop.clone());
            std::thread::spawn(move || serve_udp(&udp, &arm, &stop))
        };
        let sim = Self {
            stop,
            threads: vec![tcp_thread, udp_thread],
            arm,
        };
        let connection = Connection::open(&spec, &credentials()).map_err(|e| e.to_string())?;
        Ok((sim, connection))
    }

    /// Stops the arm (after the executor has closed its connection, everything it sent has
    /// been handled) and returns what it saw.
    pub fn finish(mut self) -> SimRecord {
        self.halt();
        std::mem::take(&mut lock(&self.arm).record)
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for KortexSim {
    fn drop(&mut self) {
        self.halt();
    }
}

fn lock(arm: &Mutex<Arm>) -> MutexGuard<'_, Arm> {
    arm.lock().unwrap_or_else(|p| p.into_inner())
}

/// Link indices.
const TCP: usize = 0;
const UDP: usize = 1;

struct Arm {
    joints: Joints,
    fault: Option<(u64, Injected)>,
    mode: i32,
    estopped: bool,
    sessions: [u16; 2],
    next_session: u16,
    /// Refresh commands taken in low-level servoing.
    refreshes: u64,
    /// Silence, or a delay added to every UDP answer.
    answers: Answers,
    refusing: bool,
    faults: [u32; JOINTS],
    last_frame_id: Option<u32>,
    /// The emergency stop's fence has come through the UDP queue: every Refresh from here on
    /// was sent after the stop (see [`FENCE`]).
    fenced: bool,
    record: SimRecord,
}

impl Arm {
    fn new(opts: &KortexSimOptions) -> Self {
        Self {
            joints: Joints::new(opts.initial, opts.tau),
            fault: opts.fault,
            mode: base::ServoingMode::SingleLevelServoing as i32,
            estopped: false,
            sessions: [0; 2],
            next_session: 1,
            refreshes: 0,
            answers: Answers::default(),
            refusing: false,
            faults: [0; JOINTS],
            last_frame_id: None,
            fenced: false,
            record: SimRecord::default(),
        }
    }

    /// The answer to one request frame on `link` (`None`: no answer), and how long to hold it
    /// back; `first_sign` is set to the answer's send time by the caller when `sign` is true.
    fn handle(&mut self, link: usize, f: Frame, now: Instant) -> (Option<Vec<u8>>, bool) {
        let h = f.header;
        if h.kind() != Some(FrameType::Request) {
            return (None, false);
        }
        let sign = self.take(h.function_uid, now);
        if self.answers.silent {
            return (None, false);
        }
        if h.function_uid != uid::CREATE_SESSION
            && (h.session_id == 0 || h.session_id != self.sessions[link])
        {
            let refused = error_frame(
                &h,
                ERROR_PROTOCOL_SERVER,
                INVALID_SESSION,
                "no such session",
            );
            return (Some(refused), sign);
        }
        (self.answer(link, &f), sign)
    }

    /// What the arm records of a request `rpc` taken at `now`, and the fault injected at it
    /// (a Refresh in low-level servoing counts the cycles); whether it is the fault's first
    /// sign.
    fn take(&mut self, rpc: u32, now: Instant) -> bool {
        let low = self.mode == base::ServoingMode::LowLevelServoing as i32;
        let mut sign = false;
        if rpc == uid::REFRESH && low {
            self.refreshes += 1;
            match self
                .fault
                .filter(|&(at, _)| at == self.refreshes)
                .map(|f| f.1)
            {
                Some(Injected::Silence) => self.answers.disturb(None, now, &mut self.record),
                Some(Injected::Late(d)) => self.answers.disturb(Some(d), now, &mut self.record),
                Some(Injected::FaultBit) => {
                    self.faults[FAULTY_ACTUATOR - 1] |= 1;
                    sign = true;
                }
                Some(Injected::ErrorFrame) => {
                    self.refusing = true;
                    sign = true;
                }
                Some(Injected::LostSession) => {
                    self.sessions = [0; 2];
                    sign = true;
                }
                None => {}
            }
        }
        if rpc == uid::REFRESH {
            self.record.sequence.push("refresh");
            if self.fenced {
                self.record.commands_after_stop += 1;
            } else if low && self.refreshes > 1 {
                // Every cycle after the seed, answered or not.
                self.record.cycle_times.push(now);
            }
        }
        // The stop reached the arm, whatever the arm makes of it.
        if rpc == uid::APPLY_EMERGENCY_STOP {
            self.record.stopped.get_or_insert(now);
        }
        sign
    }

    /// The answer to request `f` on `link` in a valid session.
    fn answer(&mut self, link: usize, f: &Frame) -> Option<Vec<u8>> {
        let h = f.header;
        let low = self.mode == base::ServoingMode::LowLevelServoing as i32;
        let refuse = |code, sub, text: &str| Some(error_frame(&h, code, sub, text));
        let ok = |payload: &[u8]| {
            let mut r = h;
            r.frame_type = FrameType::Response as u8;
            Some(codec::encode_frame(r, payload))
        };
        match h.function_uid {
            uid::CREATE_SESSION => {
                let c = credentials();
                let info =
                    omcbsa_hw::kortex::proto::CreateSessionInfo::decode(f.payload.as_slice());
                if !info.is_ok_and(|i| i.username == c.username && i.password == c.password) {
                    return refuse(ERROR_PROTOCOL_SERVER, INVALID_PASSWORD, "wrong credentials");
                }
                let mut r = h;
                r.frame_type = FrameType::Response as u8;
                r.session_id = self.next_session;
                self.sessions[link] = self.next_session;
                self.next_session += 1;
                Some(codec::encode_frame(r, &[]))
            }
            uid::CLOSE_SESSION => {
                self.sessions[link] = 0;
                ok(&[])
            }
            uid::KEEP_ALIVE => ok(&[]),
            uid::CLEAR_FAULTS => {
                self.faults = [0; JOINTS];
                self.estopped = false;
                ok(&[])
            }
            uid::APPLY_EMERGENCY_STOP => {
                self.estopped = true;
                ok(&[])
            }
            uid::SET_SERVOING_MODE => {
                let mode = base::ServoingModeInformation::decode(f.payload.as_slice())
                    .map_or(0, |m| m.servoing_mode);
                self.mode = mode;
                self.last_frame_id = None;
                let low = mode == base::ServoingMode::LowLevelServoing as i32;
                self.record
                    .sequence
                    .push(if low { "low" } else { "single" });
                ok(&[])
            }
            uid::REFRESH_FEEDBACK => ok(&self.feedback(0).encode_to_vec()),
            uid::REFRESH if self.refusing => {
                refuse(ERROR_DEVICE, ROBOT_IN_FAULT, "actuator fault (injected)")
            }
            uid::REFRESH if !low => refuse(
                ERROR_DEVICE,
                METHOD_FAILED,
                "cyclic command outside low-level servoing",
            ),
            uid::REFRESH if self.estopped => refuse(
                ERROR_DEVICE,
                ROBOT_IN_EMERGENCY_STOP,
                "emergency stop applied",
            ),
            uid::REFRESH => match base_cyclic::Command::decode(f.payload.as_slice()) {
                Ok(c) if c.actuators.len() == JOINTS => {
                    self.command(&c);
                    ok(&self.feedback(c.frame_id).encode_to_vec())
                }
                _ => refuse(ERROR_DEVICE, METHOD_FAILED, "not a command for 7 actuators"),
            },
            _ => refuse(ERROR_PROTOCOL_SERVER, 5, "unsupported method"),
        }
    }

    /// A Refresh taken: the actuators head for its positions.
    fn command(&mut self, c: &base_cyclic::Command) {
        let here = self.joints.positions();
        let targets: [f64; JOINTS] =
            std::array::from_fn(|j| from_wire(c.actuators[j].position, here[j]));
        self.joints.command(targets);
        // The seed (the first command) holds where the arm is: no motion command.
        if self.last_frame_id.is_some() && !self.fenced {
            let counts: Command = targets.map(|q| rad_to_counts(q).unwrap_or(0));
            self.record.commands.push(counts);
        }
        self.last_frame_id = Some(c.frame_id);
    }

    fn feedback(&mut self, frame_id: u32) -> base_cyclic::Feedback {
        let here = self.joints.positions();
        base_cyclic::Feedback {
            frame_id,
            actuators: (0..JOINTS)
                .map(|j| base_cyclic::ActuatorFeedback {
                    command_id: frame_id,
                    position: wire_degrees(rad_to_counts(here[j]).unwrap_or(0)),
                    fault_bank_a: self.faults[j],
                    ..Default::default()
                })
                .collect(),
            ..Default::default()
        }
    }
}

/// The datagram the TCP thread sends through the UDP socket's queue once it has handled
/// ApplyEmergencyStop. A Refresh sent before the stop is queued before it, whenever the two
/// threads get to run: the UDP thread counts the Refresh commands after the fence as sent
/// after the stop, not those that merely crossed it on the other link.
const FENCE: &[u8] = b"omcbsa-sim-estop-fence";

fn serve_tcp(listener: &TcpListener, fence: &UdpSocket, arm: &Mutex<Arm>, stop: &AtomicBool) {
    super::realtime();
    let mut stream: Option<TcpStream> = None;
    let mut rx = TcpDecoder::default();
    let mut buf = [0u8; 65536];
    while !stop.load(Ordering::SeqCst) {
        let Some(s) = stream.as_mut() else {
            match listener.accept() {
                Ok((s, _)) => {
                    let _ = s.set_nodelay(true);
                    let _ = s.set_read_timeout(Some(IDLE));
                    stream = Some(s);
                }
                Err(_) => std::thread::sleep(IDLE),
            }
            continue;
        };
        match s.read(&mut buf) {
            Ok(0) => {
                stream = None;
                continue;
            }
            Ok(n) => rx.push(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => continue,
            Err(_) => {
                stream = None;
                continue;
            }
        }
        while let Ok(Some(f)) = rx.next_frame() {
            let now = Instant::now();
            let estop = f.header.function_uid == uid::APPLY_EMERGENCY_STOP;
            let (answer, sign) = lock(arm).handle(TCP, f, now);
            if estop {
                let _ = fence.send(FENCE);
            }
            if let Some(bytes) = answer {
                let _ = s.write_all(&codec::tcp_framed(&bytes));
                if sign {
                    lock(arm).record.first_sign.get_or_insert(Instant::now());
                }
            }
        }
    }
}

fn serve_udp(socket: &UdpSocket, arm: &Mutex<Arm>, stop: &AtomicBool) {
    super::realtime();
    // Answers held back go out from a thread of their own, which sleeps to the microsecond
    // (a socket's read time-out counts in kernel ticks, several milliseconds).
    let (late_tx, late_rx) = std::sync::mpsc::channel::<(Instant, Vec<u8>, SocketAddr)>();
    let sender = socket.try_clone();
    let held = std::thread::spawn(move || {
        super::realtime();
        let Ok(sender) = sender else { return };
        for (due, bytes, peer) in late_rx {
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
            let _ = sender.send_to(&bytes, peer);
        }
    });
    let mut buf = [0u8; 65536];
    while !stop.load(Ordering::SeqCst) {
        let (n, peer) = match socket.recv_from(&mut buf) {
            Ok(r) => r,
            Err(_) => continue,
        };
        if &buf[..n] == FENCE {
            lock(arm).fenced = true;
            continue;
        }
        let Ok(f) = codec::decode_frame(&buf[..n]) else {
            continue;
        };
        let now = Instant::now();
        let mut a = lock(arm);
        let (answer, sign) = a.handle(UDP, f, now);
        let delay = a.answers.delay;
        drop(a);
        let Some(bytes) = answer else { continue };
        if delay.is_zero() {
            let _ = socket.send_to(&bytes, peer);
            if sign {
                lock(arm).record.first_sign.get_or_insert(Instant::now());
            }
        } else {
            let _ = late_tx.send((now + delay, bytes, peer));
        }
    }
    drop(late_tx);
    let _ = held.join();
}

#[cfg(test)]
mod tests {
    use super::*;
    use omcbsa_hw::kortex::channel::Channel;

    #[test]
    fn sessions_servoing_and_refusals_as_a_gen3_answers_them() {
        let (sim, c) = KortexSim::spawn(KortexSimOptions::at([0.5; JOINTS])).unwrap();
        let t = Duration::from_secs(1);
        let (mut tcp, mut udp): (Channel, Channel) = (c.tcp, c.udp);
        // No session yet.
        let e = udp.call(uid::REFRESH_FEEDBACK, &[], t).unwrap_err();
        assert!(e.contains("INVALID_SESSION"), "{e}");
        let e = tcp.call(uid::CREATE_SESSION, &[], t).unwrap_err();
        assert!(e.contains("INVALID_PASSWORD"), "{e}");
        let login = omcbsa_hw::kortex::proto::CreateSessionInfo {
            username: credentials().username,
            password: credentials().password,
            ..Default::default()
        };
        for link in [&mut tcp, &mut udp] {
            let (h, _) = link
                .call(uid::CREATE_SESSION, &login.encode_to_vec(), t)
                .unwrap();
            link.session = h.session_id;
        }
        let (_, p) = udp.call(uid::REFRESH_FEEDBACK, &[], t).unwrap();
        let f = base_cyclic::Feedback::decode(p.as_slice()).unwrap();
        let at = from_wire(f.actuators[4].position, 0.5);
        assert!((at - 0.5).abs() < 1e-6, "{at}");
        // A Refresh outside low-level servoing is refused.
        let refresh = base_cyclic::Command {
            frame_id: 1,
            actuators: vec![Default::default(); JOINTS],
        };
        let e = udp
            .call(uid::REFRESH, &refresh.encode_to_vec(), t)
            .unwrap_err();
        assert!(e.contains("outside low-level servoing"), "{e}");
        drop((tcp, udp));
        let record = sim.finish();
        assert_eq!(record.sequence, vec!["refresh"]);
    }
}
