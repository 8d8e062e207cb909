//! The watchdog's fault matrix and the loop's period jitter at the default rates, on simulated
//! arms (`omcbsa_mock::sim`: in-process, frame level; three arms, the command line's default
//! watchdog):
//!
//! - per fault and transport, control periods from the fault's first sign to the last arm's
//!   stop, the worst of `--runs` runs (CAN at 4 ms, one 1 Mbit/s bus per arm; Kortex at 1 ms);
//! - the loop's period jitter at 1 kHz (Kortex), |interval - 1 ms| between consecutive
//!   Refresh commands of each arm as the executor sent them (its command log), p50/p99/max,
//!   with the arm threads under SCHED_FIFO 50 (the `--rt-priority` default) and without (the
//!   watchdog relaxed to 1000 missed cycles there, so that a stall does not end the run).
//!
//! cargo run --release -p omcbsa-mock --example fault_matrix -- [--runs 10] [--seconds 5]
//! (`--runs 0`: the jitter alone)

mod common;

use common::{arg, percentile};
use omcbsa_hw::{ExecConfig, Fault};
use omcbsa_mock::sim::matrix::{self, Link, MatrixFault};
use serde_json::Value;
use std::collections::BTreeMap;
use std::time::Duration;

/// One cell: the worst periods to stop over the runs that stopped, and how the runs ended.
#[derive(Default)]
struct Cell {
    worst: Option<f64>,
    stopped: usize,
    tolerated: usize,
    /// Runs that ended otherwise (a fault on another arm first, a stop not seen): each named.
    other: Vec<String>,
}

fn cell(link: Link, fault: MatrixFault, runs: usize) -> Result<Cell, String> {
    let cfg = ExecConfig {
        period: link.period(),
        ..ExecConfig::default()
    };
    let plan = matrix::plan(1.0);
    let mut c = Cell::default();
    for _ in 0..runs {
        let out = matrix::run(link, Some(fault), &plan, &cfg)?;
        match &out.result {
            Ok(_) if !fault.is_fault(&cfg) => c.tolerated += 1,
            Ok(r) => c.other.push(format!("not stopped: {r}")),
            Err(r) if out.stopped_before_the_fault() => c
                .other
                .push(format!("stopped before the fault: {}", r.fault)),
            Err(r) if r.arm != matrix::FAULTY_ARM => c.other.push(format!(
                "stopped by arm {:?} first (the machine held it up): {}",
                r.arm, r.fault
            )),
            Err(r) => {
                let periods: Option<Vec<f64>> = out.periods_to_stop().into_iter().collect();
                match periods {
                    Some(p) => {
                        let worst = p.into_iter().fold(0.0, f64::max);
                        c.worst = Some(c.worst.map_or(worst, |w: f64| w.max(worst)));
                        c.stopped += 1;
                    }
                    None => c.other.push(format!("an arm's stop not seen: {}", r.fault)),
                }
            }
        }
    }
    Ok(c)
}

fn show(c: &Cell, runs: usize) -> String {
    let mut parts = Vec::new();
    if let Some(w) = c.worst {
        parts.push(format!("{w:.2} ({}/{runs} stopped)", c.stopped));
    }
    if c.tolerated > 0 {
        parts.push(format!(
            "{}/{runs} completed (within the bound)",
            c.tolerated
        ));
    }
    if !c.other.is_empty() {
        parts.push(format!("{} other", c.other.len()));
    }
    parts.join(", ")
}

/// |interval - period| between consecutive Refresh commands of each arm, from the command log,
/// in seconds, sorted.
fn jitter(log: &str, period: Duration) -> Result<Vec<f64>, String> {
    let mut sends: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for line in log.lines() {
        let e: Value = serde_json::from_str(line).map_err(|e| e.to_string())?;
        if e["frame"]
            .as_str()
            .is_some_and(|f| f.contains("BaseCyclic.Refresh"))
            && e["what"].as_str().is_some_and(|w| w.starts_with("frame "))
        {
            let arm = e["arm"].as_str().unwrap_or_default().to_string();
            sends
                .entry(arm)
                .or_default()
                .push(e["t"].as_f64().unwrap_or(0.0));
        }
    }
    let mut j: Vec<f64> = (sends.values())
        .flat_map(|t| {
            t.windows(2)
                .map(|w| (w[1] - w[0] - period.as_secs_f64()).abs())
        })
        .collect();
    j.sort_by(f64::total_cmp);
    Ok(j)
}

/// A plain run of `seconds` at 1 kHz on three simulated Gen3s, the arm threads at `priority`.
fn jitter_row(seconds: f64, priority: Option<u8>) -> Result<String, String> {
    let log = std::env::temp_dir().join(format!("omcbsa-jitter-{}.jsonl", std::process::id()));
    let mut cfg = ExecConfig {
        period: Link::Kortex.period(),
        realtime_priority: priority,
        log_path: Some(log.clone()),
        ..ExecConfig::default()
    };
    // The loop's timing, not the watchdog's: a stall of the machine past 2 periods would stop
    // the run and cut the measurement short.
    cfg.watch.missed_cycles = 1000;
    let out = matrix::run(Link::Kortex, None, &matrix::plan(seconds), &cfg)?;
    let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
    let _ = std::fs::remove_file(&log);
    let j = jitter(&text, cfg.period)?;
    if j.is_empty() {
        return Err("no Refresh in the log".into());
    }
    let us = |s: f64| s * 1e6;
    let how = match (priority, &out.result) {
        (None, _) => "normal scheduling".to_string(),
        (Some(p), Ok(r)) => match &r.realtime {
            Ok(()) => format!("SCHED_FIFO {p}"),
            Err(why) => format!("asked SCHED_FIFO {p}, refused here: {why}"),
        },
        (Some(p), Err(_)) => format!("asked SCHED_FIFO {p}"),
    };
    let how = match priority {
        Some(_) => how,
        None => format!("{how} (`--rt-priority off`)"),
    };
    let end = match &out.result {
        Ok(_) => "completed".to_string(),
        Err(r) => match &r.fault {
            Fault::Answer { .. } => format!("stopped by the watchdog: {}", r.fault),
            f => format!("stopped: {f}"),
        },
    };
    Ok(format!(
        "| {how} | {} | {:.0} | {:.0} | {:.0} | {end} |",
        j.len(),
        us(percentile(&j, 0.5)),
        us(percentile(&j, 0.99)),
        us(j[j.len() - 1]),
    ))
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let runs: usize = arg(&args, "--runs", 10)?;
    let seconds: f64 = arg(&args, "--seconds", 5.0)?;
    println!("{}", omcbsa_hw::WatchSettings::default());
    println!(
        "\nControl periods from a fault's first sign to the last of three arms stopped (worst of \
         {runs} runs; bound {}):\n",
        omcbsa_hw::STOP_BOUND_PERIODS
    );
    println!("| fault | {} | {} |", Link::Can.name(), Link::Kortex.name());
    println!("|---|---|---|");
    let mut notes = Vec::new();
    for fault in MatrixFault::ALL.into_iter().filter(|_| runs > 0) {
        let mut row = format!("| {} |", fault.name());
        for link in [Link::Can, Link::Kortex] {
            if !fault.applies_to(link) {
                row.push_str(" n/a |");
                continue;
            }
            let c = cell(link, fault, runs)?;
            row.push_str(&format!(" {} |", show(&c, runs)));
            for o in c.other {
                notes.push(format!("{} on {}: {o}", fault.name(), link.name()));
            }
        }
        println!("{row}");
    }
    for n in &notes {
        println!("- {n}");
    }
    println!(
        "\nThe loop's period jitter at 1 kHz, |interval - 1 ms| between consecutive Refresh \
         commands of each arm ({seconds} s, three arms), microseconds:\n"
    );
    println!("| arm threads | intervals | p50 | p99 | max | run |");
    println!("|---|---|---|---|---|---|");
    for priority in [Some(50), None] {
        println!("{}", jitter_row(seconds, priority)?);
    }
    Ok(())
}
