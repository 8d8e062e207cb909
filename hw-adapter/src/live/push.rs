//! A push computed beside the running stream, not in its way: the arm threads take each
//! cycle's commands from the shared generator under one lock, and a push (a new time law and a
//! check of every command through to the hold) costs milliseconds. Computed under that lock,
//! it held up the arms' next cycle; a push from a thread at normal priority, preempted while
//! holding it, held the arms for tens of milliseconds, which the watchdog rightly took for a
//! fault.
//!
//! So the caller's thread clones the generator, runs the clone on to a cycle a little ahead
//! (the `lead`: twice the last push's cost), applies the push there, and hands the result to
//! the arm threads, which switch to it when the stream reaches that cycle. The generator is
//! deterministic, so the clone computes the same commands as the stream up to the switch. If
//! the stream has passed that cycle by the time the push is ready, it is done again with
//! twice the lead.
//!
//! Costs: the lock is held to clone the generator (its queue and time law: tens of kB) and to
//! hand the result over; the rest runs on the caller's thread.

use super::{lock, Pending, Shared};
use crate::run::{Command, JOINTS};
use crate::stream::{Generator, PushError};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Attempts before a push gives up on a stream that keeps outrunning it; the lead doubles
/// with each one.
const ATTEMPTS: usize = 8;

/// The cost of the last push on the caller's thread, ns (the next one's lead is twice it).
#[derive(Debug, Default)]
pub(super) struct PushCost(AtomicU64);

/// Applies `waypoints` from `start_step` on a clone of the stream's latest generator and
/// hands it to the arm threads; returns the cycle from which they stream it.
pub(super) fn push(
    shared: &Shared,
    cost: &PushCost,
    period: Duration,
    start_step: usize,
    waypoints: &[&[[f64; JOINTS]]],
) -> Result<u64, PushError> {
    let mut lead = lead_cycles(cost, period);
    for _ in 0..ATTEMPTS {
        let began = Instant::now();
        let (mut next, now, serial) = {
            let c = lock(&shared.cycle);
            let latest = c.pending.as_ref().map(|p| (&p.generator, p.serial));
            let (g, serial) = latest.unwrap_or((&c.generator, c.pushes));
            (g.clone(), c.generator.cycle(), serial)
        };
        let at = (now + lead).max(next.cycle());
        let mut out = vec![[0; JOINTS]; next.arms()];
        run_to(&mut next, at, &mut out)?;
        next.push(start_step, waypoints)?;
        cost.0
            .store(began.elapsed().as_nanos() as u64, Ordering::Relaxed);
        let mut c = lock(&shared.cycle);
        let current = c.pending.as_ref().map_or(c.pushes, |p| p.serial);
        if c.generator.cycle() <= at && current == serial {
            c.pushes += 1;
            c.pending = Some(Pending {
                generator: next,
                serial: c.pushes,
            });
            return Ok(at);
        }
        lead = lead.saturating_mul(2).max(lead_cycles(cost, period));
    }
    Err(PushError::Outrun { attempts: ATTEMPTS })
}

/// Twice the last push's cost in cycles, and two cycles more (the first push: two cycles).
fn lead_cycles(cost: &PushCost, period: Duration) -> u64 {
    let last = Duration::from_nanos(cost.0.load(Ordering::Relaxed));
    (2.0 * last.as_secs_f64() / period.as_secs_f64()).ceil() as u64 + 2
}

/// Runs `g` on until it has produced every cycle before `at`.
fn run_to(g: &mut Generator, at: u64, out: &mut [Command]) -> Result<(), PushError> {
    while g.cycle() < at {
        g.next(out)?;
    }
    Ok(())
}
