//! Helpers of the hardware-in-the-loop tests: Python mock arms on ptys, a synthetic 3-arm
//! plan, and the mocks' records.

#![allow(dead_code)] // each test file uses a different subset

use omcbsa_hw::mock::{script_path, spawn_mock_arm, venv_python, MockArmOptions};
use omcbsa_hw::plan::{ArmPlan, Plan, PlanValidator, JOINTS};
use omcbsa_hw::transport::slcan::{SlcanTransport, DEFAULT_BITRATE};
use omcbsa_hw::{ExecConfig, Transport};
use serde_json::Value;
use std::path::PathBuf;
use std::process::Child;
use std::time::{Duration, Instant};

pub const ARMS: [&str; 3] = ["left", "right", "middle"];

/// Executor settings for the mocks: feedback deadlines generous enough for three Python
/// processes sharing a busy 2-core machine.
pub fn mock_config() -> ExecConfig {
    ExecConfig {
        feedback_timeout: Duration::from_millis(250),
        heartbeat_timeout: Duration::from_millis(500),
        ..ExecConfig::default()
    }
}

/// A smooth synthetic 3-arm plan within the Gen3 limits (stands in for a planned solution).
pub fn three_arm_plan(waypoints: usize) -> Plan {
    Plan {
        dt: 0.1,
        arms: ARMS
            .iter()
            .enumerate()
            .map(|(a, name)| ArmPlan {
                name: name.to_string(),
                joint_path: (0..waypoints)
                    .map(|i| {
                        let s = i as f64 / (waypoints - 1) as f64;
                        std::array::from_fn(|j| {
                            0.1 * a as f64 - 0.2 + 0.15 * (s * 2.0 + j as f64).sin()
                        })
                    })
                    .collect(),
            })
            .collect(),
    }
}

/// A test validator that accepts every plan.
pub struct AcceptAll;
impl PlanValidator for AcceptAll {
    fn validate(&self, _plan: &Plan) -> Result<(), String> {
        Ok(())
    }
}

pub struct MockArm {
    pub name: String,
    pub pty: String,
    pub record: PathBuf,
    child: Child,
}

impl MockArm {
    /// Waits for the mock to exit (it does when its pty is closed) and returns its record.
    pub fn finish(mut self) -> Vec<Value> {
        let deadline = Instant::now() + Duration::from_secs(5);
        while self.child.try_wait().ok().flatten().is_none() {
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!(
                    "mock arm {} did not exit after its pty was closed",
                    self.name
                );
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let text = std::fs::read_to_string(&self.record).unwrap_or_default();
        text.lines()
            .map(|l| serde_json::from_str(l).expect("record line is JSON"))
            .collect()
    }
}

impl Drop for MockArm {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub fn python() -> PathBuf {
    venv_python().unwrap_or_else(|e| panic!("{e}"))
}

/// Starts one mock arm per plan arm, at the plan's start, with `extra[i]` flags for arm i.
pub fn spawn_arms(plan: &Plan, tag: &str, extra: &[Vec<String>]) -> Vec<MockArm> {
    let python = python();
    plan.arms
        .iter()
        .enumerate()
        .map(|(i, arm)| {
            let record = std::env::temp_dir().join(format!(
                "omcbsa-hw-{tag}-{}-{}.jsonl",
                arm.name,
                std::process::id()
            ));
            let _ = std::fs::remove_file(&record);
            let opts = MockArmOptions {
                initial: arm.joint_path[0],
                period: 0.002,
                record: Some(record.clone()),
                extra_args: extra.get(i).cloned().unwrap_or_default(),
            };
            let (pty, child) =
                spawn_mock_arm(&python, &script_path(), &opts).unwrap_or_else(|e| panic!("{e}"));
            MockArm {
                name: arm.name.clone(),
                pty,
                record,
                child,
            }
        })
        .collect()
}

pub fn open_buses(mocks: &[MockArm]) -> Vec<(String, Box<dyn Transport>)> {
    mocks
        .iter()
        .map(|m| {
            let t = SlcanTransport::open(&m.pty, DEFAULT_BITRATE).unwrap_or_else(|e| panic!("{e}"));
            (m.name.clone(), Box::new(t) as Box<dyn Transport>)
        })
        .collect()
}

/// The targets a mock received, per node 1..=7, in order: (sync count, counts, controlword).
pub fn targets(record: &[Value]) -> [Vec<(u64, i64, u64)>; JOINTS] {
    let mut t: [Vec<(u64, i64, u64)>; JOINTS] = Default::default();
    for e in record.iter().filter(|e| e["kind"] == "rpdo") {
        let node = e["node"].as_u64().unwrap() as usize;
        t[node - 1].push((
            e["sync"].as_u64().unwrap(),
            e["counts"].as_i64().unwrap(),
            e["cw"].as_u64().unwrap(),
        ));
    }
    t
}

pub fn kinds(record: &[Value], kind: &str) -> usize {
    record.iter().filter(|e| e["kind"] == kind).count()
}
