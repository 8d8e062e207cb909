//! Leaving a Gen3, in the order a real arm needs: the cyclic loop has stopped (after a fault,
//! ApplyEmergencyStop went out at once); the answer to the last Refresh is waited for, so that
//! no Refresh still on its way reaches the arm after the mode change; only then
//! SetServoingMode(SINGLE_LEVEL_SERVOING), then CloseSession on both links.
//!
//! Every step is tried whatever the others gave, within one deadline (the rpc time-out) for the
//! whole sequence; a frame whose answer does not come in time is named, in the command log and
//! in what [`KortexArm::leave`] returns. A last Refresh that stays unanswered for its wait is
//! logged too: the mode change then goes out without proof that the Refresh will not follow it.

use super::KortexArm;
use crate::kortex::header::uid;
use crate::kortex::proto::base;
use prost::Message;
use std::time::Instant;

impl KortexArm {
    /// See the module: `Ok` with the frames left unanswered, or the first frame the arm refused
    /// or that could not be sent.
    pub(super) fn leave(&mut self) -> Result<Vec<String>, String> {
        let deadline = Instant::now() + self.rpc_timeout;
        let mut unanswered = Vec::new();
        let mut first_err = None;
        if let Some((id, frame, false)) = self.stop.last_refresh.take() {
            // An error frame is an answer too: the Refresh reached the arm.
            let drain = self.stop.drain;
            if let Ok(None) = self.conn.udp.answer(id, drain) {
                let what = format!("(frame {frame}, the last): no answer within {drain:?}");
                unanswered.push(self.unanswered(true, uid::REFRESH, id, &what));
            }
        }
        if let Some(id) = self.stop.estop.take() {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.conn.tcp.answer(id, left) {
                Ok(Some(_)) => {}
                Ok(None) => {
                    let what = format!("(quick stop): no answer within {:?}", self.rpc_timeout);
                    unanswered.push(self.unanswered(false, uid::APPLY_EMERGENCY_STOP, id, &what));
                }
                Err(e) => {
                    first_err.get_or_insert(e);
                }
            }
        }
        let mut steps: Vec<(bool, u32, Vec<u8>, &str)> = Vec::new();
        if self.low_level {
            let mode = base::ServoingMode::SingleLevelServoing;
            let info = base::ServoingModeInformation {
                servoing_mode: mode as i32,
            };
            steps.push((
                false,
                uid::SET_SERVOING_MODE,
                info.encode_to_vec(),
                mode.as_str_name(),
            ));
            self.low_level = false;
        }
        for udp in [true, false] {
            let link = if udp { &self.conn.udp } else { &self.conn.tcp };
            if link.session != 0 {
                steps.push((udp, uid::CLOSE_SESSION, Vec::new(), "leaving"));
            }
        }
        for (udp, rpc, payload, what) in steps {
            match self.call_until(udp, rpc, &payload, what, deadline) {
                Ok(Some(u)) => unanswered.push(u),
                Ok(None) => {}
                Err(e) => {
                    first_err.get_or_insert(e);
                }
            }
        }
        self.conn.tcp.session = 0;
        self.conn.udp.session = 0;
        first_err.map_or(Ok(unanswered), Err)
    }

    /// Sends `rpc` and waits until `deadline` for its answer: `Some` naming it if none came.
    fn call_until(
        &mut self,
        udp: bool,
        rpc: u32,
        payload: &[u8],
        what: &str,
        deadline: Instant,
    ) -> Result<Option<String>, String> {
        let id = self.send(udp, rpc, payload, what)?;
        let link = if udp {
            &mut self.conn.udp
        } else {
            &mut self.conn.tcp
        };
        let left = deadline.saturating_duration_since(Instant::now());
        match link.answer(id, left) {
            Ok(Some(_)) => Ok(None),
            Ok(None) => {
                let what = format!("({what}): no answer within {:?}", self.rpc_timeout);
                Ok(Some(self.unanswered(udp, rpc, id, &what)))
            }
            Err(e) => Err(format!("{}: {e}", self.conn.spec)),
        }
    }

    /// Logs that request `id` (`rpc`) got no answer; returns the same line.
    fn unanswered(&self, udp: bool, rpc: u32, id: u16, what: &str) -> String {
        let link = if udp { "UDP" } else { "TCP" };
        self.log(link, rpc, id, what);
        format!("kortex {link} {} message {id} {what}", uid::name(rpc))
    }
}
