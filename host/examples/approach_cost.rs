//! What the approach adds to planning time, measured so that the machine's load cancels out:
//! each problem is planned `REPS` times with the approach and `REPS` times without it, the runs
//! interleaved in one process, and the least time of each kept (load only ever adds time).
//! Prints, per family and planner, the median planning time with and without the approach
//! over the problems both solved, and their ratio: the quantity of
//! `scripts/approach_cost.py`, less noisy on a busy machine.
//!
//! Usage: cargo run --release -p omcbsa --example approach_cost -- SUITE_DIR [REPS] [FAMILY]
//! (planners omcbsa and pp-single, 5 s each, as the bench's; FAMILY may also be one problem's
//! name). Per problem, standard error gives both times and how the approach of the fastest run
//! with it was found.

use std::collections::BTreeMap;
use std::path::Path;

use omcbsa::load;
use omcbsa::models::Fleet;
use omcbsa::planners::{Capacities, PlannerKind, Storage};
use omcbsa::suite::read_index;
use omcbsa_core::planner::Status;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = Path::new(
        args.get(1)
            .ok_or("usage: approach_cost SUITE_DIR [REPS] [FAMILY]")?,
    );
    let reps: usize = args.get(2).map_or(Ok(3), |r| r.parse())?;
    let family = args.get(3);
    let index = read_index(dir)?;
    let mut storage = Storage::new(Capacities::default(), 64);
    // (family, planner) -> (times with, times without), problems both solved.
    let mut times: BTreeMap<(String, String), (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    for entry in &index.problems {
        if family.is_some_and(|f| *f != entry.family && *f != entry.name) {
            continue;
        }
        let file = load::parse_problem(&load::read_text(&dir.join(&entry.file))?)?;
        let problem = load::problem::<Fleet, 7>(&file)?;
        for kind in [PlannerKind::OmCbsa, PlannerKind::PpSingle] {
            let mut best = [f64::INFINITY; 2];
            let mut solved = [true; 2];
            let mut info = (f64::INFINITY, 0u32, String::new());
            for _ in 0..reps {
                for (k, with) in [true, false].into_iter().enumerate() {
                    storage.with_approach = with;
                    let o = storage.solve(kind, &problem, 5.0)?;
                    solved[k] &= o.status == Status::Solved;
                    if with && o.planning_time_s < best[0] {
                        info = (
                            o.approach_info.planning_time_s,
                            o.approach_info.attempts,
                            format!(
                                "{} {} steps",
                                o.approach_info.method.name(),
                                o.approach_info.steps
                            ),
                        );
                    }
                    best[k] = best[k].min(o.planning_time_s);
                }
            }
            eprintln!(
                "{} {} with {:.3} without {:.3} ms (approach {:.3} ms, {} attempts, {})",
                entry.name,
                kind,
                best[0] * 1e3,
                best[1] * 1e3,
                info.0 * 1e3,
                info.1,
                info.2
            );
            if solved == [true, true] {
                let e = times
                    .entry((entry.family.clone(), kind.to_string()))
                    .or_default();
                e.0.push(best[0]);
                e.1.push(best[1]);
            }
        }
    }
    println!("| family | planner | both solved | median with approach (ms) | median without (ms) | ratio |");
    println!("|---|---|---:|---:|---:|---:|");
    for ((family, planner), (with, without)) in times {
        let n = with.len();
        let (w, wo) = (median(with) * 1e3, median(without) * 1e3);
        println!(
            "| {family} | {planner} | {n} | {w:.2} | {wo:.2} | {:.2} |",
            w / wo
        );
    }
    Ok(())
}
