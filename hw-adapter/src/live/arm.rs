//! The arms' threads: started together ([`start`]), each arm's start-up together with the
//! others, then one cycle per period in lockstep with them, the feedback watched in between,
//! and the stop (normal end, fault, or a stop asked for).

use super::{lock, ArmEnd, ArmNow, Cycle, Mutex, ProgressFn, RunInfo, Shared, FAULT_POLL};
use crate::link::{ArmLink, StartPlan};
use crate::log::LogSink;
use crate::priority;
use crate::run::{ArmState, ArmStop, Command, ExecConfig, Fault, LinkError, Progress, JOINTS};
use crate::stream::Generator;
use crate::StreamHandle;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Barrier};
use std::time::{Duration, Instant};

/// One arm's whole run, on its own thread: start-up together with the other arms, then one
/// [`Streaming::step`] per control cycle until the run ends ([`Streaming::finish`]) or stops
/// ([`Streaming::stop`]).
pub(super) fn stream_arm(
    me: usize,
    bus: &mut dyn ArmLink,
    plan: &StartPlan,
    shared: &Shared,
    cfg: &ExecConfig,
    progress: Option<&(dyn Fn(Progress) + Send + Sync)>,
    total: Option<u64>,
) -> ArmEnd {
    // No drive of any arm is enabled unless every arm's drives are configured.
    let configured = bus.configure(cfg, plan, &shared.startup_failed);
    if let Some(end) = startup_phase_end(me, bus, configured, shared) {
        return end;
    }
    let enabled = bus.enable(cfg);
    if let Some(end) = startup_phase_end(me, bus, enabled, shared) {
        return end;
    }
    shared.publish(me, |a| {
        a.state = ArmState::Moving;
        a.measured = bus.measured();
    });
    let mut arm = Streaming::new(me, bus, shared, cfg, plan.first);
    let progress_every = (0.1 / cfg.period.as_secs_f64()).ceil().max(1.0) as usize;
    loop {
        match arm.step() {
            Ok(Some(done)) => {
                if let Some(p) = progress {
                    if (arm.k - 1).is_multiple_of(progress_every) || done {
                        p(Progress {
                            arm: arm.bus.name(),
                            cycle: arm.k,
                            cycles: total.map_or(0, |t| t as usize),
                        });
                    }
                }
                if done {
                    return arm.finish();
                }
            }
            Ok(None) => return arm.stop(None),
            Err(f) => return arm.stop(Some(f)),
        }
    }
}

/// One arm's streaming, cycle by cycle, on the common schedule.
struct Streaming<'a> {
    me: usize,
    bus: &'a mut dyn ArmLink,
    shared: &'a Shared,
    cfg: &'a ExecConfig,
    /// The schedule's origin, common to every arm.
    start: Instant,
    /// The next cycle to send.
    k: usize,
    /// The last command sent (before the first cycle: the one the arm holds).
    prev: Command,
    max_fe: f64,
    /// How late the cycles went out against the schedule.
    max_late: Duration,
    /// When this thread last looked at its bus: a gap much longer than its poll is time the
    /// host was away (descheduled), which no answer could use.
    seen: Instant,
}

impl<'a> Streaming<'a> {
    fn new(
        me: usize,
        bus: &'a mut dyn ArmLink,
        shared: &'a Shared,
        cfg: &'a ExecConfig,
        held: Command,
    ) -> Self {
        // Every arm streams on the same schedule from a common start time.
        let start = *lock(&shared.start).get_or_insert_with(|| Instant::now() + cfg.period);
        Self {
            me,
            bus,
            shared,
            cfg,
            start,
            k: 0,
            prev: held,
            max_fe: 0.0,
            max_late: Duration::ZERO,
            seen: Instant::now(),
        }
    }

    /// Waits for cycle `k`'s turn and sends it: `Some(true)` if the run ends with it,
    /// `Some(false)` if it goes on, `None` if the run is stopping (a fault elsewhere, or a stop
    /// asked for).
    fn step(&mut self) -> Result<Option<bool>, Fault> {
        let due = self.wait_turn()?;
        let fe = self.watch(true)?;
        if self.shared.stopping() {
            return Ok(None);
        }
        let k = self.k;
        self.max_late = self
            .max_late
            .max(Instant::now().saturating_duration_since(due));
        // Checked against the limits by the generator.
        let (cmd, end) = self.shared.command(self.me, k as u64)?;
        self.bus.send_cycle(&cmd).map_err(Fault::Link)?;
        self.shared.sent[self.me].store(k + 1, Ordering::SeqCst);
        self.prev = cmd;
        self.max_fe = self.max_fe.max(fe);
        let measured = self.bus.measured();
        self.shared.publish(self.me, |a| {
            a.commanded = cmd;
            a.sent = k as u64 + 1;
            a.measured = measured;
            a.following_error = fe;
        });
        self.k += 1;
        Ok(Some(end.is_some_and(|e| {
            k as u64 >= e + self.cfg.settle_cycles as u64
        })))
    }

    /// Handles the feedback received so far (so that a fault is seen when its frame arrives,
    /// not at the next cycle) and, once the cycle is `due`, whether the per-cycle accounting
    /// allows it; returns the following error.
    fn watch(&mut self, due: bool) -> Result<f64, Fault> {
        self.bus.poll().map_err(Fault::Link)?;
        let now = Instant::now();
        self.seen = now;
        let fe = self.bus.check_feedback(now, self.cfg, &self.prev)?;
        if due {
            self.bus.check_cycle()?;
        }
        self.shared.clear[self.me].store(self.bus.clear_until(), Ordering::SeqCst);
        Ok(fe)
    }

    /// Waits until cycle `k` is due, every arm has sent cycle `k - 1` and every arm's
    /// accounting allows cycle `k`, watching the feedback every [`FAULT_POLL`]; returns when
    /// it was due, or early if a fault is raised here or on another arm, or a stop is asked
    /// for. An arm that keeps the others waiting longer than the feedback timeout is a fault.
    ///
    /// A thread that wakes up [`away_after`] later than it asked was held up by the machine,
    /// not by the arms: the answers owed had that time taken from them too (on one machine,
    /// the mocks and simulators are held up alike), so the schedule slips to now: the cycle
    /// goes out at once, the next a period later, and every answer owed gets its period. So
    /// does a cycle sent that late because another arm kept this one waiting: the cell never
    /// sends cycles in a burst to catch up.
    fn wait_turn(&mut self) -> Result<Instant, Fault> {
        let (shared, cfg, k) = (self.shared, self.cfg, self.k);
        let mut asleep = Duration::ZERO;
        let mut due = shared.due(self.start, k, cfg.period);
        let mut give_up = due.max(Instant::now()) + cfg.watch.feedback_timeout;
        loop {
            if shared.stopping() {
                return Ok(due);
            }
            let now = Instant::now();
            if now.saturating_duration_since(self.seen) > asleep + away_after(cfg.period) {
                shared.slip_to(self.start, k, cfg.period, now);
                due = shared.due(self.start, k, cfg.period);
                give_up = give_up.max(due + cfg.watch.feedback_timeout);
            }
            self.watch(now >= due)?;
            let behind = (shared.sent.iter())
                .position(|c| c.load(Ordering::SeqCst) < k)
                .or_else(|| {
                    (shared.clear.iter()).position(|c| c.load(Ordering::SeqCst) <= k as u64)
                });
            if now >= due && behind.is_none() {
                // Sent past its turn (another arm kept it waiting, held up in its own cycle):
                // the schedule slips to now, as for a thread held up while asleep, so that the
                // next cycle still goes a period after this one and no answer owed loses time.
                if now > due + away_after(cfg.period) {
                    shared.slip_to(self.start, k, cfg.period, now);
                }
                return Ok(due);
            }
            if now >= give_up {
                let other = behind.unwrap_or(self.me);
                return Err(Fault::Link(LinkError::BehindSchedule {
                    arm: shared.names[other].clone(),
                    after: cfg.watch.feedback_timeout,
                }));
            }
            asleep = due
                .saturating_duration_since(now)
                .clamp(Duration::ZERO, FAULT_POLL)
                .max(Duration::from_micros(20));
            std::thread::sleep(asleep);
            // Another arm may have slipped the schedule meanwhile.
            due = due.max(shared.due(self.start, k, cfg.period));
        }
    }

    /// A fault here (`fault`) or on another arm, or a stop asked for: quick stop, and nothing
    /// after.
    fn stop(self, fault: Option<Fault>) -> ArmEnd {
        let detected = match fault {
            Some(f) => self.shared.raise(self.bus.name(), f, self.k),
            None => self.shared.fault_detected().unwrap_or_else(Instant::now),
        };
        let sent = self.bus.quick_stop(&self.prev);
        // The bound is on the stop frames going out; the answers are waited for after.
        let latency = detected.elapsed();
        self.shared
            .publish(self.me, |a| a.state = ArmState::Stopped);
        let (error, unanswered) = match (sent, self.bus.leave()) {
            (Err(e), left) => (Some(e), left.unwrap_or_default()),
            (Ok(()), Ok(unanswered)) => (None, unanswered),
            (Ok(()), Err(e)) => (Some(e), Vec::new()),
        };
        let stop = ArmStop {
            arm: self.bus.name().to_string(),
            cycles_sent: self.k,
            latency,
            error,
            unanswered,
        };
        ArmEnd::Stopped {
            stop,
            frames: self.bus.frames_sent(),
            max_following_error: self.max_fe,
        }
    }

    /// The run's normal end: the arm's stop frames, answered.
    fn finish(self) -> ArmEnd {
        let (me, shared) = (self.me, self.shared);
        shared.sent[me].store(usize::MAX, Ordering::SeqCst);
        shared.clear[me].store(u64::MAX, Ordering::SeqCst);
        // An arm that leaves a frame of its normal stop unanswered has not been seen to stop.
        let ended = self
            .bus
            .finish(&self.prev)
            .and_then(|()| match self.bus.leave()? {
                unanswered if unanswered.is_empty() => Ok(()),
                unanswered => Err(LinkError::StopUnanswered(unanswered)),
            });
        match ended {
            Ok(()) => {
                shared.publish(me, |a| a.state = ArmState::Finished);
                ArmEnd::Completed {
                    cycles: self.k,
                    frames: self.bus.frames_sent(),
                    max_following_error: self.max_fe,
                    max_lateness: self.max_late,
                }
            }
            Err(e) => {
                shared.publish(me, |a| a.state = ArmState::Stopped);
                let detected = shared.raise(self.bus.name(), Fault::Link(e.clone()), self.k);
                let stop = ArmStop {
                    arm: self.bus.name().to_string(),
                    cycles_sent: self.k,
                    latency: detected.elapsed(),
                    error: Some(e),
                    unanswered: Vec::new(),
                };
                ArmEnd::Stopped {
                    stop,
                    frames: self.bus.frames_sent(),
                    max_following_error: self.max_fe,
                }
            }
        }
    }
}

/// How much later than it asked a waiting thread may wake before it counts as held up by the
/// machine: a quarter period, at least 250 µs (a thread's ordinary wake-up latency under load
/// is tens of microseconds, see docs/HARDWARE.md).
fn away_after(period: Duration) -> Duration {
    (period / 4).max(Duration::from_micros(250))
}

/// Waits for every arm to finish a start-up phase with `result`; the arm's end if this arm or
/// another failed (an arm that did not fail stops its nodes).
fn startup_phase_end(
    me: usize,
    bus: &mut dyn ArmLink,
    result: Result<(), LinkError>,
    shared: &Shared,
) -> Option<ArmEnd> {
    if result.is_err() {
        shared.startup_failed.store(true, Ordering::SeqCst);
    }
    shared.barrier.wait();
    let end = match result {
        Err(e) => ArmEnd::StartupFailed(e),
        // What the arm leaves unanswered is in the command log; the start-up's failure is the
        // run's error.
        Ok(()) if shared.startup_failed.load(Ordering::SeqCst) => {
            match bus.abort().and_then(|()| bus.leave()) {
                Ok(_) => ArmEnd::Aborted,
                Err(e) => ArmEnd::StartupFailed(e),
            }
        }
        Ok(()) => return None,
    };
    shared.publish(me, |a| a.state = ArmState::Stopped);
    Some(end)
}

/// Starts one thread per link (link i streams the generator's arm i; `log` is the command
/// log the links write to, finished with the run): start-up of every arm together, then
/// streaming.
pub(crate) fn start(
    generator: Generator,
    links: Vec<Box<dyn ArmLink>>,
    (config, log): (ExecConfig, Option<LogSink>),
    progress: Option<ProgressFn>,
    finishing: bool,
    info: RunInfo,
) -> StreamHandle {
    let names: Vec<String> = links.iter().map(|l| l.name().to_string()).collect();
    // Start-up checks each arm against the command it holds before the first cycle.
    let first: Vec<Command> = generator.held().collect();
    let arms = generator.arms();
    let shared = Arc::new(Shared {
        barrier: Barrier::new(links.len()),
        startup_failed: AtomicBool::new(false),
        start: Mutex::new(None),
        slip_ns: AtomicU64::new(0),
        faulted: AtomicBool::new(false),
        halt: AtomicBool::new(false),
        realtime_refused: Mutex::new(None),
        finishing: AtomicBool::new(finishing),
        sent: links.iter().map(|_| AtomicUsize::new(0)).collect(),
        clear: links.iter().map(|_| AtomicU64::new(0)).collect(),
        names,
        fault: Mutex::new(None),
        cycle: Mutex::new(Cycle {
            generator,
            pending: None,
            pushes: 0,
            out: vec![[0; JOINTS]; arms],
            end: None,
            was_holding: true,
            events: VecDeque::new(),
            holds: 0,
        }),
        arms: (first.iter())
            .map(|&commanded| {
                Mutex::new(ArmNow {
                    state: ArmState::Starting,
                    commanded,
                    sent: 0,
                    measured: None,
                    following_error: 0.0,
                })
            })
            .collect(),
    });
    let progress: Option<Arc<ProgressFn>> = progress.map(Arc::new);
    let threads = (links.into_iter())
        .zip(first)
        .zip(info.spans.clone())
        .zip(info.speeds.clone())
        .enumerate()
        .map(|(me, (((mut bus, first), span), speed))| {
            let plan = StartPlan { first, span, speed };
            let (shared, config, progress) = (shared.clone(), config.clone(), progress.clone());
            let total = info.total_cycles;
            std::thread::spawn(move || {
                if let Some(Err(why)) = config.realtime_priority.map(priority::make_realtime) {
                    lock(&shared.realtime_refused).get_or_insert(why);
                }
                let progress = progress.as_deref().map(|p| p.as_ref());
                stream_arm(me, bus.as_mut(), &plan, &shared, &config, progress, total)
            })
        })
        .collect();
    StreamHandle::new(shared, threads, config, log, info)
}
