//! Hardware-in-the-loop, across crates: the demo's 3-arm box flip planned by Ω-CBSA, validated
//! by the host validator, streamed over SLCAN pseudo-terminals to three Python mock Gen3 arms
//! (hw-adapter/mock/mock_arm.py; run `bash hw-adapter/mock/setup_venv.sh` first). Every mock
//! must have received exactly the interpolated plan (within 1e-6 rad) and no command beyond a
//! joint limit (`omcbsa_hw::record::check_followed`, run by `run_on_mock_arms`); and the plan's
//! own first and last waypoints are what the arms were sent first and last.

use omcbsa::demo::{box_flip, run_on_mock_arms, ROBOTS};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::Status;
use omcbsa::planners::plan_file;
use omcbsa_hw::cia402::{counts_to_rad, CW_ENABLE_OPERATION};
use omcbsa_hw::mock::{exec_config, venv_python};
use omcbsa_hw::record::{self, TOLERANCE};
use omcbsa_hw::JOINTS;

#[test]
fn planned_three_arm_solution_streams_to_three_mock_arms() {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let demo = box_flip().unwrap_or_else(|e| panic!("{e}"));
    let solution = plan_file(&demo.problem, omcbsa::planners::PlannerKind::OmCbsa, 5.0).unwrap();
    assert_eq!(solution.status, Status::Solved, "{}", solution.message);
    let checked = CheckedSolution::new(demo.problem, solution).unwrap();
    assert!(
        checked.report().is_valid(),
        "{}",
        checked.report().summary()
    );
    let plan = checked.plan(&ROBOTS).unwrap();

    let dir = std::env::temp_dir().join(format!("omcbsa-hil-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = run_on_mock_arms(&python, plan.clone(), &checked, &dir, |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    println!("{report}");

    let settle = exec_config().settle_cycles;
    assert_eq!(report.arms.len(), 3);
    for (arm, streamed) in plan.arms.iter().zip(&report.arms) {
        assert_eq!(streamed.name, arm.name);
        assert_eq!(streamed.cycles_sent, report.cycles + settle);
        assert!(streamed.max_following_error < exec_config().following_error_bound);
        let received = record::read(&dir.join(format!("mock-{}.jsonl", arm.name))).unwrap();
        let targets = record::targets(&received).unwrap();
        let (first, last) = (
            &arm.joint_path[0],
            &arm.joint_path[arm.joint_path.len() - 1],
        );
        for j in 0..JOINTS {
            let motion: Vec<f64> = (targets[j].iter())
                .filter(|t| t.controlword == CW_ENABLE_OPERATION)
                .map(|t| counts_to_rad(t.counts))
                .collect();
            assert_eq!(
                motion.len(),
                report.cycles + settle,
                "{} joint {}",
                arm.name,
                j + 1
            );
            assert!(
                (motion[0] - first[j]).abs() <= TOLERANCE,
                "{} joint {}",
                arm.name,
                j + 1
            );
            let end = motion[motion.len() - 1];
            assert!(
                (end - last[j]).abs() <= TOLERANCE,
                "{} joint {}",
                arm.name,
                j + 1
            );
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}
