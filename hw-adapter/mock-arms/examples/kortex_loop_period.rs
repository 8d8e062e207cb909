//! Measures the executor's loop period on Kortex: three mock Gen3s (hw-adapter/mock/mock_gen3.py
//! on loopback; run hw-adapter/mock/setup_venv.sh first), a smooth 3-arm plan of about
//! `--seconds` s streamed at `--rate` Hz, and the period between consecutive Refresh commands
//! of each arm, from the executor's command log (its send times): p50, p99 and the largest.
//!
//! cargo run --release -p omcbsa-mock --example kortex_loop_period -- [--seconds 10] [--rate 1000]
//!     [--rt-priority 50|off] [--missed-cycles 2]

mod common;

use common::{arg, percentile};
use omcbsa_hw::plan::{ArmPlan, Plan, PlanValidator};
use omcbsa_hw::{ExecConfig, Executor, WatchSettings};
use omcbsa_mock::arms::{MockArms, MockKind};
use omcbsa_mock::mock::{exec_config, venv_python};
use std::collections::BTreeMap;
use std::time::Duration;

struct AcceptAll;
impl PlanValidator for AcceptAll {
    fn validate(&self, _plan: &Plan) -> Result<(), String> {
        Ok(())
    }
}

/// Waypoints 0.1 s apart over `seconds` for three arms, gentle enough to be streamed as
/// planned.
fn gentle_plan(seconds: f64) -> Plan {
    let n = (seconds / 0.1).round() as usize + 1;
    Plan {
        dt: 0.1,
        arms: ["left", "right", "middle"]
            .iter()
            .enumerate()
            .map(|(a, name)| ArmPlan {
                name: name.to_string(),
                joint_path: (0..n)
                    .map(|i| {
                        let s = i as f64 / (n - 1) as f64;
                        std::array::from_fn(|j| 0.1 * a as f64 + 0.2 * (s * 3.0 + j as f64).sin())
                    })
                    .collect(),
            })
            .collect(),
    }
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds: f64 = arg(&args, "--seconds", 10.0)?;
    let rate: f64 = arg(&args, "--rate", 1000.0)?;
    let missed: u32 = arg(&args, "--missed-cycles", 2)?;
    let priority = match arg(&args, "--rt-priority", "50".to_string())?.as_str() {
        "off" => None,
        p => Some(
            p.parse::<u8>()
                .map_err(|_| format!("--rt-priority: {p:?}"))?,
        ),
    };
    let plan = gentle_plan(seconds);
    let python = venv_python()?;
    let dir = std::env::temp_dir().join(format!("omcbsa-kortex-period-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let starts: Vec<_> = (plan.arms.iter())
        .map(|a| (a.name.clone(), a.joint_path[0]))
        .collect();
    let period = Duration::from_secs_f64(1.0 / rate);
    // The mocks step once per command of `period`.
    let mocks = MockArms::spawn(
        MockKind::Kortex,
        &python,
        period,
        &starts,
        |name| dir.join(format!("{name}.jsonl")),
        &[],
    )?;
    let log = dir.join("log.jsonl");
    let cfg = ExecConfig {
        period,
        log_path: Some(log.clone()),
        realtime_priority: priority,
        watch: WatchSettings {
            missed_cycles: missed,
            ..WatchSettings::default()
        },
        ..exec_config()
    };
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let report = Executor::new(plan, limits, mocks.ports()?, cfg)
        .map_err(|e| e.to_string())?
        .run(&AcceptAll);
    drop(mocks.finish());
    let report = report.map_err(|e| e.to_string())?;
    println!("{report}");
    let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
    let mut sends: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for line in text.lines() {
        let e: serde_json::Value = serde_json::from_str(line).map_err(|e| e.to_string())?;
        let cyclic = e["frame"]
            .as_str()
            .is_some_and(|f| f.contains("BaseCyclic.Refresh "))
            && e["what"].as_str().is_some_and(|w| w.starts_with("frame "));
        if cyclic {
            let arm = e["arm"].as_str().unwrap_or("?").to_string();
            sends
                .entry(arm)
                .or_default()
                .push(e["t"].as_f64().unwrap_or(0.0));
        }
    }
    println!(
        "loop period at {rate} Hz, rt priority {}, m = {missed}:",
        priority.map_or("off".to_string(), |p| p.to_string())
    );
    let mut all = Vec::new();
    for (arm, t) in &sends {
        let mut d: Vec<f64> = t.windows(2).map(|w| (w[1] - w[0]) * 1e3).collect();
        d.sort_by(f64::total_cmp);
        println!(
            "  {arm}: {} periods, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
            d.len(),
            percentile(&d, 0.5),
            percentile(&d, 0.99),
            d[d.len() - 1]
        );
        all.extend(d);
    }
    all.sort_by(f64::total_cmp);
    println!(
        "  all arms: {} periods, p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        all.len(),
        percentile(&all, 0.5),
        percentile(&all, 0.99),
        all[all.len() - 1]
    );
    let _ = std::fs::remove_dir_all(dir);
    Ok(())
}
