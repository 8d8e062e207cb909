//! One arm on its own bus: seven CiA 402 drives, joint k at node k+1. Start-up (SDO config, NMT
//! start, enable), one control cycle (RPDO per joint, then SYNC), feedback bookkeeping (TPDO,
//! heartbeat, EMCY), and the stop sequences.

use crate::canopen::{self, Emcy, Message, NmtCommand, SdoReply, SdoValue};
use crate::cia402::{self, counts_to_rad};
use crate::executor::{ExecConfig, Fault};
use crate::frame::CanFrame;
use crate::interpolate::Command;
use crate::log::{LogEntry, LogSink};
use crate::plan::JOINTS;
use crate::transport::{Transport, TransportError};
use std::time::{Duration, Instant};

/// CANopen node id of joint `j` (0-based).
pub fn node_id(j: usize) -> u8 {
    j as u8 + 1
}

#[derive(Clone, Copy, Default)]
struct NodeState {
    /// Last heartbeat: when, and the NMT state it reported.
    heartbeat: Option<(Instant, u8)>,
    /// Last TPDO1: when, position actual (counts), statusword.
    tpdo: Option<(Instant, i32, u16)>,
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

pub struct ArmBus {
    pub name: String,
    transport: Box<dyn Transport>,
    /// Origin of the log's time stamps.
    clock: Instant,
    send_timeout: Duration,
    log: Option<LogSink>,
    /// Frames sent so far.
    pub frames_sent: usize,
    nodes: [NodeState; JOINTS],
    sdo_reply: Option<(u8, SdoReply)>,
}

impl ArmBus {
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
            sdo_reply: None,
        }
    }

    pub fn send(&mut self, frame: &CanFrame, what: String) -> Result<(), TransportError> {
        self.transport.send(frame, self.send_timeout)?;
        self.frames_sent += 1;
        if let Some(log) = &self.log {
            log.write(&LogEntry {
                t: self.clock.elapsed().as_secs_f64(),
                arm: &self.name,
                frame: frame.to_string(),
                what: &what,
            });
        }
        Ok(())
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
                if let (Some(j), Some((pos, sw))) = (node(n), cia402::parse_tpdo1(data.data())) {
                    self.nodes[j].tpdo = Some((now, pos, sw));
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

    /// SDO expedited download, waiting for the node's confirmation.
    fn sdo_write(
        &mut self,
        node: u8,
        index: u16,
        sub: u8,
        value: SdoValue,
        timeout: Duration,
    ) -> Result<(), String> {
        let what = format!("SDO write node {node} {index:#06x}:{sub:02x} = {value:?}");
        self.sdo_reply = None;
        self.send(&canopen::sdo_download(node, index, sub, value), what)
            .map_err(|e| e.to_string())?;
        let deadline = Instant::now() + timeout;
        loop {
            if let Some((n, reply)) = self.sdo_reply.take() {
                if n == node {
                    return match reply {
                        SdoReply::DownloadAck { index: i, sub: s } if i == index && s == sub => Ok(()),
                        SdoReply::Abort { code, .. } => Err(format!(
                            "node {node} refused SDO write {index:#06x}:{sub:02x} (abort code {code:#010x})"
                        )),
                        other => Err(format!(
                            "node {node} gave an unexpected answer to SDO write {index:#06x}:{sub:02x}: {other:?}"
                        )),
                    };
                }
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(format!(
                    "node {node} did not answer SDO write {index:#06x}:{sub:02x} within {timeout:?}"
                ));
            }
            if let Some(f) = self.transport.recv(left).map_err(|e| e.to_string())? {
                self.handle(&f);
            }
        }
    }

    /// Configures and enables all drives, then checks that each reports "operation enabled" at
    /// the plan's start position. Sends no motion command.
    pub fn start_up(&mut self, cfg: &ExecConfig, start: &Command) -> Result<(), String> {
        for j in 0..JOINTS {
            let node = node_id(j);
            for (index, sub, value) in cia402::startup_config(node, cfg.heartbeat_ms) {
                self.sdo_write(node, index, sub, value, cfg.sdo_timeout)?;
            }
        }
        for j in 0..JOINTS {
            let node = node_id(j);
            self.send(
                &canopen::nmt(NmtCommand::Start, node),
                format!("NMT start node {node}"),
            )
            .map_err(|e| e.to_string())?;
        }
        for j in 0..JOINTS {
            let node = node_id(j);
            for cw in cia402::ENABLE_SEQUENCE {
                self.sdo_write(
                    node,
                    cia402::CONTROLWORD,
                    0,
                    SdoValue::U16(cw),
                    cfg.sdo_timeout,
                )?;
            }
        }
        // SYNC until every drive has answered with a TPDO and an operational heartbeat.
        let deadline = Instant::now() + cfg.startup_timeout;
        let ready = |n: &NodeState| {
            matches!(n.heartbeat, Some((_, canopen::NMT_STATE_OPERATIONAL)))
                && n.tpdo
                    .is_some_and(|(_, _, sw)| cia402::operation_enabled(sw))
        };
        while !self.nodes.iter().all(ready) {
            if let Some(j) = self.nodes.iter().position(|n| n.emcy.is_some()) {
                return Err(format!(
                    "node {} sent EMCY during start-up: {:?}",
                    node_id(j),
                    self.nodes[j].emcy
                ));
            }
            if Instant::now() >= deadline {
                let j = self.nodes.iter().position(|n| !ready(n)).unwrap_or(0);
                let n = self.nodes[j];
                return Err(format!(
                    "node {} not ready within {:?} (heartbeat state: {}, statusword: {})",
                    node_id(j),
                    cfg.startup_timeout,
                    n.heartbeat
                        .map_or("none", |(_, s)| canopen::nmt_state_name(s)),
                    n.tpdo
                        .map_or("none".to_string(), |(_, _, sw)| format!("{sw:#06x}"))
                ));
            }
            self.send(&canopen::sync(), "SYNC (start-up)".into())
                .map_err(|e| e.to_string())?;
            std::thread::sleep(cfg.period);
            self.poll().map_err(|e| e.to_string())?;
        }
        for (j, n) in self.nodes.iter().enumerate() {
            let actual = n.tpdo.map_or(0, |(_, p, _)| p);
            let diff = counts_to_rad(actual - start[j]);
            if diff.abs() > cfg.start_tolerance {
                return Err(format!(
                    "joint {} is at {:.6} rad but the plan starts at {:.6} rad (tolerance {} rad)",
                    j + 1,
                    counts_to_rad(actual),
                    counts_to_rad(start[j]),
                    cfg.start_tolerance
                ));
            }
        }
        Ok(())
    }

    /// The first fault visible in the feedback, given the last target sent (`target`); also
    /// returns the largest following error seen.
    pub fn check_feedback(
        &self,
        now: Instant,
        cfg: &ExecConfig,
        target: &Command,
    ) -> Result<f64, Fault> {
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
                Some((t, _)) if now.duration_since(t) > cfg.heartbeat_timeout => {
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
            let Some((t, pos, sw)) = n.tpdo else {
                return Err(Fault::FeedbackLost {
                    node,
                    silent_for: Duration::MAX,
                });
            };
            if now.duration_since(t) > cfg.feedback_timeout {
                return Err(Fault::FeedbackLost {
                    node,
                    silent_for: now.duration_since(t),
                });
            }
            if sw & cia402::SW_FAULT != 0 || !cia402::operation_enabled(sw) {
                return Err(Fault::DriveState {
                    node,
                    statusword: sw,
                });
            }
            let err = counts_to_rad(target[j] - pos).abs();
            if err > cfg.following_error_bound {
                return Err(Fault::FollowingError {
                    node,
                    actual: counts_to_rad(pos),
                    target: counts_to_rad(target[j]),
                });
            }
            worst = worst.max(err);
        }
        Ok(worst)
    }

    pub fn send_cycle(&mut self, cmd: &Command, controlword: u16) -> Result<(), TransportError> {
        for (f, what) in cycle_frames(cmd, controlword) {
            self.send(&f, what)?;
        }
        Ok(())
    }

    /// Quick stop of every drive (controlword, applied at the SYNC), then NMT stop of every node.
    /// Tries every frame even if one fails; returns the first failure.
    pub fn quick_stop(&mut self, hold: &Command) -> Result<(), String> {
        self.stop_with(hold, cia402::CW_QUICK_STOP, "quick stop")
    }

    /// Normal end: disable operation (the drives hold in "switched on"), then NMT stop.
    pub fn finish(&mut self, hold: &Command) -> Result<(), String> {
        self.stop_with(hold, cia402::CW_DISABLE_OPERATION, "disable operation")
    }

    fn stop_with(&mut self, hold: &Command, controlword: u16, why: &str) -> Result<(), String> {
        let mut first_err = None;
        let mut frames = cycle_frames(hold, controlword);
        for (_, what) in frames.iter_mut() {
            what.push_str(&format!(" ({why})"));
        }
        frames.push((
            canopen::nmt(NmtCommand::Stop, 0),
            "NMT stop all nodes".into(),
        ));
        for (f, what) in frames {
            if let Err(e) = self.send(&f, what) {
                first_err.get_or_insert(e.to_string());
            }
        }
        first_err.map_or(Ok(()), Err)
    }

    /// After a failed start-up elsewhere: stop this arm's nodes without moving.
    pub fn abort(&mut self) -> Result<(), String> {
        self.send(
            &canopen::nmt(NmtCommand::Stop, 0),
            "NMT stop all nodes (start-up aborted)".into(),
        )
        .map_err(|e| e.to_string())
    }
}
