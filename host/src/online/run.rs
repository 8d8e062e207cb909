//! An online run on Python mock arms: the scripted policy emits its chunks while the arms
//! move, each chunk is planned as it arrives and pushed to the streaming executor without
//! stopping; afterwards, what each mock received is compared with a replay of the pushes and
//! the whole sent timeline is validated.

use std::path::Path;
use std::time::{Duration, Instant};

use omcbsa_hw::interpolate::min_time_scale;
use omcbsa_hw::stream::Generator;
use omcbsa_hw::{ArmLimits, Event, Executor, Report, StreamHandle, WatchSettings, JOINTS};
use omcbsa_mock::arms::{MockArms, MockKind};
use omcbsa_mock::mock::exec_config;

use super::policy::{BoxFlipPolicy, Chunk};
use super::record::RunRecord;
use super::{ChunkReport, Embodier, OnlineError, OnlineOptions};
use crate::execute::{joint_limits, CAUTIOUS_SPEED};
use crate::format::{ProblemFile, SolutionFile};
use crate::models::{self, ModelKind};
use crate::planners::DOF;
use crate::validate::{validate, Report as Validation};

/// How the run goes.
#[derive(Clone, Debug)]
pub struct RunScript {
    /// The policy that emits the chunks.
    pub policy: BoxFlipPolicy,
    /// Chunks the policy emits.
    pub chunks: usize,
    /// A chunk arrives when the arms are this many steps before its first step.
    pub lead_steps: usize,
    /// This chunk arrives only once the queue ran dry (a policy that was late).
    pub late_chunk: Option<usize>,
    /// This chunk has a hand pose no arm can reach.
    pub unreachable_chunk: Option<usize>,
    /// Uniform slow-down over the first chunk's need (velocity and acceleration limits), for
    /// the room later chunks may need.
    pub time_margin: f64,
    /// How the chunks are planned.
    pub options: OnlineOptions,
    /// Fault detection (the command line's watchdog options).
    pub watch: WatchSettings,
    /// The mock arms' kind: CAN (SLCAN) or Kortex (TCP and UDP).
    pub transport: MockKind,
}

impl Default for RunScript {
    fn default() -> Self {
        RunScript {
            policy: BoxFlipPolicy::default(),
            chunks: 12,
            lead_steps: 4,
            late_chunk: None,
            unreachable_chunk: None,
            time_margin: 2.0,
            options: OnlineOptions::default(),
            watch: WatchSettings::default(),
            transport: MockKind::Can,
        }
    }
}

/// One push to the executor, as replayed afterwards.
#[derive(Clone, Debug)]
pub struct Push {
    /// The control cycle at which the push was made.
    pub cycle: u64,
    /// The timeline index the pushed waypoints start at.
    pub start: usize,
    /// Per arm, the waypoints pushed.
    pub waypoints: Vec<Vec<[f64; JOINTS]>>,
}

/// What happened in a run.
#[derive(Debug)]
pub struct RunOutcome {
    /// Planning time of each chunk planned, s.
    pub latencies: Vec<f64>,
    /// Chunks that were not planned, with why.
    pub chunk_errors: Vec<(usize, OnlineError)>,
    /// The executor's events (queue dry, resumed).
    pub events: Vec<Event>,
    /// Every push, for replaying the stream.
    pub pushes: Vec<Push>,
    /// The executor's report.
    pub exec: Report,
    /// Per arm, the cycles its mock received, all equal to the replayed stream to 1e-6 rad
    /// and within the limits.
    pub cycles: Vec<usize>,
    /// The whole sent timeline against the poses it tracked.
    pub validation: Validation,
    /// Per robot, the hand it held (`None`: it held still).
    pub assignment: Vec<Option<usize>>,
    /// The whole sent timeline as a problem and solution pair (what `validation` checked).
    pub problem: ProblemFile,
    /// The sent timeline as a solution file.
    pub solution: SolutionFile,
}

/// Runs `script` on one mock arm per robot (`python` from the mocks' venv), the mocks
/// recording to `record_dir`; `progress` gets one line per chunk.
pub fn run_on_mock_arms(
    script: &RunScript,
    python: &Path,
    record_dir: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<RunOutcome, String> {
    let setup = script.policy.setup();
    let mut e = Embodier::new(&setup, script.options.clone()).map_err(|e| e.to_string())?;
    let first = script.policy.chunk(0);
    let report = e
        .push_chunk(first.start_step, &first.hands)
        .map_err(|e| format!("chunk 0: {e}"))?;
    let n = e.robot_names().len();
    let (limits, scale) = stream_timing(script, &e, &report, progress)?;
    let dt = setup.dt;
    let initial: Vec<[f64; DOF]> = (0..n).map(|i| e.planned(i, 0)[0]).collect();
    let config = omcbsa_hw::ExecConfig {
        // The approach and the first chunk are one push.
        online_horizon: Duration::from_secs(120),
        watch: script.watch.clone(),
        ..exec_config()
    };
    let starts: Vec<(String, [f64; DOF])> = (e.robot_names().iter().cloned())
        .zip(initial.iter().copied())
        .collect();
    let record_of = |name: &str| record_dir.join(format!("online-{name}.jsonl"));
    // A slowed-down run on a busy machine outlasts a mock's default time limit (it is killed
    // when dropped in any case).
    let long = vec![vec!["--max-seconds=600".to_string()]; n];
    let kind = script.transport;
    let mocks = MockArms::spawn(kind, python, config.period, &starts, record_of, &long)?;
    let arms = (mocks.ports()?.into_iter())
        .zip(initial.iter().copied())
        .map(|((name, port), q)| (name, q, port))
        .collect();
    let handle =
        Executor::online(arms, dt, scale, &limits, config.clone()).map_err(|e| e.to_string())?;
    let mut run = Gathered {
        rec: RunRecord::default(),
        latencies: vec![report.planning_time_s],
        pushes: Vec::new(),
        events: Vec::new(),
        chunk_errors: Vec::new(),
    };
    push(&handle, &e, 1, &mut run.pushes)?;
    for c in 1..script.chunks {
        let mut chunk = script.policy.chunk(c);
        if script.unreachable_chunk == Some(c) {
            let k = chunk.hands[0].len() / 2;
            chunk.hands[0][k].position[2] += 3.0;
        }
        if let Err(why) = wait_for_chunk(&handle, script, c, &e, &chunk, &mut run.events) {
            return Err(finish_failed(handle, why));
        }
        plan_chunk(c, chunk, &mut e, &handle, &mut run, progress)?;
    }
    run.rec.send(&e, e.end());
    // The events a push causes come at the cycle it lands on (the handle goes with `finish`).
    let last = run.pushes.last().map_or(0, |p| p.cycle);
    if let Err(why) = wait(&handle, |p, _| p.cycle > last, &mut run.events) {
        return Err(finish_failed(handle, why));
    }
    run.events.extend(handle.events());
    let exec = handle.finish().map_err(|e| e.to_string())?;
    let mut cycles = Vec::with_capacity(n);
    let replay = replay(&initial, &run.pushes, scale * dt, &config, &limits)?;
    wait_for_records(starts.iter().map(|(name, _)| record_of(name)));
    for (i, (name, record)) in mocks.finish()?.into_iter().enumerate() {
        let enabled = kind.motion_commands(&record)?;
        let motion = enabled.saturating_sub(config.settle_cycles);
        let cmds: Vec<_> = replay(motion).into_iter().map(|c| c[i]).collect();
        let period = config.period.as_secs_f64();
        let got = (kind.check_followed(&record, &cmds, config.settle_cycles, &limits[i], period))
            .map_err(|err| format!("mock arm {name:?}: {err}"))?;
        cycles.push(got);
    }
    drop(replay);
    let (problem, solution) = (run.rec)
        .files(&setup, &e)
        .ok_or("nothing was sent to the arms")?;
    let core = crate::load::problem::<models::Fleet, DOF>(&problem).map_err(|e| e.to_string())?;
    let validation = validate::<models::Fleet, DOF>(&problem, &core, &solution);
    Ok(RunOutcome {
        latencies: run.latencies,
        chunk_errors: run.chunk_errors,
        events: run.events,
        pushes: run.pushes,
        exec,
        cycles,
        validation,
        assignment: e.assignment().unwrap_or(&[]).to_vec(),
        problem,
        solution,
    })
}

/// The joint limits the arms stream within (each arm's model's, at [`CAUTIOUS_SPEED`]) and
/// the uniform slow-down the first chunk's plan needs under them, with the script's margin;
/// reported on `progress` with the first chunk's planning.
fn stream_timing(
    script: &RunScript,
    e: &Embodier,
    report: &ChunkReport,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<ArmLimits>, f64), String> {
    let setup = e.setup();
    let n = e.robot_names().len();
    let kinds = (setup.robots.iter())
        .map(|r| ModelKind::parse(&r.model))
        .collect::<Result<Vec<_>, _>>()?;
    let limits: Vec<ArmLimits> = (kinds.iter())
        .map(|&k| joint_limits(k, CAUTIOUS_SPEED))
        .collect();
    let dt = setup.dt;
    let scale = script.time_margin * min_time_scale((0..n).map(|i| e.planned(i, 0)), &limits, dt);
    progress(&format!(
        "chunk 0 planned in {:.1} ms (approach {} steps, assignment {:?}); streaming at {:.2}x \
         the planned time",
        1e3 * report.planning_time_s,
        e.approach_len(),
        e.assignment().unwrap_or(&[]),
        scale
    ));
    Ok((limits, scale))
}

/// What a run gathers as its chunks come: what was sent, the planning times, the pushes, the
/// executor's events and the chunks not planned.
struct Gathered {
    rec: RunRecord,
    latencies: Vec<f64>,
    pushes: Vec<Push>,
    events: Vec<Event>,
    chunk_errors: Vec<(usize, OnlineError)>,
}

/// Waits until chunk `c` is due: until the arms are `script.lead_steps` before its first
/// step, or, for the script's late chunk, until the queue ran dry.
fn wait_for_chunk(
    handle: &StreamHandle,
    script: &RunScript,
    c: usize,
    e: &Embodier,
    chunk: &Chunk,
    events: &mut Vec<Event>,
) -> Result<(), String> {
    let due = e.timeline_index(chunk.start_step).unwrap_or(0);
    if script.late_chunk == Some(c) {
        // The hold shows in the progress a cycle before its event: wait for the event.
        wait(
            handle,
            |_, seen| seen.iter().any(|e| matches!(e, Event::QueueDry { .. })),
            events,
        )
    } else {
        wait(handle, |p, _| p.step + script.lead_steps >= due, events)
    }
}

/// Why the run ended early, with the stream's fault if it had one (the stream ends here).
fn finish_failed(handle: StreamHandle, why: String) -> String {
    match handle.finish() {
        Err(fault) => format!("{why}: {fault}"),
        Ok(_) => why,
    }
}

/// Plans chunk `c` from the steps the arms can no longer change and pushes the new tail to
/// the executor; a chunk that cannot be planned is gathered with why (the run goes on).
fn plan_chunk(
    c: usize,
    mut chunk: Chunk,
    e: &mut Embodier,
    handle: &StreamHandle,
    run: &mut Gathered,
    progress: &mut dyn FnMut(&str),
) -> Result<(), String> {
    // What the arms are executing, and the step after, cannot change any more.
    let fixed = handle.progress().fixed;
    run.rec.send(e, fixed + 2);
    e.commit_until(fixed + 2);
    let old_end = e.end();
    let result = match e.push_chunk(chunk.start_step, &chunk.hands) {
        Err(OnlineError::DeadlineMissed { .. }) => push_late(c, &mut chunk, e, fixed, progress),
        other => other,
    };
    match result {
        Ok(report) => {
            run.latencies.push(report.planning_time_s);
            push(handle, e, report.index.min(old_end), &mut run.pushes)?;
            progress(&format!(
                "chunk {c:>3} (steps {}..{}) planned in {:.1} ms, arms at step {}",
                chunk.start_step,
                chunk.start_step + chunk.hands[0].len() as u64,
                1e3 * report.planning_time_s,
                handle.progress().step
            ));
        }
        Err(err) => {
            progress(&format!("chunk {c:>3} NOT planned: {err}"));
            run.chunk_errors.push((c, err));
        }
    }
    Ok(())
}

/// A late chunk: the steps already sent (up to timeline index `fixed + 1`) are dropped, the
/// rest planned from where the arms are (holding at the end of the plan, if it ran out).
fn push_late(
    c: usize,
    chunk: &mut Chunk,
    e: &mut Embodier,
    fixed: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<ChunkReport, OnlineError> {
    let skip = (0..chunk.hands[0].len())
        .find(|&k| {
            e.timeline_index(chunk.start_step + k as u64)
                .is_some_and(|i| i >= fixed + 2)
        })
        .unwrap_or(chunk.hands[0].len());
    chunk.start_step += skip as u64;
    chunk.hands.iter_mut().for_each(|h| {
        h.drain(..skip);
    });
    if chunk.hands[0].is_empty() {
        Err(OnlineError::DeadlineMissed {
            start_step: chunk.start_step,
            committed_step: 0,
        })
    } else {
        progress(&format!(
            "chunk {c} is late: its first {skip} steps dropped, the rest planned"
        ));
        e.push_chunk(chunk.start_step, &chunk.hands)
    }
}

/// A mock writes its record as it exits; a long run's record takes a while on a busy
/// machine, longer than a mock's `finish` waits: waits up to a minute for every record.
fn wait_for_records(records: impl Iterator<Item = std::path::PathBuf>) {
    let deadline = Instant::now() + Duration::from_secs(60);
    for record in records {
        while !record.exists() && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

/// Pushes the embodier's plan from timeline index `from` to the executor.
fn push(
    handle: &StreamHandle,
    e: &Embodier,
    from: usize,
    pushes: &mut Vec<Push>,
) -> Result<(), String> {
    let waypoints: Vec<Vec<[f64; JOINTS]>> = (0..e.robot_names().len())
        .map(|i| e.planned(i, from).to_vec())
        .collect();
    let slices: Vec<&[[f64; JOINTS]]> = waypoints.iter().map(Vec::as_slice).collect();
    let cycle = handle
        .push(from, &slices)
        .map_err(|err| format!("the executor refused the plan from step {from}: {err}"))?;
    pushes.push(Push {
        cycle,
        start: from,
        waypoints,
    });
    Ok(())
}

/// Waits until `done` holds for the stream's progress and the events collected so far, or
/// fails if the stream faulted or it takes over a minute.
fn wait(
    handle: &StreamHandle,
    done: impl Fn(&omcbsa_hw::StreamProgress, &[Event]) -> bool,
    events: &mut Vec<Event>,
) -> Result<(), String> {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        events.extend(handle.events());
        if handle.faulted() {
            return Err("the stream stopped on a fault".to_string());
        }
        if done(&handle.progress(), events) {
            return Ok(());
        }
        if Instant::now() > deadline {
            return Err("the stream made no progress for a minute".to_string());
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// A generator given the same pushes at the same cycles: the commands every arm was to
/// receive, for the first `cycles` cycles.
fn replay<'a>(
    starts: &'a [[f64; JOINTS]],
    pushes: &'a [Push],
    step_time: f64,
    config: &'a omcbsa_hw::ExecConfig,
    limits: &'a [ArmLimits],
) -> Result<impl Fn(usize) -> Vec<Vec<omcbsa_hw::Command>> + 'a, String> {
    let max_queued = (config.online_horizon.as_secs_f64() / step_time)
        .floor()
        .max(1.0);
    let generator = Generator::new(starts, limits, config.period.as_secs_f64(), step_time)?
        .with_max_queued(max_queued as usize);
    Ok(move |cycles: usize| {
        let mut g = generator.clone();
        let mut out = vec![[0; JOINTS]; starts.len()];
        let mut next = pushes.iter().peekable();
        let mut cmds = Vec::with_capacity(cycles);
        for _ in 0..cycles {
            while let Some(p) = next.next_if(|p| p.cycle == g.cycle()) {
                let slices: Vec<&[[f64; JOINTS]]> = p.waypoints.iter().map(Vec::as_slice).collect();
                // Accepted live, so accepted here.
                let _ = g.push(p.start, &slices);
            }
            if g.next(&mut out).is_err() {
                break;
            }
            cmds.push(out.clone());
        }
        cmds
    })
}
