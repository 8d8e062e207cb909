//! Stopping one arm's drives, and the drives' answers to the stop: after a fault, a quick stop
//! of every drive (controlword, applied at a SYNC); at the normal end, disable operation; then,
//! and after a start-up aborted elsewhere, NMT stop of every node.
//!
//! A drive answers the stop's SYNC with its TPDO1 (the statusword in its new state) and NMT
//! stop with a heartbeat reporting "stopped". [`ArmBus::confirm_stop`] waits for both, at most
//! the heartbeat consumer time (or the feedback time-out, if longer), and names every stop frame
//! some node left unanswered, in the command log too: a drive that has stopped answering gets
//! its stop's failure written down rather than passed over.

use super::{cycle_frames, node_id, ArmBus};
use crate::canopen::{self, NmtCommand};
use crate::cia402;
use crate::run::{Command, JOINTS};
use std::time::{Duration, Instant};

impl ArmBus {
    /// Quick stop of every drive (controlword, applied at the SYNC), then NMT stop of every node.
    /// Tries every frame even if one fails; returns the first failure to send.
    pub fn quick_stop(&mut self, hold: &Command) -> Result<(), String> {
        self.stop_with(hold, cia402::CW_QUICK_STOP, "quick stop")
    }

    /// Normal end: disable operation (the drives hold in "switched on"), then NMT stop.
    pub fn finish(&mut self, hold: &Command) -> Result<(), String> {
        self.stop_with(hold, cia402::CW_DISABLE_OPERATION, "disable operation")
    }

    /// After a failed start-up elsewhere: stop this arm's nodes without moving.
    pub fn abort(&mut self) -> Result<(), String> {
        self.nmt_stop("NMT stop all nodes (start-up aborted)")
    }

    fn stop_with(
        &mut self,
        hold: &Command,
        controlword: u16,
        why: &'static str,
    ) -> Result<(), String> {
        let mut first_err = None;
        for (f, what) in cycle_frames(hold, controlword) {
            if let Err(e) = self.send(&f, format!("{what} ({why})")) {
                first_err.get_or_insert(e.to_string());
            } else if f.id() == canopen::SYNC_ID {
                self.stop.sync = Some((self.account.sent() - 1, why));
            }
        }
        let nmt = self.nmt_stop("NMT stop all nodes");
        first_err.map_or(nmt, Err)
    }

    fn nmt_stop(&mut self, what: &str) -> Result<(), String> {
        self.send(&canopen::nmt(NmtCommand::Stop, 0), what.into())
            .map_err(|e| e.to_string())?;
        self.stop.nmt_stop = Some(Instant::now());
        Ok(())
    }

    /// Waits for every node's answers to the stop frames sent (see the module), at most the
    /// stop wait; returns the frames some node left unanswered, each also logged.
    pub fn confirm_stop(&mut self) -> Vec<String> {
        let deadline = Instant::now() + self.stop_wait;
        let mut gone = false;
        loop {
            let now = Instant::now();
            if now >= deadline && !gone {
                // What came while this thread was held up past the deadline still counts:
                // read all of it before judging.
                while let Ok(Some(f)) = self.transport.recv(Duration::ZERO) {
                    self.handle(&f);
                }
            }
            let missing = self.unconfirmed();
            if missing.is_empty() {
                return Vec::new();
            }
            if gone || now >= deadline {
                let waited = format!("no answer within {:?}", self.stop_wait);
                return (missing.into_iter())
                    .map(|(frame, what)| {
                        let what = format!("{what}: {waited}");
                        self.note(frame, &what);
                        format!("{frame} {what}")
                    })
                    .collect();
            }
            let wait = (deadline - now).min(Duration::from_millis(1));
            match self.transport.recv(wait) {
                Ok(Some(f)) => self.handle(&f),
                Ok(None) => {}
                // The bus is gone: nothing more will answer.
                Err(_) => gone = true,
            }
        }
    }

    /// The stop frames some node has not answered yet: the frame (candump style) and what is
    /// missing.
    fn unconfirmed(&self) -> Vec<(&'static str, String)> {
        let nodes = |missing: &dyn Fn(usize) -> bool| {
            let n: Vec<String> = (0..JOINTS)
                .filter(|&j| missing(j))
                .map(|j| node_id(j).to_string())
                .collect();
            (!n.is_empty()).then(|| n.join(", "))
        };
        let mut out = Vec::new();
        if let Some((cycle, why)) = self.stop.sync {
            let unanswered = |j: usize| self.account.owed(j).is_some_and(|o| o <= cycle);
            if let Some(n) = nodes(&unanswered) {
                out.push(("080#", format!("(SYNC, {why}): no TPDO1 from node {n}")));
            }
        }
        if let Some(sent) = self.stop.nmt_stop {
            let running = |j: usize| {
                !matches!(self.nodes[j].heartbeat,
                    Some((t, canopen::NMT_STATE_STOPPED)) if t >= sent)
            };
            if let Some(n) = nodes(&running) {
                out.push((
                    "000#0200",
                    format!(
                        "(NMT stop all nodes): no heartbeat reporting \"stopped\" from node {n}"
                    ),
                ));
            }
        }
        out
    }
}
