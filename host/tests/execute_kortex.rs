//! `omcbsa execute` with Kortex arms: a dry run accepts `kortex:` specs (1 kHz by default), bad
//! specs and missing credentials are clear errors before anything is reached, and a live run
//! streams the demo's witness to three mock Gen3s (hw-adapter/mock/mock_gen3.py; run
//! `bash hw-adapter/mock/setup_venv.sh` first) with the password from a file, which no output
//! or log shows.

use std::path::Path;
use std::process::Command;

use omcbsa::demo::{box_flip, Demo, ROBOTS};
use omcbsa::execute::CheckedSolution;
use omcbsa::execute::{joint_limits, CAUTIOUS_SPEED};
use omcbsa::models::ModelKind;
use omcbsa_hw::interpolate::interpolate;
use omcbsa_hw::kortex::{PASSWORD_ENV, USER_ENV};
use omcbsa_mock::arms::{MockArms, MockKind};
use omcbsa_mock::mock::venv_python;
use omcbsa_mock::mock_gen3;

fn demo() -> Demo {
    box_flip().unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `omcbsa execute PROBLEM SOLUTION args...` on the demo's files written to `dir`, with no
/// Kortex credentials in the environment.
fn execute(dir: &Path, demo: &Demo, args: &[String]) -> (i32, String) {
    let (p, s) = (dir.join("problem.json"), dir.join("solution.json"));
    std::fs::write(&p, serde_json::to_string(&demo.problem).unwrap()).unwrap();
    std::fs::write(&s, serde_json::to_string(&demo.witness).unwrap()).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_omcbsa"))
        .arg("execute")
        .args([&p, &s])
        .args(args)
        .env_remove(USER_ENV)
        .env_remove(PASSWORD_ENV)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (out.status.code().unwrap_or(-1), text)
}

fn arms(spec: impl Fn(usize) -> String) -> Vec<String> {
    (ROBOTS.iter().enumerate())
        .flat_map(|(i, r)| ["--arm".to_string(), format!("{r}={}", spec(i))])
        .collect()
}

#[test]
fn a_dry_run_accepts_kortex_arms_at_1_khz_and_bad_specs_or_credentials_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    // TEST-NET addresses: nothing is reached in a dry run.
    let mut args = arms(|i| format!("kortex:192.0.2.{}", i + 1));
    args.push("--dry-run".into());
    let (code, text) = execute(dir.path(), &demo, &args);
    assert_eq!(code, 0, "{text}");
    assert!(
        text.contains("dry run: 3 arms") && text.contains("at 1ms"),
        "{text}"
    );

    let mut bad = arms(|_| "kortex:192.0.2.1".into());
    bad[1] = "north=kortex:192.0.2.1:10000".into();
    let (code, text) = execute(dir.path(), &demo, &bad);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("give both ports or neither"), "{text}");

    // A live run without a password stops before any connection.
    let (code, text) = execute(dir.path(), &demo, &arms(|_| "kortex:192.0.2.1".into()));
    assert_eq!(code, 2, "{text}");
    assert!(text.contains(USER_ENV), "{text}");
    let mut args = arms(|_| "kortex:192.0.2.1".into());
    args.extend(["--kortex-user".into(), "admin".into()]);
    let (code, text) = execute(dir.path(), &demo, &args);
    assert_eq!(code, 2, "{text}");
    assert!(text.contains(PASSWORD_ENV), "{text}");
}

#[test]
fn execute_streams_to_three_mock_gen3s_and_shows_the_password_nowhere() {
    let dir = tempfile::tempdir().unwrap();
    let demo = demo();
    let checked = CheckedSolution::new(demo.problem.clone(), demo.witness.clone()).unwrap();
    let plan = checked.plan(&ROBOTS).unwrap();
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let starts: Vec<_> = (plan.arms.iter())
        .map(|a| (a.name.clone(), a.joint_path[0]))
        .collect();
    let period = std::time::Duration::from_millis(10);
    let record = |n: &str| dir.path().join(format!("mock-{n}.jsonl"));
    let mocks = MockArms::spawn(MockKind::Kortex, &python, period, &starts, record, &[]).unwrap();
    let MockArms::Kortex(gen3s) = &mocks else {
        unreachable!()
    };
    let password = mock_gen3::credentials().password;
    let secret = dir.path().join("password");
    std::fs::write(&secret, format!("{password}\n")).unwrap();
    let log = dir.path().join("log.jsonl");
    let mut args = arms(|i| gen3s[i].spec());
    for a in [
        "--kortex-user",
        "admin",
        "--kortex-password-file",
        secret.to_str().unwrap(),
        "--rate",
        "100",
        "--rt-priority",
        "off",
        // 4 missed cycles, not the default 2: a Python mock descheduled for two 10 ms periods
        // on a shared 2-core machine stopped this run once; the watchdog's bound has its own
        // tests (hw-adapter/src/watchdog.rs, tests/faults.rs, tests/kortex.rs).
        "--missed-cycles",
        "4",
        "--log",
        log.to_str().unwrap(),
    ] {
        args.push(a.into());
    }
    let (code, text) = execute(dir.path(), &demo, &args);
    assert_eq!(code, 0, "{text}");
    assert!(text.contains("executed: 3 arms"), "{text}");
    let logged = std::fs::read_to_string(&log).unwrap();
    assert!(logged.contains("Session.CreateSession"));
    assert!(!text.contains(&password) && !logged.contains(&password));
    let limits = joint_limits(ModelKind::default(), CAUTIOUS_SPEED);
    let traj = interpolate(&plan, &vec![limits; plan.arms.len()], period.as_secs_f64()).unwrap();
    let settle = omcbsa_hw::ExecConfig::default().settle_cycles;
    for ((name, record), cmds) in mocks.finish().unwrap().iter().zip(&traj.commands) {
        MockKind::Kortex
            .check_followed(record, cmds, settle, &limits, period.as_secs_f64())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}
