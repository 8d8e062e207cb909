//! The arms' threads: started together ([`start`]), each arm's start-up together with the
//! others, then one cycle per period in lockstep with them, the feedback watched in between,
//! and the stop (normal end, fault, or a stop asked for).

use super::{lock, ArmEnd, ArmNow, Cycle, ProgressFn, RunInfo, Shared, FAULT_POLL};
use crate::link::ArmLink;
use crate::log::LogSink;
use crate::priority;
use crate::run::{ArmState, ArmStop, Command, ExecConfig, Fault, Progress, Span, JOINTS};
use crate::stream::Generator;
use crate::StreamHandle;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Barrier, Mutex};
use std::time::{Duration, Instant};

/// One arm's whole run, on its own thread, from the command it holds first, the range its
/// commands stay in and its joints' peak speeds.
pub(super) fn stream_arm(
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
        let mut fe_now = 0.0;
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
            if shared.stopping() {
                return Ok(None);
            }
            fe_now = fe;
            // Checked against the limits by the generator.
            let (cmd, end) = shared.command(me, k as u64)?;
            bus.send_cycle(&cmd).map_err(Fault::Bus)?;
            Ok(Some((cmd, end)))
        };
        let fault = match step() {
            Ok(Some((cmd, end))) => {
                shared.sent[me].store(k + 1, Ordering::SeqCst);
                prev1 = cmd;
                max_fe = max_fe.max(fe_now);
                shared.publish(me, |a| {
                    a.commanded = cmd;
                    a.sent = k as u64 + 1;
                    a.measured = bus.measured();
                    a.following_error = fe_now;
                });
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
        // A fault here or on another arm, or a stop asked for: quick stop, and nothing after.
        let detected = match fault {
            Some(f) => shared.raise(bus.name(), f, k),
            None => lock(&shared.fault)
                .as_ref()
                .map_or_else(Instant::now, |f| f.3),
        };
        let sent = bus.quick_stop(&prev1);
        // The bound is on the stop frames going out; the answers are waited for after.
        let latency = detected.elapsed();
        shared.publish(me, |a| a.state = ArmState::Stopped);
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
        return ArmEnd::Stopped {
            stop,
            frames: bus.frames_sent(),
            max_following_error: max_fe,
        };
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
        Ok(()) => {
            shared.publish(me, |a| a.state = ArmState::Finished);
            ArmEnd::Completed {
                cycles: k,
                frames: bus.frames_sent(),
                max_following_error: max_fe,
                max_lateness: max_late,
            }
        }
        Err(e) => {
            shared.publish(me, |a| a.state = ArmState::Stopped);
            let detected = shared.raise(bus.name(), Fault::Bus(e.clone()), k);
            let stop = ArmStop {
                arm: bus.name().to_string(),
                cycles_sent: k,
                latency: detected.elapsed(),
                error: Some(e),
                unanswered: Vec::new(),
            };
            ArmEnd::Stopped {
                stop,
                frames: bus.frames_sent(),
                max_following_error: max_fe,
            }
        }
    }
}

/// Waits for every arm to finish a start-up phase with `result`; the arm's end if this arm or
/// another failed (an arm that did not fail stops its nodes).
fn startup_phase_end(
    me: usize,
    bus: &mut dyn ArmLink,
    result: Result<(), String>,
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
                Err(e) => ArmEnd::StartupFailed(format!("while aborting: {e}")),
            }
        }
        Ok(()) => return None,
    };
    shared.publish(me, |a| a.state = ArmState::Stopped);
    Some(end)
}

/// Waits until cycle `k` is due, every arm has sent cycle `k - 1` and every arm's accounting
/// allows cycle `k`, calling `watch` (this arm's feedback check) every [`FAULT_POLL`]; returns
/// early if a fault is raised here or on another arm, or a stop is asked for. An arm that keeps
/// the others waiting longer than the feedback timeout is a fault.
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
        if shared.stopping() {
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
    StreamHandle::new(shared, threads, config, log, info)
}
