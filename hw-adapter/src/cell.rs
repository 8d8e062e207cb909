//! A cell: several arms streamed together while a policy runs, the API a policy loop (the
//! Python `Cell`, `omcbsa online --arm`) drives. Each arm is given by its URL
//! ([`crate::port::ArmUrl`]: a real arm, or a Python mock started for the cell), its start
//! configuration and its joint limits.
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
//! A Python mock runs at [`crate::mock::MOCK_PERIOD`] at the fastest; the cell's period is the
//! slowest default of its arms ([`CellOptions::new`]). The mocks write their records (what they
//! received) to [`CellOptions::records`], returned by [`Cell::finish`] and [`Cell::stop`].

use crate::kortex::Credentials;
use crate::live::StreamProgress;
use crate::mock::{self, MockArm, MockArmOptions};
use crate::mock_gen3::MockGen3;
use crate::plan::ArmLimits;
use crate::port::{ArmPort, ArmUrl};
use crate::run::{ArmState, ArmStatus, ExecConfig, ExecError, FaultReport, Report, JOINTS};
use crate::stream::PushError;
use crate::{Event, Executor, StreamHandle};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// Cells started by this process (their records' directories are numbered).
static CELLS: AtomicUsize = AtomicUsize::new(0);

/// One arm of a cell.
#[derive(Clone, Debug)]
pub struct CellArm {
    /// The arm's name.
    pub name: String,
    /// Where it is.
    pub url: ArmUrl,
    /// Where it stands, rad: the cell's first waypoint (a real arm must be within
    /// [`ExecConfig::start_tolerance`] of it; a mock is started there).
    pub start: [f64; JOINTS],
    /// Its joint limits.
    pub limits: ArmLimits,
}

/// How a cell runs.
#[derive(Clone, Debug)]
pub struct CellOptions {
    /// Time between waypoints, s (the policy's step).
    pub dt: f64,
    /// Uniform slow-down of the pushed motion (>= 1).
    pub time_scale: f64,
    /// The run's settings (its period: see [`CellOptions::new`]).
    pub config: ExecConfig,
    /// Who Kortex arms are reached as (the mocks have their own).
    pub credentials: Option<Credentials>,
    /// Where the mocks write their records (`NAME.jsonl`, and a CAN mock's bus log
    /// `NAME.log`); `None`: a directory of its own under the system's temporary directory.
    pub records: Option<PathBuf>,
}

impl CellOptions {
    /// Options for `arms` with waypoints `dt` apart: the command line's settings at the
    /// slowest default period of the arms (CAN 4 ms, SLCAN 5 ms, Kortex 1 ms, the mocks 10 ms).
    pub fn new(dt: f64, arms: &[CellArm]) -> Self {
        let period = (arms.iter().map(|a| a.url.default_period()))
            .max()
            .unwrap_or(Duration::from_millis(2));
        Self {
            dt,
            time_scale: 1.0,
            config: ExecConfig {
                period,
                ..ExecConfig::default()
            },
            credentials: None,
            records: None,
        }
    }
}

/// Why a cell did not do what it was asked.
#[derive(Debug, thiserror::Error)]
pub enum CellError {
    /// The arms or options are wrong (named in the text); nothing was started.
    #[error("{0}")]
    Setup(String),
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
    /// Per mock arm, what it received (its record), in the order given; empty for real arms.
    pub records: Vec<(String, Vec<Value>)>,
}

/// A started Python mock.
enum Mock {
    Can(MockArm),
    Kortex(MockGen3),
}

impl Mock {
    /// Waits for it to exit (it does once its connection is closed): its name and record.
    fn finish(self) -> Result<(String, Vec<Value>), String> {
        match self {
            Mock::Can(m) => Ok((m.name.clone(), m.finish()?)),
            Mock::Kortex(m) => Ok((m.name.clone(), m.finish()?)),
        }
    }
}

/// Several arms streaming together: see the module.
pub struct Cell {
    handle: Option<StreamHandle>,
    /// Set once the run has ended: why.
    ended: Option<String>,
    mocks: Vec<Mock>,
}

impl Cell {
    /// Starts every arm (mocks first) and returns once every arm holds at its start.
    pub fn start(arms: Vec<CellArm>, options: CellOptions) -> Result<Cell, CellError> {
        let setup = CellError::Setup;
        for (i, a) in arms.iter().enumerate() {
            if arms[..i].iter().any(|b| b.name == a.name) {
                return Err(setup(format!("arm {:?} is given twice", a.name)));
            }
            if a.url.is_mock() && options.config.period < mock::MOCK_PERIOD {
                return Err(setup(format!(
                    "arm {:?} ({}) is a Python mock, which runs at a period of {:?} at the \
                     fastest; the cell's period is {:?}",
                    a.name,
                    a.url,
                    mock::MOCK_PERIOD,
                    options.config.period
                )));
            }
        }
        let records = match &options.records {
            Some(dir) => dir.clone(),
            None => std::env::temp_dir().join(format!(
                "omcbsa-cell-{}-{}",
                std::process::id(),
                CELLS.fetch_add(1, Ordering::SeqCst)
            )),
        };
        let mut cell = Cell {
            handle: None,
            ended: None,
            mocks: Vec::new(),
        };
        let mut ports: Vec<(String, [f64; JOINTS], ArmPort)> = Vec::new();
        for a in &arms {
            let port = cell.port(a, &options, &records).map_err(setup)?;
            ports.push((a.name.clone(), a.start, port));
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

    /// The port of arm `a`: opened, or its mock started.
    fn port(
        &mut self,
        a: &CellArm,
        options: &CellOptions,
        records: &Path,
    ) -> Result<ArmPort, String> {
        // A cell's mock lives as long as the cell: it exits when the cell closes its connection or
        // connection, not after the mocks' own backstop for a test that leaks one (a minute or
        // ten). The URL's flags come after, so that a query may still set one.
        let flags = |f: &[(String, String)]| -> Vec<String> {
            let own = f.iter().map(|(k, v)| format!("--{k}={v}"));
            std::iter::once("--max-seconds=inf".to_string())
                .chain(own)
                .collect()
        };
        let record = records.join(format!("{}.jsonl", a.name));
        let at = |e: String| format!("arm {:?} ({}): {e}", a.name, a.url);
        match &a.url {
            ArmUrl::MockCan(f) => {
                std::fs::create_dir_all(records).map_err(|e| at(e.to_string()))?;
                let python = mock::ensure_venv().map_err(at)?;
                let opts = MockArmOptions {
                    initial: a.start,
                    record: Some(record.clone()),
                    bus_log: Some(mock::bus_log_path(&record)),
                    extra_args: flags(f),
                };
                let m =
                    MockArm::spawn(&python, &mock::script_path(), &a.name, &opts).map_err(at)?;
                let bus = m.open_bus().map_err(|e| at(e.to_string()))?;
                self.mocks.push(Mock::Can(m));
                Ok(ArmPort::Can(bus))
            }
            ArmUrl::MockKortex(f) => {
                std::fs::create_dir_all(records).map_err(|e| at(e.to_string()))?;
                let python = mock::ensure_venv().map_err(at)?;
                let period = options.config.period;
                let m = MockGen3::spawn(&python, &a.name, &a.start, period, &record, &flags(f))
                    .map_err(at)?;
                let conn = m.connect().map_err(at)?;
                self.mocks.push(Mock::Kortex(m));
                Ok(conn.into())
            }
            url => {
                let none = Credentials {
                    username: String::new(),
                    password: String::new(),
                };
                let credentials = match (url, &options.credentials) {
                    (ArmUrl::Kortex(_), None) => {
                        return Err(at("a Kortex arm needs credentials".into()))
                    }
                    (_, c) => c.as_ref().unwrap_or(&none),
                };
                url.open(credentials).map_err(at)
            }
        }
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
    /// the mocks' records.
    pub fn finish(self) -> Result<CellEnd, CellError> {
        self.end(StreamHandle::finish)
    }

    /// Stops every arm now (a quick stop, no fault); the report and the mocks' records.
    pub fn stop(self) -> Result<CellEnd, CellError> {
        self.end(StreamHandle::stop)
    }

    /// Ends the stream with `how`, then waits for the mocks to exit: their records.
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
        let records = (self.mocks.drain(..))
            .map(Mock::finish)
            .collect::<Result<_, String>>()
            .map_err(|e| {
                CellError::Ended(format!(
                    "the run ended but a mock's record is unreadable: {e}"
                ))
            })?;
        Ok(CellEnd { report, records })
    }
}

impl Drop for Cell {
    /// Stops every arm; the mocks write their records as they exit.
    fn drop(&mut self) {
        drop(self.handle.take());
        for m in self.mocks.drain(..) {
            let _ = m.finish();
        }
    }
}
