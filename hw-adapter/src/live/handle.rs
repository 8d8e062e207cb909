//! [`StreamHandle`]: what the caller holds while the arms move: push segments, watch the stream
//! and each arm, finish it or stop it. Dropping it stops every arm.

use super::{lock, ArmEnd, Event, RunInfo, Shared, StreamProgress};
use crate::cia402::counts_to_rad;
use crate::log::LogSink;
use crate::run::{
    ArmReport, ArmState, ArmStatus, ArmStop, ExecConfig, ExecError, FaultReport, LinkError, Report,
    JOINTS, STOP_BOUND_PERIODS,
};
use crate::stream::PushError;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// A stream to the arms while it runs: push segments, watch it, finish it or stop it. Dropped
/// while the arms run, it stops every arm (a quick stop, as for a fault) and waits for them.
pub struct StreamHandle {
    shared: Arc<Shared>,
    /// The arm threads, until they are joined.
    threads: Vec<JoinHandle<ArmEnd>>,
    config: ExecConfig,
    log: Option<LogSink>,
    info: RunInfo,
    push_cost: super::push::PushCost,
}

impl StreamHandle {
    pub(super) fn new(
        shared: Arc<Shared>,
        threads: Vec<JoinHandle<ArmEnd>>,
        config: ExecConfig,
        log: Option<LogSink>,
        info: RunInfo,
    ) -> Self {
        Self {
            shared,
            threads,
            config,
            log,
            info,
            push_cost: Default::default(),
        }
    }

    /// Replaces every arm's waypoints from step `start_step` on (arms in the order given at
    /// the start; waypoint `i` of each at step `start_step + i`), from a control cycle a little
    /// ahead of the stream's (see below). Refused, with nothing changed, if `start_step` is
    /// already fixed by that cycle ([`StreamProgress::fixed`] is where the stream is now),
    /// leaves a gap, queues too far ahead, or if any command the new tail leads to (through to
    /// the hold at its end) would break a limit; or if the stream has stopped. Returns the
    /// control cycle from which the new tail is streamed (a [`crate::stream::Generator`]
    /// given the same pushes at the same cycles computes the same commands).
    ///
    /// Cost: one pass of the generator over the whole new tail (bounded by
    /// [`ExecConfig::online_horizon`]), on the caller's thread: the arm threads never wait for
    /// it. It applies from a cycle twice its own cost ahead of the stream's, so that it is
    /// ready before the arms get there.
    pub fn push(
        &self,
        start_step: usize,
        waypoints: &[&[[f64; JOINTS]]],
    ) -> Result<u64, PushError> {
        if let Some(f) = lock(&self.shared.fault).as_ref() {
            return Err(PushError::Stopped(format!(
                "fault on arm {:?}: {}",
                f.arm, f.fault
            )));
        }
        if self.shared.halt.load(Ordering::SeqCst) || self.threads.iter().all(|t| t.is_finished()) {
            return Err(PushError::Stopped("the stream has ended".into()));
        }
        let period = self.config.period;
        super::push::push(&self.shared, &self.push_cost, period, start_step, waypoints)
    }

    /// Where the stream is now.
    pub fn progress(&self) -> StreamProgress {
        let c = lock(&self.shared.cycle);
        StreamProgress {
            cycle: c.generator.cycle(),
            step: c.generator.step(),
            fixed: c.generator.fixed(),
            holding: c.holding_at_end(),
        }
    }

    /// Each arm now, in the order given at the start.
    pub fn status(&self) -> Vec<ArmStatus> {
        let (holding, queue_depth) = {
            let c = lock(&self.shared.cycle);
            let g = &c.generator;
            (
                c.holding_at_end(),
                c.latest().end().saturating_sub(g.step() + 1),
            )
        };
        let period = self.config.period;
        (self.shared.names.iter().zip(&self.shared.arms))
            .map(|(name, now)| {
                let a = *lock(now);
                let state = match a.state {
                    ArmState::Moving if holding => ArmState::Holding,
                    s => s,
                };
                let lag = (a.measured)
                    .and_then(|m| m.cycle)
                    .map(|c| period * (a.sent.saturating_sub(c + 1)) as u32);
                ArmStatus {
                    name: name.clone(),
                    state,
                    commanded: a.commanded.map(counts_to_rad),
                    measured: a.measured,
                    following_error: a.following_error,
                    queue_depth,
                    lag,
                }
            })
            .collect()
    }

    /// The events since the last call (at most [`super::MAX_EVENTS`]; older ones are dropped).
    pub fn events(&self) -> Vec<Event> {
        lock(&self.shared.cycle).events.drain(..).collect()
    }

    /// A fault has stopped the stream (every arm quick-stopped); [`StreamHandle::finish`] or
    /// [`StreamHandle::stop`] returns its report.
    pub fn faulted(&self) -> bool {
        self.shared.faulted.load(Ordering::SeqCst)
    }

    /// Every arm's thread has ended (the run finished, stopped, or failed its start-up):
    /// [`StreamHandle::finish`] or [`StreamHandle::stop`] returns how.
    pub fn ended(&self) -> bool {
        self.threads.iter().all(|t| t.is_finished())
    }

    /// Lets the queue run to its end, holds for the settle cycles, disables the drives, and
    /// returns the report (or the fault that stopped the run).
    pub fn finish(mut self) -> Result<Report, ExecError> {
        self.shared.finishing.store(true, Ordering::SeqCst);
        self.join()
    }

    /// Stops every arm now (a quick stop, as for a fault, but no fault) and returns the report
    /// ([`Report::halted`]), or the fault that had stopped the run already.
    pub fn stop(mut self) -> Result<Report, ExecError> {
        self.shared.halt.store(true, Ordering::SeqCst);
        self.join()
    }

    fn join(&mut self) -> Result<Report, ExecError> {
        let ends: Vec<ArmEnd> = (self.threads.drain(..))
            .map(|h| {
                h.join()
                    .unwrap_or(ArmEnd::StartupFailed(LinkError::ThreadPanicked))
            })
            .collect();
        finish_run(
            &self.config,
            &self.info,
            ends,
            &self.shared,
            self.log.take(),
        )
    }
}

impl Drop for StreamHandle {
    fn drop(&mut self) {
        if !self.threads.is_empty() {
            self.shared.halt.store(true, Ordering::SeqCst);
            let _ = self.join();
        }
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
    let mut stopped_fe = Vec::new();
    for (end, name) in ends.into_iter().zip(&shared.names) {
        match end {
            ArmEnd::StartupFailed(e) => startup_errors.push((name.clone(), e)),
            ArmEnd::Aborted => {}
            ArmEnd::Stopped {
                stop,
                frames,
                max_following_error,
            } => {
                frames_sent += frames;
                stopped_fe.push(max_following_error);
                stops.push(stop)
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
    if let Some(first) = lock(&shared.fault).take() {
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
            arm: first.arm,
            fault: first.fault,
            cycle: first.cycle,
            stops,
            bound: cfg.period * STOP_BOUND_PERIODS,
        })));
    }
    logged?;
    // Stopped on request: each arm as it was when it stopped, in the order given.
    let halted = !stops.is_empty();
    arms.extend(stops.into_iter().zip(stopped_fe).map(|(s, fe)| ArmReport {
        name: s.arm,
        cycles_sent: s.cycles_sent,
        max_following_error: fe,
    }));
    arms.sort_by_key(|a| shared.names.iter().position(|n| *n == a.name));
    let c = lock(&shared.cycle);
    Ok(Report {
        dry_run: false,
        period: cfg.period,
        time_scale: info.time_scale,
        cycles: c
            .end
            .map_or(c.generator.cycle() as usize, |e| e as usize + 1),
        frames_sent,
        arms,
        max_lateness,
        holds: c.holds,
        halted,
        realtime: (*lock(&shared.realtime_refused)).map_or(Ok(()), Err),
    })
}
