//! The `omcbsa` binary: fk and ik over stdin (bad lines included) and validate's exit codes.

mod common;

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

use common::*;
use serde_json::Value;

fn omcbsa(args: &[&str], stdin: &str) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_omcbsa"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // A child that stops reading early (it exits on a usage error) closes the pipe: what it
    // printed is what the tests check, so a broken pipe here is not itself a failure.
    let _ = child.stdin.take().unwrap().write_all(stdin.as_bytes());
    child.wait_with_output().unwrap()
}

fn stdout_lines(out: &Output) -> Vec<Value> {
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    text.lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn error_of(v: &Value) -> &str {
    v["error"]
        .as_str()
        .unwrap_or_else(|| panic!("not an error object: {v}"))
}

fn fk(q: &[f64]) -> Value {
    let out = omcbsa(
        &["fk", "--model", "kinova_gen3"],
        &format!("{}\n", Value::from(q.to_vec())),
    );
    assert_eq!(out.status.code(), Some(0));
    stdout_lines(&out).remove(0)
}

#[test]
fn fk_answers_every_line_and_reports_bad_ones() {
    let input = "[0, 0, 0, 0, 0, 0, 0]\nnot json\n[0, 0, 0]\n[0, 0, 0, 3.5, 0, 0, 0]\n\n[0.1, 0.35, 0, 1.8, 0, 1.0, 0]\n";
    let out = omcbsa(&["fk", "--model", "kinova_gen3"], input);
    assert_eq!(
        out.status.code(),
        Some(1),
        "a failed line makes exit code 1"
    );
    let lines = stdout_lines(&out);
    assert_eq!(lines.len(), 6, "one answer per line");
    // All zeros: the Gen3 stands straight up, its tool frame 1.187 m above the base.
    let z = lines[0]["position"][2].as_f64().unwrap();
    assert!((z - 1.18738).abs() < 1e-4, "{}", lines[0]);
    assert!(error_of(&lines[1]).starts_with("line 2: q: not a JSON array of 7 numbers"));
    assert_eq!(
        error_of(&lines[2]),
        "line 3: q: expected 7 joint values for model kinova_gen3, got 3"
    );
    assert_eq!(
        error_of(&lines[3]),
        "line 4: q[3]: 3.5 is outside the limits [-2.57, 2.57] of joint joint_4"
    );
    assert_eq!(error_of(&lines[4]), "line 5: empty line");
    let quat: Vec<f64> = serde_json::from_value(lines[5]["quat_xyzw"].clone()).unwrap();
    assert!((quat.iter().map(|x| x * x).sum::<f64>() - 1.0).abs() < 1e-12);
    assert!(quat[3] >= 0.0, "w >= 0");
}

#[test]
fn fk_with_only_good_lines_exits_0_and_an_unknown_model_is_a_usage_error() {
    assert_eq!(fk(&Q0)["position"].as_array().unwrap().len(), 3);
    let out = omcbsa(&["fk", "--model", "ur5"], "");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr)
        .contains("unknown model \"ur5\" (compiled in: kinova_gen3, franka_panda"));
}

#[test]
fn the_panda_answers_fk_and_ik_under_its_name_and_alias() {
    // Zero configuration: the TCP 0.088 m out and 0.5226 m up (0.333 + 0.316 + 0.384 - 0.107
    // - 0.1034), pointing down.
    let q = "[0, 0, 0, -1.5, 0, 1.5, 0]\n[0, 0, 0, 0, 0, 0, 0]\n";
    let out = omcbsa(&["fk", "--model", "franka_panda"], q);
    let lines = stdout_lines(&out);
    // Joint 4's upper limit is -0.0698: zero is outside it.
    assert_eq!(
        error_of(&lines[1]),
        "line 2: q[3]: 0 is outside the limits [-3.0718, -0.0698] of joint panda_joint4"
    );
    assert_eq!(out.status.code(), Some(1));
    let pose = &lines[0];
    let input = format!("{pose}\n");
    for name in ["franka_panda", "panda"] {
        let out = omcbsa(&["ik", "--model", name], &input);
        assert_eq!(out.status.code(), Some(0), "{name}");
        let q: Vec<f64> = serde_json::from_value(stdout_lines(&out).remove(0)).unwrap();
        let back = omcbsa(&["fk", "--model", name], &format!("{}\n", Value::from(q)));
        let back = stdout_lines(&back).remove(0);
        for k in 0..3 {
            let d = back["position"][k].as_f64().unwrap() - pose["position"][k].as_f64().unwrap();
            assert!(d.abs() < 1e-5, "{back} vs {pose}");
        }
    }
}

#[test]
fn ik_inverts_fk_and_reports_bad_and_unreachable_poses() {
    let pose = fk(&Q0);
    let input = format!(
        "{pose}\n{}\n{}\n{}\n",
        r#"{"position": [0.5, 0, 0.3], "quat_xyzw": [0, 0, 0, 0.98]}"#,
        r#"{"position": [5.0, 0, 0.3], "quat_xyzw": [0, 0, 0, 1]}"#,
        r#"{"position": [NaN, 0, 0.3], "quat_xyzw": [0, 0, 0, 1]}"#
    );
    let out = omcbsa(&["ik", "--model", "kinova_gen3"], &input);
    assert_eq!(out.status.code(), Some(1));
    let lines = stdout_lines(&out);
    assert_eq!(lines.len(), 4);
    let q: Vec<f64> = serde_json::from_value(lines[0].clone()).expect("a configuration");
    let back = fk(&q);
    for k in 0..3 {
        let d = back["position"][k].as_f64().unwrap() - pose["position"][k].as_f64().unwrap();
        assert!(d.abs() < 1e-5, "{back} vs {pose}");
    }
    assert_eq!(
        error_of(&lines[1]),
        "line 2: quat_xyzw: norm 0.98 is more than 1e-6 away from 1"
    );
    assert!(
        error_of(&lines[2]).starts_with("line 3: no IK solution found"),
        "{}",
        lines[2]
    );
    assert!(
        error_of(&lines[3]).starts_with("line 4: not a pose"),
        "{}",
        lines[3]
    );
}

#[test]
fn ik_is_deterministic_and_follows_the_seed_configuration() {
    let input = format!("{}\n", fk(&Q0));
    let a = omcbsa(&["ik", "--model", "kinova_gen3"], &input);
    let b = omcbsa(&["ik", "--model", "kinova_gen3"], &input);
    assert_eq!((a.status.code(), &a.stdout), (Some(0), &b.stdout));
    // Started next to Q0, the projection lands next to Q0 (the arm has a null space, so only
    // "next to").
    let seed = Value::from(near_q0(0.2).to_vec()).to_string();
    let out = omcbsa(
        &["ik", "--model", "kinova_gen3", "--seed-config", &seed],
        &input,
    );
    let q: Vec<f64> = serde_json::from_value(stdout_lines(&out).remove(0)).unwrap();
    let far = q
        .iter()
        .zip(Q0)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(far < 0.1, "{q:?}");
    let out = omcbsa(
        &["ik", "--model", "kinova_gen3", "--seed-config", "[0, 0]"],
        &input,
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--seed-config: expected 7 joint values"));
}

/// Writes `(name, text)` files into a fresh directory and returns their paths.
fn files(test: &str, contents: &[(&str, String)]) -> Vec<String> {
    let dir: PathBuf =
        std::env::temp_dir().join(format!("omcbsa-cli-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    (contents.iter())
        .map(|(name, text)| {
            let path = dir.join(name);
            std::fs::write(&path, text).unwrap();
            path.to_string_lossy().into_owned()
        })
        .collect()
}

#[test]
fn validate_exit_codes() {
    let (p, s) = tiny();
    let mut bad_s = s.clone();
    bad_s.joint_paths.as_mut().unwrap()[0][1][5] = 2.5;
    let mut bad_p = serde_json::to_value(&p).unwrap();
    bad_p["dt"] = Value::from(0);
    let paths = files(
        "validate",
        &[
            ("p.json", serde_json::to_string(&p).unwrap()),
            ("s.json", serde_json::to_string(&s).unwrap()),
            ("bad_s.json", serde_json::to_string(&bad_s).unwrap()),
            ("bad_p.json", bad_p.to_string()),
        ],
    );
    let run = |args: &[&str]| {
        let out = omcbsa(args, "");
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (code, stdout, _) = run(&["validate", &paths[0], &paths[1]]);
    assert_eq!((code, stdout.as_str()), (Some(0), "valid\n"));
    let (code, stdout, _) = run(&["validate", &paths[0], &paths[2]]);
    assert_eq!(code, Some(1));
    assert!(
        stdout.starts_with("invalid: rule 1 (joint limits), robot 0, step 1: joint joint_6 = 2.5"),
        "{stdout}"
    );
    let (code, stdout, _) = run(&["validate", "--json", &paths[0], &paths[2]]);
    let report: Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(
        (code, &report["valid"], &report["violations"][0]["rule"]),
        (Some(1), &Value::from(false), &Value::from("joint_limits"))
    );
    let (code, _, stderr) = run(&["validate", &paths[3], &paths[1]]);
    assert_eq!(code, Some(2));
    assert!(
        stderr.contains("bad_p.json: dt: must be > 0, got 0"),
        "{stderr}"
    );
    let (code, _, stderr) = run(&["validate", &paths[0], "/nonexistent/s.json"]);
    assert_eq!(code, Some(2));
    assert!(
        stderr.contains("cannot read /nonexistent/s.json"),
        "{stderr}"
    );
    assert_eq!(run(&["validate", &paths[0]]).0, Some(2), "usage error");
}

/// Issue 22: an arm whose `initial` collides (here with the other arm, standing at the same
/// spot) is bad input, exit 2, naming both robots; never `no_solution`.
#[test]
fn plan_refuses_a_start_in_collision_naming_the_robots() {
    let path = [near_q0(0.0), near_q0(1.0), near_q0(2.0)];
    let (a, b) = (at([0.0; 3]), at([0.05, 0.0, 0.0]));
    let file = problem(
        vec![robot("left", a, Some(Q0)), robot("right", b, Some(Q0))],
        vec![trajectory_of("hand", &a, &path)],
        0.1,
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.json");
    std::fs::write(&p, serde_json::to_string(&file).unwrap()).unwrap();
    let out = omcbsa(&["plan", p.to_str().unwrap()], "");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("robots[0].initial"), "{err}");
    assert!(
        err.contains("\"left\"") && err.contains("\"right\""),
        "{err}"
    );
}

#[test]
fn bench_online_runs_the_bimanual_family_and_refuses_mixed_options() {
    let out = omcbsa(
        &[
            "bench-online",
            "--family",
            "bimanual",
            "--arms",
            "2",
            "--episodes",
            "1",
            "--chunk-len",
            "64",
            "--stride",
            "16",
        ],
        "",
    );
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(
        table.contains("| 2 | 64 / 16 (lead 0) | 2 | 0 | 100.0 %"),
        "{table}"
    );
    assert!(table.contains("whole windows (reference)"), "{table}");
    for bad in [
        &["bench-online", "--family", "bimanual", "--arms", "7"][..],
        &[
            "bench-online",
            "--family",
            "bimanual",
            "--chunk-len",
            "8",
            "--stride",
            "16",
        ],
        &["bench-online", "--family", "shelves"],
        &[
            "bench-online",
            "--family",
            "bimanual",
            "--axis-weight",
            "-1",
        ],
        &[
            "bench-online",
            "--family",
            "bimanual",
            "--axis-weight",
            "NaN",
        ],
        &["bench-online", "/nonexistent", "--hz", "50"],
        &["bench-online"],
        &[
            "bench-online",
            "--family",
            "bimanual",
            "--dir",
            "data/aloha_sim",
        ],
        &[
            "bench-online",
            "--family",
            "aloha-sim",
            "--dir",
            "/nonexistent",
        ],
        &["bench-online", "--family", "aloha-sim", "--layouts", "ring"],
        &["bench-online", "--family", "aloha-sim", "--hz", "30"],
    ] {
        let out = omcbsa(bad, "");
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("error"),
            "{bad:?}"
        );
    }
}

#[test]
fn a_panda_problem_is_validated_and_planned_with_the_panda() {
    // Gen3 paths near Q0 (joint 4 at 1.8 rad) break the Panda's joint 4 limit (-3.0718 to
    // -0.0698): validate checks them against the Panda.
    let (p, s) = tiny();
    let mut panda = serde_json::to_value(&p).unwrap();
    panda["robots"][0]["model"] = Value::from("franka_panda");
    let paths = files(
        "panda",
        &[
            ("p.json", panda.to_string()),
            ("s.json", serde_json::to_string(&s).unwrap()),
        ],
    );
    let out = omcbsa(&["validate", &paths[0], &paths[1]], "");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stdout.starts_with("invalid: rule 1 (joint limits), robot 0, step 0: joint panda_joint4"),
        "{stdout}"
    );
    // The planners take the Panda too: an answer (solved or not), not a refusal of the input.
    let out = omcbsa(&["plan", &paths[0], "--timeout", "2"], "");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(2), "{stderr}");
}

#[test]
fn unknown_planners_are_usage_errors_listing_the_known_ones() {
    let out = omcbsa(&["plan", "--planner", "fast", "p.json"], "");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr.contains("unknown planner \"fast\" (known: omcbsa, pp, pp-single, ik-tracking, descartes, composite-astar, omega-astar)"),
        "{stderr}"
    );
    let out = omcbsa(&["plan", "--help"], "");
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("pp-single: OM-PP-A*_single"), "{help}");
    // The bench runs planners of several robots only.
    let out = omcbsa(&["bench", "suite", "--planners", "pp,omega-astar"], "");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr.contains("unknown planner \"omega-astar\" (known: omcbsa, pp, pp-single, ik-tracking, descartes, composite-astar)"),
        "{stderr}"
    );
}
