//! [`LiveCell`]: an [`Embodier`] and the arms it plans for, streamed while a policy runs.
//!
//! The Embodier's timeline index is the executor's waypoint index: index 0 is where the arms
//! stand when the cell starts (`initial`), the approach follows, then the chunks, `dt` apart
//! (streamed `time_scale` times slower). A push plans the chunk and hands the new tail of the
//! plan to the executor, which streams it from its own threads:
//!
//! 1. The executor has fixed the waypoints up to `fixed` (a push may start at `fixed + 1`).
//!    While the arms move it fixes one more every step, so the waypoints it will fix while
//!    the chunk is planned (the *lead*: the longest recent planning and checking time, with a
//!    margin) are committed to the Embodier with the ones fixed: it plans from after them and
//!    never replans what the arms execute. Holding, the arms fix nothing more: no lead.
//! 2. The chunk's poses at steps the arms have passed (their timeline index is committed) are
//!    dropped (reported as `late`); the rest is planned.
//! 3. The plan from the first waypoint that changed is checked whole ([`super::check`]); then
//!    pushed. If the arms passed its first waypoint after all (planning took longer than the
//!    lead), the Embodier is put back as it was ([`Embodier::restore`]) and the chunk planned
//!    again with a longer lead, up to [`ATTEMPTS`] times. If the check or the executor refuses
//!    it, the Embodier is put back too: it always holds the plan the arms execute.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use omcbsa_hw::cell::{Cell, CellArm, CellEnd, CellError, CellOptions, CellStatus};
use omcbsa_hw::connect::RealArms;
use omcbsa_hw::kortex::Credentials;
use omcbsa_hw::{ExecConfig, ExecError, FaultReport, PushError};
use omcbsa_mock::connect::{ArmOrMockUrl, MockConnector};

use super::check::check_segment;
use crate::error::quoted;
use crate::execute::{joint_limits, CAUTIOUS_SPEED};
use crate::format::Pose;
use crate::models::{ModelKind, DOF};
use crate::online::{ChunkReport, Embodier, OnlineError, Target};

/// How many times a push plans its chunk when the arms pass its first waypoint while it is
/// planned.
pub const ATTEMPTS: usize = 3;

/// Planning times remembered for the lead.
const RECENT: usize = 8;

/// The lead is this many times the longest recent planning and checking time.
const LEAD_MARGIN: f64 = 1.5;

/// How a live cell runs.
#[derive(Clone, Debug, Default)]
pub struct LiveOptions {
    /// Uniform slow-down of the arms against the policy's rate (at least 1); `None`: the
    /// least that keeps the Embodier's joint speeds within the executor's
    /// ([`speed_ratio`]).
    pub time_scale: Option<f64>,
    /// Control period; `None`: the slowest default of the arms (SocketCAN 4 ms, SLCAN 5 ms, Kortex 1 ms, the
    /// mocks 10 ms).
    pub period: Option<Duration>,
    /// The run's settings but for the period (the watchdog, time-outs, priority).
    pub config: ExecConfig,
    /// Who Kortex arms are reached as (needed for a real Kortex arm).
    pub credentials: Option<Credentials>,
    /// Where mock arms write their records; `None`: a directory of the cell's own under the
    /// system's temporary directory ([`LiveCell::records`]).
    pub records: Option<PathBuf>,
}

/// Why a live cell did not do what it was asked.
#[derive(Debug)]
pub enum LiveError {
    /// The arms, their names or the options are wrong; nothing was started.
    Setup(String),
    /// The arms did not start (the arm named in the text); no arm moved.
    Start(ExecError),
    /// The chunk was not planned (bad input, out of reach, blocked, all of it too late); the
    /// plan the arms execute is unchanged.
    Chunk(OnlineError),
    /// The chunk was planned, but its plan failed the check before sending; not sent, the
    /// plan the arms execute is unchanged.
    Invalid(String),
    /// The executor refused the chunk's plan (a limit of the executor's, the queue's length,
    /// or the arms passed its start on every attempt); not sent, the plan unchanged.
    Refused(PushError),
    /// A fault stopped every arm (reported once, on the first call after it).
    Fault(Box<FaultReport>),
    /// The cell has ended: nothing more is taken.
    Ended(String),
}

impl std::fmt::Display for LiveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LiveError::Setup(s) | LiveError::Ended(s) => write!(f, "{s}"),
            LiveError::Start(e) => write!(f, "{e}"),
            LiveError::Chunk(e) => write!(f, "{e}"),
            LiveError::Invalid(s) => {
                write!(f, "the chunk's plan failed its check and was not sent: {s}")
            }
            LiveError::Refused(e) => write!(f, "the executor refused the chunk's plan: {e}"),
            LiveError::Fault(r) => write!(f, "{r}"),
        }
    }
}

impl std::error::Error for LiveError {}

impl From<CellError> for LiveError {
    fn from(e: CellError) -> Self {
        match e {
            CellError::Setup(s) => LiveError::Setup(s),
            e @ CellError::Connect { .. } => LiveError::Setup(e.to_string()),
            CellError::Start(e) => LiveError::Start(e),
            CellError::Push(e) => LiveError::Refused(e),
            CellError::Fault(r) => LiveError::Fault(r),
            e @ (CellError::Ended(_) | CellError::Record { .. }) => LiveError::Ended(e.to_string()),
        }
    }
}

/// What a push did.
#[derive(Clone, Debug)]
pub struct LivePush {
    /// The Embodier's report on the chunk (its `start_step` after the late poses).
    pub report: ChunkReport,
    /// The chunk's first poses, at steps the arms had passed, that were not planned.
    pub late: usize,
    /// The waypoint (timeline index) the new tail was pushed from.
    pub from: usize,
    /// The control cycle from which it streams.
    pub cycle: u64,
    /// How many times the chunk was planned (more than 1: the arms passed its first
    /// waypoint while it was planned).
    pub attempts: usize,
}

/// The cell now.
#[derive(Clone, Debug)]
pub struct LiveStatus {
    /// The executor's: progress, events since the last call, every arm.
    pub cell: CellStatus,
    /// The policy step the arms are at (`None`: between poses of a slowed chunk, the approach,
    /// a hold, or before the first chunk).
    pub policy_step: Option<u64>,
    /// Seconds the Embodier's plan is behind the policy (time scaling, holds), at the last
    /// chunk's last pose.
    pub lag_s: f64,
}

/// An Embodier's arms, streaming: see the module.
pub struct LiveCell {
    cell: Cell,
    names: Vec<String>,
    time_scale: f64,
    period: Duration,
    step_time: f64,
    records: PathBuf,
    /// Wall time of the recent pushes' planning and checking, s.
    recent: VecDeque<f64>,
    /// What each queued waypoint tracks, from the one being executed to the queue's end.
    queued: VecDeque<(usize, Target)>,
    lag_s: f64,
}

/// The least uniform slow-down that keeps the Embodier's joint speeds (each model's velocity
/// limits, which its plans keep to at `dt`) within the executor's ([`joint_limits`] at
/// [`CAUTIOUS_SPEED`]): the fastest joint's ratio.
pub fn speed_ratio(embodier: &Embodier) -> Result<f64, String> {
    use omcbsa_core::model::Models;
    let mut ratio: f64 = 1.0;
    for r in &embodier.setup().robots {
        let kind = ModelKind::parse(&r.model)?;
        let executor = joint_limits(kind, CAUTIOUS_SPEED);
        let model = crate::models::Fleet::velocity(kind.id());
        for (l, v) in executor.iter().zip(model) {
            ratio = ratio.max(v / l.velocity);
        }
    }
    Ok(ratio)
}

impl LiveCell {
    /// Starts the arms of `embodier` (which has planned no chunk yet): `arms` gives every
    /// robot's URL by name. Each arm must stand at its robot's `initial` (a mock is started
    /// there), and its drives' limits must cover the model's; returns once every arm holds
    /// there. Nothing moves until the first push.
    pub fn start(
        embodier: &Embodier,
        arms: &[(String, ArmOrMockUrl)],
        options: LiveOptions,
    ) -> Result<LiveCell, LiveError> {
        let setup = embodier.setup();
        let names = embodier.robot_names().to_vec();
        let mut errors = Vec::new();
        if embodier.end() > 0 {
            errors.push(
                "the Embodier has planned chunks already: a cell starts where the arms stand, \
                 before the first chunk"
                    .to_string(),
            );
        }
        for (i, (name, _)) in arms.iter().enumerate() {
            if !names.contains(name) {
                errors.push(format!(
                    "arm {}: no robot of the Embodier has this name (robots: {})",
                    quoted(name),
                    names
                        .iter()
                        .map(|n| quoted(n))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            if arms[..i].iter().any(|(n, _)| n == name) {
                errors.push(format!("arm {} is given twice", quoted(name)));
            }
        }
        for name in &names {
            if !arms.iter().any(|(n, _)| n == name) {
                errors.push(format!(
                    "robot {} has no arm: every robot needs a URL",
                    quoted(name)
                ));
            }
        }
        let scale = match options.time_scale {
            Some(s) if !(s.is_finite() && s >= 1.0) => {
                errors.push(format!("time_scale {s}: must be a number, at least 1"));
                1.0
            }
            Some(s) => s,
            None => speed_ratio(embodier).map_err(LiveError::Setup)?,
        };
        if !errors.is_empty() {
            return Err(LiveError::Setup(errors.join("; ")));
        }
        let cell_arms = (setup.robots.iter())
            .map(|r| {
                let url = (arms.iter().find(|(n, _)| *n == r.name))
                    .map(|(_, u)| u.clone())
                    .ok_or_else(|| format!("robot {} has no arm", quoted(&r.name)))?;
                let initial = r.initial.as_deref().unwrap_or_default();
                let start = <[f64; DOF]>::try_from(initial)
                    .map_err(|_| format!("robot {}: no initial configuration", quoted(&r.name)))?;
                Ok(CellArm {
                    name: r.name.clone(),
                    url,
                    start,
                    limits: joint_limits(ModelKind::parse(&r.model)?, CAUTIOUS_SPEED),
                })
            })
            .collect::<Result<Vec<_>, String>>()
            .map_err(LiveError::Setup)?;
        let records = (options.records.clone()).unwrap_or_else(|| {
            std::env::temp_dir().join(format!("omcbsa-live-{}-{}", std::process::id(), unique()))
        });
        let real = RealArms {
            credentials: options.credentials,
        };
        let connector = MockConnector::new(real, Some(records.clone()));
        let mut cell_options = CellOptions::new(setup.dt, &cell_arms, &connector);
        let period = options.period.unwrap_or(cell_options.config.period);
        cell_options.time_scale = scale;
        cell_options.config = ExecConfig {
            period,
            ..options.config
        };
        let cell = Cell::start(cell_arms, cell_options, &connector)?;
        Ok(LiveCell {
            cell,
            names,
            time_scale: scale,
            period,
            step_time: setup.dt * scale,
            records,
            recent: VecDeque::with_capacity(RECENT),
            queued: VecDeque::new(),
            lag_s: 0.0,
        })
    }

    /// The arms' names, in the Embodier's order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The uniform slow-down of the arms against the policy's rate.
    pub fn time_scale(&self) -> f64 {
        self.time_scale
    }

    /// The control period.
    pub fn period(&self) -> Duration {
        self.period
    }

    /// Seconds per waypoint as streamed (`dt` times the time scale).
    pub fn step_time(&self) -> f64 {
        self.step_time
    }

    /// Where mock arms write their records (`NAME.jsonl`; a CAN mock's bus log `NAME.log`).
    pub fn records(&self) -> &std::path::Path {
        &self.records
    }

    /// Waypoints the Embodier must not replan while a push is planned: the longest recent
    /// planning and checking time, with a margin, in steps (at least one).
    fn lead(&self) -> usize {
        let longest = self.recent.iter().copied().fold(0.0, f64::max);
        (LEAD_MARGIN * longest / self.step_time).ceil() as usize + 1
    }

    fn remember(&mut self, seconds: f64) {
        if self.recent.len() == RECENT {
            self.recent.pop_front();
        }
        self.recent.push_back(seconds);
    }

    /// Plans a chunk (`hands[j][k]`: hand `j` at policy step `start_step + k`) and streams it:
    /// see the module. Returns once it is queued; the arms move on their own.
    pub fn push(
        &mut self,
        embodier: &mut Embodier,
        start_step: u64,
        hands: &[Vec<Pose>],
    ) -> Result<LivePush, LiveError> {
        let mut attempts = 0;
        loop {
            attempts += 1;
            let clock = Instant::now();
            let progress = self.cell.status()?.progress;
            let first = embodier.end() == 0;
            let from = match (first, progress.holding) {
                (true, _) => 1,
                (false, true) => progress.fixed + 1,
                (false, false) => progress.fixed + 1 + self.lead(),
            };
            if !first {
                embodier.commit_until(from);
            }
            let (late, chunk) = unsent(embodier, from, start_step, hands)?;
            let saved = embodier.checkpoint();
            let old_end = embodier.end();
            let report = (embodier.push_chunk(start_step + late as u64, &chunk))
                .map_err(LiveError::Chunk)?;
            let at = if first { 1 } else { report.index.min(old_end) };
            if let Err(why) = check_segment(embodier, at) {
                embodier.restore(saved);
                return Err(LiveError::Invalid(why));
            }
            self.remember(clock.elapsed().as_secs_f64());
            let tail: Vec<&[[f64; DOF]]> = (0..self.names.len())
                .map(|i| embodier.planned(i, at))
                .collect();
            match self.cell.push(at, &tail) {
                Ok(cycle) => {
                    self.queued.retain(|&(i, _)| i < at);
                    self.queued
                        .extend((at..embodier.end()).map(|i| (i, embodier.target(i))));
                    self.lag_s = report.total_lag_s;
                    return Ok(LivePush {
                        report,
                        late,
                        from: at,
                        cycle,
                        attempts,
                    });
                }
                Err(CellError::Push(PushError::AlreadyFixed { .. })) if attempts < ATTEMPTS => {
                    embodier.restore(saved);
                }
                Err(e) => {
                    embodier.restore(saved);
                    return Err(e.into());
                }
            }
        }
    }

    /// Where the stream and each arm are, the events since the last call, and the Embodier's
    /// lag.
    pub fn status(&mut self) -> Result<LiveStatus, LiveError> {
        let cell = self.cell.status()?;
        let step = cell.progress.step;
        while self.queued.front().is_some_and(|&(i, _)| i < step) {
            self.queued.pop_front();
        }
        let policy_step = (self.queued.front())
            .filter(|&&(i, _)| i == step)
            .and_then(|(_, t)| t.exact_step());
        Ok(LiveStatus {
            cell,
            policy_step,
            lag_s: self.lag_s,
        })
    }

    /// Lets the queue run out, holds for the settle cycles, disables the drives: the report
    /// and the mocks' records.
    pub fn finish(self) -> Result<CellEnd, LiveError> {
        Ok(self.cell.finish()?)
    }

    /// Stops every arm now (a quick stop, no fault): the report and the mocks' records.
    pub fn stop(self) -> Result<CellEnd, LiveError> {
        Ok(self.cell.stop()?)
    }
}

/// The chunk without its first poses at steps whose timeline index is before `from` (the
/// arms have them, or will before the chunk is planned): how many were dropped, and the rest.
/// All of them: the chunk is too late.
fn unsent(
    embodier: &Embodier,
    from: usize,
    start_step: u64,
    hands: &[Vec<Pose>],
) -> Result<(usize, Vec<Vec<Pose>>), LiveError> {
    let len = hands.first().map_or(0, Vec::len);
    let late = (0..len)
        .take_while(|&k| (embodier.timeline_index(start_step + k as u64)).is_some_and(|i| i < from))
        .count();
    if late == len && len > 0 {
        return Err(LiveError::Chunk(OnlineError::DeadlineMissed {
            start_step,
            committed_step: (start_step + late as u64) as i64 - 1,
        }));
    }
    Ok((
        late,
        hands
            .iter()
            .map(|h| h[late.min(h.len())..].to_vec())
            .collect(),
    ))
}

/// A number no other cell of this process has.
fn unique() -> usize {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static CELLS: AtomicUsize = AtomicUsize::new(0);
    CELLS.fetch_add(1, Ordering::SeqCst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::online::testing::{self, one_gen3, HOME};
    use crate::online::OnlineOptions;

    #[test]
    fn the_poses_the_arms_have_passed_are_dropped_and_a_chunk_all_passed_is_late() {
        let mut e = Embodier::new(&one_gen3(HOME), OnlineOptions::default()).unwrap();
        let chunk = |s: u64| testing::chunk(s, |k| 0.4 + 0.01 * k as f64);
        // Before the first chunk nothing is placed: nothing is late.
        assert_eq!(unsent(&e, 5, 0, &chunk(0)).unwrap().0, 0);
        let first = e.push_chunk(0, &chunk(0)).unwrap();
        // The arms have fixed step 1's waypoint: steps 0 and 1 are passed.
        let (late, rest) = unsent(&e, first.index + 2, 0, &chunk(0)).unwrap();
        assert_eq!(late, 2);
        assert_eq!(rest[0], chunk(0)[0][2..]);
        match unsent(&e, first.index + 4, 0, &chunk(0)) {
            Err(LiveError::Chunk(OnlineError::DeadlineMissed { start_step: 0, .. })) => {}
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_default_time_scale_brings_the_models_speeds_within_the_executors() {
        let e = Embodier::new(&one_gen3([0.0; DOF]), OnlineOptions::default()).unwrap();
        // The Gen3's joints 1-4 turn at 1.3963 rad/s, the executor keeps to 0.8727.
        let ratio = speed_ratio(&e).unwrap();
        assert!((ratio - 1.3963 / CAUTIOUS_SPEED).abs() < 1e-12, "{ratio}");
    }
}
