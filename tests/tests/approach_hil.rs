//! Issue 15, item 4: a problem that gives `initial` is planned with an approach from there;
//! executed on mock arms standing at `initial` it runs to completion, and with an arm 0.2 rad
//! away the executor refuses to start, naming the joint. A broken approach fails validation.

use omcbsa::demo::{box_flip, run_on_mock_arms, ROBOTS};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::Status;
use omcbsa::online::policy::RETRACT;
use omcbsa::plan::plan_file;
use omcbsa_hw::{Executor, Transport};
use omcbsa_mock::arms::MockKind;
use omcbsa_mock::mock::{exec_config, script_path, venv_python, MockArm, MockArmOptions};

#[test]
fn a_plan_from_initial_runs_on_arms_at_initial_and_is_refused_0_2_rad_away() {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let mut problem = box_flip().unwrap().problem;
    for r in &mut problem.robots {
        r.initial = Some(RETRACT.to_vec());
    }
    let solution = plan_file(&problem, omcbsa::planners::PlannerKind::OmCbsa, 5.0).unwrap();
    assert_eq!(solution.status, Status::Solved, "{}", solution.message);
    let a = solution
        .approach
        .as_ref()
        .expect("an approach from initial")[0]
        .len();
    assert!(a > 0, "the arms stand folded away from the box");

    // Regression: a broken approach is a violation that names it.
    let mut broken = solution.clone();
    broken.approach.as_mut().unwrap()[1][a / 2][0] += 0.5;
    let report = CheckedSolution::new(problem.clone(), broken).unwrap();
    let summary = report.report().summary();
    assert!(summary.contains("approach step"), "{summary}");

    let checked = CheckedSolution::new(problem, solution).unwrap();
    assert!(
        checked.report().is_valid(),
        "{}",
        checked.report().summary()
    );
    let plan = checked.plan(&ROBOTS).unwrap();
    for arm in &plan.arms {
        assert_eq!(arm.joint_path[0], RETRACT, "the timeline starts at initial");
    }
    let dir = std::env::temp_dir().join(format!("omcbsa-approach-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    run_on_mock_arms(&python, MockKind::Can, plan.clone(), &checked, &dir, |_| {})
        .unwrap_or_else(|e| panic!("{e}"));

    // The same plan with arm 1 standing 0.2 rad off on joint 3.
    let mocks: Vec<MockArm> = (plan.arms.iter().enumerate())
        .map(|(i, arm)| {
            let mut initial = arm.joint_path[0];
            if i == 1 {
                initial[2] += 0.2;
            }
            let opts = MockArmOptions {
                initial,
                record: None,
                bus_log: None,
                extra_args: Vec::new(),
            };
            MockArm::spawn(&python, &script_path(), &arm.name, &opts).unwrap()
        })
        .collect();
    let buses: Vec<(String, Box<dyn Transport>)> = (mocks.iter())
        .map(|m| (m.name.clone(), m.open_bus().unwrap()))
        .collect();
    let limits = checked.joint_limits(&plan).unwrap();
    let err = Executor::new(plan, limits, buses, exec_config())
        .unwrap()
        .run(&checked)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("joint 3 is at") && err.contains("the plan starts at"),
        "{err}"
    );
    assert!(err.contains(ROBOTS[1]), "{err}");
}
