//! Helpers of the hardware-in-the-loop tests: a synthetic 3-arm plan, and the library's mock
//! arms and records (`omcbsa_mock::mock`, `omcbsa_mock::record`) with failures as panics.

#![allow(dead_code)] // each test file uses a different subset

#[allow(unused_imports)] // used by some test files only
pub use omcbsa_mock::mock::exec_config as mock_config;
#[allow(unused_imports)] // used by some test files only
pub use omcbsa_mock::record::kinds;

use omcbsa_hw::plan::{ArmLimits, ArmPlan, Plan, PlanValidator};
use omcbsa_hw::stream::Generator;
use omcbsa_hw::{Command, Transport, JOINTS};
use omcbsa_mock::mock::{spawn_for_plan, venv_python, MockArm};

pub const ARMS: [&str; 3] = ["left", "right", "middle"];

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

/// Starts one mock arm per plan arm, at the plan's start, with `extra[i]` flags for arm i.
pub fn spawn_arms(plan: &Plan, tag: &str, extra: &[Vec<String>]) -> Vec<MockArm> {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let record = |name: &str| {
        std::env::temp_dir().join(format!(
            "omcbsa-hw-{tag}-{name}-{}.jsonl",
            std::process::id()
        ))
    };
    spawn_for_plan(&python, plan, record, extra).unwrap_or_else(|e| panic!("{e}"))
}

pub fn open_buses(mocks: &[MockArm]) -> Vec<(String, Box<dyn Transport>)> {
    omcbsa_mock::mock::open_buses(mocks).unwrap_or_else(|e| panic!("{e}"))
}

/// The record of a mock, once it has exited.
pub fn record_of(mock: MockArm) -> Vec<serde_json::Value> {
    mock.finish().unwrap_or_else(|e| panic!("{e}"))
}

/// A push as the stream applied it: start step, per-arm waypoints, the cycle it applied at.
pub struct Pushed {
    pub start: usize,
    pub waypoints: Vec<Vec<[f64; JOINTS]>>,
    pub cycle: u64,
}

/// The commands a generator computes given the same pushes at the same cycles, from `starts`,
/// through to the hold at the end of the last: per arm, one per cycle.
pub fn replay(
    starts: &[[f64; JOINTS]],
    limits: &[ArmLimits],
    period: f64,
    step_time: f64,
    pushes: &[Pushed],
) -> Vec<Vec<Command>> {
    let mut g = Generator::new(starts, limits, period, step_time).unwrap();
    let mut out = vec![[0; JOINTS]; starts.len()];
    let mut cmds: Vec<Vec<Command>> = vec![Vec::new(); starts.len()];
    let mut step = |g: &mut Generator| {
        let tick = g.next(&mut out).unwrap();
        for (c, o) in cmds.iter_mut().zip(&out) {
            c.push(*o);
        }
        tick
    };
    for p in pushes {
        while g.cycle() < p.cycle {
            step(&mut g);
        }
        let slices: Vec<&[[f64; JOINTS]]> = p.waypoints.iter().map(|w| w.as_slice()).collect();
        g.push(p.start, &slices).unwrap();
    }
    while !step(&mut g).holding {}
    cmds
}
