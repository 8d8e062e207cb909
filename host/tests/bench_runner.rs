//! The benchmark runner with fake planners: CSV rows, re-validation of successes, resuming
//! after an interruption, the summary and the plots, a report of runs made elsewhere.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use omcbsa::bench::{csv_header, csv_line, run_bench_with, BenchOptions, Error, Row, QUICK_STRIDE};
use omcbsa::format::{
    Pose, ProblemFile, RobotSpec, SolutionFile, Status, ToleranceSpec, TrajectorySpec,
    PROBLEM_FORMAT, SOLUTION_FORMAT,
};
use omcbsa::pose::from_frame;
use omcbsa::suite::{SuiteEntry, SuiteIndex, INDEX_FILE, INDEX_FORMAT};
use omcbsa_core::model::{KinovaGen3, Model};
use omcbsa_core::problem::{Assigned, Problem};

/// Kinova's home configuration: clear of itself.
const HOME: [f64; 7] = [0.0, 0.26, 3.1, -2.27, 0.0, 0.96, 1.57];

/// A one-arm problem whose hand stays where `HOME` puts it, for `h` steps.
fn problem(name: &str, h: usize) -> ProblemFile {
    let pose = from_frame(&KinovaGen3::fk(&HOME));
    ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: name.to_string(),
        dt: 0.2,
        robots: vec![RobotSpec {
            name: "arm".to_string(),
            model: "kinova_gen3".to_string(),
            base: Pose::IDENTITY,
            initial: None,
            tcp: None,
            tool: None,
        }],
        trajectories: vec![TrajectorySpec {
            name: "hand".to_string(),
            poses: vec![pose; h],
        }],
        obstacles: Vec::new(),
        tolerance: ToleranceSpec::default(),
    }
}

/// A suite of `n` such problems (2 arms claimed in the index for half of them, to group by).
fn write_suite(dir: &Path, n: usize) {
    let mut problems = Vec::new();
    for k in 0..n {
        let name = format!("p{k:02}");
        let file = format!("{name}.json");
        std::fs::write(
            dir.join(&file),
            serde_json::to_string(&problem(&name, 3)).unwrap(),
        )
        .unwrap();
        problems.push(SuiteEntry {
            name,
            file,
            family: "still".to_string(),
            layout: "single".to_string(),
            robots: 1 + k % 2,
            trajectories: 1,
            horizon: 3,
            known_solvable: k % 3 != 0,
            seed: k as u64,
            redraws: 0,
            witness: None,
            witness_method: None,
            stance: None,
            straight_bridge_collides: None,
            assignment: None,
        });
    }
    let index = SuiteIndex {
        format: INDEX_FORMAT.to_string(),
        seed: 0,
        problems,
        undrawn: Vec::new(),
    };
    std::fs::write(dir.join(INDEX_FILE), serde_json::to_string(&index).unwrap()).unwrap();
}

/// Fake planners: `good` solves correctly, `liar` claims a success with a path that leaves
/// the trajectory, `slow` times out, `crash` panics.
fn fake(
    planner: &str,
    file: &ProblemFile,
    problem: &Problem<7>,
    _timeout: f64,
) -> Result<SolutionFile, String> {
    let h = problem.horizon();
    let (status, paths) = match planner {
        "good" => (Status::Solved, Some(vec![vec![HOME.to_vec(); h]])),
        "liar" => (Status::Solved, Some(vec![vec![[0.0; 7].to_vec(); h]])),
        "slow" => (Status::Timeout, None),
        _ => panic!("crash"),
    };
    Ok(SolutionFile {
        approach: None,
        format: SOLUTION_FORMAT.to_string(),
        problem: file.name.clone(),
        planner: planner.to_string(),
        status,
        message: String::new(),
        planning_time_s: if planner == "good" { 0.002 } else { 0.5 },
        assignment: vec![Some(0)],
        joint_paths: paths,
        stats: serde_json::json!({"expansions": 7})
            .as_object()
            .unwrap()
            .clone(),
    })
}

fn options(planners: &[&str], out: &Path) -> BenchOptions {
    BenchOptions {
        planners: planners.iter().map(|p| p.to_string()).collect(),
        timeout_s: 5.0,
        jobs: 2,
        quick: false,
        out: Some(out.to_path_buf()),
        progress: false,
        approach: true,
        report_only: false,
    }
}

fn read_rows(path: &Path) -> Vec<Row> {
    csv::Reader::from_path(path)
        .unwrap()
        .deserialize()
        .map(|r| r.unwrap())
        .collect()
}

#[test]
fn every_run_is_a_row_and_invalid_successes_are_failures() {
    let suite = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    write_suite(suite.path(), 4);
    let report = run_bench_with(
        suite.path(),
        &options(&["good", "liar", "slow", "crash"], out.path()),
        &fake,
    )
    .unwrap();
    assert_eq!((report.runs, report.resumed), (16, 0));
    let rows = read_rows(&report.results_path);
    assert_eq!(rows.len(), 16);
    for r in &rows {
        let expected = match r.planner.as_str() {
            "good" => ("solved", Some(true), true),
            "liar" => ("solved", Some(false), false),
            "slow" => ("timeout", None, false),
            _ => ("error", None, false),
        };
        assert_eq!((r.status.as_str(), r.valid, r.success), expected, "{r:?}");
    }
    let liar = rows.iter().find(|r| r.planner == "liar").unwrap();
    assert!(
        liar.message.contains("rule 2 (tracking)"),
        "{}",
        liar.message
    );
    assert_eq!(
        rows.iter()
            .find(|r| r.planner == "good")
            .unwrap()
            .expansions,
        Some(7)
    );
    assert!(rows
        .iter()
        .find(|r| r.planner == "crash")
        .unwrap()
        .message
        .contains("panicked"));

    let summary = std::fs::read_to_string(&report.summary_path).unwrap();
    assert!(
        summary.contains("| good | 1 | 2 | 100.0 % (2) |"),
        "{summary}"
    );
    assert!(
        summary.contains("| liar | all | 4 | 0.0 % (0) |"),
        "{summary}"
    );
    assert!(summary.contains("Invalid \"successes\""), "{summary}");
    // Per family (every fake problem is of the family `still`): a column, and rows.
    assert!(summary.contains("| planner | still | all |\n"), "{summary}");
    assert!(
        summary.contains("| good | 4/4 (100.0 %) | 4/4 (100.0 %) |"),
        "{summary}"
    );
    assert!(
        summary.contains("| liar | still | 4 | 0.0 % (0) |"),
        "{summary}"
    );
    let good = report.summary.cell("good", None).unwrap();
    assert_eq!((good.median(), good.mean()), (Some(0.002), Some(0.002)));
    assert_eq!(report.plot_error, None);
    assert_eq!(report.plots.len(), 12);
    for plot in &report.plots {
        assert!(
            std::fs::metadata(plot).unwrap().len() > 1000,
            "{}",
            plot.display()
        );
    }
    // Path quality only for valid successes: `good` holds HOME, so it does not move at all.
    for r in &rows {
        let expected = (r.planner == "good").then_some((0.0, 0.0, 0.0));
        let got = r
            .path_length_rad
            .map(|l| (l, r.max_speed_frac.unwrap(), r.path_cost.unwrap()));
        assert_eq!(got, expected, "{r:?}");
    }
    // index.html: the summary's tables, the plots, a view of every problem (good's plan).
    let index = std::fs::read_to_string(&report.index).unwrap();
    assert!(index.contains("<table>") && index.contains("runtime_mean.png"));
    for k in 0..4 {
        assert!(
            index.contains(&format!("<a href=\"views/p{k:02}.html\">good</a>")),
            "{index}"
        );
        let view = std::fs::read_to_string(out.path().join(format!("views/p{k:02}.html"))).unwrap();
        assert!(view.contains("<script src=\"assets.js\">") && view.contains("\"planned\":true"));
    }
    assert!(out.path().join("views/assets.js").exists());
}

#[test]
fn rerunning_resumes_and_a_cut_last_line_is_run_again() {
    let suite = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    write_suite(suite.path(), 3);
    let calls = AtomicUsize::new(0);
    let counting = |p: &str, f: &ProblemFile, pr: &Problem<7>, t: f64| {
        calls.fetch_add(1, Ordering::SeqCst);
        fake(p, f, pr, t)
    };
    let first = run_bench_with(suite.path(), &options(&["good"], out.path()), &counting).unwrap();
    assert_eq!((first.runs, calls.load(Ordering::SeqCst)), (3, 3));

    // A second planner: only its runs are made.
    let second = run_bench_with(
        suite.path(),
        &options(&["good", "slow"], out.path()),
        &counting,
    )
    .unwrap();
    assert_eq!(
        (second.runs, second.resumed, calls.load(Ordering::SeqCst)),
        (3, 3, 6)
    );

    // An interruption in the middle of writing the last row: that run is made again.
    let path = &second.results_path;
    let text = std::fs::read_to_string(path).unwrap();
    let cut = text.trim_end().rfind('\n').unwrap() + 10;
    std::fs::write(path, &text[..cut]).unwrap();
    let third = run_bench_with(
        suite.path(),
        &options(&["good", "slow"], out.path()),
        &counting,
    )
    .unwrap();
    assert_eq!(
        (third.runs, third.resumed, calls.load(Ordering::SeqCst)),
        (1, 5, 7)
    );
    let rows = read_rows(path);
    assert_eq!(rows.len(), 6);
    let mut keys: Vec<_> = rows
        .iter()
        .map(|r| (r.problem.clone(), r.planner.clone()))
        .collect();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), 6);
    assert_eq!(third.summary.cell("slow", None).unwrap().runs, 3);

    // Nothing left to do.
    let fourth = run_bench_with(
        suite.path(),
        &options(&["good", "slow"], out.path()),
        &counting,
    )
    .unwrap();
    assert_eq!((fourth.runs, calls.load(Ordering::SeqCst)), (0, 7));
}

#[test]
fn another_timeout_is_refused_rather_than_mixed() {
    let suite = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    write_suite(suite.path(), 1);
    run_bench_with(suite.path(), &options(&["good"], out.path()), &fake).unwrap();
    let opts = BenchOptions {
        timeout_s: 2.0,
        ..options(&["good"], out.path())
    };
    match run_bench_with(suite.path(), &opts, &fake) {
        Err(Error::Options(m)) => assert!(m.contains("timeout of 5 s"), "{m}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn quick_runs_every_stride_th_problem_with_a_short_timeout() {
    let suite = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    write_suite(suite.path(), 2 * QUICK_STRIDE + 1);
    let opts = BenchOptions {
        quick: true,
        ..options(&["good"], out.path())
    };
    let report = run_bench_with(suite.path(), &opts, &fake).unwrap();
    let mut problems: Vec<String> = read_rows(&report.results_path)
        .into_iter()
        .map(|r| r.problem)
        .collect();
    problems.sort();
    let expected: Vec<String> = (0..3)
        .map(|k| format!("p{:02}", k * QUICK_STRIDE))
        .collect();
    assert_eq!(problems, expected);
    assert!(read_rows(&report.results_path)
        .iter()
        .all(|r| r.timeout_s == 1.0));
}

#[test]
fn a_missing_suite_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let err = run_bench_with(
        &dir.path().join("nope"),
        &options(&["good"], dir.path()),
        &fake,
    )
    .unwrap_err();
    assert!(err.to_string().contains("suite.json"), "{err}");
}

/// `--report-only`: the summary, plots and index of a results file made elsewhere, row by
/// row from `csv_header` and `csv_line` (as a sweep writes it), without a single run.
#[test]
fn a_report_of_runs_made_elsewhere_runs_nothing() {
    let suite = tempfile::tempdir().unwrap();
    let (here, elsewhere) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    write_suite(suite.path(), 3);
    let planners = ["good", "liar", "slow"];
    let made = run_bench_with(suite.path(), &options(&planners, here.path()), &fake).unwrap();
    let mut text = csv_header().unwrap() + "\n";
    for row in &read_rows(&made.results_path) {
        text += &csv_line(row).unwrap();
    }
    std::fs::write(elsewhere.path().join("results.csv"), text).unwrap();
    let never =
        |_: &str, _: &ProblemFile, _: &Problem<7>, _: f64| -> Result<SolutionFile, String> {
            panic!("a report runs nothing")
        };
    let opts = BenchOptions {
        report_only: true,
        ..options(&planners, elsewhere.path())
    };
    let report = run_bench_with(suite.path(), &opts, &never).unwrap();
    assert_eq!((report.runs, report.resumed), (0, 9));
    assert_eq!(report.summary, made.summary);
    let summary = |dir: &Path| std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert_eq!(
        summary(elsewhere.path()).replace(&elsewhere.path().display().to_string(), "OUT"),
        summary(here.path()).replace(&here.path().display().to_string(), "OUT")
    );
    assert_eq!(report.plots.len(), 12);
}

/// Two Gen3s 3 m apart at HOME and one hand where robot 0's HOME puts it; `assignment` in the
/// index fixes it to robot 1.
fn write_fixed_suite(dir: &Path, assignment: Vec<Option<usize>>) {
    let mut p = problem("fixed", 2);
    let mut far = p.robots[0].clone();
    far.name = "far".to_string();
    far.base.position = [3.0, 0.0, 0.0];
    p.robots.push(far);
    for r in &mut p.robots {
        r.initial = Some(HOME.to_vec());
    }
    std::fs::write(dir.join("fixed.json"), serde_json::to_string(&p).unwrap()).unwrap();
    let index = SuiteIndex {
        format: INDEX_FORMAT.to_string(),
        seed: 0,
        problems: vec![SuiteEntry {
            name: "fixed".to_string(),
            file: "fixed.json".to_string(),
            family: "fixed".to_string(),
            layout: "pair".to_string(),
            robots: 2,
            trajectories: 1,
            horizon: 2,
            known_solvable: false,
            seed: 0,
            redraws: 0,
            witness: None,
            witness_method: None,
            stance: None,
            straight_bridge_collides: None,
            assignment: Some(assignment),
        }],
        undrawn: Vec::new(),
    };
    std::fs::write(dir.join(INDEX_FILE), serde_json::to_string(&index).unwrap()).unwrap();
}

/// Robot 0 tracks the hand (a valid plan), robot 1 holds, whatever the problem fixes; it
/// reports the assignment the problem handed it as the message.
fn robot0_tracks(
    planner: &str,
    file: &ProblemFile,
    problem: &Problem<7>,
    timeout: f64,
) -> Result<SolutionFile, String> {
    let mut s = fake("good", file, problem, timeout)?;
    s.planner = planner.to_string();
    s.assignment = vec![Some(0), None];
    s.joint_paths = Some(vec![vec![HOME.to_vec(); 2]; 2]);
    let assigned: Vec<Assigned> = problem.robots.iter().map(|r| r.assigned).collect();
    s.message = format!("{assigned:?}");
    Ok(s)
}

#[test]
fn a_fixed_assignment_is_planned_under_and_checked() {
    // Fixed as the plan goes: the planner is handed it, and the plan counts.
    let suite = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    write_fixed_suite(suite.path(), vec![Some(0), None]);
    let report =
        run_bench_with(suite.path(), &options(&["p"], out.path()), &robot0_tracks).unwrap();
    let rows = read_rows(&report.results_path);
    assert_eq!(
        (rows[0].success, rows[0].valid),
        (true, Some(true)),
        "{:?}",
        rows[0]
    );
    assert_eq!(rows[0].message, "[Track(0), Hold]");

    // Fixed the other way: a valid plan under another assignment is not a success.
    let out = tempfile::tempdir().unwrap();
    write_fixed_suite(suite.path(), vec![None, Some(0)]);
    let report =
        run_bench_with(suite.path(), &options(&["p"], out.path()), &robot0_tracks).unwrap();
    let rows = read_rows(&report.results_path);
    assert_eq!(
        (rows[0].success, rows[0].valid),
        (false, Some(false)),
        "{:?}",
        rows[0]
    );
    assert!(
        rows[0]
            .message
            .contains("the plan's assignment [Some(0), None] is not the fixed [None, Some(0)]"),
        "{}",
        rows[0].message
    );

    // An assignment that does not fit the problem is an error of the suite, named.
    let out = tempfile::tempdir().unwrap();
    write_fixed_suite(suite.path(), vec![Some(1), None]);
    let report =
        run_bench_with(suite.path(), &options(&["p"], out.path()), &robot0_tracks).unwrap();
    let rows = read_rows(&report.results_path);
    assert_eq!(rows[0].status, "error");
    assert!(
        rows[0]
            .message
            .contains("suite.json: fixed: assignment[0]: hand 1 does not exist"),
        "{}",
        rows[0].message
    );
}
