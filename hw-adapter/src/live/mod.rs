//! Streaming to the arms: one thread per bus, in lockstep on a common schedule, each cycle's
//! commands taken from the shared [`Generator`] as they are sent. The offline run
//! ([`crate::Executor::run`]) and online execution ([`StreamHandle`], segments pushed while
//! the arms move) are the same loop; a run ends once it is told to finish and the queue is
//! done, after the settle cycles, or once it is stopped (a fault, or on request).
//!
//! - `arm`: the arms' threads: started together, each one's start-up, cycles and stop.
//! - `handle`: [`StreamHandle`], what the caller holds while the arms move.
//! - `push`: a push computed on the caller's thread, for the arms to take over a few cycles on.

mod arm;
mod handle;
mod push;

pub(crate) use arm::start;
pub use handle::StreamHandle;

use crate::run::{ArmState, ArmStop, Command, Fault, LinkError, Measured, Progress, Span, JOINTS};
use crate::stream::Generator;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Barrier;
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
    /// The generator with the latest push applied, taken over when `generator` reaches its
    /// cycle ([`push`]).
    pending: Option<Pending>,
    /// Pushes handed over so far.
    pushes: u64,
    out: Vec<Command>,
    /// The cycle whose hold ends the run, once the run is finishing and the queue done.
    end: Option<u64>,
    was_holding: bool,
    events: VecDeque<Event>,
    holds: usize,
}

/// A generator with a push applied, for the arm threads to take over at its cycle.
#[derive(Debug)]
struct Pending {
    generator: Generator,
    /// Which push this is (each handed over counts one), so that two pushes racing from two
    /// threads cannot both be based on the same state.
    serial: u64,
}

impl Cycle {
    /// The arms hold at the end of the queue, with no push waiting to move them on.
    fn holding_at_end(&self) -> bool {
        let g = &self.generator;
        g.holding() && self.pending.is_none() && g.fixed() == g.end()
    }

    /// The generator with every push handed over applied (the pending one, if any).
    fn latest(&self) -> &Generator {
        self.pending
            .as_ref()
            .map_or(&self.generator, |p| &p.generator)
    }

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
    realtime_refused: Mutex<Option<crate::run::RealtimeRefused>>,
    finishing: AtomicBool,
    names: Vec<String>,
    /// Cycles each arm has sent (`usize::MAX` once it has finished).
    sent: Vec<AtomicUsize>,
    /// Per arm, the first cycle its per-cycle accounting does not yet allow
    /// ([`crate::link::ArmLink::clear_until`]; `u64::MAX` once it has finished): no arm sends a cycle that
    /// another arm's drives have not earned, so that a fault stops every arm at the same cycle.
    clear: Vec<AtomicU64>,
    /// How far the common schedule has slipped behind `start + k period`, ns: see
    /// [`Shared::due`].
    slip_ns: AtomicU64,
    /// The first fault.
    fault: Mutex<Option<FirstFault>>,
    cycle: Mutex<Cycle>,
    /// Per arm, what its thread last published.
    arms: Vec<Mutex<ArmNow>>,
}

/// The first fault of a run, which every arm stops for.
#[derive(Clone, Debug)]
struct FirstFault {
    /// The arm it was seen on.
    arm: String,
    fault: Fault,
    /// The control cycle in which it was detected.
    cycle: usize,
    /// When it was detected: each arm's stop latency counts from here.
    detected: Instant,
}

/// The lock of what the arm threads share with the caller's threads. On Linux it inherits
/// priority: a caller's thread at normal priority that holds it (to push, or to read the
/// stream's progress) runs at the arm threads' real-time priority while one of them waits,
/// instead of waiting itself behind every other real-time thread on the machine (mock arms,
/// other programs) while the arms miss their cycles.
#[cfg(target_os = "linux")]
type Mutex<T> = priority_inheriting_lock::PriorityInheritingLock<T>;
#[cfg(not(target_os = "linux"))]
type Mutex<T> = std::sync::Mutex<T>;

#[cfg(target_os = "linux")]
fn lock<T>(m: &Mutex<T>) -> priority_inheriting_lock::PriorityInheritingLockGuard<'_, T> {
    m.lock()
}

#[cfg(not(target_os = "linux"))]
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl Shared {
    fn raise(&self, arm: &str, fault: Fault, cycle: usize) -> Instant {
        let now = Instant::now();
        lock(&self.fault).get_or_insert(FirstFault {
            arm: arm.to_string(),
            fault,
            cycle,
            detected: now,
        });
        self.faulted.store(true, Ordering::SeqCst);
        now
    }

    /// When the first fault was detected, if there was one.
    fn fault_detected(&self) -> Option<Instant> {
        lock(&self.fault).as_ref().map(|f| f.detected)
    }

    /// When cycle `k` is due on the common schedule: `start + k period + slip`. The schedule
    /// slips (never catches up in a burst) when the host itself was away past a cycle: see
    /// [`Shared::slip_to`].
    fn due(&self, start: Instant, k: usize, period: Duration) -> Instant {
        start + period.mul_f64(k as f64) + Duration::from_nanos(self.slip_ns.load(Ordering::SeqCst))
    }

    /// Moves the common schedule so that cycle `k` is due no earlier than `at` (every arm
    /// follows: the latest of the arms' requests wins). The cycles after it keep their period
    /// from there: commands are never sent faster than one a period to make up for lost time,
    /// so that every answer has its period to arrive, and the arms get each cycle's command
    /// one period after the last.
    fn slip_to(&self, start: Instant, k: usize, period: Duration, at: Instant) {
        let on_time = start + period.mul_f64(k as f64);
        let slip = at.saturating_duration_since(on_time).as_nanos() as u64;
        self.slip_ns.fetch_max(slip, Ordering::SeqCst);
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
            if let Some(p) = c.pending.take_if(|p| p.generator.cycle() == k) {
                c.generator = p.generator;
            }
            let tick = c
                .generator
                .next(&mut c.out)
                .map_err(|e| Fault::CommandRefused(e.to_string()))?;
            let finishing = self.finishing.load(Ordering::SeqCst);
            if tick.holding && finishing && c.pending.is_none() {
                c.end.get_or_insert(k);
            } else if tick.ran_dry {
                c.holds += 1;
                c.event(Event::QueueDry {
                    cycle: tick.cycle,
                    step: tick.step,
                });
            } else if c.was_holding && !tick.holding && c.holds > 0 {
                // (The hold before the first push, at the start, is no dry queue.)
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

/// How an arm's thread ended.
enum ArmEnd {
    StartupFailed(LinkError),
    /// Start-up went fine but another arm's did not.
    Aborted,
    Completed {
        cycles: usize,
        frames: usize,
        max_following_error: f64,
        max_lateness: Duration,
    },
    /// Quick-stopped after a fault, or on request.
    Stopped {
        stop: ArmStop,
        frames: usize,
        max_following_error: f64,
    },
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
