//! Jitter is not a fault: three simulated arms (`omcbsa_mock::sim`) of each transport stream a
//! plan at the transport's default rate with the command line's default watchdog while one arm
//! answers every cycle one period late from its 40th cycle on (the jitter the watchdog is
//! stated to tolerate), `--runs` times per transport; prints how many runs completed and each
//! that was stopped, with its fault. Exit code 1 if any run was stopped.
//!
//! cargo run --release -p omcbsa-mock --example jitter_tolerance -- [--runs 100] [--seconds 1]

// Each example uses part of what the examples share.
#[allow(dead_code)]
mod common;

use common::arg;
use omcbsa_hw::timing;
use omcbsa_hw::ExecConfig;
use omcbsa_mock::sim::matrix::{self, Link, MatrixFault};

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let runs: usize = arg(&args, "--runs", 100)?;
    let seconds: f64 = arg(&args, "--seconds", 1.0)?;
    let plan = matrix::plan(seconds);
    println!("{}", omcbsa_hw::WatchSettings::default());
    println!(
        "\nAnswers one period late from cycle {} on, three arms, {seconds} s of motion, {runs} \
         runs per transport (load average {}):\n",
        matrix::FAULT_AT,
        std::fs::read_to_string("/proc/loadavg")
            .map(|l| l.split(' ').take(3).collect::<Vec<_>>().join(" "))
            .unwrap_or_default()
    );
    println!("| transport | timer (preflight) | completed | stopped |");
    println!("|---|---|---|---|");
    let mut stopped_any = false;
    for link in [Link::Can, Link::Kortex] {
        let defaults = ExecConfig {
            period: link.period(),
            ..ExecConfig::default()
        };
        let preflight = defaults.preflight.unwrap_or_default();
        let jitter = timing::measure(defaults.period, preflight, defaults.realtime_priority)
            .map_err(|e| e.to_string())?;
        // The preflight is measured once above, not before each of the runs.
        let cfg = ExecConfig {
            preflight: None,
            ..defaults
        };
        let (mut completed, mut stops) = (0, Vec::new());
        for k in 0..runs {
            let out = matrix::run(link, Some(MatrixFault::Late(1)), &plan, &cfg)?;
            match out.result {
                Ok(_) => completed += 1,
                Err(r) => stops.push(format!("run {k}: arm {:?}: {}", r.arm, r.fault)),
            }
        }
        println!(
            "| {} | p99 {:?}, worst {:?} | {completed}/{runs} | {} |",
            link.name(),
            jitter.p99,
            jitter.max,
            stops.len()
        );
        for s in &stops {
            println!("- {}: {s}", link.name());
        }
        stopped_any |= !stops.is_empty();
    }
    if stopped_any {
        return Err("a run with answers one period late was stopped".into());
    }
    Ok(())
}
