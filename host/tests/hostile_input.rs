//! Regression tests for hostile input on the command line (issue #15, items 2, 3, 5, 6, 7):
//! each case runs the binary and checks its exit code and message. No case may exit 101
//! (a panic): every one is a clear error with the documented code.

mod common;

use std::fs::File;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::*;
use omcbsa::format::{SolutionFile, MAX_JOINT_VALUE};
use omcbsa::load;
use omcbsa_core::model::KinovaGen3;
use omcbsa_hw::cia402::{rad_to_counts, MAX_POSITION_RAD};
use serde_json::{json, Value};

/// Exit code and stdout + stderr of `omcbsa args`, with stdout going to `stdout`.
fn run_with(args: &[&str], stdout: Stdio) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_omcbsa"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (
        out.status.code().expect("exited, not killed by a signal"),
        text,
    )
}

fn run(args: &[&str]) -> (i32, String) {
    run_with(args, Stdio::piped())
}

fn write(dir: &Path, name: &str, value: &impl serde::Serialize) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string(value).unwrap()).unwrap();
    path
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The tiny one-robot scene written to `dir`: problem.json, solution.json.
fn tiny_files(dir: &Path) -> (PathBuf, PathBuf) {
    let (problem, solution) = tiny();
    (
        write(dir, "problem.json", &problem),
        write(dir, "solution.json", &solution),
    )
}

// Item 2: a full or closed stdout.

#[test]
fn plan_and_validate_into_a_full_stdout_fail_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (p, sol) = tiny_files(dir.path());
    let full = || Stdio::from(File::create("/dev/full").unwrap());
    for args in [vec!["plan", s(&p)], vec!["validate", s(&p), s(&sol)]] {
        let (code, text) = run_with(&args, full());
        assert_eq!(code, 2, "{args:?}: {text}");
        assert!(
            text.contains("error: cannot write standard output: No space left on device"),
            "{args:?}: {text}"
        );
    }
}

#[test]
fn plan_and_validate_into_a_closed_pipe_fail_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (p, sol) = tiny_files(dir.path());
    for args in [
        vec!["plan", s(&p)],
        vec!["validate", s(&p), s(&sol)],
        vec!["validate", "--json", s(&p), s(&sol)],
    ] {
        // The reading end is closed before the program starts: its write fails (EPIPE).
        let (ours, theirs) = UnixStream::pair().unwrap();
        drop(ours);
        let (code, text) = run_with(&args, Stdio::from(std::os::fd::OwnedFd::from(theirs)));
        assert_eq!(code, 2, "{args:?}: {text}");
        assert!(
            text.contains("error: cannot write standard output: Broken pipe"),
            "{args:?}: {text}"
        );
    }
}

// Item 3: what validates can execute.

#[test]
fn the_joint_range_of_files_is_the_bus_range() {
    assert_eq!(MAX_JOINT_VALUE, MAX_POSITION_RAD);
    // Joint 1 of the Gen3 is continuous: its range in files is the bus's, and both ends encode.
    let (lower, upper) = load::joint_range::<KinovaGen3, 7>(0, 0);
    assert_eq!((lower, upper), (-MAX_POSITION_RAD, MAX_POSITION_RAD));
    assert!(rad_to_counts(lower).is_some() && rad_to_counts(upper).is_some());
    // A joint with limits keeps them.
    assert_eq!(load::joint_range::<KinovaGen3, 7>(0, 1), (-2.24, 2.24));
}

#[test]
fn an_initial_value_beyond_the_bus_range_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (mut problem, _) = two_robots();
    problem.robots[1].initial.as_mut().unwrap()[2] = 1e308;
    let p = write(dir.path(), "p.json", &problem);
    let (code, text) = run(&["plan", s(&p)]);
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains(
            "robots[1].initial[2]: 1e308 is outside the limits [-214.7483647, 214.7483647] of \
             joint joint_3"
        ),
        "{text}"
    );
}

/// A continuous joint turned by whole turns: the same poses, so only the range can object.
fn turned(solution: &SolutionFile, turns: f64) -> SolutionFile {
    let mut s = solution.clone();
    for q in s.joint_paths.as_mut().unwrap().iter_mut().flatten() {
        q[0] += turns * std::f64::consts::TAU;
    }
    s
}

#[test]
fn a_solution_validates_exactly_when_it_can_execute() {
    let dir = tempfile::tempdir().unwrap();
    let (problem, solution) = tiny();
    let p = write(dir.path(), "p.json", &problem);
    let arm = ["--arm", "solo=slcan:/dev/ttyACM0", "--dry-run"];
    // 34 turns (213.6 rad): within the bus range; validates and executes.
    let inside = write(dir.path(), "inside.json", &turned(&solution, 34.0));
    let (code, text) = run(&["validate", s(&p), s(&inside)]);
    assert_eq!((code, text.trim()), (0, "valid"));
    let (code, text) = run(&[&["execute", s(&p), s(&inside)][..], &arm].concat());
    assert_eq!(code, 0, "{text}");
    // 35 turns (219.9 rad): beyond it; rule 1 in validate, and execute refuses for that reason.
    let outside = write(dir.path(), "outside.json", &turned(&solution, 35.0));
    let (code, text) = run(&["validate", s(&p), s(&outside)]);
    assert_eq!(code, 1, "{text}");
    assert!(
        text.contains(
            "invalid: rule 1 (joint limits), robot 0, step 0: joint joint_1 = 219.911485751 is \
             outside its limits [-214.7483647, 214.7483647]"
        ),
        "{text}"
    );
    let (code, text) = run(&[&["execute", s(&p), s(&outside)][..], &arm].concat());
    assert_eq!(code, 2, "{text}");
    assert!(text.contains("rule 1 (joint limits)"), "{text}");
}

// Item 5: bounded input.

#[test]
fn an_endless_input_is_refused_at_the_size_cap() {
    let (code, text) = run(&["plan", "/dev/zero"]);
    assert_eq!(code, 2, "{text}");
    assert_eq!(
        text.trim(),
        "error: /dev/zero: larger than the input limit of 16777216 bytes (refused, not \
         truncated; --max-input-mib raises the limit)"
    );
}

#[test]
fn the_size_cap_is_a_flag() {
    let dir = tempfile::tempdir().unwrap();
    let (mut problem, solution) = tiny();
    // Over 1 MiB: a long name (valid JSON, otherwise the same problem).
    problem.name = "x".repeat(1 << 20);
    let p = write(dir.path(), "p.json", &problem);
    let sol = write(dir.path(), "s.json", &solution);
    let (code, text) = run(&["validate", "--max-input-mib", "1", s(&p), s(&sol)]);
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("larger than the input limit of 1048576 bytes"),
        "{text}"
    );
    // Raised to 2 MiB it is read (and the solution is for another problem name).
    let (code, text) = run(&["validate", "--max-input-mib", "2", s(&p), s(&sol)]);
    assert_eq!(code, 1, "{text}");
    for bad in ["0", "4097", "-1", "x"] {
        let flag = format!("--max-input-mib={bad}");
        let (code, text) = run(&["plan", &flag, s(&p)]);
        assert_eq!(code, 2, "{bad}: {text}");
        assert!(text.contains("--max-input-mib"), "{bad}: {text}");
    }
}

// Item 6: duplicate robot names.

#[test]
fn duplicate_robot_names_are_refused_naming_the_duplicate() {
    let dir = tempfile::tempdir().unwrap();
    let (mut problem, solution) = two_robots();
    problem.robots[1].name = "left".into();
    let p = write(dir.path(), "p.json", &problem);
    let sol = write(dir.path(), "s.json", &solution);
    let expected = "robots[1].name: \"left\" is also the name of robots[0]: robot names must \
                    be unique";
    for args in [vec!["plan", s(&p)], vec!["validate", s(&p), s(&sol)]] {
        let (code, text) = run(&args);
        assert_eq!(code, 2, "{args:?}: {text}");
        assert!(text.contains(expected), "{args:?}: {text}");
    }
    // Names that `--arm NAME=BUS` cannot give are refused too.
    for (name, why) in [("", "empty: a robot needs a name"), ("a=b", "contains '='")] {
        problem.robots[1].name = name.into();
        let p = write(dir.path(), "p.json", &problem);
        let (code, text) = run(&["plan", s(&p)]);
        assert_eq!(code, 2, "{text}");
        assert!(
            text.contains("robots[1].name: ") && text.contains(why),
            "{text}"
        );
    }
}

// Item 7: usage errors, bus specs, long names, a byte order mark; numeric flags.

#[test]
fn omega_astar_on_several_robots_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "p.json", &two_robots().0);
    let (code, text) = run(&["plan", "--planner", "omega-astar", s(&p)]);
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("--planner omega-astar plans one robot, but") && text.contains("has 2"),
        "{text}"
    );
}

#[test]
fn a_dry_run_refuses_buses_a_live_run_could_never_open() {
    let dir = tempfile::tempdir().unwrap();
    let (p, sol) = tiny_files(dir.path());
    for (bus, why) in [
        ("mock", "expected `slcan:/dev/ttyXXX` or `socketcan:IFACE`"),
        ("slcan:", "the serial device path is empty"),
        ("socketcan:a/b", "not a network interface name"),
        ("socketcan:sixteen_bytes_ab", "not a network interface name"),
    ] {
        let arm = format!("solo={bus}");
        let (code, text) = run(&["execute", s(&p), s(&sol), "--arm", &arm, "--dry-run"]);
        assert_eq!(code, 2, "{bus}: {text}");
        assert!(text.contains(why), "{bus}: {text}");
    }
}

#[test]
fn long_names_are_cut_short_in_messages() {
    let dir = tempfile::tempdir().unwrap();
    let (mut problem, solution) = tiny();
    let long = "n".repeat(4 << 20);
    problem.name = long.clone();
    problem.trajectories[0].name = long.clone();
    let p = write(dir.path(), "p.json", &problem);
    let sol = write(dir.path(), "s.json", &solution);
    // The solution names another problem: the validator quotes both names.
    let (code, text) = run(&["validate", s(&p), s(&sol)]);
    assert_eq!(code, 1, "{text}");
    assert!(text.contains("(4194304 bytes)"), "{text}");
    assert!(text.len() < 400, "{} bytes: {text:.400}", text.len());
    // serde quotes unknown fields and variants in full: cut in the middle.
    let mut v = serde_json::to_value(&solution).unwrap();
    v["status"] = Value::from(long.clone());
    let sol = write(dir.path(), "s.json", &v);
    let (code, text) = run(&["validate", s(&p), s(&sol)]);
    assert_eq!(code, 2, "{text:.400}");
    assert!(text.contains("characters cut]"), "{text:.400}");
    assert!(text.contains("unknown variant"), "{text:.400}");
    assert!(text.len() < 600, "{} bytes: {text:.600}", text.len());
    let mut v = serde_json::to_value(&problem).unwrap();
    v[long.as_str()] = json!(1);
    let p = write(dir.path(), "p.json", &v);
    let (code, text) = run(&["plan", s(&p)]);
    assert_eq!(code, 2, "{text:.400}");
    assert!(text.contains("unknown field"), "{text:.400}");
    assert!(text.len() < 600, "{} bytes: {text:.600}", text.len());
}

#[test]
fn a_byte_order_mark_is_accepted_and_bad_utf8_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let (problem, solution) = tiny();
    let p = write(dir.path(), "p.json", &problem);
    let bom = dir.path().join("bom.json");
    let text = "\u{feff}".to_string() + &serde_json::to_string(&solution).unwrap();
    std::fs::write(&bom, text).unwrap();
    let (code, text) = run(&["validate", s(&p), s(&bom)]);
    assert_eq!((code, text.trim()), (0, "valid"));
    let latin1 = dir.path().join("latin1.json");
    std::fs::write(&latin1, b"{\"format\": \"caf\xe9\"}").unwrap();
    let (code, text) = run(&["validate", s(&p), s(&latin1)]);
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("latin1.json: not UTF-8 text: invalid byte at offset 15"),
        "{text}"
    );
}

#[test]
fn a_truncated_problem_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let text = serde_json::to_string(&two_robots().0).unwrap();
    let p = dir.path().join("cut.json");
    std::fs::write(&p, &text[..200]).unwrap();
    let (code, text) = run(&["plan", s(&p)]);
    assert_eq!(code, 2, "{text}");
    assert!(
        text.contains("cut.json: not valid JSON: EOF while parsing"),
        "{text}"
    );
}

#[test]
fn numeric_flags_are_checked_for_their_range() {
    let dir = tempfile::tempdir().unwrap();
    let (p, _) = tiny_files(dir.path());
    let out = dir.path().join("out");
    for bad in ["0", "-1", "nan", "inf", "1e999", "soon"] {
        let flag = format!("--timeout={bad}");
        for args in [
            vec!["plan", &flag, s(&p)],
            vec!["bench", &flag, s(&out)],
            vec!["demo", &flag, "--out", s(&out)],
        ] {
            let (code, text) = run(&args);
            assert_eq!(code, 2, "{args:?}: {text}");
            assert!(text.contains("--timeout"), "{args:?}: {text}");
        }
    }
    for args in [
        vec!["bench", "--jobs", "0", s(&out)],
        vec!["gen-bench", "--per-family", "0", s(&out)],
        vec!["gen-bench", "--per-family", "10001", s(&out)],
    ] {
        let (code, text) = run(&args);
        assert_eq!(code, 2, "{args:?}: {text}");
    }
    assert!(!out.exists(), "nothing was written");
}

#[test]
fn a_huge_malformed_solution_gives_a_bounded_report() {
    let dir = tempfile::tempdir().unwrap();
    let (problem, mut solution) = tiny();
    // 100 000 configurations of no joint values: one violation each, only 1000 listed.
    solution.joint_paths = Some(vec![vec![Vec::new(); 100_000]]);
    let p = write(dir.path(), "p.json", &problem);
    let sol = write(dir.path(), "s.json", &solution);
    let (code, text) = run(&["validate", s(&p), s(&sol)]);
    assert_eq!(code, 1, "{text:.400}");
    assert!(text.contains("(and 100000 more)"), "{text:.400}");
    assert!(text.contains("  and 99001 more, not listed"), "{text:.400}");
    assert_eq!(text.lines().count(), 1 + 1000 + 1, "{text:.400}");
}
