//! Per-chunk planning latency of the [`Embodier`] on the benchmark suite's trajectories, cut
//! into chunks of `chunk_len` poses every `stride` poses, against planning each problem whole.
//!
//! Each problem is planned whole with the same planner first; the arms stand at that plan's
//! first configurations (so the first chunk needs no approach). Then the chunks are pushed in
//! order, each just in time (everything before its first step sent), as in an online run. The
//! first chunk of each problem chooses the assignment and is reported apart; the later ones,
//! planned from where the arms are with the assignment kept, are the online case.

use std::path::Path;

use super::{Embodier, OnlineOptions, Setup};
use crate::format::Pose;
use crate::load;
use crate::models::{Fleet, DOF};
use crate::planners::{Capacities, Storage};

/// Timings of one arm count.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ArmsRow {
    /// Robots in the problems.
    pub arms: usize,
    /// Problems of this arm count.
    pub problems: usize,
    /// Planning times of the later chunks, s, and how many were attempted.
    pub chunks: Vec<f64>,
    /// Later chunks attempted.
    pub attempted: usize,
    /// Planning times of the first chunks, s (solved ones).
    pub first: Vec<f64>,
    /// Planning times of the same problems whole, s.
    pub whole: Vec<f64>,
}

/// The `q`-quantile of sorted `v` (nearest rank); NaN when `v` is empty.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[k - 1]
}

/// [`quantile`] of seconds, in ms.
pub fn quantile_ms(v: &[f64], q: f64) -> f64 {
    1e3 * quantile(v, q)
}

/// Runs the benchmark on the suite in `dir` for each arm count of `arms`, until at least
/// `min_chunks` later chunks were attempted per count (or the suite's problems run out).
pub fn bench_online(
    dir: &Path,
    arms: &[usize],
    min_chunks: usize,
    options: &OnlineOptions,
    chunk_len: usize,
    stride: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<ArmsRow>, String> {
    let index = crate::suite::read_index(dir).map_err(|e| format!("{e:?}"))?;
    let mut whole = Storage::new(Capacities::default(), 256);
    let mut rows = Vec::new();
    for &n in arms {
        let mut row = ArmsRow {
            arms: n,
            ..ArmsRow::default()
        };
        for entry in index.problems.iter().filter(|p| p.robots == n) {
            if row.attempted >= min_chunks {
                break;
            }
            if entry.horizon < chunk_len {
                continue;
            }
            let text = load::read_text(&dir.join(&entry.file)).map_err(|e| e.to_string())?;
            let file = load::parse_problem(&text).map_err(|e| e.to_string())?;
            let problem = load::problem::<Fleet, DOF>(&file).map_err(|e| e.to_string())?;
            let outcome = whole.solve(options.planner, &problem, 5.0)?;
            if outcome.status != omcbsa_core::planner::Status::Solved {
                continue;
            }
            row.whole.push(outcome.planning_time_s);
            row.problems += 1;
            let mut setup = Setup::of_problem(&file);
            for (r, path) in setup.robots.iter_mut().zip(&outcome.joint_paths) {
                r.initial = Some(path[0].to_vec());
            }
            let mut e = Embodier::new(&setup, options.clone()).map_err(|e| e.to_string())?;
            let mut start = 0;
            while start + chunk_len <= entry.horizon {
                let hands: Vec<Vec<Pose>> = (file.trajectories.iter())
                    .map(|t| t.poses[start..start + chunk_len].to_vec())
                    .collect();
                if let Some(index) = e.timeline_index(start as u64) {
                    e.commit_until(index);
                }
                let first = start == 0;
                if !first {
                    row.attempted += 1;
                }
                match e.push_chunk(start as u64, &hands) {
                    Ok(r) if first => row.first.push(r.planning_time_s),
                    Ok(r) => row.chunks.push(r.planning_time_s),
                    // A first chunk not planned: the problem's later chunks cannot be.
                    Err(_) if first => break,
                    Err(_) => {}
                }
                start += stride;
            }
        }
        progress(&format!(
            "{n} arms: {} problems, {} later chunks ({} planned)",
            row.problems,
            row.attempted,
            row.chunks.len()
        ));
        for v in [&mut row.chunks, &mut row.first, &mut row.whole] {
            v.sort_by(f64::total_cmp);
        }
        rows.push(row);
    }
    Ok(rows)
}

/// The rows as a markdown table.
pub fn table(rows: &[ArmsRow]) -> String {
    let mut s = String::from(
        "| arms | problems | later chunks | solved | p50 (ms) | p99 (ms) | max (ms) | first chunk p50 (ms) | whole p50 (ms) | whole p50 / chunk p50 |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let share = 100.0 * r.chunks.len() as f64 / r.attempted.max(1) as f64;
        s += &format!(
            "| {} | {} | {} | {:.1} % | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1}x |\n",
            r.arms,
            r.problems,
            r.attempted,
            share,
            quantile_ms(&r.chunks, 0.5),
            quantile_ms(&r.chunks, 0.99),
            quantile_ms(&r.chunks, 1.0),
            quantile_ms(&r.first, 0.5),
            quantile_ms(&r.whole, 0.5),
            quantile_ms(&r.whole, 0.5) / quantile_ms(&r.chunks, 0.5),
        );
    }
    s
}

/// How the policy's chunks reach the [`Embodier`] in [`run_episode`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chunking {
    /// Poses per hand in a chunk.
    pub len: usize,
    /// Policy steps between chunk starts (`len > stride`: an action-chunking policy, each
    /// chunk replacing the unsent tail of the one before).
    pub stride: usize,
    /// The chunk arrives when the arms have been sent everything up to this many steps
    /// before its first step (0: just in time).
    pub lead: usize,
}

/// One chunk's outcome in [`EpisodeRun::outcomes`].
#[derive(Clone, Debug, PartialEq)]
pub struct ChunkOutcome {
    /// The chunk's first policy step.
    pub start: u64,
    /// The plan's recovery (`Ok(None)`: planned from where the last chunk left the arms), or
    /// the Embodier's error.
    pub result: Result<Option<super::Recovery>, String>,
    /// Why a recovered chunk needed one ([`super::ChunkReport::blocked`]).
    pub blocked: Option<String>,
}

/// One episode's result.
#[derive(Clone, Debug, Default)]
pub struct EpisodeRun {
    /// Chunks pushed.
    pub chunks: usize,
    /// Chunks planned.
    pub planned: usize,
    /// Planning times of the chunks after the first, s (planned ones).
    pub later: Vec<f64>,
    /// Planning time of the first chunk (assignment and approach), s.
    pub first: Option<f64>,
    /// Chunks planned by a recovery (see `super::Recovery`).
    pub recovered: usize,
    /// Every chunk planned, every pose tracked in order (none dropped) and the whole sent
    /// timeline valid under the validator.
    pub embodied: bool,
    /// Chunks the Embodier slowed ([`super::Recovery::TimeScaled`]).
    pub scaled: usize,
    /// How far the arms were behind the policy at the episode's last step, s.
    pub lag_s: f64,
    /// The episode's duration at the policy's rate, s.
    pub duration_s: f64,
    /// The first error, as the Embodier gave it.
    pub error: Option<String>,
    /// Chunks after which the plan no longer held what the arms had been sent.
    pub broken_commitments: usize,
    /// Every chunk's outcome, in order.
    pub outcomes: Vec<ChunkOutcome>,
    /// What was sent to the arms, and what each index tracked.
    pub record: super::record::RunRecord,
}

/// Runs `episode` through an Embodier as a policy at its own rate would: chunk `c` covers
/// policy steps `c * stride ..` (up to `len` of them, the episode's end at most), and arrives
/// `lead` steps before its first step is due (everything before that already sent to the
/// arms). Afterwards the
/// whole sent timeline is checked by the validator, in windows of at most `MAX_STEPS`.
pub fn run_episode(
    episode: &super::bimanual::Episode,
    options: &OnlineOptions,
    chunking: Chunking,
) -> Result<EpisodeRun, String> {
    run_altered(episode, options, chunking, &mut |_, _| {})
}

/// [`run_episode`] with each chunk passed through `alter` (its first step and its poses per
/// hand) before it is pushed: a policy that sends a bad chunk.
pub fn run_altered(
    episode: &super::bimanual::Episode,
    options: &OnlineOptions,
    chunking: Chunking,
    alter: &mut dyn FnMut(u64, &mut [Vec<Pose>]),
) -> Result<EpisodeRun, String> {
    use super::record::RunRecord;
    let mut e = Embodier::new(&episode.setup, options.clone()).map_err(|e| e.to_string())?;
    let mut record = RunRecord::default();
    let mut run = EpisodeRun::default();
    let steps = episode.hands.first().map_or(0, Vec::len);
    let mut start = 0;
    while start < steps {
        let end = (start + chunking.len).min(steps);
        let mut hands: Vec<Vec<Pose>> = episode
            .hands
            .iter()
            .map(|h| h[start..end].to_vec())
            .collect();
        alter(start as u64, &mut hands);
        if let Some(index) = e.timeline_index(start as u64) {
            let sent = index
                .saturating_sub(chunking.lead)
                .max(e.approach_len() + 1);
            record.send(&e, sent);
            e.commit_until(sent);
        }
        run.chunks += 1;
        let pushed = e.push_chunk(start as u64, &hands);
        run.outcomes.push(ChunkOutcome {
            start: start as u64,
            result: (pushed.as_ref())
                .map(|r| r.recovery)
                .map_err(ToString::to_string),
            blocked: pushed.as_ref().ok().and_then(|r| r.blocked.clone()),
        });
        if let Some(broken) = changed_sent(&record, &e) {
            run.error.get_or_insert(format!("step {start}: {broken}"));
            run.broken_commitments += 1;
        }
        match pushed {
            Ok(r) => {
                run.recovered += usize::from(r.recovery.is_some());
                run.scaled += usize::from(r.recovery == Some(super::Recovery::TimeScaled));
                // A chunk whose first poses were dropped (an approach after a hold) is not
                // embodied.
                if r.dropped == 0 {
                    run.planned += 1;
                } else {
                    run.error
                        .get_or_insert(format!("step {start}: {} poses dropped", r.dropped));
                }
                match run.first {
                    None => run.first = Some(r.planning_time_s),
                    Some(_) => run.later.push(r.planning_time_s),
                }
            }
            Err(err) => {
                run.error.get_or_insert(format!("step {start}: {err}"));
                if run.first.is_none() {
                    // No first chunk: nothing to continue from.
                    return Ok(run);
                }
            }
        }
        if end == steps {
            break;
        }
        start += chunking.stride;
    }
    record.send(&e, e.end());
    run.duration_s = steps as f64 * episode.setup.dt;
    run.lag_s = e.lag_s(steps.saturating_sub(1) as u64);
    let windows = record.windows(&episode.setup, &e, omcbsa_core::problem::MAX_STEPS - 1);
    let mut valid = !windows.is_empty();
    match record.check_order() {
        Ok(order) if order.dropped == 0 => {}
        Ok(order) => {
            run.error
                .get_or_insert(format!("{} steps dropped by catch-ups", order.dropped));
            valid = false;
        }
        Err(e) => {
            run.error.get_or_insert(e);
            valid = false;
        }
    }
    for (problem, solution) in &windows {
        let core = load::problem::<Fleet, DOF>(problem).map_err(|e| e.to_string())?;
        let report = crate::validate::validate::<Fleet, DOF>(problem, &core, solution);
        if let Some(v) = report.violations.first() {
            run.error.get_or_insert(format!("{}: {v:?}", problem.name));
            valid = false;
        }
    }
    run.embodied = valid && run.planned == run.chunks && run.broken_commitments == 0;
    run.record = record;
    Ok(run)
}

/// Where the Embodier's plan no longer starts from the last configuration sent to the arms
/// (a chunk that replaced what the arms were already given), named.
fn changed_sent(record: &super::record::RunRecord, e: &Embodier) -> Option<String> {
    let sent = record.sent.first().map_or(0, Vec::len);
    let last = sent.checked_sub(1)?;
    (record.sent.iter().enumerate()).find_map(|(i, path)| {
        (e.configuration(i, last) != Some(path[last])).then(|| {
            format!(
                "robot {i}'s configuration at timeline index {last}, already sent, was replaced"
            )
        })
    })
}

/// The results of one arm count and chunking.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EpisodeRow {
    /// Robots in the episodes.
    pub arms: usize,
    /// How the episodes were cut into chunks (`None`: whole).
    pub chunking: Option<Chunking>,
    /// Episodes run.
    pub episodes: usize,
    /// Episodes whose every chunk was planned.
    pub embodied: usize,
    /// Chunks pushed.
    pub chunks: usize,
    /// Chunks planned.
    pub planned: usize,
    /// Chunks planned by a recovery ([`crate::online::Recovery`]).
    pub recovered: usize,
    /// Episodes with a hand pose that no arm reaches ([`super::reach::out_of_reach`]; run
    /// all the same, and not embodied).
    pub out_of_reach: usize,
    /// Planning times of the chunks after the first, s.
    pub later: Vec<f64>,
    /// Planning times of the first chunks, s.
    pub first: Vec<f64>,
    /// Chunks slowed by time scaling.
    pub scaled: usize,
    /// Per episode, the arms' lag at its end as a share of its duration.
    pub lags: Vec<f64>,
}

impl EpisodeRow {
    /// Counts one episode's result in.
    pub fn add(&mut self, run: &EpisodeRun) {
        self.episodes += 1;
        self.embodied += usize::from(run.embodied);
        self.chunks += run.chunks;
        self.planned += run.planned;
        self.recovered += run.recovered;
        self.later.extend(&run.later);
        self.first.extend(run.first);
        self.scaled += run.scaled;
        self.lags
            .push(run.lag_s / run.duration_s.max(f64::MIN_POSITIVE));
    }
}

/// The rows as a markdown table (`None` chunking: the reference, whole windows).
pub fn episode_table(rows: &[EpisodeRow]) -> String {
    let mut s = String::from(
        "| arms | chunks (len / stride) | episodes | out of reach | embodied | chunks | planned | recovered | time-scaled | lag p50 / max (% of episode) | p50 (ms) | p99 (ms) | max (ms) | first chunk p50 (ms) |\n\
         |---:|---|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let mut later = r.later.clone();
        later.sort_by(f64::total_cmp);
        let mut first = r.first.clone();
        first.sort_by(f64::total_cmp);
        let chunking = r
            .chunking
            .map_or("whole windows (reference)".to_string(), |c| {
                format!("{} / {} (lead {})", c.len, c.stride, c.lead)
            });
        let mut lags = r.lags.clone();
        lags.sort_by(f64::total_cmp);
        s += &format!(
            "| {} | {} | {} | {} | {:.1} % | {} | {:.1} % | {} | {} | {:.2} / {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |\n",
            r.arms,
            chunking,
            r.episodes,
            r.out_of_reach,
            100.0 * r.embodied as f64 / r.episodes.max(1) as f64,
            r.chunks,
            100.0 * r.planned as f64 / r.chunks.max(1) as f64,
            r.recovered,
            r.scaled,
            100.0 * quantile(&lags, 0.5),
            100.0 * quantile(&lags, 1.0),
            quantile_ms(&later, 0.5),
            quantile_ms(&later, 0.99),
            quantile_ms(&later, 1.0),
            quantile_ms(&first, 0.5),
        );
    }
    s
}

/// The chunking and options of the reference: each episode planned whole, in windows of
/// `MAX_STEPS - 1` poses, 5 s per window (as `omcbsa plan` would be given).
pub fn whole_windows(options: &OnlineOptions) -> (OnlineOptions, Chunking) {
    let len = omcbsa_core::problem::MAX_STEPS - 1;
    let options = OnlineOptions {
        max_chunk_len: len,
        chunk_timeout_s: 5.0,
        capacities: Capacities::default(),
        ..options.clone()
    };
    let chunking = Chunking {
        len,
        stride: len,
        lead: 0,
    };
    (options, chunking)
}

/// Runs `episodes` (of `arms` arms) through the Embodier with `chunking`, and each also in
/// whole windows when `reference` ([`whole_windows`]): the online row and the reference's.
/// `note` gets, per episode, the first error of a run that did not embody it and whether a
/// pose is out of every arm's reach.
pub fn bench_episodes(
    episodes: impl Iterator<Item = super::bimanual::Episode>,
    arms: usize,
    options: &OnlineOptions,
    chunking: Chunking,
    reference: bool,
    note: &mut dyn FnMut(&str),
) -> Result<(EpisodeRow, EpisodeRow), String> {
    let (whole_options, whole) = whole_windows(options);
    let mut online = EpisodeRow {
        arms,
        chunking: Some(chunking),
        ..EpisodeRow::default()
    };
    let mut reference_row = EpisodeRow {
        arms,
        ..EpisodeRow::default()
    };
    for ep in episodes {
        let context = |e: String| format!("{}: {e}", ep.name);
        let far = super::reach::out_of_reach(&ep).map_err(context)?;
        if let Some(far) = far {
            note(&format!(
                "{}: hand {} is out of every arm's reach at step {}",
                ep.name, far.hand, far.step
            ));
        }
        let mut rows = vec![(&mut online, options, chunking, "")];
        if reference {
            rows.push((&mut reference_row, &whole_options, whole, " (reference)"));
        }
        for (row, options, chunking, label) in rows {
            let run = run_episode(&ep, options, chunking).map_err(context)?;
            if let Some(err) = run.error.as_ref().filter(|_| !run.embodied) {
                note(&format!("{}{label}: {err}", ep.name));
            }
            row.add(&run);
            row.out_of_reach += usize::from(far.is_some());
        }
    }
    Ok((online, reference_row))
}
