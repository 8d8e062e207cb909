//! `omcbsa execute` and its library glue: a solution that does not validate is refused before
//! anything is sent, and bad arm names and buses are clear errors. The solution is the demo
//! problem's witness (valid), or that witness broken.

use std::path::Path;
use std::process::{Command, Output};

use omcbsa::demo::{box_flip, Demo, ROBOTS};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::SolutionFile;
use omcbsa_hw::{ExecConfig, ExecError, Executor, PlanValidator};
use omcbsa_mock::transport::MockTransport;

fn demo() -> Demo {
    box_flip().unwrap_or_else(|e| panic!("{e}"))
}

/// The witness with robot 0 jumping by 0.5 rad on joint 1 at step 10 (breaks the velocity
/// rule and tracking).
fn broken(witness: &SolutionFile) -> SolutionFile {
    let mut s = witness.clone();
    s.joint_paths.as_mut().unwrap()[0][10][0] += 0.5;
    s
}

/// Runs `omcbsa execute PROBLEM SOLUTION args...` on files written to `dir`.
fn execute(dir: &Path, demo: &Demo, solution: &SolutionFile, args: &[&str]) -> (i32, String) {
    let (p, s) = (dir.join("problem.json"), dir.join("solution.json"));
    std::fs::write(&p, serde_json::to_string(&demo.problem).unwrap()).unwrap();
    std::fs::write(&s, serde_json::to_string(solution).unwrap()).unwrap();
    let out: Output = Command::new(env!("CARGO_BIN_EXE_omcbsa"))
        .arg("execute")
        .args([&p, &s])
        .args(args)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text)
}

/// `--arm NAME=BUS` for every demo robot, on buses that do not exist.
fn missing_buses() -> Vec<String> {
    ROBOTS
        .iter()
        .flat_map(|r| ["--arm".to_string(), format!("{r}=slcan:/dev/ttyNOPE-{r}")])
        .collect()
}

fn strs(v: &[String]) -> Vec<&str> {
    v.iter().map(String::as_str).collect()
}

#[test]
fn solution_that_does_not_validate_is_refused_before_any_bus_is_opened() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    let args = missing_buses();
    // The buses do not exist: had they been opened, the error would be about them.
    let (code, text) = execute(dir.path(), &demo, &broken(&demo.witness), &strs(&args));
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains(
            "refusing to start: the plan does not validate: invalid: rule 2 (tracking), robot 0, \
             step 10"
        ),
        "{text}"
    );
    assert!(!text.contains("cannot open"), "{text}");
    // A dry run with a log refuses too, and writes no log.
    let log = dir.path().join("log.jsonl");
    let mut dry = strs(&args);
    dry.extend(["--dry-run", "--log", log.to_str().unwrap()]);
    let (code, text) = execute(dir.path(), &demo, &broken(&demo.witness), &dry);
    assert_eq!(code, 2, "{text}");
    assert!(!log.exists());
}

#[test]
fn the_executor_gate_sends_nothing_for_an_invalid_solution() {
    let demo = demo();
    let checked = CheckedSolution::new(demo.problem, broken(&demo.witness)).unwrap();
    assert!(!checked.report().is_valid());
    let plan = checked.plan(&ROBOTS).unwrap();
    let (buses, devices) = MockTransport::buses(&ROBOTS);
    let limits = checked.joint_limits(&plan).unwrap();
    let exec = Executor::new(plan, limits, buses, ExecConfig::default()).unwrap();
    let e = exec.run(&checked).unwrap_err();
    assert!(matches!(e, ExecError::Refused(_)), "{e}");
    for mut d in devices {
        assert!(d.drain().is_empty());
    }
}

#[test]
fn the_gate_accepts_only_the_solution_itself_on_every_moving_robot() {
    let demo = demo();
    let checked = CheckedSolution::new(demo.problem, demo.witness).unwrap();
    let plan = checked.plan(&ROBOTS).unwrap();
    assert_eq!(checked.validate(&plan), Ok(()));
    let mut changed = plan.clone();
    changed.arms[1].joint_path[3][2] += 1e-9;
    let e = checked.validate(&changed).unwrap_err();
    assert!(
        e.contains("arm \"south_west\": the joint path is not the solution's"),
        "{e}"
    );
    let mut slower = plan.clone();
    slower.dt *= 2.0;
    assert!(checked.validate(&slower).unwrap_err().contains("time step"));
    let two = checked.plan(&ROBOTS[..2]).unwrap();
    let e = checked.validate(&two).unwrap_err();
    assert!(
        e.contains("robot \"south_east\" moves in the solution but has no arm"),
        "{e}"
    );
}

#[test]
fn arm_names_must_be_the_problems_robots() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    let mut args = missing_buses();
    args.extend([
        "--arm".into(),
        "left=slcan:/dev/x".into(),
        "--arm".into(),
        "right=slcan:/dev/y".into(),
    ]);
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &strs(&args));
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("--arm: unknown arm name \"left\", \"right\": the problem's robots are \"north\", \"south_west\", \"south_east\""),
        "{text}"
    );
    let twice = ["--arm", "north=slcan:/dev/x", "--arm", "north=slcan:/dev/y"];
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &twice);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("arm \"north\" is given twice"), "{text}");
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &strs(&args[..4]));
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("robot \"south_east\" moves in the solution but has no arm"),
        "{text}"
    );
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &["--arm", "north"]);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("expected NAME=SPEC"), "{text}");
}

#[test]
fn bus_that_cannot_be_opened_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &strs(&missing_buses()));
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("arm \"north\": cannot open CAN bus slcan:/dev/ttyNOPE-north"),
        "{text}"
    );
    let mut args = missing_buses();
    args[1] = "north=can0".into();
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &strs(&args));
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("expected `slcan:/dev/ttyXXX` or `socketcan:IFACE`"),
        "{text}"
    );
}

#[test]
fn dry_run_checks_everything_and_logs_what_it_would_send() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    let log = dir.path().join("log.jsonl");
    let mut args = missing_buses();
    args.extend([
        "--dry-run".into(),
        "--log".into(),
        log.display().to_string(),
        "--rate".into(),
        "250".into(),
    ]);
    let (code, text) = execute(dir.path(), &demo, &demo.witness, &strs(&args));
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("dry run: 3 arms"), "{text}");
    assert!(text.contains("at 4ms"), "{text}");
    let lines = std::fs::read_to_string(&log).unwrap().lines().count();
    assert!(
        text.contains(&format!(" {lines} frames")),
        "{lines}: {text}"
    );
    let (code, text) = execute(
        dir.path(),
        &demo,
        &demo.witness,
        &["--dry-run", "--rate", "0"],
    );
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("--rate"), "{text}");
}

/// Issue 15: values that once aborted, panicked or talked about NaN are bad input (exit 2)
/// with a message naming the value, never a crash (exit 101).
#[test]
fn out_of_range_dt_and_rate_are_refused_with_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    for (dt, shown) in [
        (1e6, "1000000"),
        (1e308, "1000000000000000"),
        (1e-4, "0.0001"),
    ] {
        let mut d = Demo {
            problem: demo.problem.clone(),
            witness: demo.witness.clone(),
        };
        d.problem.dt = dt;
        let (code, text) = execute(dir.path(), &d, &d.witness, &["--dry-run"]);
        assert_eq!(code, 2, "dt {dt}: {text}");
        assert!(
            text.contains("dt: must be within [0.001, 60] s, got ") && text.contains(shown),
            "dt {dt}: {text}"
        );
        assert!(!text.contains("NaN"), "{text}");
    }
    for rate in ["1e-20", "99", "1001", "NaN", "inf", "-500"] {
        let flag = format!("--rate={rate}");
        let (code, text) = execute(dir.path(), &demo, &demo.witness, &["--dry-run", &flag]);
        assert_eq!(code, 2, "--rate {rate}: {text}");
        assert!(
            text.contains("--rate: must be within [100, 1000] Hz, got "),
            "--rate {rate}: {text}"
        );
    }
}
