//! The executor: validates, interpolates, starts every arm together (one thread per bus),
//! streams, watches the feedback, and on any fault quick-stops every arm.

use crate::arm::{cycle_frames, SetupOverride, Span};
use crate::cia402;
use crate::interpolate::{peak_speeds, plan_generator};
use crate::link::ArmPort;
use crate::live::{self, RunInfo, StreamHandle};
use crate::log::LogEntry;
use crate::plan::{ArmLimits, Plan, PlanValidator, JOINTS};
use crate::stream::Generator;
use crate::watch::WatchSettings;
use crate::watchdog::CycleFault;
use std::fmt;
use std::path::PathBuf;
use std::time::Duration;

/// Every arm sends its stop frames within this many control periods of a fault's detection.
/// The arms stream in lockstep (no arm sends cycle k+1 before every arm has sent cycle k), so no
/// arm sends more than one further cycle after the cycle in which a fault was detected; each
/// arm thread looks at the shared fault flag at least every `FAULT_POLL` while it waits, so
/// its stop follows within a fraction of a period, preemption by the OS aside.
pub const STOP_BOUND_PERIODS: u32 = 3;

#[derive(Clone, Debug)]
pub struct ExecConfig {
    /// Control period (default 2 ms = 500 Hz).
    pub period: Duration,
    /// Interpolate and check everything, write the log of what would be sent, send nothing.
    pub dry_run: bool,
    /// Where to write the command log (JSON lines).
    pub log_path: Option<PathBuf>,
    pub sdo_timeout: Duration,
    /// Time the drives get, after enabling, to report "operation enabled" by TPDO and heartbeat.
    pub startup_timeout: Duration,
    /// Fault detection: per-cycle accounting, heartbeat, following error ([`WatchSettings`]).
    pub watch: WatchSettings,
    /// Backstops on the wall clock, behind the per-cycle accounting: a SYNC unanswered for
    /// longer is a fault, and so is an arm that keeps the others waiting longer on the common
    /// schedule (its thread stalled, its bus full).
    pub feedback_timeout: Duration,
    /// Largest allowed distance of an arm's start position from the plan's first waypoint, rad.
    pub start_tolerance: f64,
    /// Largest wait for room on a bus when sending one frame.
    pub send_timeout: Duration,
    /// Cycles holding the final position, feedback still watched, before the drives are disabled.
    pub settle_cycles: usize,
    /// Online execution: the most motion a push may queue ahead of the fixed waypoint (each
    /// push is checked cycle by cycle over its whole tail while the stream waits).
    pub online_horizon: Duration,
    /// `SCHED_FIFO` priority (1 to 99) asked for the arm threads while they stream; `None`
    /// keeps normal scheduling. Refused (no `CAP_SYS_NICE`), the run goes on at normal
    /// priority and [`Report::realtime`] says why.
    pub realtime_priority: Option<u8>,
    /// Tests only: one start-up SDO write changed on purpose ([`SetupOverride`]).
    #[doc(hidden)]
    pub setup_override: Option<SetupOverride>,
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
            feedback_timeout: Duration::from_millis(50),
            start_tolerance: 1e-3,
            send_timeout: Duration::from_millis(2),
            settle_cycles: 50,
            online_horizon: Duration::from_secs(20),
            realtime_priority: Some(50),
            setup_override: None,
        }
    }
}

/// What went wrong on an arm while streaming.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    Emcy {
        node: u8,
        code: u16,
        register: u8,
    },
    HeartbeatLost {
        node: u8,
        silent_for: Duration,
    },
    NmtState {
        node: u8,
        state: &'static str,
    },
    FeedbackLost {
        node: u8,
        silent_for: Duration,
    },
    /// The per-cycle accounting: a SYNC unanswered by its deadline, or answered late.
    Answer {
        node: u8,
        fault: CycleFault,
    },
    DriveState {
        node: u8,
        statusword: u16,
    },
    FollowingError {
        node: u8,
        actual: f64,
        target: f64,
    },
    /// The runtime limit check refused a command (it was not sent).
    CommandRefused(String),
    /// The arm answered with an error frame (Kortex): what it refused, and why.
    ArmRefused(String),
    /// An actuator, or the base, reports a fault in the cyclic feedback (Kortex; joint 0: the base).
    ActuatorFault {
        joint: u8,
        bank_a: u32,
        bank_b: u32,
    },
    Bus(String),
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
                        cia402::EMCY_FOLLOWING_ERROR => ", following error beyond its window",
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
            Fault::Bus(e) => write!(f, "bus error: {e}"),
        }
    }
}

/// How one arm was stopped after a fault.
#[derive(Clone, Debug)]
pub struct ArmStop {
    pub arm: String,
    /// Control cycles streamed before the stop.
    pub cycles_sent: usize,
    /// From the fault's detection to this arm's last stop frame.
    pub latency: Duration,
    /// A stop frame that could not be sent.
    pub error: Option<String>,
}

#[derive(Clone, Debug)]
pub struct FaultReport {
    pub arm: String,
    pub fault: Fault,
    /// Control cycle in which the fault was detected.
    pub cycle: usize,
    pub stops: Vec<ArmStop>,
    /// The promised bound on every stop latency.
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
        }
        Ok(())
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ExecError {
    #[error("invalid plan: {0}")]
    InvalidPlan(String),
    #[error("invalid watchdog settings: {0}")]
    Settings(String),
    #[error("arms and buses do not match: {0}")]
    Buses(String),
    #[error("refusing to start: the plan does not validate: {0}")]
    Refused(String),
    #[error("refusing to start: {0}")]
    Limits(String),
    #[error("start-up failed, no motion command was sent: {}", .0.iter().map(|(a, e)| format!("arm {a:?}: {e}")).collect::<Vec<_>>().join("; "))]
    Startup(Vec<(String, String)>),
    #[error("{0}")]
    Fault(Box<FaultReport>),
    #[error("cannot write the command log {path}: {error}")]
    Log {
        path: PathBuf,
        error: std::io::Error,
    },
}

#[derive(Clone, Debug)]
pub struct ArmReport {
    pub name: String,
    pub cycles_sent: usize,
    pub max_following_error: f64,
}

#[derive(Clone, Debug)]
pub struct Report {
    pub dry_run: bool,
    pub period: Duration,
    /// Uniform slow-down applied to the plan (1 = as planned).
    pub time_scale: f64,
    /// Control cycles of the trajectory (without the settle cycles).
    pub cycles: usize,
    pub frames_sent: usize,
    pub arms: Vec<ArmReport>,
    /// Largest delay of a cycle behind its schedule.
    pub max_lateness: Duration,
    /// Online execution: times the queue ran dry and the arms held.
    pub holds: usize,
    /// The arm threads' scheduling: `Ok` under the asked-for real-time priority (or none
    /// asked), else why it was refused.
    pub realtime: Result<(), String>,
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mode = if self.dry_run { "dry run" } else { "executed" };
        write!(
            f,
            "{mode}: {} arms, {} cycles at {:?} ({:.3} s), {} frames",
            self.arms.len(),
            self.cycles,
            self.period,
            self.cycles as f64 * self.period.as_secs_f64(),
            self.frames_sent
        )?;
        if self.time_scale > 1.0 {
            write!(
                f,
                "\nplan slowed down {:.3}x to stay within velocity/acceleration limits",
                self.time_scale
            )?;
        }
        for a in &self.arms {
            write!(
                f,
                "\n  {}: {} cycles, max following error {:.2e} rad",
                a.name, a.cycles_sent, a.max_following_error
            )?;
        }
        if self.holds > 0 {
            write!(
                f,
                "\nthe queue ran dry {} times (the arms held)",
                self.holds
            )?;
        }
        if !self.dry_run {
            write!(f, "\nlargest cycle lateness {:?}", self.max_lateness)?;
            if let Err(why) = &self.realtime {
                write!(f, "\nstreamed at normal priority: {why}")?;
            }
        }
        Ok(())
    }
}

/// Progress of one arm, passed to the progress callback about every 0.1 s of streaming.
#[derive(Clone, Debug)]
pub struct Progress<'a> {
    pub arm: &'a str,
    pub cycle: usize,
    pub cycles: usize,
}

pub(crate) type ProgressFn = Box<dyn Fn(Progress) + Send + Sync>;

pub struct Executor {
    plan: Plan,
    /// One table per plan arm, in plan order.
    limits: Vec<ArmLimits>,
    /// One port per plan arm, in plan order.
    buses: Vec<ArmPort>,
    config: ExecConfig,
    progress: Option<ProgressFn>,
}

impl Executor {
    /// `arms` pairs each plan arm's name with its bus or Kortex connection ([`ArmPort`]);
    /// every plan arm needs exactly one (none in a dry run). `limits` holds each plan arm's
    /// joint limits, in plan order.
    pub fn new<P: Into<ArmPort>>(
        plan: Plan,
        limits: Vec<ArmLimits>,
        arms: Vec<(String, P)>,
        config: ExecConfig,
    ) -> Result<Self, ExecError> {
        let mut arms: Vec<(String, ArmPort)> =
            arms.into_iter().map(|(n, p)| (n, p.into())).collect();
        plan.check_shape().map_err(ExecError::InvalidPlan)?;
        if limits.len() != plan.arms.len() {
            return Err(ExecError::InvalidPlan(format!(
                "{} tables of joint limits for {} arms: one per arm",
                limits.len(),
                plan.arms.len()
            )));
        }
        config.watch.check().map_err(ExecError::Settings)?;
        let mut buses = Vec::with_capacity(plan.arms.len());
        if !config.dry_run {
            for a in &plan.arms {
                let i = arms.iter().position(|(n, _)| *n == a.name).ok_or_else(|| {
                    ExecError::Buses(format!("no bus given for arm {:?}", a.name))
                })?;
                buses.push(arms.swap_remove(i).1);
            }
        }
        if let Some((n, _)) = arms.first() {
            return Err(ExecError::Buses(if config.dry_run {
                "a dry run takes no buses".into()
            } else {
                format!("bus given for {n:?}, which is not an arm of the plan (or is given twice)")
            }));
        }
        Ok(Self {
            plan,
            limits,
            buses,
            config,
            progress: None,
        })
    }

    pub fn on_progress(mut self, f: impl Fn(Progress) + Send + Sync + 'static) -> Self {
        self.progress = Some(Box::new(f));
        self
    }

    /// Validates the plan with `validator` (refusing to start, nothing sent, if it fails),
    /// checks every command it leads to against the limits (likewise), and streams it to
    /// every arm, computing each cycle's commands as they are sent.
    pub fn run(self, validator: &dyn PlanValidator) -> Result<Report, ExecError> {
        validator.validate(&self.plan).map_err(ExecError::Refused)?;
        let period = self.config.period.as_secs_f64();
        let (generator, timing) =
            plan_generator(&self.plan, &self.limits, period).map_err(ExecError::Limits)?;
        let names: Vec<String> = self.plan.arms.iter().map(|a| a.name.clone()).collect();
        if self.config.dry_run {
            return dry_run(generator, &names, &self.config, timing.time_scale);
        }
        // The interpolation never leaves the waypoints' range (interpolate.rs).
        let spans = (self.plan.arms.iter())
            .map(|a| {
                std::array::from_fn(|j| {
                    let (lo, hi) = (a.joint_path.iter().map(|q| q[j]))
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
                            (l.min(x), h.max(x))
                        });
                    (to_counts(lo), to_counts(hi))
                })
            })
            .collect();
        let info = RunInfo {
            time_scale: timing.time_scale,
            total_cycles: Some(timing.cycles as u64 + 1 + self.config.settle_cycles as u64),
            spans,
            speeds: peak_speeds(&self.plan, timing.step_time),
        };
        let progress = self.progress;
        live::start(
            names,
            generator,
            self.buses,
            self.config,
            progress,
            true,
            info,
        )?
        .finish()
    }

    /// Online execution: starts every arm holding still at its start configuration and returns
    /// the handle that pushes segments (waypoints `dt` apart, streamed slowed down uniformly by
    /// `time_scale` >= 1) while the arms move. `arms` pairs each arm's name with its start
    /// configuration and its bus, `limits` each arm's joint limits in the same order; the
    /// handle's pushes take the arms in this order. A dry run
    /// is not supported here. Each push may queue at most [`ExecConfig::online_horizon`] of
    /// motion ahead.
    pub fn online<P: Into<ArmPort>>(
        arms: Vec<(String, [f64; JOINTS], P)>,
        dt: f64,
        time_scale: f64,
        limits: &[ArmLimits],
        config: ExecConfig,
    ) -> Result<StreamHandle, ExecError> {
        if config.dry_run {
            return Err(ExecError::Buses(
                "online execution streams to buses; it has no dry run".into(),
            ));
        }
        config.watch.check().map_err(ExecError::Settings)?;
        if !(time_scale.is_finite() && time_scale >= 1.0) {
            return Err(ExecError::InvalidPlan(format!(
                "time scale must be a number >= 1, got {time_scale}"
            )));
        }
        let mut names: Vec<String> = Vec::with_capacity(arms.len());
        for (n, ..) in &arms {
            if names.contains(n) {
                return Err(ExecError::Buses(format!("arm {n:?} is given twice")));
            }
            names.push(n.clone());
        }
        let starts: Vec<[f64; JOINTS]> = arms.iter().map(|a| a.1).collect();
        let step_time = dt * time_scale;
        let max_queued = (config.online_horizon.as_secs_f64() / step_time).floor();
        let generator = Generator::new(&starts, limits, config.period.as_secs_f64(), step_time)
            .map_err(ExecError::InvalidPlan)?
            .with_max_queued(if max_queued >= 1.0 {
                max_queued as usize
            } else {
                1
            });
        let buses = arms.into_iter().map(|a| a.2.into()).collect();
        // Online segments are not known in advance: they may use the joints' whole range.
        let span = |l: &ArmLimits| -> Span {
            std::array::from_fn(|j| match l[j].position {
                Some((lo, hi)) => (to_counts(lo), to_counts(hi)),
                None => (-i32::MAX, i32::MAX),
            })
        };
        let info = RunInfo {
            time_scale,
            total_cycles: None,
            spans: limits.iter().map(span).collect(),
            // Likewise their speeds: up to the joints' limits.
            speeds: limits.iter().map(|l| l.map(|j| j.velocity)).collect(),
        };
        live::start(names, generator, buses, config, None, false, info)
    }
}

/// The dry run: every cycle computed and checked as in a real run, and logged if asked,
/// without buses.
fn dry_run(
    mut generator: Generator,
    names: &[String],
    config: &ExecConfig,
    time_scale: f64,
) -> Result<Report, ExecError> {
    let log = live::open_log(config)?;
    let period = config.period.as_secs_f64();
    let mut out = vec![[0; JOINTS]; names.len()];
    let mut frames_sent = 0;
    loop {
        let tick = generator
            .next(&mut out)
            .map_err(|e| ExecError::Limits(e.to_string()))?;
        for (name, cmd) in names.iter().zip(&out) {
            match &log {
                Some(log) => {
                    for (f, what) in cycle_frames(cmd, cia402::CW_ENABLE_OPERATION) {
                        log.write(&LogEntry {
                            t: tick.cycle as f64 * period,
                            arm: name,
                            frame: f.to_string(),
                            what: &what,
                        });
                        frames_sent += 1;
                    }
                }
                None => frames_sent += JOINTS + 1,
            }
        }
        if tick.holding {
            live::finish_log(log)?;
            let cycles = tick.cycle as usize + 1;
            return Ok(Report {
                dry_run: true,
                period: config.period,
                time_scale,
                cycles,
                frames_sent,
                arms: (names.iter())
                    .map(|name| ArmReport {
                        name: name.clone(),
                        cycles_sent: cycles,
                        max_following_error: 0.0,
                    })
                    .collect(),
                max_lateness: Duration::ZERO,
                holds: 0,
                realtime: Ok(()),
            });
        }
    }
}

/// `rad` in bus counts, saturating at the ends of the bus range (which the generator never
/// goes beyond).
fn to_counts(rad: f64) -> i32 {
    cia402::rad_to_counts(rad).unwrap_or(if rad < 0.0 { -i32::MAX } else { i32::MAX })
}
