//! Hardware-in-the-loop, across crates: the demo's 3-arm box flip planned by Ω-CBSA, validated
//! by the host validator, streamed over SLCAN pseudo-terminals to three Python mock Gen3 arms
//! (hw-adapter/mock/mock_arm.py; run `bash hw-adapter/mock/setup_venv.sh` first). Every mock
//! must have received exactly the interpolated plan (within 1e-6 rad) and no command beyond a
//! joint limit (`omcbsa_mock::record::check_followed`, run by `run_on_mock_arms`); and the plan's
//! own first and last waypoints are what the arms were sent first and last.

use omcbsa::demo::{box_flip, run_on_mock_arms_watched, ROBOTS};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::Status;
use omcbsa::plan::plan_file;
use omcbsa_hw::cia402::{counts_to_rad, CW_ENABLE_OPERATION};
use omcbsa_hw::{Plan, Report, JOINTS};
use omcbsa_mock::arms::MockKind;
use omcbsa_mock::mock::{exec_config, venv_python};
use omcbsa_mock::record::{self, TOLERANCE};

/// One set of mocks at a time: two sets of three Python mocks beside two planners starve the
/// mocks on a 2-core machine, and a starved mock's late answers rightly stop the run.
static STREAMING: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn streaming() -> std::sync::MutexGuard<'static, ()> {
    STREAMING.lock().unwrap_or_else(|p| p.into_inner())
}

/// The box-flip demo planned by Ω-CBSA, validated, as the executor's plan.
fn planned_demo() -> (CheckedSolution, Plan) {
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
    (checked, plan)
}

/// Streams the planned demo to three mock arms of `kind`, recording in a fresh directory:
/// the plan, that directory and the run's report.
fn stream_demo(kind: MockKind, tag: &str) -> (Plan, std::path::PathBuf, Report) {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let (checked, plan) = planned_demo();
    let dir = std::env::temp_dir().join(format!("omcbsa-hil-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = run_on_mock_arms_watched(
        &python,
        kind,
        plan.clone(),
        &checked,
        &dir,
        &omcbsa_hw::WatchSettings::default(),
        |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    println!("{report}");
    (plan, dir, report)
}

#[test]
fn planned_three_arm_solution_streams_to_three_mock_arms() {
    let _one = streaming();
    let (plan, dir, report) = stream_demo(MockKind::Can, "can");

    let settle = exec_config().settle_cycles;
    assert_eq!(report.arms.len(), 3);
    for (arm, streamed) in plan.arms.iter().zip(&report.arms) {
        assert_eq!(streamed.name, arm.name);
        assert_eq!(streamed.cycles_sent, report.cycles + settle);
        assert!(streamed.max_following_error < exec_config().watch.following_error_bound);
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

/// The same demo on three mock Gen3s on Kortex (hw-adapter/mock/mock_gen3.py, loopback TCP and
/// UDP): every command as planned within 1e-6 rad (degrees on the wire) and none past a limit
/// (`omcbsa_mock::mock_gen3::check_followed`, run by `run_on_mock_arms`), the plan's first and last
/// waypoints sent first and last.
#[test]
fn planned_three_arm_solution_streams_to_three_mock_gen3s_on_kortex() {
    let _one = streaming();
    let (plan, dir, report) = stream_demo(MockKind::Kortex, "kortex");
    let settle = omcbsa_mock::mock::exec_config().settle_cycles;
    for (arm, streamed) in plan.arms.iter().zip(&report.arms) {
        assert_eq!(streamed.cycles_sent, report.cycles + settle);
        let received = record::read(&dir.join(format!("mock-{}.jsonl", arm.name))).unwrap();
        let refreshes: Vec<&serde_json::Value> = (received.iter())
            .filter(|e| e["event"] == "refresh")
            .collect();
        // The seed, then every cycle.
        assert_eq!(refreshes.len(), 1 + report.cycles + settle, "{}", arm.name);
        let ends = [
            (refreshes[1], &arm.joint_path[0]),
            (
                refreshes[refreshes.len() - 1],
                &arm.joint_path[arm.joint_path.len() - 1],
            ),
        ];
        for (sent, want) in ends {
            for j in 0..JOINTS {
                let deg = sent["positions"][j].as_f64().unwrap() as f32;
                let rad = omcbsa_hw::kortex::arm::from_wire(deg, want[j]);
                assert!(
                    (rad - want[j]).abs() <= TOLERANCE,
                    "{} joint {}",
                    arm.name,
                    j + 1
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(dir);
}
