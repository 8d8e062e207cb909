//! The vocabulary of a run: the units every arm is driven in ([`JOINTS`], [`Command`],
//! [`Span`]), the settings ([`ExecConfig`], [`WatchSettings`]), what can go wrong ([`Fault`],
//! [`CycleFault`], [`FaultReport`], [`ExecError`]) and what a run reports ([`Report`],
//! [`Progress`], and while it runs [`ArmStatus`]).
//!
//! This module imports nothing else of the crate: the links (CAN, Kortex), the loop that drives
//! them and the executor that composes both all speak it, and none of them is needed to read it.

mod fault;
mod overload;
mod report;
mod status;
pub mod watch;

pub use fault::{
    ArmStop, CycleFault, ExecError, Fault, FaultReport, LinkError, RealtimeRefused, TimingError,
    EMCY_FOLLOWING_ERROR,
};
pub use overload::BusOverload;
pub use report::{ArmReport, Progress, Report};
pub use status::{ArmState, ArmStatus, Measured};
pub use watch::{SettingsError, WatchSettings, DEFAULT_MISSED_CYCLES, MAX_MISSED_CYCLES};

use std::path::PathBuf;
use std::time::Duration;

/// Joints per arm (the Kinova Gen3 has 7; a 7-DoF Franka Panda streams the same way).
pub const JOINTS: usize = 7;

/// One arm's joint commands for one control cycle, in bus counts (1 count = 1e-7 rad, see
/// `cia402`).
pub type Command = [i32; JOINTS];

/// Per joint, the range (bus counts, lowest and highest) an arm's commands stay in.
pub type Span = [(i32, i32); JOINTS];

/// Every arm sends its stop frames within this many control periods of a fault's detection.
/// The arms stream in lockstep (no arm sends cycle k+1 before every arm has sent cycle k), so no
/// arm sends more than one further cycle after the cycle in which a fault was detected; each
/// arm thread looks at the shared fault flag many times a period while it waits, so its stop
/// follows within a fraction of a period, preemption by the OS aside.
pub const STOP_BOUND_PERIODS: u32 = 3;

/// The settings of one run: its period, its time-outs and its fault detection.
///
/// [`ExecConfig::default`] holds the command line's defaults (2 ms, the watchdog of
/// [`WatchSettings::default`], real-time priority 50 asked for).
///
/// ```
/// use omcbsa_hw::ExecConfig;
/// use std::time::Duration;
///
/// let cfg = ExecConfig { period: Duration::from_millis(1), ..ExecConfig::default() };
/// assert_eq!(cfg.watch.missed_cycles, 2);
/// // Every stop is promised within 3 periods of a fault's detection.
/// assert_eq!(cfg.period * omcbsa_hw::STOP_BOUND_PERIODS, Duration::from_millis(3));
/// ```
#[derive(Clone, Debug)]
pub struct ExecConfig {
    /// Control period (default 2 ms = 500 Hz, Kortex's and the dry run's: a CAN bus of
    /// 1 Mbit/s carries one CiA 402 arm from 4 ms, `bus::CAN_PERIOD`, and the executor refuses
    /// a bus loaded over `bus::MAX_LOAD`).
    pub period: Duration,
    /// Interpolate and check everything, write the log of what would be sent, send nothing.
    pub dry_run: bool,
    /// Where to write the command log (JSON lines, one per frame, written as the frames go
    /// out: nothing is kept in memory). A write error ends nothing: the later lines are
    /// dropped and the run's result is [`ExecError::Log`] (after the arms have stopped).
    pub log_path: Option<PathBuf>,
    /// Longest wait for a drive's answer to one SDO request at start-up (Kortex: for one
    /// rpc's answer, at least 500 ms).
    pub sdo_timeout: Duration,
    /// Time the drives get, after enabling, to report "operation enabled" by TPDO and heartbeat.
    pub startup_timeout: Duration,
    /// Fault detection: per-cycle accounting, heartbeat, following error ([`WatchSettings`]).
    pub watch: WatchSettings,
    /// Largest allowed distance of an arm's start position from the plan's first waypoint, rad.
    pub start_tolerance: f64,
    /// Largest wait for room on a bus when sending one frame.
    pub send_timeout: Duration,
    /// Cycles holding the final position, feedback still watched, before the drives are disabled.
    pub settle_cycles: usize,
    /// Online execution: the most motion a push may queue ahead of the fixed waypoint (each
    /// push is checked cycle by cycle over its whole tail while the stream waits, so this
    /// bounds a push's cost and the queue's memory).
    pub online_horizon: Duration,
    /// `SCHED_FIFO` priority (1 to 99) asked for the arm threads while they stream; `None`
    /// keeps normal scheduling. Refused (no `CAP_SYS_NICE`), the run goes on at normal
    /// priority and [`Report::realtime`] says why.
    pub realtime_priority: Option<u8>,
    /// Before any arm is set up, the machine's timer is measured at the period for this long
    /// (under the arm threads' scheduling) and a rate it does not hold is refused
    /// ([`crate::timing`]); `None` skips the check.
    pub preflight: Option<Duration>,
}

impl Default for ExecConfig {
    fn default() -> Self {
        Self {
            period: Duration::from_millis(2),
            dry_run: false,
            log_path: None,
            sdo_timeout: Duration::from_millis(100),
            startup_timeout: Duration::from_secs(1),
            watch: WatchSettings::default(),
            start_tolerance: 1e-3,
            send_timeout: Duration::from_millis(2),
            settle_cycles: 50,
            online_horizon: Duration::from_secs(20),
            realtime_priority: Some(50),
            preflight: Some(Duration::from_secs(1)),
        }
    }
}
