//! Streaming to the arms: one thread per bus, in lockstep on a common schedule, each cycle's
//! commands taken from the shared [`Generator`] as they are sent. The offline run
//! ([`crate::Executor::run`]) and online execution ([`StreamHandle`], segments pushed while
//! the arms move) are the same loop; a run ends once it is told to finish and the queue is
//! done, after the settle cycles.

use crate::link::ArmLink;
use crate::log::LogSink;
use crate::priority;
use crate::run::{
    ArmReport, ArmStop, Command, ExecConfig, ExecError, Fault, FaultReport, Progress, Report, Span,
    JOINTS, STOP_BOUND_PERIODS,
};
use crate::stream::{Generator, PushError};
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Barrier, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How often a waiting arm thread looks at the shared fault flag and at its own bus.
const FAULT_POLL: Duration = Duration::from_micros(100);

/// The progress callback of a run.
pub(crate) type ProgressFn = Box<dyn Fn(Progress) + Send + Sync>;

/// Events kept for [`StreamHandle::events`]; older ones are dropped beyond this.
pub const MAX_EVENTS: usize = 1024;

/// Something the stream did that its caller should know about.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// The queue ran dry: the arms came to rest at the last queued waypoint `step` and hold
    /// there (from control cycle `cycle`) until a push extends the queue.
    QueueDry {
        /// The first cycle of the hold.
        cycle: u64,
        /// The waypoint held.
        step: usize,
    },
    /// A push extended the queue and the arms move on from the held `step`.
    Resumed {
        /// The first cycle of the motion.
        cycle: u64,
        /// The waypoint they held.
        step: usize,
    },
}

/// Where the stream is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamProgress {
    /// Control cycles computed so far.
    pub cycle: u64,
    /// The step being executed (moving from it toward the next, or holding at it).
    pub step: usize,
    /// The last waypoint already fixed: a push may start at `fixed + 1` at the earliest.
    pub fixed: usize,
    /// The arms hold at the end of the queue.
    pub holding: bool,
}

/// The generator and the commands of the cycle being sent.
struct Cycle {
    generator: Generator,
    out: Vec<Command>,
    /// The cycle whose hold ends the run, once the run is finishing and the queue done.
    end: Option<u64>,
    was_holding: bool,
    events: VecDeque<Event>,
    holds: usize,
}

impl Cycle {
    fn event(&mut self, e: Event) {
        if self.events.len() == MAX_EVENTS {
            self.events.pop_front();
        }
        self.events.push_back(e);
    }
}

/// State shared by the arm threads and the handle.
struct Shared {
    barrier: Barrier,
    startup_failed: AtomicBool,
    start: Mutex<Option<Instant>>,
    faulted: AtomicBool,
    /// Why an arm thread did not get the real-time priority asked for, if one did not.
    realtime_refused: Mutex<Option<String>>,
    finishing: AtomicBool,
    names: Vec<String>,
    /// Cycles each arm has sent (`usize::MAX` once it has finished).
    sent: Vec<AtomicUsize>,
    /// Per arm, the first cycle its per-cycle accounting does not yet allow
    /// ([`ArmBus::clear_until`]; `u64::MAX` once it has finished): no arm sends a cycle that
    /// another arm's drives have not earned, so that a fault stops every arm at the same cycle.
    clear: Vec<AtomicU64>,
    /// The first fault: arm, fault, cycle, when detected.
    fault: Mutex<Option<(String, Fault, usize, Instant)>>,
    cycle: Mutex<Cycle>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Shared {
    fn raise(&self, arm: &str, fault: Fault, cycle: usize) -> Instant {
        let now = Instant::now();
        lock(&self.fault).get_or_insert((arm.to_string(), fault, cycle, now));
        self.faulted.store(true, Ordering::SeqCst);
        now
    }

    /// Arm `me`'s command of cycle `k` (computing the cycle if no arm has yet), and whether
    /// the run ends with this cycle's hold (`Some(end cycle)`).
    fn command(&self, me: usize, k: u64) -> Result<(Command, Option<u64>), Fault> {
        let mut c = lock(&self.cycle);
        if c.generator.cycle() == k {
            let c = &mut *c;
            let tick = c
                .generator
                .next(&mut c.out)
                .map_err(|e| Fault::CommandRefused(e.to_string()))?;
            let finishing = self.finishing.load(Ordering::SeqCst);
            if tick.holding && finishing {
                c.end.get_or_insert(k);
            } else if tick.ran_dry {
                c.holds += 1;
                c.event(Event::QueueDry {
                    cycle: tick.cycle,
                    step: tick.step,
                });
            } else if c.was_holding && !tick.holding && k > 0 {
                c.event(Event::Resumed {
                    cycle: tick.cycle,
                    step: tick.step,
                });
            }
            c.was_holding = tick.holding;
        }
        Ok((c.out[me], c.end))
    }
}

enum ArmEnd {
    StartupFailed(String),
    /// Start-up went fine but another arm's did not.
    Aborted,
    Completed {
        cycles: usize,
        frames: usize,
        max_following_error: f64,
        max_lateness: Duration,
    },
    Stopped(ArmStop, usize),
}

/// What the run's report needs that the threads do not know.
pub(crate) struct RunInfo {
    pub time_scale: f64,
    /// Total cycles (with the settle cycles) when known in advance, for progress output.
    pub total_cycles: Option<u64>,
    /// Per arm and joint, the range (bus counts) every command stays in: each drive's
    /// software position limits (0x607D) must cover it before any drive is enabled.
    pub spans: Vec<Span>,
    /// Per arm and joint, the peak commanded speed, rad/s (the drives' following-error
    /// windows).
    pub speeds: Vec<[f64; JOINTS]>,
}

/// A stream to the arms while it runs: push segments, watch it, finish it.
pub struct StreamHandle {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<ArmEnd>>,
    config: ExecConfig,
    log: Option<LogSink>,
    info: RunInfo,
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
        faulted: AtomicBool::new(false),
        realtime_refused: Mutex::new(None),
        finishing: AtomicBool::new(finishing),
        sent: links.iter().map(|_| AtomicUsize::new(0)).collect(),
        clear: links.iter().map(|_| AtomicU64::new(0)).collect(),
        names,
        fault: Mutex::new(None),
        cycle: Mutex::new(Cycle {
            generator,
            out: vec![[0; JOINTS]; arms],
            end: None,
            was_holding: true,
            events: VecDeque::new(),
            holds: 0,
        }),
    });
    let progress: Option<Arc<ProgressFn>> = progress.map(Arc::new);
    let threads = (links.into_iter())
        .zip(first)
        .zip(info.spans.clone())
        .zip(info.speeds.clone())
        .enumerate()
        .map(|(me, (((mut bus, first), span), speed))| {
            let (shared, config, progress) = (shared.clone(), config.clone(), progress.clone());
            let total = info.total_cycles;
            std::thread::spawn(move || {
                if let Some(Err(why)) = config.realtime_priority.map(priority::make_realtime) {
                    lock(&shared.realtime_refused).get_or_insert(why);
                }
                let progress = progress.as_deref().map(|p| p.as_ref());
                stream_arm(
                    me,
                    bus.as_mut(),
                    (first, span, speed),
                    &shared,
                    &config,
                    progress,
                    total,
                )
            })
        })
        .collect();
    StreamHandle {
        shared,
        threads,
        config,
        log,
        info,
    }
}

impl StreamHandle {
    /// Replaces every arm's waypoints from step `start_step` on (arms in the order given at
    /// the start; waypoint `i` of each at step `start_step + i`). Refused, with nothing
    /// changed, if `start_step` is already fixed ([`StreamProgress::fixed`]), leaves a gap,
    /// queues too far ahead, or if any command the new tail leads to (through to the hold at
    /// its end) would break a limit; or if the stream has stopped. Returns the control cycle
    /// from which the new tail is streamed (the generator's state when it was applied: a
    /// [`Generator`] given the same pushes at the same cycles computes the same commands).
    pub fn push(
        &self,
        start_step: usize,
        waypoints: &[&[[f64; JOINTS]]],
    ) -> Result<u64, PushError> {
        if let Some((arm, fault, ..)) = lock(&self.shared.fault).as_ref() {
            return Err(PushError::Stopped(format!("fault on arm {arm:?}: {fault}")));
        }
        if self.threads.iter().all(|t| t.is_finished()) {
            return Err(PushError::Stopped("the stream has ended".into()));
        }
        let mut c = lock(&self.shared.cycle);
        c.generator.push(start_step, waypoints)?;
        Ok(c.generator.cycle())
    }

    /// Where the stream is now.
    pub fn progress(&self) -> StreamProgress {
        let c = lock(&self.shared.cycle);
        StreamProgress {
            cycle: c.generator.cycle(),
            step: c.generator.step(),
            fixed: c.generator.fixed(),
            holding: c.generator.holding() && c.generator.fixed() == c.generator.end(),
        }
    }

    /// The events since the last call (at most [`MAX_EVENTS`]; older ones are dropped).
    pub fn events(&self) -> Vec<Event> {
        lock(&self.shared.cycle).events.drain(..).collect()
    }

    /// A fault has stopped the stream (every arm quick-stopped); [`StreamHandle::finish`]
    /// returns its report.
    pub fn faulted(&self) -> bool {
        self.shared.faulted.load(Ordering::SeqCst)
    }

    /// Lets the queue run to its end, holds for the settle cycles, disables the drives, and
    /// returns the report (or the fault that stopped the run).
    pub fn finish(self) -> Result<Report, ExecError> {
        self.shared.finishing.store(true, Ordering::SeqCst);
        let ends: Vec<ArmEnd> = (self.threads.into_iter())
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| ArmEnd::StartupFailed("arm thread panicked".into()))
            })
            .collect();
        finish_run(&self.config, &self.info, ends, &self.shared, self.log)
    }
}

/// One arm's whole run, on its own thread, from the command it holds first, the range its
/// commands stay in and its joints' peak speeds.
fn stream_arm(
    me: usize,
    bus: &mut dyn ArmLink,
    (first, span, speed): (Command, Span, [f64; JOINTS]),
    shared: &Shared,
    cfg: &ExecConfig,
    progress: Option<&(dyn Fn(Progress) + Send + Sync)>,
    total: Option<u64>,
) -> ArmEnd {
    // No drive of any arm is enabled unless every arm's drives are configured.
    let configured = bus.configure(cfg, (&first, &span, &speed), &shared.startup_failed);
    if let Some(end) = startup_phase_end(bus, configured, shared) {
        return end;
    }
    let enabled = bus.enable(cfg);
    if let Some(end) = startup_phase_end(bus, enabled, shared) {
        return end;
    }
    // Every arm streams on the same schedule from a common start time.
    let t0 = *lock(&shared.start).get_or_insert_with(|| Instant::now() + cfg.period);
    let progress_every = (0.1 / cfg.period.as_secs_f64()).ceil().max(1.0) as usize;
    let mut prev1 = first;
    let mut max_fe: f64 = 0.0;
    let mut max_late = Duration::ZERO;
    let mut k: usize = 0;
    loop {
        let due = t0 + cfg.period.mul_f64(k as f64);
        max_late = max_late.max(Instant::now().saturating_duration_since(due));
        let mut step = || -> Result<Option<(Command, Option<u64>)>, Fault> {
            // Feedback is read while waiting too, so that a fault is seen when its frame
            // arrives rather than at the next cycle.
            // Once the cycle is due, the per-cycle accounting says whether it may be sent.
            let mut watch = || -> Result<f64, Fault> {
                bus.poll().map_err(Fault::Bus)?;
                let now = Instant::now();
                let fe = bus.check_feedback(now, cfg, &prev1)?;
                if now >= due {
                    bus.check_cycle()?;
                }
                shared.clear[me].store(bus.clear_until(), Ordering::SeqCst);
                Ok(fe)
            };
            wait_turn(me, k, due, shared, cfg, &mut watch)?;
            let fe = watch()?;
            if shared.faulted.load(Ordering::SeqCst) {
                return Ok(None);
            }
            max_fe = max_fe.max(fe);
            // Checked against the limits by the generator.
            let (cmd, end) = shared.command(me, k as u64)?;
            bus.send_cycle(&cmd).map_err(Fault::Bus)?;
            Ok(Some((cmd, end)))
        };
        let fault = match step() {
            Ok(Some((cmd, end))) => {
                shared.sent[me].store(k + 1, Ordering::SeqCst);
                prev1 = cmd;
                let done = end.is_some_and(|e| k as u64 >= e + cfg.settle_cycles as u64);
                if let Some(p) = progress {
                    if k.is_multiple_of(progress_every) || done {
                        p(Progress {
                            arm: bus.name(),
                            cycle: k + 1,
                            cycles: total.map_or(0, |t| t as usize),
                        });
                    }
                }
                k += 1;
                if done {
                    break;
                }
                continue;
            }
            Ok(None) => None,
            Err(f) => Some(f),
        };
        // A fault here or on another arm: quick stop, and nothing after it.
        let detected = match fault {
            Some(f) => shared.raise(bus.name(), f, k),
            None => lock(&shared.fault)
                .as_ref()
                .map_or_else(Instant::now, |f| f.3),
        };
        let sent = bus.quick_stop(&prev1);
        // The bound is on the stop frames going out; the answers are waited for after.
        let latency = detected.elapsed();
        let (error, unanswered) = match (sent, bus.leave()) {
            (Err(e), left) => (Some(e), left.unwrap_or_default()),
            (Ok(()), Ok(unanswered)) => (None, unanswered),
            (Ok(()), Err(e)) => (Some(e), Vec::new()),
        };
        let stop = ArmStop {
            arm: bus.name().to_string(),
            cycles_sent: k,
            latency,
            error,
            unanswered,
        };
        return ArmEnd::Stopped(stop, bus.frames_sent());
    }
    shared.sent[me].store(usize::MAX, Ordering::SeqCst);
    shared.clear[me].store(u64::MAX, Ordering::SeqCst);
    // An arm that leaves a frame of its normal stop unanswered has not been seen to stop.
    let ended = bus.finish(&prev1).and_then(|()| match bus.leave()? {
        unanswered if unanswered.is_empty() => Ok(()),
        unanswered => Err(format!(
            "the arm did not answer its stop: {}",
            unanswered.join("; ")
        )),
    });
    match ended {
        Ok(()) => ArmEnd::Completed {
            cycles: k,
            frames: bus.frames_sent(),
            max_following_error: max_fe,
            max_lateness: max_late,
        },
        Err(e) => {
            let detected = shared.raise(bus.name(), Fault::Bus(e.clone()), k);
            let stop = ArmStop {
                arm: bus.name().to_string(),
                cycles_sent: k,
                latency: detected.elapsed(),
                error: Some(e),
                unanswered: Vec::new(),
            };
            ArmEnd::Stopped(stop, bus.frames_sent())
        }
    }
}

/// Waits for every arm to finish a start-up phase with `result`; the arm's end if this arm or
/// another failed (an arm that did not fail stops its nodes).
fn startup_phase_end(
    bus: &mut dyn ArmLink,
    result: Result<(), String>,
    shared: &Shared,
) -> Option<ArmEnd> {
    if result.is_err() {
        shared.startup_failed.store(true, Ordering::SeqCst);
    }
    shared.barrier.wait();
    match result {
        Err(e) => Some(ArmEnd::StartupFailed(e)),
        Ok(()) if shared.startup_failed.load(Ordering::SeqCst) => {
            // What the arm leaves unanswered is in the command log; the start-up's failure is
            // the run's error.
            Some(match bus.abort().and_then(|()| bus.leave()) {
                Ok(_) => ArmEnd::Aborted,
                Err(e) => ArmEnd::StartupFailed(format!("while aborting: {e}")),
            })
        }
        Ok(()) => None,
    }
}

/// Waits until cycle `k` is due, every arm has sent cycle `k - 1` and every arm's accounting
/// allows cycle `k`, calling `watch` (this arm's feedback check) every [`FAULT_POLL`]; returns
/// early if a fault is raised here or on another arm. An arm that keeps the others waiting
/// longer than the feedback timeout is a fault.
fn wait_turn(
    me: usize,
    k: usize,
    due: Instant,
    shared: &Shared,
    cfg: &ExecConfig,
    watch: &mut dyn FnMut() -> Result<f64, Fault>,
) -> Result<(), Fault> {
    let give_up = due.max(Instant::now()) + cfg.feedback_timeout;
    loop {
        if shared.faulted.load(Ordering::SeqCst) {
            return Ok(());
        }
        watch()?;
        let now = Instant::now();
        let behind = (shared.sent.iter())
            .position(|c| c.load(Ordering::SeqCst) < k)
            .or_else(|| (shared.clear.iter()).position(|c| c.load(Ordering::SeqCst) <= k as u64));
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
    cfg: &ExecConfig,
    info: &RunInfo,
    ends: Vec<ArmEnd>,
    shared: &Shared,
    log: Option<LogSink>,
) -> Result<Report, ExecError> {
    let mut startup_errors = Vec::new();
    let mut stops = Vec::new();
    let mut arms = Vec::new();
    let mut max_lateness = Duration::ZERO;
    let mut frames_sent = 0;
    for (end, name) in ends.into_iter().zip(&shared.names) {
        match end {
            ArmEnd::StartupFailed(e) => startup_errors.push((name.clone(), e)),
            ArmEnd::Aborted => {}
            ArmEnd::Stopped(s, frames) => {
                frames_sent += frames;
                stops.push(s)
            }
            ArmEnd::Completed {
                cycles,
                frames,
                max_following_error,
                max_lateness: late,
            } => {
                frames_sent += frames;
                max_lateness = max_lateness.max(late);
                arms.push(ArmReport {
                    name: name.clone(),
                    cycles_sent: cycles,
                    max_following_error,
                });
            }
        }
    }
    let logged = crate::log::finish(log);
    if !startup_errors.is_empty() {
        return Err(ExecError::Startup(startup_errors));
    }
    if let Some((arm, fault, cycle, _)) = lock(&shared.fault).take() {
        // Arms that had already finished normally count as stopped at once.
        for a in arms {
            stops.push(ArmStop {
                arm: a.name,
                cycles_sent: a.cycles_sent,
                latency: Duration::ZERO,
                error: None,
                unanswered: Vec::new(),
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
    let c = lock(&shared.cycle);
    Ok(Report {
        dry_run: false,
        period: cfg.period,
        time_scale: info.time_scale,
        cycles: c.end.map_or(0, |e| e as usize + 1),
        frames_sent,
        arms,
        max_lateness,
        holds: c.holds,
        realtime: lock(&shared.realtime_refused).clone().map_or(Ok(()), Err),
    })
}
