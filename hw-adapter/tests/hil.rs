//! Hardware-in-the-loop: the executor streams a 3-arm plan over SLCAN ptys to three Python mock
//! Gen3 arms (hw-adapter/mock/mock_arm.py; run hw-adapter/mock/setup_venv.sh first).

mod common;

use common::*;
use omcbsa_hw::cia402::{counts_to_rad, CW_DISABLE_OPERATION, CW_ENABLE_OPERATION};
use omcbsa_hw::interpolate::interpolate;
use omcbsa_hw::{ExecConfig, Executor, JointLimits};

#[test]
fn three_arms_follow_the_interpolated_plan() {
    let plan = three_arm_plan(8);
    let limits = JointLimits::kinova_gen3();
    let mocks = spawn_arms(&plan, "ok", &[]);
    let log = std::env::temp_dir().join(format!("omcbsa-hw-ok-log-{}.jsonl", std::process::id()));
    let cfg = ExecConfig {
        log_path: Some(log.clone()),
        ..mock_config()
    };
    let exec = Executor::new(plan.clone(), limits, open_buses(&mocks), cfg.clone()).unwrap();
    let report = exec.run(&AcceptAll).unwrap_or_else(|e| panic!("{e}"));
    println!("{report}");

    let traj = interpolate(&plan, &limits, 0.002).unwrap();
    for (arm, mock) in mocks.into_iter().enumerate() {
        let name = mock.name.clone();
        let record = mock.finish();
        assert_eq!(
            kinds(&record, "violation"),
            0,
            "{name}: the mock refused commands"
        );
        let per_node = targets(&record);
        let cmds = &traj.commands[arm];
        for (j, received) in per_node.iter().enumerate() {
            let streamed: Vec<_> = received
                .iter()
                .filter(|r| r.2 == u64::from(CW_ENABLE_OPERATION))
                .collect();
            assert_eq!(
                streamed.len(),
                cmds.len() + cfg.settle_cycles,
                "{name} joint {}",
                j + 1
            );
            for (k, r) in streamed.iter().enumerate() {
                let want = counts_to_rad(cmds[k.min(cmds.len() - 1)][j]);
                let got = counts_to_rad(r.1 as i32);
                assert!(
                    (got - want).abs() <= 1e-6,
                    "{name} joint {} cycle {k}: {got} vs {want}",
                    j + 1
                );
            }
            // the plan's waypoints themselves are reached: first and last exactly (to 1e-7)
            let path = &plan.arms[arm].joint_path;
            assert!((counts_to_rad(streamed[0].1 as i32) - path[0][j]).abs() <= 1e-7);
            assert!(
                (counts_to_rad(streamed.last().unwrap().1 as i32) - path[path.len() - 1][j]).abs()
                    <= 1e-7
            );
            // and the run ends by disabling operation
            assert_eq!(received.last().unwrap().2, u64::from(CW_DISABLE_OPERATION));
        }
    }
    let lines = std::fs::read_to_string(&log).unwrap();
    assert_eq!(lines.lines().count(), report.frames_sent);
    assert!(report.arms.iter().all(|a| a.max_following_error < 0.05));
    let _ = std::fs::remove_file(log);
}
