//! The bus logs the mock drives write (candump `-L` format, python-can's `CanutilsLogWriter`):
//! every frame on an arm's bus with the time it crossed the mock's end of it, `R` from the host,
//! `T` from the drives. From them, the fault reaction: when a fault became visible on the bus,
//! and when each arm's quick stop reached its drives.

use crate::canopen::{self, Message, NMT_STATE_OPERATIONAL, SYNC_ID};
use crate::cia402::{self, counts_to_rad};
use crate::executor::{ExecConfig, Fault};
use crate::frame::CanFrame;
use std::collections::VecDeque;
use std::path::Path;

/// One frame of a bus log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Logged {
    /// Seconds (Unix time, as the mock stamped it).
    pub t: f64,
    /// Sent by the host (`R` at the mock), else by a drive (`T`).
    pub from_host: bool,
    pub frame: CanFrame,
}

/// Parses one line, e.g. `(1795461605.878019) can0 701#05 T`.
fn parse_line(line: &str) -> Option<Logged> {
    let mut parts = line.split_whitespace();
    let t = parts
        .next()?
        .strip_prefix('(')?
        .strip_suffix(')')?
        .parse()
        .ok()?;
    let _channel = parts.next()?;
    let (id, data) = parts.next()?.split_once('#')?;
    let from_host = match parts.next()? {
        "R" => true,
        "T" => false,
        _ => return None,
    };
    if parts.next().is_some() || data.len() % 2 != 0 || id.len() != 3 {
        return None;
    }
    let bytes = (0..data.len() / 2)
        .map(|i| u8::from_str_radix(&data[2 * i..2 * i + 2], 16).ok())
        .collect::<Option<Vec<u8>>>()?;
    let frame = CanFrame::new(u16::from_str_radix(id, 16).ok()?, &bytes)?;
    Some(Logged {
        t,
        from_host,
        frame,
    })
}

/// Reads a bus log; a line that is not a classic CAN frame in candump `-L` format is an error.
pub fn read(path: &Path) -> Result<Vec<Logged>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read bus log {}: {e}", path.display()))?;
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            parse_line(l).ok_or_else(|| {
                format!(
                    "{} line {}: not a candump -L frame: {l:?}",
                    path.display(),
                    i + 1
                )
            })
        })
        .collect()
}

fn is_sync(f: &Logged) -> bool {
    f.from_host && f.frame.id() == SYNC_ID && f.frame.data().is_empty()
}

/// When `fault` became visible on the faulty arm's bus `log`, by the executor's own rules in
/// `cfg`: the EMCY, the first TPDO with the drive out of "operation enabled", the first
/// heartbeat out of operational, the first TPDO off its target by more than the bound; for a
/// silence, the moment it outlasted its timeout. `None` if the log does not show it (or the
/// fault is not about a drive).
pub fn fault_onset(log: &[Logged], fault: &Fault, cfg: &ExecConfig) -> Option<f64> {
    let from = |node: u8| {
        log.iter()
            .filter(move |f| !f.from_host)
            .filter_map(move |f| match canopen::decode(&f.frame) {
                m @ (Message::Heartbeat { node: n, .. }
                | Message::Tpdo1 { node: n, .. }
                | Message::Emcy(canopen::Emcy { node: n, .. }))
                    if n == node =>
                {
                    Some((f.t, m))
                }
                _ => None,
            })
    };
    let feedback = |node: u8| {
        from(node).filter_map(|(t, m)| match m {
            Message::Tpdo1 { data, .. } => cia402::parse_tpdo1(data.data()).map(|p| (t, p)),
            _ => None,
        })
    };
    let heartbeats = |node: u8| {
        from(node).filter_map(|(t, m)| match m {
            Message::Heartbeat { state, .. } => Some((t, state)),
            _ => None,
        })
    };
    match *fault {
        Fault::Emcy { node, .. } => from(node).find_map(|(t, m)| match m {
            Message::Emcy(e) if e.code != 0 => Some(t),
            _ => None,
        }),
        Fault::DriveState { node, .. } => feedback(node)
            .skip_while(|(_, (_, sw))| !cia402::operation_enabled(*sw))
            .find(|(_, (_, sw))| !cia402::operation_enabled(*sw))
            .map(|(t, _)| t),
        Fault::NmtState { node, .. } => heartbeats(node)
            .skip_while(|(_, s)| *s != NMT_STATE_OPERATIONAL)
            .find(|(_, s)| *s != NMT_STATE_OPERATIONAL)
            .map(|(t, _)| t),
        Fault::HeartbeatLost { node, .. } => {
            let timeout = cfg.heartbeat_timeout.as_secs_f64();
            // watched from the node's first operational heartbeat on
            let beats: Vec<f64> = heartbeats(node)
                .skip_while(|(_, s)| *s != NMT_STATE_OPERATIONAL)
                .map(|(t, _)| t)
                .collect();
            let gap = beats.windows(2).find(|w| w[1] - w[0] > timeout);
            gap.map(|w| w[0])
                .or(beats.last().copied())
                .map(|t| t + timeout)
        }
        Fault::FeedbackLost { node, .. } => {
            // From the NMT start on, each TPDO of `node` answers the oldest SYNC not yet
            // answered; the first SYNC answered late, or never, by more than the timeout.
            let timeout = cfg.feedback_timeout.as_secs_f64();
            let start = log.iter().position(|f| {
                f.from_host
                    && f.frame.id() == canopen::NMT_ID
                    && matches!(f.frame.data(), [1, n] if *n == 0 || *n == node)
            })?;
            let tpdo = canopen::tpdo1_cob_id(node);
            let mut owed = VecDeque::new();
            for f in &log[start..] {
                if is_sync(f) {
                    owed.push_back(f.t);
                } else if !f.from_host && u32::from(f.frame.id()) == tpdo {
                    match owed.pop_front() {
                        Some(s) if f.t - s > timeout => return Some(s + timeout),
                        _ => {}
                    }
                }
            }
            owed.front().map(|s| s + timeout)
        }
        Fault::FollowingError { node, .. } => {
            let rpdo = canopen::rpdo1_cob_id(node);
            let mut target = None;
            log.iter().find_map(|f| {
                if f.from_host && u32::from(f.frame.id()) == rpdo {
                    // RPDO1 has TPDO1's layout: a position (the target), then a 16-bit word
                    target = cia402::parse_tpdo1(f.frame.data()).map(|(counts, _)| counts);
                    return None;
                }
                let (Message::Tpdo1 { node: n, data }, Some(goal)) =
                    (canopen::decode(&f.frame), target)
                else {
                    return None;
                };
                let (pos, _) = cia402::parse_tpdo1(data.data())?;
                (n == node
                    && !f.from_host
                    && counts_to_rad(goal - pos).abs() > cfg.following_error_bound)
                    .then_some(f.t)
            })
        }
        // Not CAN faults: the Kortex mocks' records measure these.
        Fault::CommandRefused(_)
        | Fault::Bus(_)
        | Fault::ArmRefused(_)
        | Fault::ActuatorFault { .. }
        | Fault::Unanswered { .. } => None,
    }
}

/// When an arm's quick stop reached its drives: the SYNC after its first quick-stop RPDO.
pub fn quick_stop_time(log: &[Logged]) -> Option<f64> {
    let first_stop = log.iter().position(|f| {
        f.from_host
            && matches!(f.frame.id(), 0x201..=0x27F)
            // RPDO1 has TPDO1's layout: target position, then the controlword
            && cia402::parse_tpdo1(f.frame.data())
                .is_some_and(|(_, cw)| cw == cia402::CW_QUICK_STOP)
    })?;
    log[first_stop..].iter().find(|f| is_sync(f)).map(|f| f.t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn frame(t: f64, from_host: bool, id: u16, data: &[u8]) -> Logged {
        Logged {
            t,
            from_host,
            frame: CanFrame::new(id, data).unwrap(),
        }
    }

    #[test]
    fn parses_candump_lines_and_refuses_others() {
        assert_eq!(
            parse_line("(1795461605.878019) can0 203#C2330E000F00 R"),
            Some(frame(
                1795461605.878019,
                true,
                0x203,
                &[0xC2, 0x33, 0x0E, 0, 0x0F, 0]
            ))
        );
        assert_eq!(
            parse_line("(1.5) can0 080# T"),
            Some(frame(1.5, false, 0x80, &[]))
        );
        for bad in [
            "1.5 can0 080# T",
            "(1.5) can0 080#0 T",
            "(1.5) can0 12345678#00 T",
            "(1.5) can0 080#00 X",
            "(1.5) can0 080#00",
            "(1.5) can0 080#001122334455667788 T",
        ] {
            assert_eq!(parse_line(bad), None, "{bad}");
        }
    }

    #[test]
    fn onsets_and_stops_from_frames() {
        let cfg = ExecConfig {
            heartbeat_timeout: Duration::from_millis(500),
            feedback_timeout: Duration::from_millis(250),
            following_error_bound: 0.05,
            ..ExecConfig::default()
        };
        let enabled = cia402::rpdo1_payload(0, 0x0237);
        let faulted = cia402::rpdo1_payload(0, 0x0008);
        let far = cia402::rpdo1_payload(1_000_000, 0x0237); // 0.1 rad
        let log = [
            frame(0.9, true, 0x000, &[1, 0]),
            frame(1.0, false, 0x703, &[0x05]),
            frame(1.1, true, 0x203, &cia402::rpdo1_payload(0, 0x0F)),
            frame(1.2, true, 0x080, &[]),
            frame(1.3, false, 0x183, &enabled),
            frame(1.4, false, 0x183, &far),
            frame(1.5, false, 0x083, &[0x10, 0x23, 1, 0, 0, 0, 0, 0]),
            frame(1.6, false, 0x183, &faulted),
            frame(1.7, false, 0x703, &[0x04]),
            frame(
                1.8,
                true,
                0x203,
                &cia402::rpdo1_payload(0, cia402::CW_QUICK_STOP),
            ),
            frame(1.9, true, 0x080, &[]),
        ];
        let onset = |f: Fault| fault_onset(&log, &f, &cfg);
        assert_eq!(
            onset(Fault::Emcy {
                node: 3,
                code: 0x2310,
                register: 1
            }),
            Some(1.5)
        );
        assert_eq!(
            onset(Fault::Emcy {
                node: 2,
                code: 0x2310,
                register: 1
            }),
            None
        );
        assert_eq!(
            onset(Fault::DriveState {
                node: 3,
                statusword: 8
            }),
            Some(1.6)
        );
        assert_eq!(
            onset(Fault::NmtState {
                node: 3,
                state: "stopped"
            }),
            Some(1.7)
        );
        let hb = onset(Fault::HeartbeatLost {
            node: 3,
            silent_for: Duration::ZERO,
        });
        // 0.7 s between the two heartbeats: lost 0.5 s after the first
        assert_eq!(hb, Some(1.0 + 0.5));
        // no heartbeat after the one at 1.0
        let last_only = fault_onset(
            &log[..8],
            &Fault::HeartbeatLost {
                node: 3,
                silent_for: Duration::ZERO,
            },
            &cfg,
        );
        assert_eq!(last_only, Some(1.0 + 0.5));
        let fe = Fault::FollowingError {
            node: 3,
            actual: 0.1,
            target: 0.0,
        };
        assert_eq!(onset(fe), Some(1.4));
        // the SYNC at 1.9 is never answered; the one at 1.2 is
        let fl = onset(Fault::FeedbackLost {
            node: 3,
            silent_for: Duration::ZERO,
        });
        assert_eq!(fl, Some(1.9 + 0.25));
        assert_eq!(quick_stop_time(&log), Some(1.9));
        assert_eq!(quick_stop_time(&log[..10]), None);
    }
}
