//! Setting up one arm's drives before any motion, in two phases that every arm finishes before
//! the next begins (the executor waits for all arms in between):
//! 1. [`ArmBus::configure`]: per drive, by SDO, check the device type, write the CSP
//!    configuration (mode, SYNC, interpolation period, PDO mappings, following error window
//!    and time-out, heartbeat), and read back
//!    what must hold before enabling: the mode in effect, the start position, the software
//!    position limits. Nothing is enabled, so a refusal anywhere leaves every arm disabled.
//! 2. [`ArmBus::enable`]: NMT start, the CiA 402 enable sequence, and SYNCs until every drive
//!    reports "operation enabled" by TPDO and an operational heartbeat.
//!
//! A drive's SDO abort ends the set-up with the node, the object and the abort code.

use super::{node_id, ArmBus, NodeState};
use crate::canopen::{self, NmtCommand, SdoReply, SdoValue};
use crate::cia402::{self, counts_to_rad};
use crate::frame::CanFrame;
use crate::link::StartPlan;
use crate::run::{ExecConfig, JOINTS};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// A start-up SDO write changed on purpose, to show that the drives' refusals are handled: on
/// node `node` of the arm whose port carries it (`ArmPort::CanSetupOverride`), the write to
/// `index:sub` sends `value` instead (if the set-up has no write to that object, `value` is
/// written to it first). For tests only.
#[doc(hidden)]
#[derive(Clone, Debug, PartialEq)]
pub struct SetupOverride {
    /// The node whose set-up changes.
    pub node: u8,
    /// The object written.
    pub index: u16,
    /// Its sub-index.
    pub sub: u8,
    /// The value written instead.
    pub value: SdoValue,
}

impl SetupOverride {
    fn apply(&self, writes: &mut Vec<(u16, u8, SdoValue)>) {
        match writes
            .iter_mut()
            .find(|(i, s, _)| (*i, *s) == (self.index, self.sub))
        {
            Some(w) => w.2 = self.value,
            None => writes.insert(0, (self.index, self.sub, self.value)),
        }
    }
}

impl ArmBus {
    /// Sends one SDO request (`what`, about `index:sub`) and waits for the node's answer; an
    /// abort is an error naming the node, the request and the abort code.
    fn sdo_request(
        &mut self,
        node: u8,
        request: CanFrame,
        what: String,
        (index, sub): (u16, u8),
        timeout: Duration,
    ) -> Result<SdoReply, String> {
        self.sdo_reply = None;
        self.send(&request, format!("node {node} {what}"))
            .map_err(|e| e.to_string())?;
        let deadline = Instant::now() + timeout;
        loop {
            if let Some((n, reply)) = self.sdo_reply.take() {
                if n == node {
                    return match reply {
                        SdoReply::Abort { code, .. } => Err(format!(
                            "node {node} aborted {what} (abort code {code:#010x}: {})",
                            canopen::sdo_abort_text(code)
                        )),
                        SdoReply::DownloadAck { index: i, sub: s }
                        | SdoReply::Upload {
                            index: i, sub: s, ..
                        } if (i, s) == (index, sub) => Ok(reply),
                        other => Err(format!(
                            "node {node} gave an unexpected answer to {what}: {other:?}"
                        )),
                    };
                }
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Err(format!(
                    "node {node} did not answer {what} within {timeout:?}"
                ));
            }
            if let Some(f) = self.transport.recv(left).map_err(|e| e.to_string())? {
                self.handle(&f);
            }
        }
    }

    /// SDO expedited download, waiting for the node's confirmation.
    fn sdo_write(
        &mut self,
        node: u8,
        (index, sub, value): (u16, u8, SdoValue),
        timeout: Duration,
    ) -> Result<(), String> {
        let what = format!("SDO write {index:#06x}:{sub:02x} = {value}");
        let request = canopen::sdo_download(node, index, sub, value);
        match self.sdo_request(node, request, what.clone(), (index, sub), timeout)? {
            SdoReply::DownloadAck { .. } => Ok(()),
            other => Err(format!(
                "node {node} gave an unexpected answer to {what}: {other:?}"
            )),
        }
    }

    /// SDO expedited upload of an object of `N` bytes (1 to 4), little endian.
    fn sdo_read<const N: usize>(
        &mut self,
        node: u8,
        (index, sub): (u16, u8),
        timeout: Duration,
    ) -> Result<[u8; N], String> {
        let what = format!("SDO read {index:#06x}:{sub:02x}");
        let request = canopen::sdo_upload(node, index, sub);
        match self.sdo_request(node, request, what.clone(), (index, sub), timeout)? {
            SdoReply::Upload { data, len, .. } if usize::from(len) == N => {
                Ok(std::array::from_fn(|i| data[i]))
            }
            other => Err(format!(
                "node {node} gave an unexpected answer to {what} (expected {N} bytes): {other:?}"
            )),
        }
    }

    /// Phase 1: checks and configures every drive and reads back what must hold before
    /// enabling (see the module); `speed` is each joint's peak commanded speed, rad/s, for its
    /// following-error window. Returns `Ok` early, having sent nothing more, once `stop` is
    /// raised: another arm failed, and its error is the one to report.
    pub fn configure(
        &mut self,
        cfg: &ExecConfig,
        plan: &StartPlan,
        stop: &AtomicBool,
    ) -> Result<(), String> {
        let StartPlan {
            first: start,
            span,
            speed,
        } = plan;
        let period = cia402::interpolation_time_period(cfg.period).ok_or_else(|| {
            format!(
                "the control period {:?} cannot be written as an interpolation time period \
                 (0x60C2: 1 to 255 times 10^-6 to 10^0 s)",
                cfg.period
            )
        })?;
        let timeout = cfg.sdo_timeout;
        for j in 0..JOINTS {
            let node = node_id(j);
            let window = cfg.watch.following_error_window(speed[j], cfg.period);
            let following = (
                cia402::window_counts(window),
                cfg.watch.following_error_timeout_ms,
            );
            let mut writes =
                cia402::startup_config(node, cfg.watch.heartbeat_ms, period, following);
            if let Some(o) = self.setup_override.as_ref().filter(|o| o.node == node) {
                o.apply(&mut writes);
            }
            if stop.load(Ordering::SeqCst) {
                return Ok(());
            }
            let device =
                u32::from_le_bytes(self.sdo_read(node, (cia402::DEVICE_TYPE, 0), timeout)?);
            if !cia402::is_cia402_device(device) {
                return Err(format!(
                    "node {node} is not a CiA 402 drive: device type {device:#010x} (0x1000)"
                ));
            }
            for write in writes {
                if stop.load(Ordering::SeqCst) {
                    return Ok(());
                }
                self.sdo_write(node, write, timeout)?;
            }
            let [mode] = self.sdo_read(node, (cia402::MODES_OF_OPERATION_DISPLAY, 0), timeout)?;
            if mode != cia402::MODE_CSP {
                return Err(format!(
                    "node {node} reports mode of operation {} (0x6061), not cyclic synchronous \
                     position ({})",
                    mode as i8,
                    cia402::MODE_CSP
                ));
            }
            let actual =
                i32::from_le_bytes(self.sdo_read(node, (cia402::POSITION_ACTUAL, 0), timeout)?);
            let diff = counts_to_rad(actual - start[j]);
            if diff.abs() > cfg.start_tolerance {
                return Err(format!(
                    "joint {} is at {:.6} rad (0x6064 of node {node}) but the plan starts at \
                     {:.6} rad (tolerance {} rad)",
                    j + 1,
                    counts_to_rad(actual),
                    counts_to_rad(start[j]),
                    cfg.start_tolerance
                ));
            }
            let limit = cia402::SOFTWARE_POSITION_LIMIT;
            let lo = i32::from_le_bytes(self.sdo_read(node, (limit, 1), timeout)?);
            let hi = i32::from_le_bytes(self.sdo_read(node, (limit, 2), timeout)?);
            let (min, max) = span[j];
            if min < lo || max > hi {
                return Err(format!(
                    "joint {}: the plan spans [{:.6}, {:.6}] rad, beyond the drive's software \
                     position limits [{:.6}, {:.6}] rad (0x607D of node {node})",
                    j + 1,
                    counts_to_rad(min),
                    counts_to_rad(max),
                    counts_to_rad(lo),
                    counts_to_rad(hi)
                ));
            }
        }
        Ok(())
    }

    /// Phase 2: starts the nodes, enables every drive, and SYNCs until each reports "operation
    /// enabled" by TPDO and an operational heartbeat. Sends no motion command.
    pub fn enable(&mut self, cfg: &ExecConfig) -> Result<(), String> {
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
                let write = (cia402::CONTROLWORD, 0, SdoValue::U16(cw));
                self.sdo_write(node, write, cfg.sdo_timeout)?;
            }
        }
        let deadline = Instant::now() + cfg.startup_timeout;
        let ready = |n: &NodeState| {
            matches!(n.heartbeat, Some((_, canopen::NMT_STATE_OPERATIONAL)))
                && n.tpdo.is_some_and(|(_, sw)| cia402::operation_enabled(sw))
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
                        .map_or("none".to_string(), |(_, sw)| format!("{sw:#06x}"))
                ));
            }
            self.send(&canopen::sync(), "SYNC (start-up)".into())
                .map_err(|e| e.to_string())?;
            std::thread::sleep(cfg.period);
            self.poll().map_err(|e| e.to_string())?;
        }
        self.reset_sync_clock();
        Ok(())
    }
}
