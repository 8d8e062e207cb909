//! The executor: validates, interpolates, starts every arm together (one thread per bus),
//! streams, watches the feedback, and on any fault quick-stops every arm.
//!
//! Two arms of simulated CiA 402 drives on in-process buses (`omcbsa_mock::sim::can`) follow a
//! plan, then one of them faults in a second run and both are stopped:
//!
//! ```
//! use omcbsa_mock::sim::can::{CanSim, CanSimOptions, Injected, FAULTY_NODE};
//! use omcbsa_hw::{ArmPlan, ExecConfig, ExecError, Executor, Fault, Plan, PlanValidator};
//! use omcbsa_hw::JOINTS;
//! use std::time::Duration;
//!
//! struct Accept;
//! impl PlanValidator for Accept {
//!     fn validate(&self, _: &Plan) -> Result<(), String> { Ok(()) }
//! }
//!
//! let start = [0.0; JOINTS];
//! let plan = Plan {
//!     dt: 0.25,
//!     arms: ["left", "right"]
//!         .map(|name| ArmPlan {
//!             name: name.into(),
//!             joint_path: vec![start, [0.01; JOINTS], [0.02; JOINTS], [0.02; JOINTS]],
//!         })
//!         .into(),
//! };
//! // Arms at 100 Hz; the watchdog, scheduling and timer check at their defaults.
//! let cfg = ExecConfig { period: Duration::from_millis(10), ..ExecConfig::default() };
//! let limits = omcbsa_mock::testing::fleet_limits(2);
//!
//! let (left, left_bus) = CanSim::spawn(CanSimOptions::at(start));
//! let (right, right_bus) = CanSim::spawn(CanSimOptions::at(start));
//! let arms = vec![("left".to_string(), left_bus), ("right".to_string(), right_bus)];
//! let report = Executor::new(plan.clone(), limits.clone(), arms, cfg.clone())?.run(&Accept)?;
//! // Within the limits as planned: 0.75 s at 10 ms, then the hold on the last waypoint.
//! assert_eq!((report.time_scale, report.cycles), (1.0, 76));
//! let taken = left.finish().commands;
//! assert_eq!(taken.len(), report.cycles + cfg.settle_cycles);
//! assert_eq!(taken.last(), Some(&[200_000; JOINTS])); // 0.02 rad
//! right.finish();
//!
//! // The right arm's node 3 reports a fault at its 20th SYNC: both arms are stopped.
//! let faulty = CanSimOptions { fault: Some((20, Injected::FaultBit)), ..CanSimOptions::at(start) };
//! let (left, left_bus) = CanSim::spawn(CanSimOptions::at(start));
//! let (right, right_bus) = CanSim::spawn(faulty);
//! let arms = vec![("left".to_string(), left_bus), ("right".to_string(), right_bus)];
//! let Err(ExecError::Fault(report)) = Executor::new(plan, limits, arms, cfg)?.run(&Accept) else {
//!     panic!("the fault must stop the run")
//! };
//! assert_eq!(report.arm, "right");
//! assert!(matches!(report.fault, Fault::DriveState { node: FAULTY_NODE, .. }));
//! for sim in [left, right] {
//!     let seen = sim.finish();
//!     assert!(seen.stopped.is_some());
//!     assert_eq!(seen.commands_after_stop, 0);
//! }
//! # Ok::<(), ExecError>(())
//! ```

use crate::arm::cycle_frames;
use crate::cia402;
use crate::interpolate::{peak_speeds, plan_generator};
use crate::live::{self, ProgressFn, RunInfo, StreamHandle};
use crate::log::LogEntry;
use crate::plan::{ArmLimits, Plan, PlanValidator};
use crate::port::ArmPort;
use crate::run::{ArmReport, ExecConfig, ExecError, Progress, Report, Span, JOINTS};
use crate::stream::Generator;
use std::time::{Duration, Instant};

/// Streams a plan to its arms, all together: see the module. Built with [`Executor::new`]
/// (offline, the whole plan known) or started with [`Executor::online`] (segments pushed while
/// the arms move).
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

    /// Calls `f` about every 0.1 s of streaming, per arm (from the arms' threads: keep it
    /// short).
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
        let arms = names.into_iter().zip(self.buses).collect();
        launch(generator, arms, self.config, self.progress, true, info)?.finish()
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
        let ports = arms.into_iter().map(|(n, _, p)| (n, p.into())).collect();
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
        launch(generator, ports, config, None, false, info)
    }
}

/// Refuses a CAN bus its arms would load over [`crate::bus::MAX_LOAD`] at the period (before
/// any arm is set up), then opens the command log, makes each port's link and starts
/// streaming (the arms as the generator's, in order).
fn launch(
    generator: Generator,
    arms: Vec<(String, ArmPort)>,
    config: ExecConfig,
    progress: Option<ProgressFn>,
    finishing: bool,
    info: RunInfo,
) -> Result<StreamHandle, ExecError> {
    if let Some(duration) = config.preflight {
        crate::timing::measure(config.period, duration, config.realtime_priority)
            .and_then(|j| j.holds())
            .map_err(ExecError::Timing)?;
    }
    let buses = (arms.iter()).filter_map(|(n, p)| p.can_transport().map(|t| (n.as_str(), t)));
    crate::bus::check(buses, &config).map_err(ExecError::BusLoad)?;
    let log = crate::log::open(config.log_path.as_deref())?;
    let clock = Instant::now();
    let links = (arms.into_iter())
        .map(|(name, port)| port.into_link(name, clock, &config, log.clone()))
        .collect();
    Ok(live::start(
        generator,
        links,
        (config, log),
        progress,
        finishing,
        info,
    ))
}

/// The dry run: every cycle computed and checked as in a real run, and logged if asked,
/// without buses.
fn dry_run(
    mut generator: Generator,
    names: &[String],
    config: &ExecConfig,
    time_scale: f64,
) -> Result<Report, ExecError> {
    let log = crate::log::open(config.log_path.as_deref())?;
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
            crate::log::finish(log)?;
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
                halted: false,
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
