//! The executor: validates, interpolates, starts every arm together (one thread per bus),
//! streams, watches the feedback, and on any fault quick-stops every arm.

use crate::arm::{cycle_frames, ArmBus, SetupOverride};
use crate::cia402;
use crate::interpolate::{check_command, interpolate, Command, Trajectory};
use crate::log::{write_jsonl, LogEntry};
use crate::plan::{JointLimits, Plan, PlanValidator, JOINTS};
use crate::transport::Transport;
use std::fmt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Barrier, Mutex};
use std::time::{Duration, Instant};

/// Every arm sends its stop frames within this many control periods of a fault's detection.
/// The arms stream in lockstep (no arm sends cycle k+1 before every arm has sent cycle k), so no
/// arm sends more than one further cycle after the cycle in which a fault was detected; each
/// arm thread looks at the shared fault flag at least every `FAULT_POLL` while it waits, so
/// its stop follows within a fraction of a period, preemption by the OS aside.
pub const STOP_BOUND_PERIODS: u32 = 3;

/// How often a waiting arm thread looks at the shared fault flag.
const FAULT_POLL: Duration = Duration::from_micros(100);

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
    /// Heartbeat producer time configured in every drive (0x1017), ms.
    pub heartbeat_ms: u16,
    /// Heartbeat consumer time: a node silent for longer is a fault.
    pub heartbeat_timeout: Duration,
    /// A node whose TPDO is older than this is a fault.
    pub feedback_timeout: Duration,
    /// Largest allowed |target - actual|, rad.
    pub following_error_bound: f64,
    /// Largest allowed distance of an arm's start position from the plan's first waypoint, rad.
    pub start_tolerance: f64,
    /// Largest wait for room on a bus when sending one frame.
    pub send_timeout: Duration,
    /// Cycles holding the final position, feedback still watched, before the drives are disabled.
    pub settle_cycles: usize,
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
            heartbeat_ms: 100,
            heartbeat_timeout: Duration::from_millis(350),
            feedback_timeout: Duration::from_millis(50),
            following_error_bound: 0.05,
            start_tolerance: 1e-3,
            send_timeout: Duration::from_millis(2),
            settle_cycles: 50,
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
                    "node {node} sent EMCY error code {code:#06x} (error register {register:#04x})"
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
        if !self.dry_run {
            write!(f, "\nlargest cycle lateness {:?}", self.max_lateness)?;
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

type ProgressFn = Box<dyn Fn(Progress) + Send + Sync>;

pub struct Executor {
    plan: Plan,
    limits: [JointLimits; JOINTS],
    /// One bus per plan arm, in plan order.
    buses: Vec<Box<dyn Transport>>,
    config: ExecConfig,
    progress: Option<ProgressFn>,
}

/// State shared by the arm threads.
struct Shared {
    barrier: Barrier,
    startup_failed: AtomicBool,
    start: Mutex<Option<Instant>>,
    faulted: AtomicBool,
    names: Vec<String>,
    /// Cycles each arm has sent (`usize::MAX` once it has finished).
    sent: Vec<AtomicUsize>,
    /// The first fault: arm, fault, cycle, when detected.
    fault: Mutex<Option<(String, Fault, usize, Instant)>>,
}

impl Shared {
    fn raise(&self, arm: &str, fault: Fault, cycle: usize) -> Instant {
        let now = Instant::now();
        let mut first = self.fault.lock().unwrap_or_else(|p| p.into_inner());
        first.get_or_insert((arm.to_string(), fault, cycle, now));
        self.faulted.store(true, Ordering::SeqCst);
        now
    }
}

enum ArmEnd {
    StartupFailed(String),
    /// Start-up went fine but another arm's did not.
    Aborted,
    Completed {
        cycles: usize,
        max_following_error: f64,
        max_lateness: Duration,
    },
    Stopped(ArmStop),
}

impl Executor {
    /// `arms` pairs each plan arm's name with its bus; every plan arm needs exactly one bus
    /// (none in a dry run).
    pub fn new(
        plan: Plan,
        limits: [JointLimits; JOINTS],
        mut arms: Vec<(String, Box<dyn Transport>)>,
        config: ExecConfig,
    ) -> Result<Self, ExecError> {
        plan.check_shape().map_err(ExecError::InvalidPlan)?;
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
    /// interpolates it, and streams it to every arm.
    pub fn run(self, validator: &dyn PlanValidator) -> Result<Report, ExecError> {
        validator.validate(&self.plan).map_err(ExecError::Refused)?;
        let traj = interpolate(&self.plan, &self.limits, self.config.period.as_secs_f64())
            .map_err(ExecError::Limits)?;
        if self.config.dry_run {
            return self.dry_run(&traj);
        }
        let clock = Instant::now();
        let Executor {
            plan,
            limits,
            buses,
            config,
            progress,
        } = self;
        let shared = Shared {
            barrier: Barrier::new(buses.len()),
            startup_failed: AtomicBool::new(false),
            start: Mutex::new(None),
            faulted: AtomicBool::new(false),
            names: plan.arms.iter().map(|a| a.name.clone()).collect(),
            sent: buses.iter().map(|_| AtomicUsize::new(0)).collect(),
            fault: Mutex::new(None),
        };
        let (limits, config, progress) = (&limits, &config, progress.as_deref());
        let ends: Vec<(ArmEnd, Vec<LogEntry>)> = std::thread::scope(|s| {
            let handles: Vec<_> = buses
                .into_iter()
                .zip(&plan.arms)
                .zip(&traj.commands)
                .enumerate()
                .map(|(me, ((bus, arm), cmds))| {
                    let shared = &shared;
                    let mut bus = ArmBus::new(arm.name.clone(), bus, clock, config);
                    s.spawn(move || {
                        let end = stream_arm(me, &mut bus, cmds, shared, config, limits, progress);
                        (end, bus.log)
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join().unwrap_or_else(|_| {
                        (
                            ArmEnd::StartupFailed("arm thread panicked".into()),
                            Vec::new(),
                        )
                    })
                })
                .collect()
        });
        finish_run(&plan, config, &traj, ends, shared)
    }

    fn dry_run(&self, traj: &Trajectory) -> Result<Report, ExecError> {
        let period = self.config.period.as_secs_f64();
        let mut log = Vec::new();
        for (arm, cmds) in self.plan.arms.iter().zip(&traj.commands) {
            for (k, cmd) in cmds.iter().enumerate() {
                for (f, what) in cycle_frames(cmd, cia402::CW_ENABLE_OPERATION) {
                    log.push(LogEntry {
                        t: k as f64 * period,
                        arm: arm.name.clone(),
                        frame: f.to_string(),
                        what,
                    });
                }
            }
        }
        let frames_sent = log.len();
        write_log(&self.config, &mut log)?;
        Ok(Report {
            dry_run: true,
            period: self.config.period,
            time_scale: traj.time_scale,
            cycles: traj.commands.first().map_or(0, |c| c.len()),
            frames_sent,
            arms: self
                .plan
                .arms
                .iter()
                .zip(&traj.commands)
                .map(|(a, c)| ArmReport {
                    name: a.name.clone(),
                    cycles_sent: c.len(),
                    max_following_error: 0.0,
                })
                .collect(),
            max_lateness: Duration::ZERO,
        })
    }
}

fn write_log(cfg: &ExecConfig, log: &mut [LogEntry]) -> Result<(), ExecError> {
    match &cfg.log_path {
        Some(path) => write_jsonl(path, log).map_err(|error| ExecError::Log {
            path: path.clone(),
            error,
        }),
        None => Ok(()),
    }
}

/// One arm's whole run, on its own thread.
fn stream_arm(
    me: usize,
    bus: &mut ArmBus,
    cmds: &[Command],
    shared: &Shared,
    cfg: &ExecConfig,
    limits: &[JointLimits; JOINTS],
    progress: Option<&(dyn Fn(Progress) + Send + Sync)>,
) -> ArmEnd {
    // The trajectory always has a first command (plans have at least one waypoint).
    let (first, last) = (cmds[0], cmds[cmds.len() - 1]);
    // No drive of any arm is enabled unless every arm's drives are configured.
    let configured = bus.configure(cfg, cmds, &shared.startup_failed);
    if let Some(end) = startup_phase_end(bus, configured, shared) {
        return end;
    }
    let enabled = bus.enable(cfg);
    if let Some(end) = startup_phase_end(bus, enabled, shared) {
        return end;
    }
    // Every arm streams on the same schedule from a common start time.
    let t0 = *shared
        .start
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .get_or_insert_with(|| Instant::now() + cfg.period);
    let period = cfg.period.as_secs_f64();
    let total = cmds.len() + cfg.settle_cycles;
    let progress_every = (0.1 / period).ceil().max(1.0) as usize;
    let (mut prev2, mut prev1) = (first, first);
    let mut max_fe: f64 = 0.0;
    let mut max_late = Duration::ZERO;
    for k in 0..total {
        let due = t0 + cfg.period * k as u32;
        max_late = max_late.max(Instant::now().saturating_duration_since(due));
        let fault = if let Err(e) = wait_turn(me, k, due, shared, cfg) {
            Some(e)
        } else if let Err(e) = bus.poll() {
            Some(Fault::Bus(e.to_string()))
        } else if shared.faulted.load(Ordering::SeqCst) {
            None
        } else {
            let cmd = cmds.get(k).unwrap_or(&last);
            match bus.check_feedback(Instant::now(), cfg, &prev1) {
                Err(f) => Some(f),
                Ok(fe) => {
                    max_fe = max_fe.max(fe);
                    match check_command(limits, &prev2, &prev1, cmd, period) {
                        Err(e) => Some(Fault::CommandRefused(e)),
                        Ok(()) => match bus.send_cycle(cmd, cia402::CW_ENABLE_OPERATION) {
                            Err(e) => Some(Fault::Bus(e.to_string())),
                            Ok(()) => {
                                shared.sent[me].store(k + 1, Ordering::SeqCst);
                                (prev2, prev1) = (prev1, *cmd);
                                if let Some(p) = progress {
                                    if k % progress_every == 0 || k + 1 == total {
                                        p(Progress {
                                            arm: &bus.name,
                                            cycle: k + 1,
                                            cycles: total,
                                        });
                                    }
                                }
                                continue;
                            }
                        },
                    }
                }
            }
        };
        // A fault here or on another arm: quick stop, and nothing after it.
        let detected = match fault {
            Some(f) => shared.raise(&bus.name, f, k),
            None => shared
                .fault
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .as_ref()
                .map_or_else(Instant::now, |f| f.3),
        };
        let error = bus.quick_stop(&prev1).err();
        return ArmEnd::Stopped(ArmStop {
            arm: bus.name.clone(),
            cycles_sent: k,
            latency: detected.elapsed(),
            error,
        });
    }
    shared.sent[me].store(usize::MAX, Ordering::SeqCst);
    match bus.finish(&last) {
        Ok(()) => ArmEnd::Completed {
            cycles: total,
            max_following_error: max_fe,
            max_lateness: max_late,
        },
        Err(e) => {
            let detected = shared.raise(&bus.name, Fault::Bus(e.clone()), total);
            ArmEnd::Stopped(ArmStop {
                arm: bus.name.clone(),
                cycles_sent: total,
                latency: detected.elapsed(),
                error: Some(e),
            })
        }
    }
}

/// Waits for every arm to finish a start-up phase with `result`; the arm's end if this arm or
/// another failed (an arm that did not fail stops its nodes).
fn startup_phase_end(
    bus: &mut ArmBus,
    result: Result<(), String>,
    shared: &Shared,
) -> Option<ArmEnd> {
    if result.is_err() {
        shared.startup_failed.store(true, Ordering::SeqCst);
    }
    shared.barrier.wait();
    match result {
        Err(e) => Some(ArmEnd::StartupFailed(e)),
        Ok(()) if shared.startup_failed.load(Ordering::SeqCst) => Some(match bus.abort() {
            Ok(()) => ArmEnd::Aborted,
            Err(e) => ArmEnd::StartupFailed(format!("while aborting: {e}")),
        }),
        Ok(()) => None,
    }
}

/// Waits until cycle `k` is due and every arm has sent cycle `k - 1`; returns early if a fault
/// is raised. An arm that keeps the others waiting longer than the feedback timeout is a fault.
fn wait_turn(
    me: usize,
    k: usize,
    due: Instant,
    shared: &Shared,
    cfg: &ExecConfig,
) -> Result<(), Fault> {
    let give_up = due.max(Instant::now()) + cfg.feedback_timeout;
    loop {
        if shared.faulted.load(Ordering::SeqCst) {
            return Ok(());
        }
        let now = Instant::now();
        let behind = shared
            .sent
            .iter()
            .position(|c| c.load(Ordering::SeqCst) < k);
        if now >= due && behind.is_none() {
            return Ok(());
        }
        if now >= give_up {
            let other = behind.unwrap_or(me);
            return Err(Fault::Bus(format!(
                "arm {:?} fell more than {:?} behind the common schedule",
                shared.names[other], cfg.feedback_timeout
            )));
        }
        std::thread::sleep(
            due.saturating_duration_since(now)
                .clamp(Duration::ZERO, FAULT_POLL)
                .max(Duration::from_micros(20)),
        );
    }
}

fn finish_run(
    plan: &Plan,
    cfg: &ExecConfig,
    traj: &Trajectory,
    ends: Vec<(ArmEnd, Vec<LogEntry>)>,
    shared: Shared,
) -> Result<Report, ExecError> {
    let mut log: Vec<LogEntry> = Vec::new();
    let mut startup_errors = Vec::new();
    let mut stops = Vec::new();
    let mut arms = Vec::new();
    let mut max_lateness = Duration::ZERO;
    for ((end, entries), arm) in ends.into_iter().zip(&plan.arms) {
        log.extend(entries);
        match end {
            ArmEnd::StartupFailed(e) => startup_errors.push((arm.name.clone(), e)),
            ArmEnd::Aborted => {}
            ArmEnd::Stopped(s) => stops.push(s),
            ArmEnd::Completed {
                cycles,
                max_following_error,
                max_lateness: late,
            } => {
                max_lateness = max_lateness.max(late);
                arms.push(ArmReport {
                    name: arm.name.clone(),
                    cycles_sent: cycles,
                    max_following_error,
                });
            }
        }
    }
    let frames_sent = log.len();
    let logged = write_log(cfg, &mut log);
    if !startup_errors.is_empty() {
        return Err(ExecError::Startup(startup_errors));
    }
    if let Some((arm, fault, cycle, _)) =
        shared.fault.into_inner().unwrap_or_else(|p| p.into_inner())
    {
        // Arms that had already finished normally count as stopped at once.
        for a in arms {
            stops.push(ArmStop {
                arm: a.name,
                cycles_sent: a.cycles_sent,
                latency: Duration::ZERO,
                error: None,
            });
        }
        return Err(ExecError::Fault(Box::new(FaultReport {
            arm,
            fault,
            cycle,
            stops,
            bound: cfg.period * STOP_BOUND_PERIODS,
        })));
    }
    logged?;
    Ok(Report {
        dry_run: false,
        period: cfg.period,
        time_scale: traj.time_scale,
        cycles: traj.commands.first().map_or(0, |c| c.len()),
        frames_sent,
        arms,
        max_lateness,
    })
}
