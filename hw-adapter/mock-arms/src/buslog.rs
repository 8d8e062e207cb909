//! The bus logs the mock drives write (candump `-L` format, python-can's `CanutilsLogWriter`):
//! every frame on an arm's bus with the time it crossed the mock's end of it, `R` from the host,
//! `T` from the drives. From them, the fault reaction: when a fault became visible on the bus,
//! and when each arm's quick stop reached its drives.

use omcbsa_hw::canopen::{self, Message, NMT_STATE_OPERATIONAL, SYNC_ID};
use omcbsa_hw::cia402;
use omcbsa_hw::frame::CanFrame;
use omcbsa_hw::run::{Fault, WatchSettings, JOINTS};
use std::collections::VecDeque;
use std::path::Path;

/// One frame of a bus log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Logged {
    /// Seconds (Unix time, as the mock stamped it).
    pub t: f64,
    /// Sent by the host (`R` at the mock), else by a drive (`T`).
    pub from_host: bool,
    /// The frame.
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

/// The first sign of a fault on the faulty arm's bus, and the grace the rules give before the
/// stop bound (in periods) starts counting.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sign {
    /// When the fault first showed, s (the mock's time stamps).
    pub t: f64,
    /// The heartbeat consumer time for a lost heartbeat, the drive's following-error time-out
    /// for a lag it reports itself; else 0.
    pub grace: f64,
}

/// The first sign of `fault` on the faulty arm's bus `log`, from the frames alone where they
/// tell (not from when the executor's thresholds fire): the EMCY; for the drive's following
/// error (EMCY 0x8611), the first TPDO off its target by more than the window written to
/// 0x6065, with the time-out written to 0x6066 as grace; the first TPDO with the drive out of
/// "operation enabled"; the first heartbeat out of operational; for a lost heartbeat, the last
/// heartbeat, with the consumer time of `watch` as grace; for a SYNC unanswered or answered
/// late, the first SYNC of the run of SYNCs the node left unanswered until the next SYNC that
/// the stop ended; for the executor's own following-error check, the first TPDO off its target
/// by more than its bound. `None` if the log does not show it (or the fault is not about a
/// drive).
pub fn first_sign(log: &[Logged], fault: &Fault, watch: &WatchSettings) -> Option<Sign> {
    let now = |t| Sign { t, grace: 0.0 };
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
        Fault::Emcy {
            code: cia402::EMCY_FOLLOWING_ERROR,
            ..
        } => {
            let (window, time_out) = following_error_settings(log);
            let t = (1..=JOINTS as u8)
                .filter_map(|node| beyond(log, node, |_| window[usize::from(node) - 1]))
                .min_by(f64::total_cmp)?;
            Some(Sign {
                t,
                grace: time_out.iter().copied().max()? as f64 * 1e-3,
            })
        }
        Fault::Emcy { node, .. } => from(node)
            .find_map(|(t, m)| match m {
                Message::Emcy(e) if e.code != 0 => Some(t),
                _ => None,
            })
            .map(now),
        Fault::DriveState { node, .. } => feedback(node)
            .skip_while(|(_, (_, sw))| !cia402::operation_enabled(*sw))
            .find(|(_, (_, sw))| !cia402::operation_enabled(*sw))
            .map(|(t, _)| now(t)),
        Fault::NmtState { node, .. } => heartbeats(node)
            .skip_while(|(_, s)| *s != NMT_STATE_OPERATIONAL)
            .find(|(_, s)| *s != NMT_STATE_OPERATIONAL)
            .map(|(t, _)| now(t)),
        Fault::HeartbeatLost { node, .. } => {
            let consumer = watch.heartbeat_consumer_time().as_secs_f64();
            // watched from the node's first operational heartbeat on
            let beats: Vec<f64> = heartbeats(node)
                .skip_while(|(_, s)| *s != NMT_STATE_OPERATIONAL)
                .map(|(t, _)| t)
                .collect();
            let gap = beats.windows(2).find(|w| w[1] - w[0] > consumer);
            gap.map(|w| w[0])
                .or(beats.last().copied())
                .map(|t| Sign { t, grace: consumer })
        }
        Fault::FeedbackLost { node, .. } | Fault::Answer { node, .. } => {
            unanswered_since(log, node).map(now)
        }
        Fault::FollowingError { node, .. } => {
            let bound = (watch.following_error_bound * cia402::COUNTS_PER_RAD) as u32;
            beyond(log, node, |_| bound).map(now)
        }
        // Not CAN faults: the Kortex mocks' records measure these.
        Fault::CommandRefused(_)
        | Fault::Link(_)
        | Fault::ArmRefused(_)
        | Fault::ActuatorFault { .. } => None,
    }
}

/// Per node (joint j at index j), the following error window and time-out last written to it
/// by SDO (0 where none was).
fn following_error_settings(log: &[Logged]) -> ([u32; JOINTS], [u16; JOINTS]) {
    let (mut window, mut time_out) = ([0; JOINTS], [0; JOINTS]);
    for f in log.iter().filter(|f| f.from_host) {
        let id = usize::from(f.frame.id());
        let (d, node) = (f.frame.data(), id.wrapping_sub(0x601));
        // an expedited SDO download (0x23: 4 bytes, 0x2B: 2 bytes) to a joint's node
        if !(node < JOINTS && d.len() == 8 && matches!(d[0], 0x23 | 0x2B)) {
            continue;
        }
        let value = u32::from_le_bytes([d[4], d[5], d[6], d[7]]);
        match u16::from_le_bytes([d[1], d[2]]) {
            cia402::FOLLOWING_ERROR_WINDOW => window[node] = value,
            cia402::FOLLOWING_ERROR_TIME_OUT => time_out[node] = value as u16,
            _ => {}
        }
    }
    (window, time_out)
}

/// The first TPDO of `node` whose position is off by more than `bound` (counts) from the
/// target the drive applied at the SYNC it answers (the last RPDO before that SYNC).
fn beyond(log: &[Logged], node: u8, bound: impl Fn(u8) -> u32) -> Option<f64> {
    let (rpdo, tpdo) = (canopen::rpdo1_cob_id(node), canopen::tpdo1_cob_id(node));
    let (mut sent, mut applied) = (None, None);
    log.iter().find_map(|f| {
        let id = u32::from(f.frame.id());
        if f.from_host && id == rpdo {
            // RPDO1 has TPDO1's layout: a position (the target), then a 16-bit word
            sent = cia402::parse_tpdo1(f.frame.data()).map(|(counts, _)| counts);
        } else if is_sync(f) {
            applied = sent.or(applied);
        } else if !f.from_host && id == tpdo {
            let (pos, _) = cia402::parse_tpdo1(f.frame.data())?;
            let goal = applied?;
            return (goal.abs_diff(pos) > bound(node)).then_some(f.t);
        }
        None
    })
}

/// The first SYNC of the last run of SYNCs that `node` left unanswered until the next SYNC
/// (from the NMT start on, each TPDO1 of `node` answers the oldest SYNC not yet answered),
/// up to the first quick stop.
fn unanswered_since(log: &[Logged], node: u8) -> Option<f64> {
    let start = log.iter().position(|f| {
        f.from_host
            && f.frame.id() == canopen::NMT_ID
            && matches!(f.frame.data(), [1, n] if *n == 0 || *n == node)
    })?;
    let end = quick_stop_index(log).unwrap_or(log.len());
    let tpdo = canopen::tpdo1_cob_id(node);
    // (send time, answered before the next SYNC) of each SYNC, and the ones owed
    let mut syncs: Vec<(f64, bool)> = Vec::new();
    let mut owed = VecDeque::new();
    for (i, f) in log.iter().enumerate().skip(start) {
        if is_sync(f) {
            // the stop's SYNC ends the search
            if i > end {
                break;
            }
            owed.push_back(syncs.len());
            syncs.push((f.t, false));
        } else if !f.from_host && u32::from(f.frame.id()) == tpdo {
            if let Some(k) = owed.pop_front() {
                // in time if no later SYNC had been sent yet
                syncs[k].1 = k + 1 == syncs.len();
            }
        }
    }
    let last_in_time = syncs.iter().rposition(|s| s.1);
    syncs.get(last_in_time.map_or(0, |i| i + 1)).map(|s| s.0)
}

/// The index of an arm's first quick-stop RPDO.
fn quick_stop_index(log: &[Logged]) -> Option<usize> {
    log.iter().position(|f| {
        f.from_host
            && matches!(f.frame.id(), 0x201..=0x27F)
            // RPDO1 has TPDO1's layout: target position, then the controlword
            && cia402::parse_tpdo1(f.frame.data())
                .is_some_and(|(_, cw)| cw == cia402::CW_QUICK_STOP)
    })
}

/// When an arm's quick stop reached its drives: the SYNC after its first quick-stop RPDO.
pub fn quick_stop_time(log: &[Logged]) -> Option<f64> {
    let first_stop = quick_stop_index(log)?;
    log[first_stop..].iter().find(|f| is_sync(f)).map(|f| f.t)
}

/// Targets the arm's drives received after its quick stop: RPDOs with any controlword but
/// the quick stop's, after the first quick-stop RPDO (none if there was no stop).
pub fn targets_after_stop(log: &[Logged]) -> usize {
    let Some(first_stop) = quick_stop_index(log) else {
        return 0;
    };
    (log[first_stop..].iter())
        .filter(|f| f.from_host && matches!(f.frame.id(), 0x201..=0x27F))
        .filter(|f| {
            cia402::parse_tpdo1(f.frame.data()).is_none_or(|(_, cw)| cw != cia402::CW_QUICK_STOP)
        })
        .count()
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
    fn first_signs_and_stops_from_frames() {
        let watch = WatchSettings {
            following_error_bound: 0.05,
            ..WatchSettings::default()
        };
        let enabled = cia402::rpdo1_payload(0, 0x0237);
        let faulted = cia402::rpdo1_payload(0, 0x0008);
        let far = cia402::rpdo1_payload(1_000_000, 0x0237); // 0.1 rad
        let window = 500_000u32.to_le_bytes(); // 0.05 rad
        let log = [
            frame(
                0.8,
                true,
                0x603,
                &[0x23, 0x65, 0x60, 0, window[0], window[1], window[2], 0],
            ),
            frame(0.85, true, 0x603, &[0x2B, 0x66, 0x60, 0, 10, 0, 0, 0]),
            frame(0.9, true, 0x000, &[1, 0]),
            frame(1.0, false, 0x703, &[0x05]),
            frame(1.1, true, 0x203, &cia402::rpdo1_payload(0, 0x0F)),
            frame(1.2, true, 0x080, &[]),
            frame(1.3, false, 0x183, &enabled),
            frame(1.4, false, 0x183, &far),
            frame(1.45, true, 0x080, &[]),
            frame(1.5, false, 0x083, &[0x10, 0x23, 1, 0, 0, 0, 0, 0]),
            frame(1.55, true, 0x080, &[]),
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
        let sign = |f: Fault| first_sign(&log, &f, &watch);
        let at = |t| Some(Sign { t, grace: 0.0 });
        let emcy = |node, code| Fault::Emcy {
            node,
            code,
            register: 1,
        };
        assert_eq!(sign(emcy(3, 0x2310)), at(1.5));
        assert_eq!(sign(emcy(2, 0x2310)), None);
        // the drive's own following error: the first TPDO beyond the window it was given,
        // with its time-out as grace
        assert_eq!(
            sign(emcy(3, cia402::EMCY_FOLLOWING_ERROR)),
            Some(Sign {
                t: 1.4,
                grace: 0.01
            })
        );
        let drive = Fault::DriveState {
            node: 3,
            statusword: 8,
        };
        assert_eq!(sign(drive), at(1.6));
        let nmt = Fault::NmtState {
            node: 3,
            state: "stopped",
        };
        assert_eq!(sign(nmt), at(1.7));
        let lost = Fault::HeartbeatLost {
            node: 3,
            silent_for: Duration::ZERO,
        };
        // 0.7 s between the two heartbeats: the sign is the first, the consumer time grace
        let consumer = watch.heartbeat_consumer_time().as_secs_f64();
        let hb = Some(Sign {
            t: 1.0,
            grace: consumer,
        });
        assert_eq!(sign(lost.clone()), hb);
        // no heartbeat after the one at 1.0
        assert_eq!(first_sign(&log[..10], &lost, &watch), hb);
        let fe = Fault::FollowingError {
            node: 3,
            actual: 0.1,
            target: 0.0,
        };
        assert_eq!(sign(fe), at(1.4));
        // SYNC 1.2 answered in time (1.3); 1.45 answered only after 1.55 was sent; 1.55 never
        let cycle = omcbsa_hw::watchdog::CycleFault::Missing {
            source: 2,
            cycle: 1,
            next: 3,
        };
        let answer = Fault::Answer {
            node: 3,
            fault: cycle,
        };
        assert_eq!(sign(answer), at(1.45));
        let silent = Fault::FeedbackLost {
            node: 3,
            silent_for: Duration::ZERO,
        };
        assert_eq!(first_sign(&log[..9], &silent, &watch), at(1.45));
        assert_eq!(first_sign(&log[..7], &silent, &watch), None);
        assert_eq!(quick_stop_time(&log), Some(1.9));
        assert_eq!(quick_stop_time(&log[..14]), None);
        assert_eq!(targets_after_stop(&log), 0);
        let mut more = log.to_vec();
        more.push(frame(2.0, true, 0x201, &cia402::rpdo1_payload(5, 0x0F)));
        assert_eq!(targets_after_stop(&more), 1);
    }
}
