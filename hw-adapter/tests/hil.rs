//! Hardware-in-the-loop: the executor streams a 3-arm plan over SLCAN ptys to three Python mock
//! Gen3 arms (hw-adapter/mock/mock_arm.py; run hw-adapter/mock/setup_venv.sh first).

mod common;

use common::*;
use omcbsa_hw::cia402::counts_to_rad;
use omcbsa_hw::interpolate::interpolate;
use omcbsa_hw::{ExecConfig, Executor, JOINTS};
use omcbsa_mock::record::check_followed;

#[test]
fn three_arms_follow_the_interpolated_plan() {
    let plan = three_arm_plan(8);
    let limits = omcbsa_mock::testing::fleet_limits(plan.arms.len());
    let mocks = spawn_arms(&plan, "ok", &[]);
    let log = std::env::temp_dir().join(format!("omcbsa-hw-ok-log-{}.jsonl", std::process::id()));
    let cfg = ExecConfig {
        log_path: Some(log.clone()),
        ..mock_config()
    };
    let exec = Executor::new(
        plan.clone(),
        limits.clone(),
        open_buses(&mocks),
        cfg.clone(),
    )
    .unwrap();
    let report = exec.run(&AcceptAll).unwrap_or_else(|e| panic!("{e}"));
    println!("{report}");

    let period = cfg.period.as_secs_f64();
    let traj = interpolate(&plan, &limits, period).unwrap();
    for (arm, mock) in mocks.into_iter().enumerate() {
        let name = mock.name.clone();
        let record = record_of(mock);
        let cmds = &traj.commands[arm];
        let cycles = check_followed(&record, cmds, cfg.settle_cycles, &limits[arm], period)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(cycles, cmds.len() + cfg.settle_cycles);
        // the plan's waypoints themselves are reached: first and last exactly (to 1e-7)
        let path = &plan.arms[arm].joint_path;
        for j in 0..JOINTS {
            assert!((counts_to_rad(cmds[0][j]) - path[0][j]).abs() <= 1e-7);
            assert!(
                (counts_to_rad(cmds[cmds.len() - 1][j]) - path[path.len() - 1][j]).abs() <= 1e-7
            );
        }
    }
    let lines = std::fs::read_to_string(&log).unwrap();
    assert_eq!(lines.lines().count(), report.frames_sent);
    assert!(report.arms.iter().all(|a| a.max_following_error < 0.05));
    let _ = std::fs::remove_file(log);
}
