//! A cell: several arms streamed together while a policy runs, the API a policy loop (the
//! Python `Cell`, `omcbsa online --arm`) drives. Each arm is given by its URL, its start
//! configuration and its joint limits ([`CellArm`]), and reached through a [`Connector`]
//! ([`crate::connect::RealArms`] for real arms).
//!
//! - [`Cell::start`] sets every arm up (the checks of a run: the arm where the cell says it
//!   starts, the drives' limits covering the joints' range, ...), then returns with every arm
//!   holding at its start; an arm that fails its set-up is the error, and no arm moved.
//! - [`Cell::push`] replaces the queue's tail from a step with waypoint chunks, `dt` apart,
//!   checked in full against the limits before any of it is sent; it returns at once.
//! - [`Cell::status`]: per arm, its state, the last commanded and measured joints, the
//!   following error, the queue depth and the lag of its feedback; and the stream's events.
//! - A queue that runs dry holds the arms ([`crate::ArmState::Holding`], an
//!   [`crate::Event::QueueDry`]): no fault; the next push moves them on.
//! - A fault stops every arm (the watchdog, as in any run) and the next call returns
//!   [`CellError::Fault`] with its report; later calls return [`CellError::Ended`].
//! - [`Cell::finish`] lets the queue run out and ends the run; [`Cell::stop`], and dropping the
//!   cell, stop every arm at once.
//!
//! The cell's period is the slowest default of its arms ([`CellOptions::new`]); the connector
//! may refuse a period an arm cannot keep up with ([`Connector::check`]). What the arms'
//! guards recorded ([`crate::connect::ArmGuard`]: a stand-in arm's record of what it received)
//! is returned by [`Cell::finish`] and [`Cell::stop`].

pub use crate::connect::CellArm;
use crate::connect::{ArmGuard, ConnectError, Connector, GuardError};
use crate::live::StreamProgress;
use crate::plan::ArmLimits;
use crate::port::ArmPort;
use crate::run::{ArmState, ArmStatus, ExecConfig, ExecError, FaultReport, Report, JOINTS};
use crate::stream::PushError;
use crate::{Event, Executor, StreamHandle};
use serde_json::Value;
use std::time::{Duration, Instant};

/// How a cell runs.
#[derive(Clone, Debug)]
pub struct CellOptions {
    /// Time between waypoints, s (the policy's step).
    pub dt: f64,
    /// Uniform slow-down of the pushed motion (>= 1).
    pub time_scale: f64,
    /// The run's settings (its period: see [`CellOptions::new`]).
    pub config: ExecConfig,
}

impl CellOptions {
    /// Options for `arms` with waypoints `dt` apart: the command line's settings at the
    /// slowest default period of the arms as `connector` reaches them (CAN 4 ms, SLCAN 5 ms,
    /// Kortex 1 ms).
    pub fn new<C: Connector>(dt: f64, arms: &[CellArm<C::Url>], connector: &C) -> Self {
        let period = (arms.iter().map(|a| connector.default_period(&a.url)))
            .max()
            .unwrap_or(Duration::from_millis(2));
        Self {
            dt,
            time_scale: 1.0,
            config: ExecConfig {
                period,
                ..ExecConfig::default()
            },
        }
    }
}

/// Why a cell did not do what it was asked.
#[derive(Debug, thiserror::Error)]
pub enum CellError {
    /// The arms or options are wrong (named in the text); nothing was started.
    #[error("{0}")]
    Setup(String),
    /// An arm could not be reached (or cannot run with the cell's settings); no arm moved.
    #[error("arm {arm:?} ({url}): {source}")]
    Connect {
        /// The arm.
        arm: String,
        /// Its URL.
        url: String,
        /// Why.
        source: ConnectError,
    },
    /// The run refused to start or its start-up failed; no arm moved.
    #[error("{0}")]
    Start(ExecError),
    /// A push was refused; nothing of it was sent, the queue is as it was.
    #[error("{0}")]
    Push(PushError),
    /// A fault stopped every arm (reported once, on the first call after it).
    #[error("{0}")]
    Fault(Box<FaultReport>),
    /// The cell has ended: nothing more is taken.
    #[error("the cell has ended: {0}")]
    Ended(String),
    /// The run ended, but what an arm's guard recorded could not be read.
    #[error("the cell has ended: the run ended but arm {arm:?}'s record is unreadable: {source}")]
    Record {
        /// The arm.
        arm: String,
        /// Why.
        source: GuardError,
    },
}

/// The cell now.
#[derive(Clone, Debug)]
pub struct CellStatus {
    /// Where the stream is.
    pub progress: StreamProgress,
    /// What it did since the last call (a queue that ran dry, a motion resumed).
    pub events: Vec<Event>,
    /// Each arm, in the order given.
    pub arms: Vec<ArmStatus>,
}

/// How a cell ended.
#[derive(Debug)]
pub struct CellEnd {
    /// The run's report.
    pub report: Report,
    /// Per arm with a guard (a stand-in arm), what it recorded, in the order given; empty for
    /// real arms.
    pub records: Vec<(String, Vec<Value>)>,
}

/// Several arms streaming together: see the module.
pub struct Cell {
    handle: Option<StreamHandle>,
    /// Set once the run has ended: why.
    ended: Option<String>,
    /// Per arm with one, its guard, by the arm's name.
    guards: Vec<(String, Box<dyn ArmGuard>)>,
}

impl Cell {
    /// Reaches every arm through `connector` (stand-in arms started first) and returns once
    /// every arm holds at its start.
    pub fn start<C: Connector>(
        arms: Vec<CellArm<C::Url>>,
        options: CellOptions,
        connector: &C,
    ) -> Result<Cell, CellError> {
        let connect_error = |a: &CellArm<C::Url>, source| CellError::Connect {
            arm: a.name.clone(),
            url: a.url.to_string(),
            source,
        };
        for (i, a) in arms.iter().enumerate() {
            if arms[..i].iter().any(|b| b.name == a.name) {
                return Err(CellError::Setup(format!("arm {:?} is given twice", a.name)));
            }
            (connector.check(a, &options.config)).map_err(|e| connect_error(a, e))?;
        }
        let mut cell = Cell {
            handle: None,
            ended: None,
            guards: Vec::new(),
        };
        let mut ports: Vec<(String, [f64; JOINTS], ArmPort)> = Vec::new();
        for a in &arms {
            let connected =
                (connector.connect(a, &options.config)).map_err(|e| connect_error(a, e))?;
            if let Some(guard) = connected.guard {
                cell.guards.push((a.name.clone(), guard));
            }
            ports.push((a.name.clone(), a.start, connected.port));
        }
        let limits: Vec<ArmLimits> = arms.iter().map(|a| a.limits).collect();
        let handle = Executor::online(
            ports,
            options.dt,
            options.time_scale,
            &limits,
            options.config.clone(),
        )
        .map_err(CellError::Start)?;
        cell.handle = Some(handle);
        cell.wait_started(&options.config)?;
        Ok(cell)
    }

    /// Waits until no arm is starting (at most the set-up's own time-outs, and some): the
    /// start-up's error if it failed.
    fn wait_started(&mut self, cfg: &ExecConfig) -> Result<(), CellError> {
        // Per drive: an SDO time-out for each of about 30 requests, then the enable time-out.
        let limit = cfg.sdo_timeout * 30 * JOINTS as u32 + cfg.startup_timeout * 2;
        let deadline = Instant::now() + limit.max(Duration::from_secs(10));
        loop {
            self.check()?;
            let starting = (self.handle.as_ref().into_iter())
                .flat_map(|h| h.status())
                .any(|a| a.state == ArmState::Starting);
            if !starting {
                return Ok(());
            }
            if Instant::now() >= deadline {
                return Err(CellError::Setup(format!(
                    "the arms were not set up within {limit:?}"
                )));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// The run's end if it has stopped since the last call (a fault, a failed start-up):
    /// reported once; afterwards [`CellError::Ended`].
    fn check(&mut self) -> Result<&StreamHandle, CellError> {
        if let Some(why) = &self.ended {
            return Err(CellError::Ended(why.clone()));
        }
        let stopped = self
            .handle
            .as_ref()
            .is_none_or(|h| h.faulted() || h.ended());
        if stopped {
            let result = self.handle.take().map(StreamHandle::stop);
            let err = match result {
                Some(Err(ExecError::Fault(report))) => {
                    self.ended = Some(format!("stopped by a fault: {}", report.fault));
                    CellError::Fault(report)
                }
                Some(Err(e)) => {
                    self.ended = Some(e.to_string());
                    CellError::Start(e)
                }
                Some(Ok(_)) | None => {
                    let why = "the stream has ended".to_string();
                    self.ended = Some(why.clone());
                    CellError::Ended(why)
                }
            };
            return Err(err);
        }
        self.handle
            .as_ref()
            .ok_or_else(|| CellError::Ended("the stream has ended".into()))
    }

    /// Replaces every arm's waypoints from step `start_step` on (arms in the order given;
    /// waypoint `i` of each at step `start_step + i`), see [`StreamHandle::push`]: the control
    /// cycle from which the new tail streams. Returns at once.
    pub fn push(
        &mut self,
        start_step: usize,
        waypoints: &[&[[f64; JOINTS]]],
    ) -> Result<u64, CellError> {
        let pushed = self.check()?.push(start_step, waypoints);
        match pushed {
            Ok(cycle) => Ok(cycle),
            // The stream stopped while the push was being checked: its report, once.
            Err(PushError::Stopped(_)) => {
                self.check()?;
                Err(CellError::Ended("the stream has ended".into()))
            }
            Err(e) => Err(CellError::Push(e)),
        }
    }

    /// Where the stream and each arm are now, with the events since the last call.
    pub fn status(&mut self) -> Result<CellStatus, CellError> {
        let h = self.check()?;
        Ok(CellStatus {
            progress: h.progress(),
            events: h.events(),
            arms: h.status(),
        })
    }

    /// Lets the queue run out, holds for the settle cycles, disables the drives; the report and
    /// the arms' records.
    pub fn finish(self) -> Result<CellEnd, CellError> {
        self.end(StreamHandle::finish)
    }

    /// Stops every arm now (a quick stop, no fault); the report and the arms' records.
    pub fn stop(self) -> Result<CellEnd, CellError> {
        self.end(StreamHandle::stop)
    }

    /// Ends the stream with `how`, then waits for the guards to end: their records.
    fn end(
        mut self,
        how: fn(StreamHandle) -> Result<Report, ExecError>,
    ) -> Result<CellEnd, CellError> {
        self.check()?;
        let handle = (self.handle.take()).ok_or_else(|| CellError::Ended("no stream".into()))?;
        self.ended = Some("the cell has ended".into());
        let report = how(handle).map_err(|e| match e {
            ExecError::Fault(r) => CellError::Fault(r),
            e => CellError::Start(e),
        })?;
        let records = (self.guards.drain(..))
            .map(|(arm, guard)| match guard.finish() {
                Ok(record) => Ok((arm, record)),
                Err(source) => Err(CellError::Record { arm, source }),
            })
            .collect::<Result<_, _>>()?;
        Ok(CellEnd { report, records })
    }
}

impl Drop for Cell {
    /// Stops every arm, then ends the guards (a stand-in arm writes its record as it exits).
    fn drop(&mut self) {
        drop(self.handle.take());
        for (_, guard) in self.guards.drain(..) {
            let _ = guard.finish();
        }
    }
}
