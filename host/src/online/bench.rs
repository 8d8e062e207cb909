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
use crate::planners::{Capacities, Storage};

/// Timings of one arm count.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ArmsRow {
    pub arms: usize,
    pub problems: usize,
    /// Planning times of the later chunks, s, and how many were attempted.
    pub chunks: Vec<f64>,
    pub attempted: usize,
    /// Planning times of the first chunks, s (solved ones).
    pub first: Vec<f64>,
    /// Planning times of the same problems whole, s.
    pub whole: Vec<f64>,
}

/// The `q`-quantile of sorted `v` (nearest rank), in ms.
pub fn quantile_ms(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len());
    1e3 * v[k - 1]
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
            let problem = load::problem::<omcbsa_core::model::KinovaGen3, 7>(&file)
                .map_err(|e| e.to_string())?;
            let outcome = whole.solve(crate::planners::parse(&options.planner)?, &problem, 5.0)?;
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
