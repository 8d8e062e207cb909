//! A Kinova Gen3 as the executor's loop drives it ([`ArmLink`]), in the order a real arm expects:
//! 1. start-up, phase 1 ([`ArmLink::configure`]): a session on TCP and one on UDP, ClearFaults,
//!    RefreshFeedback (seven actuators, each within the start tolerance of the plan's start);
//! 2. phase 2 ([`ArmLink::enable`]): SetServoingMode(LOW_LEVEL_SERVOING), then one Refresh that
//!    commands every actuator where it was measured (the seed);
//! 3. one BaseCyclic.Refresh on UDP per control cycle, frame_id and command_id stepping by one
//!    (wrapping at 65535), positions in degrees in [0, 360); each actuator's answer matched to
//!    the cycle its command_id names ([`cycle_of`]) by the per-cycle accounting ([`crate::watchdog`]: an
//!    answer missing when cycle k + m is due, or more than m periods stale, is a fault);
//!    KeepAlive on a link idle for more than [`KEEP_ALIVE_AFTER`];
//! 4. leaving (`stop`): after a fault, ApplyEmergencyStop at once; then, once the last
//!    Refresh is answered (or its wait is over), SetServoingMode(SINGLE_LEVEL_SERVOING), then
//!    CloseSession on both links; every frame of it left unanswered is logged.
//!
//! The command log names each frame's rpc and message id; the CreateSession payload, which
//! holds the credentials, is never logged.

mod stop;

use super::channel::Channel;
use super::header::uid;
use super::proto::{self, base, base_cyclic, common};
use super::Connection;
use crate::cia402::{counts_to_rad, COUNTS_PER_RAD};
use crate::link::{ArmLink, StartPlan};
use crate::log::{LogEntry, LogSink};
use crate::run::{Command, ExecConfig, Fault, LinkError, Measured, JOINTS, MAX_MISSED_CYCLES};
use crate::watchdog::CycleAccount;
use prost::Message;
use std::f64::consts::{PI, TAU};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// A link idle for longer gets a KeepAlive.
pub const KEEP_ALIVE_AFTER: Duration = Duration::from_millis(150);
/// Asked for in CreateSession: the session ends after this long without a frame, ms.
pub const SESSION_INACTIVITY_MS: u32 = 60_000;
/// Asked for in CreateSession: the arm stops motion after this long without a frame on a
/// link, ms.
pub const CONNECTION_INACTIVITY_MS: u32 = 2_000;

/// `counts` (the executor's command unit) in degrees within [0, 360), as sent.
pub fn wire_degrees(counts: i32) -> f32 {
    let deg = counts_to_rad(counts).to_degrees().rem_euclid(360.0) as f32;
    // Rounding to f32 can reach 360 itself.
    if deg >= 360.0 {
        0.0
    } else {
        deg
    }
}

/// The cycle (0 = the first after the seed) whose command carried frame_id `frame`, given
/// `sent` cycles sent, the last with frame_id `last`: frame_ids step by one (wrapping at 65535)
/// from the seed's, so counting back from the last one. `None`: no cycle sent carried it.
pub fn cycle_of(sent: u64, last: u16, frame: u32) -> Option<u64> {
    let frame = u16::try_from(frame).ok()?;
    sent.checked_sub(1 + u64::from(last.wrapping_sub(frame)))
}

/// Degrees from the wire, in radians on the turn nearest `near` (rad).
///
/// ```
/// use omcbsa_hw::kortex::arm::{from_wire, wire_degrees};
/// use omcbsa_hw::cia402::rad_to_counts;
///
/// // -1 rad goes out as 302.7 degrees, and comes back on the turn of the target.
/// let deg = wire_degrees(rad_to_counts(-1.0).unwrap());
/// assert!((deg - 302.704_2).abs() < 1e-3);
/// assert!((from_wire(deg, -1.0) + 1.0).abs() < 1e-6);
/// assert!((from_wire(deg, 5.0) - (std::f64::consts::TAU - 1.0)).abs() < 1e-6);
/// ```
pub fn from_wire(deg: f32, near: f64) -> f64 {
    let d = (f64::from(deg).to_radians() - near).rem_euclid(TAU);
    near + if d > PI { d - TAU } else { d }
}

/// The answers the stop waits for.
#[derive(Clone, Copy, Debug)]
struct StopAwaited {
    /// The last Refresh sent: its message id, its frame_id, and whether an answer to it (an
    /// error frame counts: the Refresh reached the arm) has come.
    last_refresh: Option<(u16, u16, bool)>,
    /// The message id of ApplyEmergencyStop, once sent.
    estop: Option<u16>,
    /// The longest wait for the last Refresh's answer: m + 1 periods, or the feedback time-out
    /// if longer (an answer later than that is a fault anyway).
    drain: Duration,
}

impl StopAwaited {
    fn new(cfg: &ExecConfig) -> Self {
        let m = cfg.watch.missed_cycles.clamp(1, MAX_MISSED_CYCLES);
        Self {
            last_refresh: None,
            estop: None,
            drain: cfg.watch.feedback_timeout.max(cfg.period * (m + 1)),
        }
    }

    /// A UDP response with `message_id` was received.
    fn answer_seen(&mut self, message_id: u16) {
        if let Some((id, _, answered)) = &mut self.last_refresh {
            *answered |= *id == message_id;
        }
    }
}

/// A Gen3 on Kortex as the executor drives it (see the module).
pub struct KortexArm {
    name: String,
    conn: Connection,
    clock: Instant,
    log: Option<LogSink>,
    frames_sent: usize,
    rpc_timeout: Duration,
    /// The last frame_id sent (the seed's before the first cycle).
    frame_id: u16,
    /// Per actuator, the cycles answered; each cycle's targets kept until then.
    account: CycleAccount<Command>,
    /// The last feedback: positions (degrees as received) and the targets of the cycle it answers.
    answered: Option<([f32; JOINTS], Command)>,
    /// The first fault seen in what the arm sent.
    fault: Option<Fault>,
    /// Measured at start-up: where the seed command holds every actuator.
    measured: Option<[f32; JOINTS]>,
    low_level: bool,
    /// What the stop waits for (`stop`).
    stop: StopAwaited,
}

impl KortexArm {
    /// The link for arm `name` over `conn`, for a run with `cfg`; frames go to `log`, stamped
    /// from `clock`. Sends nothing yet.
    pub fn new(
        name: String,
        conn: Connection,
        clock: Instant,
        cfg: &ExecConfig,
        log: Option<LogSink>,
    ) -> Self {
        Self {
            name,
            conn,
            clock,
            log,
            frames_sent: 0,
            rpc_timeout: cfg.sdo_timeout.max(Duration::from_millis(500)),
            frame_id: 0,
            account: CycleAccount::watching(JOINTS, &cfg.watch),
            answered: None,
            fault: None,
            measured: None,
            low_level: false,
            stop: StopAwaited::new(cfg),
        }
    }

    fn log(&self, link: &str, rpc: u32, message_id: u16, what: &str) {
        if let Some(log) = &self.log {
            log.write(&LogEntry {
                t: self.clock.elapsed().as_secs_f64(),
                arm: &self.name,
                frame: format!("kortex {link} {} message {message_id}", uid::name(rpc)),
                what,
            });
        }
    }

    /// Calls `rpc` on TCP (`udp`: on UDP) and returns the response's payload.
    fn call(&mut self, udp: bool, rpc: u32, payload: &[u8], what: &str) -> Result<Vec<u8>, String> {
        let timeout = self.rpc_timeout;
        let link = if udp {
            &mut self.conn.udp
        } else {
            &mut self.conn.tcp
        };
        let kind = link.kind();
        let out = link.call(rpc, payload, timeout);
        self.frames_sent += 1;
        let (h, p) = out.map_err(|e| format!("{}: {e}", self.conn.spec))?;
        self.log(kind, rpc, h.message_id, what);
        Ok(p)
    }

    fn send(&mut self, udp: bool, rpc: u32, payload: &[u8], what: &str) -> Result<u16, String> {
        let link = if udp {
            &mut self.conn.udp
        } else {
            &mut self.conn.tcp
        };
        let kind = link.kind();
        let id = link
            .send(rpc, payload)
            .map_err(|e| format!("{}: {e}", self.conn.spec))?;
        self.frames_sent += 1;
        self.log(kind, rpc, id, what);
        Ok(id)
    }

    fn create_session(&mut self, udp: bool) -> Result<(), String> {
        let info = proto::CreateSessionInfo {
            username: self.conn.credentials.username.clone(),
            password: self.conn.credentials.password.clone(),
            session_inactivity_timeout: SESSION_INACTIVITY_MS,
            connection_inactivity_timeout: CONNECTION_INACTIVITY_MS,
        }
        .encode_to_vec();
        let link = if udp {
            &mut self.conn.udp
        } else {
            &mut self.conn.tcp
        };
        let kind = link.kind();
        let (h, _) = link
            .call(uid::CREATE_SESSION, &info, self.rpc_timeout)
            .map_err(|e| format!("{}: {e}", self.conn.spec))?;
        link.session = h.session_id;
        self.frames_sent += 1;
        let what = format!(
            "session {} as user {:?} (password withheld)",
            h.session_id, self.conn.credentials.username
        );
        self.log(kind, uid::CREATE_SESSION, h.message_id, &what);
        Ok(())
    }

    fn set_servoing(&mut self, mode: base::ServoingMode) -> Result<(), String> {
        let info = base::ServoingModeInformation {
            servoing_mode: mode as i32,
        }
        .encode_to_vec();
        self.call(false, uid::SET_SERVOING_MODE, &info, mode.as_str_name())?;
        self.low_level = mode == base::ServoingMode::LowLevelServoing;
        Ok(())
    }

    fn refresh_payload(frame_id: u16, degrees: &[f32; JOINTS]) -> Vec<u8> {
        base_cyclic::Command {
            frame_id: u32::from(frame_id),
            actuators: (degrees.iter())
                .map(|&position| base_cyclic::ActuatorCommand {
                    command_id: u32::from(frame_id),
                    position,
                    ..Default::default()
                })
                .collect(),
        }
        .encode_to_vec()
    }

    /// The positions of a Feedback from the arm, with its faults: seven actuators, each
    /// fault-free, the base fault-free.
    fn feedback(payload: &[u8]) -> Result<(u16, [f32; JOINTS], [u32; JOINTS]), Fault> {
        let f = base_cyclic::Feedback::decode(payload)
            .map_err(|e| Fault::ArmRefused(format!("cannot decode the arm's Feedback: {e}")))?;
        if let Some(b) = f
            .base
            .filter(|b| b.fault_bank_a != 0 || b.fault_bank_b != 0)
        {
            return Err(Fault::ActuatorFault {
                joint: 0,
                bank_a: b.fault_bank_a,
                bank_b: b.fault_bank_b,
            });
        }
        if f.actuators.len() != JOINTS {
            return Err(Fault::ArmRefused(format!(
                "the arm reports {} actuators; a Gen3 has {JOINTS}",
                f.actuators.len()
            )));
        }
        let mut pos = [0.0; JOINTS];
        let mut ids = [0; JOINTS];
        for (j, a) in f.actuators.iter().enumerate() {
            if a.fault_bank_a != 0 || a.fault_bank_b != 0 {
                return Err(Fault::ActuatorFault {
                    joint: j as u8 + 1,
                    bank_a: a.fault_bank_a,
                    bank_b: a.fault_bank_b,
                });
            }
            pos[j] = a.position;
            ids[j] = a.command_id;
        }
        Ok((f.frame_id as u16, pos, ids))
    }

    fn keep_alive(&mut self) -> Result<(), String> {
        for udp in [false, true] {
            let link: &Channel = if udp { &self.conn.udp } else { &self.conn.tcp };
            if link.session != 0 && link.last_sent.elapsed() > KEEP_ALIVE_AFTER {
                self.send(udp, uid::KEEP_ALIVE, &[], "idle link")?;
            }
        }
        Ok(())
    }

    /// A Feedback of `frame_id`, each actuator's command_id naming the same frame: every
    /// actuator's answer to that cycle goes to the per-cycle accounting (one source per
    /// actuator); the feedback of a cycle still kept is kept for the following error.
    fn answered(
        &mut self,
        frame_id: u16,
        pos: [f32; JOINTS],
        ids: [u32; JOINTS],
    ) -> Result<(), Fault> {
        if ids.iter().any(|&id| id != u32::from(frame_id)) {
            return Err(Fault::ArmRefused(format!(
                "the feedback of frame {frame_id} carries command ids {ids:?}"
            )));
        }
        let last = self.frame_id;
        let c = cycle_of(self.account.sent(), last, u32::from(frame_id)).ok_or_else(|| {
            Fault::ArmRefused(format!(
                "the arm answered frame {frame_id}, which was not sent (last frame {last})"
            ))
        })?;
        let mut targets = None;
        for j in 0..JOINTS {
            targets = self
                .account
                .answer(j, c)
                .map_err(Fault::answer)?
                .map(|(_, t)| *t);
        }
        if let Some(t) = targets {
            self.answered = Some((pos, t));
        }
        Ok(())
    }
}

impl KortexArm {
    /// Start-up, phase 1 (see the module): sessions, faults cleared, every actuator within
    /// the start tolerance of `start`.
    fn check_start(
        &mut self,
        cfg: &ExecConfig,
        start: &Command,
        stop: &AtomicBool,
    ) -> Result<(), String> {
        let empty = common::Empty {}.encode_to_vec();
        self.create_session(false)?;
        if stop.load(Ordering::SeqCst) {
            return Ok(());
        }
        self.create_session(true)?;
        if stop.load(Ordering::SeqCst) {
            return Ok(());
        }
        self.call(false, uid::CLEAR_FAULTS, &empty, "before motion")?;
        let payload = self.call(true, uid::REFRESH_FEEDBACK, &empty, "start position")?;
        let (_, measured, _) = Self::feedback(&payload)
            .map_err(|f| format!("{}: at start-up: {f}", self.conn.spec))?;
        for j in 0..JOINTS {
            let want = counts_to_rad(start[j]);
            let at = from_wire(measured[j], want);
            if (at - want).abs() > cfg.start_tolerance {
                return Err(format!(
                    "joint {} is at {:.6} rad ({} degrees reported by actuator {}) but the plan \
                     starts at {want:.6} rad (tolerance {} rad)",
                    j + 1,
                    at,
                    measured[j],
                    j + 1,
                    cfg.start_tolerance
                ));
            }
        }
        self.measured = Some(measured);
        Ok(())
    }

    /// Start-up, phase 2: low-level servoing, seeded where the arm was measured.
    fn start_servoing(&mut self) -> Result<(), String> {
        let seed = self.measured.ok_or("enable before configure")?;
        self.set_servoing(base::ServoingMode::LowLevelServoing)?;
        self.frame_id = 0;
        self.account.reset();
        let payload = Self::refresh_payload(self.frame_id, &seed);
        let answer = self.call(true, uid::REFRESH, &payload, "seed: hold where measured")?;
        Self::feedback(&answer).map_err(|f| format!("{}: seeding: {f}", self.conn.spec))?;
        Ok(())
    }

    /// Handles everything received on both links, and keeps the sessions alive.
    fn receive(&mut self) -> Result<(), String> {
        while let Some(f) = self.conn.tcp.recv()? {
            if let Err(e) = super::codec::response_payload(f) {
                self.fault.get_or_insert(Fault::ArmRefused(e.to_string()));
            }
        }
        while let Some(f) = self.conn.udp.recv()? {
            self.stop.answer_seen(f.header.message_id);
            let answer = super::codec::response_payload(f)
                .map_err(|e| Fault::ArmRefused(e.to_string()))
                .and_then(|p| Self::feedback(&p));
            match answer.and_then(|(frame_id, pos, ids)| self.answered(frame_id, pos, ids)) {
                Ok(()) => {}
                Err(fault) => {
                    self.fault.get_or_insert(fault);
                }
            }
        }
        self.keep_alive()
    }
}

impl ArmLink for KortexArm {
    fn name(&self) -> &str {
        &self.name
    }

    fn frames_sent(&self) -> usize {
        self.frames_sent
    }

    fn configure(
        &mut self,
        cfg: &ExecConfig,
        plan: &StartPlan,
        stop: &AtomicBool,
    ) -> Result<(), LinkError> {
        self.check_start(cfg, &plan.first, stop)
            .map_err(LinkError::Setup)
    }

    fn enable(&mut self, _cfg: &ExecConfig) -> Result<(), LinkError> {
        self.start_servoing().map_err(LinkError::Setup)
    }

    fn poll(&mut self) -> Result<(), LinkError> {
        self.receive().map_err(LinkError::Io)
    }

    fn measured(&self) -> Option<Measured> {
        let answered = (0..JOINTS).filter_map(|j| self.account.owed(j)).min();
        let cycle = answered.and_then(|o| o.checked_sub(1));
        match (&self.answered, self.measured) {
            (Some((pos, targets)), _) => Some(Measured {
                positions: std::array::from_fn(|j| from_wire(pos[j], counts_to_rad(targets[j]))),
                cycle,
            }),
            // Before any cycle: where start-up measured it (degrees on the turn nearest 0).
            (None, Some(deg)) => Some(Measured {
                positions: deg.map(|d| from_wire(d, 0.0)),
                cycle: None,
            }),
            (None, None) => None,
        }
    }

    fn check_feedback(
        &self,
        _now: Instant,
        cfg: &ExecConfig,
        _target: &Command,
    ) -> Result<f64, Fault> {
        if let Some(f) = &self.fault {
            return Err(f.clone());
        }
        let mut worst: f64 = 0.0;
        if let Some((pos, targets)) = &self.answered {
            for j in 0..JOINTS {
                let target = targets[j] as f64 / COUNTS_PER_RAD;
                let actual = from_wire(pos[j], target);
                let err = (actual - target).abs();
                if err > cfg.watch.following_error_bound {
                    return Err(Fault::FollowingError {
                        node: j as u8 + 1,
                        actual,
                        target,
                    });
                }
                worst = worst.max(err);
            }
        }
        Ok(worst)
    }

    fn check_cycle(&self) -> Result<(), Fault> {
        self.account.check_send().map_err(Fault::answer)
    }

    fn clear_until(&self) -> u64 {
        self.account.clear_until()
    }

    fn send_cycle(&mut self, cmd: &Command) -> Result<(), LinkError> {
        self.frame_id = self.frame_id.wrapping_add(1);
        let degrees = cmd.map(wire_degrees);
        let payload = Self::refresh_payload(self.frame_id, &degrees);
        let what = if self.log.is_some() {
            format!("frame {} positions {degrees:?} degrees", self.frame_id)
        } else {
            String::new()
        };
        let id = (self.send(true, uid::REFRESH, &payload, &what)).map_err(LinkError::Io)?;
        self.stop.last_refresh = Some((id, self.frame_id, false));
        self.account.sent_cycle(*cmd);
        Ok(())
    }

    fn quick_stop(&mut self, _hold: &Command) -> Result<(), LinkError> {
        let id = (self.send(false, uid::APPLY_EMERGENCY_STOP, &[], "quick stop"))
            .map_err(LinkError::StopFailed)?;
        self.stop.estop = Some(id);
        Ok(())
    }

    /// Nothing to send: [`ArmLink::leave`] ends low-level servoing once the last command is
    /// answered.
    fn finish(&mut self, _hold: &Command) -> Result<(), LinkError> {
        Ok(())
    }

    fn abort(&mut self) -> Result<(), LinkError> {
        Ok(())
    }

    fn leave(&mut self) -> Result<Vec<String>, LinkError> {
        KortexArm::leave(self).map_err(LinkError::StopFailed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cia402::rad_to_counts;

    #[test]
    fn positions_go_out_in_degrees_within_0_to_360_and_come_back_on_the_nearest_turn() {
        for rad in [0.0, 1.0, -1.0, 3.1, -3.1, 6.2, -6.2, 2.09, -2.57] {
            let counts = rad_to_counts(rad).unwrap();
            let deg = wire_degrees(counts);
            assert!((0.0..360.0).contains(&deg), "{rad} -> {deg}");
            let back = from_wire(deg, rad);
            assert!((back - rad).abs() < 1e-6, "{rad} -> {deg} -> {back}");
        }
        // Just below a whole turn stays below 360 after rounding to f32.
        assert_eq!(wire_degrees(rad_to_counts(-1e-7).unwrap()), 0.0);
    }

    #[test]
    fn answers_name_their_cycle_by_frame_id_across_the_wrap_at_65535() {
        // The seed was frame 0: cycle c carries frame (c + 1) mod 65536.
        assert_eq!(cycle_of(3, 3, 3), Some(2));
        assert_eq!(cycle_of(3, 3, 1), Some(0));
        assert_eq!(cycle_of(3, 3, 0), None, "the seed is no cycle");
        assert_eq!(cycle_of(3, 3, 4), None, "not sent yet");
        assert_eq!(cycle_of(3, 3, 70000), None, "no frame_id");
        // 65536 cycles: the last carries frame 0 again (65535 wrapped), the one before 65535.
        assert_eq!(cycle_of(65536, 0, 0), Some(65535));
        assert_eq!(cycle_of(65536, 0, 65535), Some(65534));
        assert_eq!(cycle_of(65537, 1, 65535), Some(65534));
    }
}
