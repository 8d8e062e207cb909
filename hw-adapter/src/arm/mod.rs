//! One arm on its own bus: seven CiA 402 drives, joint k at node k+1. Start-up (`setup`: SDO
//! configuration and read-back, NMT start, enable), one control cycle (RPDO per joint, then
//! SYNC), feedback bookkeeping (TPDO, heartbeat, EMCY), and the stop sequences.

mod setup;
mod stop;

pub use setup::SetupOverride;

use crate::canopen::{self, Emcy, Message, SdoReply};
use crate::cia402::{self, counts_to_rad};
use crate::frame::CanFrame;
use crate::link::ArmLink;
use crate::log::{LogEntry, LogSink};
use crate::run::{Command, CycleFault, ExecConfig, Fault, LinkError, Measured, JOINTS};
use crate::transport::{Transport, TransportError};
use crate::watchdog::CycleAccount;
use std::time::{Duration, Instant};

/// CANopen node id of joint `j` (0-based).
pub fn node_id(j: usize) -> u8 {
    j as u8 + 1
}

#[derive(Clone, Copy, Default)]
struct NodeState {
    /// Last heartbeat: when, and the NMT state it reported.
    heartbeat: Option<(Instant, u8)>,
    /// Last TPDO1: position actual (counts), statusword.
    tpdo: Option<(i32, u16)>,
    /// The targets in force at the SYNC the last TPDO1 answers (None: it answered none). The
    /// following error is the distance to these, not to a target sent after the drive
    /// measured (feedback that arrives late is no following error).
    answered_target: Option<i32>,
    emcy: Option<Emcy>,
}

/// The frames of one control cycle: an RPDO1 per joint (target, controlword), then SYNC; with a
/// description of each for the command log.
pub fn cycle_frames(cmd: &Command, controlword: u16) -> Vec<(CanFrame, String)> {
    let mut frames: Vec<(CanFrame, String)> = cmd
        .iter()
        .enumerate()
        .map(|(j, &c)| {
            let node = node_id(j);
            (
                canopen::rpdo1(node, &cia402::rpdo1_payload(c, controlword)),
                format!(
                    "RPDO1 node {node} target {:.7} rad cw {controlword:#06x}",
                    counts_to_rad(c)
                ),
            )
        })
        .collect();
    frames.push((canopen::sync(), "SYNC".into()));
    frames
}

/// The stop frames sent so far, awaiting the drives' answers.
#[derive(Clone, Copy, Debug, Default)]
struct StopSent {
    /// The stop's SYNC: its cycle in the accounting and what it applied.
    sync: Option<(u64, &'static str)>,
    /// When NMT stop was sent.
    nmt_stop: Option<Instant>,
}

/// One arm of seven CiA 402 drives on its own bus, as the executor drives it (see the module).
pub struct ArmBus {
    /// The arm's name.
    pub name: String,
    transport: Box<dyn Transport>,
    /// Origin of the log's time stamps.
    clock: Instant,
    send_timeout: Duration,
    log: Option<LogSink>,
    /// Frames sent so far.
    pub frames_sent: usize,
    nodes: [NodeState; JOINTS],
    /// Per-cycle accounting of the SYNCs and each node's TPDO1 answers (source j = joint j),
    /// with each SYNC's send time and the targets of its cycle (none for start-up SYNCs).
    account: CycleAccount<(Instant, Option<Command>)>,
    /// The first answer the accounting found late.
    late: Option<CycleFault>,
    sdo_reply: Option<(u8, SdoReply)>,
    /// Tests only: one start-up SDO write changed on purpose.
    setup_override: Option<SetupOverride>,
    /// The stop frames sent, awaiting the drives' answers (`stop`).
    stop: StopSent,
    /// The longest wait for the drives' answers to the stop frames.
    stop_wait: Duration,
}

impl ArmBus {
    /// The link for arm `name` on `transport`, for a run with `cfg`; frames go to `log`,
    /// stamped from `clock`. Sends nothing yet.
    pub fn new(
        name: String,
        transport: Box<dyn Transport>,
        clock: Instant,
        cfg: &ExecConfig,
        log: Option<LogSink>,
    ) -> Self {
        Self {
            name,
            transport,
            clock,
            send_timeout: cfg.send_timeout,
            log,
            frames_sent: 0,
            nodes: [NodeState::default(); JOINTS],
            account: CycleAccount::watching(JOINTS, &cfg.watch),
            late: None,
            sdo_reply: None,
            setup_override: None,
            stop: StopSent::default(),
            stop_wait: cfg
                .watch
                .heartbeat_consumer_time()
                .max(cfg.watch.feedback_timeout),
        }
    }

    /// Tests only: one start-up SDO write changed on purpose ([`SetupOverride`]).
    pub(crate) fn with_setup_override(mut self, o: SetupOverride) -> Self {
        self.setup_override = Some(o);
        self
    }

    /// Sends one frame (waiting at most [`ExecConfig::send_timeout`] for room) and logs it
    /// with its meaning `what`; a SYNC opens a cycle in the accounting.
    pub fn send(&mut self, frame: &CanFrame, what: String) -> Result<(), TransportError> {
        self.transport.send(frame, self.send_timeout)?;
        if frame.id() == canopen::SYNC_ID {
            self.account.sent_cycle((Instant::now(), None));
        }
        self.frames_sent += 1;
        self.note(&frame.to_string(), &what);
        Ok(())
    }

    /// Writes a line about `frame` (candump style) to the command log, if there is one.
    fn note(&self, frame: &str, what: &str) {
        if let Some(log) = &self.log {
            log.write(&LogEntry {
                t: self.clock.elapsed().as_secs_f64(),
                arm: &self.name,
                frame: frame.to_string(),
                what,
            });
        }
    }

    /// Starts counting SYNC answers afresh: from here, every SYNC sent is owed a TPDO1 by every
    /// node (they are operational with TPDO1 on every SYNC).
    fn reset_sync_clock(&mut self) {
        self.account.reset();
        self.late = None;
    }

    /// Handles every frame received so far.
    pub fn poll(&mut self) -> Result<(), TransportError> {
        while let Some(f) = self.transport.recv(Duration::ZERO)? {
            self.handle(&f);
        }
        Ok(())
    }

    fn handle(&mut self, f: &CanFrame) {
        let now = Instant::now();
        let node = |n: u8| usize::from(n).checked_sub(1).filter(|&j| j < JOINTS);
        match canopen::decode(f) {
            Message::Heartbeat { node: n, state } => {
                if let Some(j) = node(n) {
                    self.nodes[j].heartbeat = Some((now, state));
                }
            }
            Message::Tpdo1 { node: n, data } => {
                if let (Some(j), Some(feedback)) = (node(n), cia402::parse_tpdo1(data.data())) {
                    self.nodes[j].tpdo = Some(feedback);
                    // The SYNC this TPDO1 answers, if one is owed.
                    self.nodes[j].answered_target = match self.account.answer_next(j) {
                        Ok(answered) => answered.and_then(|(_, (_, cmd))| cmd.map(|c| c[j])),
                        Err(late) => {
                            self.late.get_or_insert(late);
                            None
                        }
                    };
                }
            }
            // Error code 0 is "error reset / no error".
            Message::Emcy(e) if e.code != 0 => {
                if let Some(j) = node(e.node) {
                    self.nodes[j].emcy.get_or_insert(e);
                }
            }
            Message::SdoResponse { node: n, reply } => self.sdo_reply = Some((n, reply)),
            Message::Emcy(_) | Message::Other => {}
        }
    }

    /// The first fault visible in the feedback, given the last target sent (`target`, the
    /// reference for feedback that answers no SYNC of a cycle); also returns the largest
    /// following error seen.
    pub fn check_feedback(
        &self,
        now: Instant,
        cfg: &ExecConfig,
        target: &Command,
    ) -> Result<f64, Fault> {
        if let Some(fault) = self.late {
            return Err(Fault::answer(fault));
        }
        let consumer_time = cfg.watch.heartbeat_consumer_time();
        let mut worst: f64 = 0.0;
        for (j, n) in self.nodes.iter().enumerate() {
            let node = node_id(j);
            if let Some(e) = n.emcy {
                return Err(Fault::Emcy {
                    node,
                    code: e.code,
                    register: e.register,
                });
            }
            match n.heartbeat {
                Some((t, _)) if now.duration_since(t) > consumer_time => {
                    return Err(Fault::HeartbeatLost {
                        node,
                        silent_for: now.duration_since(t),
                    })
                }
                Some((_, state)) if state != canopen::NMT_STATE_OPERATIONAL => {
                    return Err(Fault::NmtState {
                        node,
                        state: canopen::nmt_state_name(state),
                    })
                }
                Some(_) => {}
                None => {
                    return Err(Fault::HeartbeatLost {
                        node,
                        silent_for: Duration::MAX,
                    })
                }
            }
            let Some((pos, sw)) = n.tpdo else {
                return Err(Fault::FeedbackLost {
                    node,
                    silent_for: Duration::MAX,
                });
            };
            // Backstop on the wall clock (the accounting counts SYNCs sent): the oldest SYNC the
            // drive has not answered, late by more than the timeout even while TPDOs keep coming
            // (a backlog); a wait with no SYNC sent is no silence.
            let owed = self.account.owed(j).and_then(|k| self.account.record(k));
            if let Some(&(t, _)) = owed {
                if now.duration_since(t) > cfg.watch.feedback_timeout {
                    return Err(Fault::FeedbackLost {
                        node,
                        silent_for: now.duration_since(t),
                    });
                }
            }
            if sw & cia402::SW_FAULT != 0 || !cia402::operation_enabled(sw) {
                return Err(Fault::DriveState {
                    node,
                    statusword: sw,
                });
            }
            let goal = n.answered_target.unwrap_or(target[j]);
            let err = counts_to_rad(goal - pos).abs();
            if err > cfg.watch.following_error_bound {
                return Err(Fault::FollowingError {
                    node,
                    actual: counts_to_rad(pos),
                    target: counts_to_rad(goal),
                });
            }
            worst = worst.max(err);
        }
        Ok(worst)
    }

    /// Whether the next cycle may be sent, by the per-cycle accounting: call it when the
    /// cycle is due (a node that has not answered SYNC k by then, with k + m the next, is a
    /// fault).
    pub fn check_cycle(&self) -> Result<(), Fault> {
        self.account.check_send().map_err(Fault::answer)
    }

    /// The first cycle this arm's answers do not yet allow to be sent.
    pub fn clear_until(&self) -> u64 {
        self.account.clear_until()
    }

    /// Sends one control cycle: an RPDO1 per joint with `controlword`, then SYNC.
    pub fn send_cycle(&mut self, cmd: &Command, controlword: u16) -> Result<(), TransportError> {
        for (f, what) in cycle_frames(cmd, controlword) {
            self.send(&f, what)?;
        }
        if let Some(sync) = self.account.last_mut() {
            sync.1 = Some(*cmd);
        }
        Ok(())
    }
}

impl ArmLink for ArmBus {
    fn name(&self) -> &str {
        &self.name
    }

    fn frames_sent(&self) -> usize {
        self.frames_sent
    }

    fn configure(
        &mut self,
        cfg: &ExecConfig,
        plan: &crate::link::StartPlan,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<(), LinkError> {
        ArmBus::configure(self, cfg, plan, stop).map_err(LinkError::Setup)
    }

    fn enable(&mut self, cfg: &ExecConfig) -> Result<(), LinkError> {
        ArmBus::enable(self, cfg).map_err(LinkError::Setup)
    }

    fn poll(&mut self) -> Result<(), LinkError> {
        ArmBus::poll(self).map_err(|e| LinkError::Io(e.to_string()))
    }

    fn measured(&self) -> Option<Measured> {
        let mut positions = [0.0; JOINTS];
        for (p, n) in positions.iter_mut().zip(&self.nodes) {
            *p = counts_to_rad(n.tpdo?.0);
        }
        let answered = (0..JOINTS).filter_map(|j| self.account.owed(j)).min();
        Some(Measured {
            positions,
            cycle: answered.and_then(|o| o.checked_sub(1)),
        })
    }

    fn check_feedback(
        &self,
        now: Instant,
        cfg: &ExecConfig,
        target: &Command,
    ) -> Result<f64, Fault> {
        ArmBus::check_feedback(self, now, cfg, target)
    }

    fn check_cycle(&self) -> Result<(), Fault> {
        ArmBus::check_cycle(self)
    }

    fn clear_until(&self) -> u64 {
        ArmBus::clear_until(self)
    }

    fn send_cycle(&mut self, cmd: &Command) -> Result<(), LinkError> {
        ArmBus::send_cycle(self, cmd, cia402::CW_ENABLE_OPERATION)
            .map_err(|e| LinkError::Io(e.to_string()))
    }

    fn quick_stop(&mut self, hold: &Command) -> Result<(), LinkError> {
        ArmBus::quick_stop(self, hold).map_err(LinkError::StopFailed)
    }

    fn finish(&mut self, hold: &Command) -> Result<(), LinkError> {
        ArmBus::finish(self, hold).map_err(LinkError::StopFailed)
    }

    fn abort(&mut self) -> Result<(), LinkError> {
        ArmBus::abort(self).map_err(LinkError::StopFailed)
    }

    fn leave(&mut self) -> Result<Vec<String>, LinkError> {
        Ok(self.confirm_stop())
    }
}
