//! What can go wrong in a run: a fault seen while streaming ([`Fault`], [`CycleFault`]), how
//! every arm was stopped for it ([`FaultReport`]), and every error a run ends with
//! ([`ExecError`]).

use std::fmt;
use std::path::PathBuf;
use std::time::Duration;

/// EMCY error code of a following error (CiA 402): a drive whose actual position stayed beyond
/// its following-error window for the time-out.
pub const EMCY_FOLLOWING_ERROR: u16 = 0x8611;

/// A breach of the per-cycle accounting (`watchdog`), naming the source (its index: joint j's
/// drive or actuator is source j) and the cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CycleFault {
    /// `source` had not answered `cycle` when cycle `next` (= `cycle` + m or later) was due.
    Missing {
        /// The silent source.
        source: usize,
        /// The oldest cycle it owes an answer to.
        cycle: u64,
        /// The cycle that was due.
        next: u64,
    },
    /// `source`'s answer to `cycle` arrived after cycle `last_sent` (>= `cycle` + m) was sent.
    Late {
        /// The late source.
        source: usize,
        /// The cycle its answer answers.
        cycle: u64,
        /// The last cycle sent when the answer arrived.
        last_sent: u64,
    },
    /// `source` answered `cycle`, which has not been sent (the source or the link is confused).
    Unsent {
        /// The confused source.
        source: usize,
        /// The cycle its answer names.
        cycle: u64,
        /// Cycles sent so far.
        sent: u64,
    },
}

impl CycleFault {
    /// The source the fault is about.
    pub fn source(&self) -> usize {
        match *self {
            CycleFault::Missing { source, .. }
            | CycleFault::Late { source, .. }
            | CycleFault::Unsent { source, .. } => source,
        }
    }
}

/// Says what happened with "source N" standing for the source; callers name it (a node, an
/// actuator) in their own messages.
impl fmt::Display for CycleFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CycleFault::Missing { cycle, next, .. } => write!(
                f,
                "no answer to cycle {cycle} when cycle {next} was due ({} periods)",
                next - cycle
            ),
            CycleFault::Late {
                cycle, last_sent, ..
            } => write!(
                f,
                "answer to cycle {cycle} arrived after cycle {last_sent} was sent ({} periods \
                 stale)",
                last_sent - cycle
            ),
            CycleFault::Unsent { cycle, sent, .. } => write!(
                f,
                "answer to cycle {cycle}, which was never sent ({sent} cycles sent)"
            ),
        }
    }
}

/// What went wrong on an arm while streaming. Any fault stops every arm of the run.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// A drive sent an emergency message (CANopen EMCY).
    Emcy {
        /// The drive's node id (joint j is node j + 1).
        node: u8,
        /// The EMCY error code ([`EMCY_FOLLOWING_ERROR`]: the drive's own following error).
        code: u16,
        /// The drive's error register (0x1001).
        register: u8,
    },
    /// A drive's heartbeat stayed away longer than the consumer time
    /// ([`super::WatchSettings::heartbeat_consumer_time`]).
    HeartbeatLost {
        /// The drive's node id.
        node: u8,
        /// Since its last heartbeat (`Duration::MAX`: never heard).
        silent_for: Duration,
    },
    /// A drive's heartbeat reports a state other than operational.
    NmtState {
        /// The drive's node id.
        node: u8,
        /// The state it reports.
        state: &'static str,
    },
    /// The wall-clock backstop: a drive's position feedback missing for longer than
    /// [`super::WatchSettings::feedback_timeout`].
    FeedbackLost {
        /// The drive's node id.
        node: u8,
        /// Since the oldest cycle it has not answered (`Duration::MAX`: never heard).
        silent_for: Duration,
    },
    /// The per-cycle accounting: a cycle unanswered by its deadline, or answered late.
    Answer {
        /// The drive's node id, or the actuator's number (joint j: j + 1).
        node: u8,
        /// What the accounting found.
        fault: CycleFault,
    },
    /// A drive's statusword says it is not in "operation enabled" (or reports a fault).
    DriveState {
        /// The drive's node id.
        node: u8,
        /// Its statusword.
        statusword: u16,
    },
    /// The executor's own check: |target - actual| beyond
    /// [`super::WatchSettings::following_error_bound`].
    FollowingError {
        /// The drive's node id, or the actuator's number.
        node: u8,
        /// Measured position, rad.
        actual: f64,
        /// The target of the cycle the measurement answers, rad.
        target: f64,
    },
    /// The runtime limit check refused a command (it was not sent).
    CommandRefused(String),
    /// The arm answered with an error frame (Kortex): what it refused, and why.
    ArmRefused(String),
    /// An actuator, or the base, reports a fault in the cyclic feedback (Kortex; joint 0: the base).
    ActuatorFault {
        /// The actuator's number (1 to 7), or 0 for the base.
        joint: u8,
        /// Its fault bank A.
        bank_a: u32,
        /// Its fault bank B.
        bank_b: u32,
    },
    /// The link itself failed: a frame that could not be sent or received, an arm that did
    /// not answer its stop, an arm thread that fell behind the common schedule.
    Link(LinkError),
}

/// What went wrong on one arm's link (its bus or its connection), by what the loop was doing:
/// what [`crate::link::ArmLink`]'s methods return, and [`Fault::Link`] when it stops a run.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum LinkError {
    /// A start-up step failed (configuring or enabling the arm): the arm refused it, did not
    /// answer it, or is not as the plan needs it (where it stands, its limits, its mode). No
    /// motion command was sent.
    #[error("{0}")]
    Setup(String),
    /// A frame could not be sent or received: the bus or connection failed or closed.
    #[error("{0}")]
    Io(String),
    /// A frame of the arm's stop, or of its leaving, could not be sent or was refused (an
    /// error frame, a refused mode change): the arm may not have stopped.
    #[error("{0}")]
    StopFailed(String),
    /// The arm did not answer every frame of its normal stop: each frame, and what was
    /// missing.
    #[error("the arm did not answer its stop: {}", .0.join("; "))]
    StopUnanswered(Vec<String>),
    /// The arm's thread panicked (a bug): its arm is in an unknown state.
    #[error("the arm's thread panicked")]
    ThreadPanicked,
    /// An arm kept the others waiting on the common schedule longer than the backstop
    /// ([`super::WatchSettings::feedback_timeout`]): its thread stalled, or its bus is full.
    #[error("arm {arm:?} fell more than {after:?} behind the common schedule")]
    BehindSchedule {
        /// The arm that was behind.
        arm: String,
        /// The backstop.
        after: Duration,
    },
}

impl Fault {
    /// A breach of the per-cycle accounting as a fault of its source's joint (source j is
    /// joint j: node, or actuator, j + 1).
    pub fn answer(fault: CycleFault) -> Self {
        Fault::Answer {
            node: fault.source() as u8 + 1,
            fault,
        }
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let silent = |d: &Duration| {
            if *d == Duration::MAX {
                "never heard".to_string()
            } else {
                format!("silent for {d:?}")
            }
        };
        match self {
            Fault::Emcy {
                node,
                code,
                register,
            } => {
                write!(
                    f,
                    "node {node} sent EMCY error code {code:#06x}{} (error register {register:#04x})",
                    match *code {
                        EMCY_FOLLOWING_ERROR => ", following error beyond its window",
                        _ => "",
                    }
                )
            }
            Fault::HeartbeatLost { node, silent_for } => {
                write!(f, "node {node} heartbeat lost ({})", silent(silent_for))
            }
            Fault::NmtState { node, state } => {
                write!(f, "node {node} left the operational state ({state})")
            }
            Fault::FeedbackLost { node, silent_for } => {
                write!(
                    f,
                    "node {node} position feedback (TPDO) missing ({})",
                    silent(silent_for)
                )
            }
            Fault::Answer { node, fault } => write!(f, "node {node}: {fault}"),
            Fault::DriveState { node, statusword } => {
                write!(
                    f,
                    "node {node} drive not in operation enabled (statusword {statusword:#06x})"
                )
            }
            Fault::FollowingError {
                node,
                actual,
                target,
            } => write!(
                f,
                "node {node} following error {:.4} rad (actual {actual:.4}, target {target:.4})",
                (target - actual).abs()
            ),
            Fault::CommandRefused(e) => write!(f, "command refused by the limit check: {e}"),
            Fault::ArmRefused(e) => write!(f, "{e}"),
            Fault::ActuatorFault {
                joint: 0,
                bank_a,
                bank_b,
            } => write!(
                f,
                "the base reports a fault (fault banks A {bank_a:#010x}, B {bank_b:#010x})"
            ),
            Fault::ActuatorFault {
                joint,
                bank_a,
                bank_b,
            } => write!(
                f,
                "actuator {joint} reports a fault (fault banks A {bank_a:#010x}, B {bank_b:#010x})"
            ),
            Fault::Link(e) => write!(f, "link error: {e}"),
        }
    }
}

/// Why the arm threads run at normal priority: `SCHED_FIFO` was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RealtimeRefused {
    /// The system refused it (no `CAP_SYS_NICE`, no `rtprio` limit): the `errno` it gave.
    #[error("SCHED_FIFO priority {priority} refused: {}", std::io::Error::from_raw_os_error(*errno))]
    Refused {
        /// The priority asked for.
        priority: u8,
        /// The system's error number.
        errno: i32,
    },
    /// Not on this system (Linux only).
    #[error("SCHED_FIFO priority {0}: only on Linux")]
    Unsupported(u8),
}

/// How one arm was stopped after a fault.
#[derive(Clone, Debug)]
pub struct ArmStop {
    /// The arm's name.
    pub arm: String,
    /// Control cycles streamed before the stop.
    pub cycles_sent: usize,
    /// From the fault's detection to this arm's last stop frame.
    pub latency: Duration,
    /// The first stop frame that could not be sent, or that the arm refused (the arm may not
    /// have stopped: check it).
    pub error: Option<LinkError>,
    /// The stop frames the arm left unanswered (an arm that has stopped answering cannot
    /// confirm its stop: check it).
    pub unanswered: Vec<String>,
}

/// A fault and how every arm was stopped for it.
#[derive(Clone, Debug)]
pub struct FaultReport {
    /// The arm the fault was seen on.
    pub arm: String,
    /// The fault.
    pub fault: Fault,
    /// Control cycle in which the fault was detected.
    pub cycle: usize,
    /// One entry per arm that was streaming.
    pub stops: Vec<ArmStop>,
    /// The promised bound on every stop latency ([`super::STOP_BOUND_PERIODS`] periods).
    pub bound: Duration,
}

impl fmt::Display for FaultReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "fault on arm {:?} at cycle {}: {}",
            self.arm, self.cycle, self.fault
        )?;
        write!(f, "quick stop of every arm (bound {:?}):", self.bound)?;
        for s in &self.stops {
            write!(
                f,
                "\n  {}: stopped {:?} after detection, {} cycles streamed",
                s.arm, s.latency, s.cycles_sent
            )?;
            if let Some(e) = &s.error {
                write!(f, ", stop frame failed: {e}")?;
            }
            for u in &s.unanswered {
                write!(f, "\n    unanswered: {u}")?;
            }
        }
        Ok(())
    }
}

/// Why a run did not complete. Every variant but [`ExecError::Fault`] (and a late
/// [`ExecError::Log`]) is raised before any motion command is sent.
#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    /// The plan's shape is wrong (no arms, uneven paths, a bad `dt`, ...).
    #[error("invalid plan: {0}")]
    InvalidPlan(String),
    /// A fault-detection setting is out of its range.
    #[error("invalid watchdog settings: {0}")]
    Settings(super::watch::SettingsError),
    /// The arms given do not match the plan's (missing, unknown, twice).
    #[error("arms and buses do not match: {0}")]
    Buses(String),
    /// A CAN bus would be loaded over the share allowed (`crate::bus::MAX_LOAD`) by the
    /// arms on it at the run's period; no arm was set up.
    #[error("refusing to start: {0}")]
    BusLoad(Box<super::BusOverload>),
    /// The validator refused the plan.
    #[error("refusing to start: the plan does not validate: {0}")]
    Refused(String),
    /// A command the plan leads to breaks a joint limit.
    #[error("refusing to start: {0}")]
    Limits(String),
    /// An arm's start-up failed (per arm: its name and why); no drive of any arm was enabled.
    #[error("start-up failed, no motion command was sent: {}", .0.iter().map(|(a, e)| format!("arm {a:?}: {e}")).collect::<Vec<_>>().join("; "))]
    Startup(Vec<(String, LinkError)>),
    /// A fault stopped every arm.
    #[error("{0}")]
    Fault(Box<FaultReport>),
    /// The machine does not hold the control rate (measured before any arm was set up).
    #[error("refusing to start: {0}")]
    Timing(TimingError),
    /// The command log could not be written.
    #[error("cannot write the command log {path}: {error}")]
    Log {
        /// The log's path.
        path: PathBuf,
        /// The first error writing it.
        error: std::io::Error,
    },
}

/// Why a rate is refused (or could not be measured).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TimingError {
    /// The machine does not hold the rate.
    #[error(
        "this machine does not hold {hz:.0} Hz: 99 % of a {period:?} timer's wake-ups come \
         within {p99:?} of their deadline, over the {limit:?} the watchdog tolerates (median {p50:?}, \
         worst {max:?}, {scheduling}); lower the rate, run the arm threads under SCHED_FIFO \
         (root or CAP_SYS_NICE, `--rt-priority`), or run less beside them"
    )]
    RateNotHeld {
        /// The rate asked for, Hz.
        hz: f64,
        /// Its period.
        period: Duration,
        /// The measured 99th percentile of the lateness.
        p99: Duration,
        /// The median.
        p50: Duration,
        /// The worst.
        max: Duration,
        /// The lateness tolerated: a period.
        limit: Duration,
        /// What the thread ran under.
        scheduling: String,
    },
    /// The measurement's arguments are out of range.
    #[error("timer measurement: {0}")]
    Arguments(&'static str),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_breach_of_the_accounting_names_the_joint_of_its_source() {
        let fault = CycleFault::Missing {
            source: 2,
            cycle: 5,
            next: 7,
        };
        let f = Fault::answer(fault);
        assert_eq!(f, Fault::Answer { node: 3, fault });
        assert_eq!(
            f.to_string(),
            "node 3: no answer to cycle 5 when cycle 7 was due (2 periods)"
        );
    }
}
