//! Streaming to the arms: one thread per bus, in lockstep on a common schedule, each cycle's
//! commands taken from the shared [`Generator`] as they are sent. The offline run
//! ([`crate::Executor::run`]) and online execution ([`StreamHandle`], segments pushed while
//! the arms move) are the same loop; a run ends once it is told to finish and the queue is
//! done, after the settle cycles, or once it is stopped (a fault, or on request).
//!
//! - `arm`: one arm's thread: start-up, the cycles, the stop.
//! - `handle`: [`StreamHandle`], what the caller holds while the arms move.

mod arm;
mod handle;

pub use handle::StreamHandle;

use crate::link::ArmLink;
use crate::log::LogSink;
use crate::priority;
use crate::run::{ArmState, Command, ExecConfig, Fault, Measured, Progress, Span, JOINTS};
use crate::stream::Generator;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Barrier, Mutex, MutexGuard};
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

/// What one arm's thread publishes about its arm, for [`StreamHandle::status`].
#[derive(Clone, Copy, Debug)]
struct ArmNow {
    state: ArmState,
    /// The last command sent (before the first cycle: the start).
    commanded: Command,
    /// Cycles sent.
    sent: u64,
    measured: Option<Measured>,
    following_error: f64,
}

/// State shared by the arm threads and the handle.
struct Shared {
    barrier: Barrier,
    startup_failed: AtomicBool,
    start: Mutex<Option<Instant>>,
    faulted: AtomicBool,
    /// Stop every arm now, on request (no fault).
    halt: AtomicBool,
    /// Why an arm thread did not get the real-time priority asked for, if one did not.
    realtime_refused: Mutex<Option<String>>,
    finishing: AtomicBool,
    names: Vec<String>,
    /// Cycles each arm has sent (`usize::MAX` once it has finished).
    sent: Vec<AtomicUsize>,
    /// Per arm, the first cycle its per-cycle accounting does not yet allow
    /// ([`ArmLink::clear_until`]; `u64::MAX` once it has finished): no arm sends a cycle that
    /// another arm's drives have not earned, so that a fault stops every arm at the same cycle.
    clear: Vec<AtomicU64>,
    /// The first fault: arm, fault, cycle, when detected.
    fault: Mutex<Option<(String, Fault, usize, Instant)>>,
    cycle: Mutex<Cycle>,
    /// Per arm, what its thread last published.
    arms: Vec<Mutex<ArmNow>>,
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

    /// A fault here or elsewhere, or a stop asked for: every arm stops.
    fn stopping(&self) -> bool {
        self.faulted.load(Ordering::SeqCst) || self.halt.load(Ordering::SeqCst)
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

    /// Publishes what arm `me` is at.
    fn publish(&self, me: usize, update: impl FnOnce(&mut ArmNow)) {
        update(&mut lock(&self.arms[me]));
    }
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
        halt: AtomicBool::new(false),
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
            let (shared, config, progress) = (shared.clone(), config.clone(), progress.clone());
            let total = info.total_cycles;
            std::thread::spawn(move || {
                if let Some(Err(why)) = config.realtime_priority.map(priority::make_realtime) {
                    lock(&shared.realtime_refused).get_or_insert(why);
                }
                let progress = progress.as_deref().map(|p| p.as_ref());
                arm::stream_arm(
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
    StreamHandle::new(shared, threads, config, log, info)
}
