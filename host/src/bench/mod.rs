//! The benchmark runner (`omcbsa bench`): every selected planner on every problem of a suite,
//! one run per job across a pool of threads, each reported success re-checked with the host
//! validator. Writes into the output directory:
//! - `results.csv`: one row per run, appended and flushed as runs finish. Interrupting keeps
//!   the rows written; rerunning skips the (problem, planner) pairs already there.
//! - `summary.md`: success rate, planning time (median, mean, σ, min, max) and path quality
//!   per planner and arm count.
//! - `success_overall`, `success_by_robots`, `runtime_cdf`, `runtime_mean`, `path_length` as
//!   `.svg` and `.png`.
//! - `index.html`: the summary with the plots, and every problem with a page to view it.
//!
//! A suite entry with an `assignment` (a problem set that says which arm goes where) is planned
//! under it, and a plan with another assignment counts as invalid.
//!
//! The planners are reached through [`Solver`], so the runner is tested with fake planners and
//! anyone can bench their own planner on the suite.

mod error;
mod index;
mod plots;
mod quality;
mod results;
mod summary;

use std::cell::RefCell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use omcbsa_core::problem::Problem;

use crate::assignment::AssignmentRule;
use crate::format::{ProblemFile, SolutionFile, Status};
use crate::plan::{plan_loaded, InputOrPlanError};
use crate::suite::{self, SuiteEntry};
use crate::{load, validate};

pub use error::Error;
pub use quality::{path_quality, PathQuality};
use results::Appender;
pub use results::{csv_header, csv_line, Row};
pub use summary::{Cell, Spread, Summary};

use crate::models::{Fleet, DOF};
use crate::planners::{self, PlannerKind, Pools};
/// `--quick` runs every this-many-th problem of the suite...
pub const QUICK_STRIDE: usize = 15;
/// ... with at most this timeout, so that all six planners finish in under two minutes.
pub const QUICK_TIMEOUT_S: f64 = 1.0;
/// The results file in the output directory.
pub const RESULTS_FILE: &str = "results.csv";
/// The summary table in the output directory.
pub const SUMMARY_FILE: &str = "summary.md";
/// Stack of the worker threads: planners keep their fixed-size workspaces on it.
pub(crate) const WORKER_STACK: usize = 16 << 20;

/// Runs one planner on one problem: the problem as read and as loaded, and the timeout.
pub trait Solver: Sync {
    /// Plans `file` (loaded as `problem`) with the planner called `planner` within
    /// `timeout_s` seconds; `Err` when the run could not happen.
    fn solve(
        &self,
        planner: &str,
        file: &ProblemFile,
        problem: &Problem<7>,
        timeout_s: f64,
    ) -> Result<SolutionFile, String>;
}

impl<F> Solver for F
where
    F: Fn(&str, &ProblemFile, &Problem<7>, f64) -> Result<SolutionFile, String> + Sync,
{
    fn solve(
        &self,
        planner: &str,
        file: &ProblemFile,
        problem: &Problem<7>,
        timeout_s: f64,
    ) -> Result<SolutionFile, String> {
        self(planner, file, problem, timeout_s)
    }
}

/// How `omcbsa bench` runs.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Planner names, run in this order.
    pub planners: Vec<String>,
    /// Per run, seconds.
    pub timeout_s: f64,
    /// Runs at a time.
    pub jobs: usize,
    /// Every [`QUICK_STRIDE`]-th problem, timeout at most [`QUICK_TIMEOUT_S`].
    pub quick: bool,
    /// Output directory; default `SUITE_DIR/bench` (`SUITE_DIR/bench-quick` with `quick`).
    pub out: Option<PathBuf>,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Plan the approach from `initial` (the default); off only to measure what it costs.
    pub approach: bool,
    /// Run nothing: only write the summary, plots and index of the runs already in the
    /// output directory's `results.csv` (made elsewhere, e.g. by a sweep on a cluster).
    pub report_only: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            planners: PlannerKind::BENCH.iter().map(|p| p.to_string()).collect(),
            timeout_s: 5.0,
            jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
            quick: false,
            out: None,
            progress: true,
            approach: true,
            report_only: false,
        }
    }
}

impl BenchOptions {
    /// The timeout actually used.
    pub fn effective_timeout(&self) -> f64 {
        if self.quick {
            self.timeout_s.min(QUICK_TIMEOUT_S)
        } else {
            self.timeout_s
        }
    }
}

/// What a benchmark run did.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// Where the results were written.
    pub out_dir: PathBuf,
    /// Runs made now.
    pub runs: usize,
    /// Runs found in `results.csv` from before (not run again).
    pub resumed: usize,
    /// Over every row of `results.csv`.
    pub summary: Summary,
    /// `summary.md`.
    pub summary_path: PathBuf,
    /// `results.csv`.
    pub results_path: PathBuf,
    /// The plots drawn (SVG and PNG).
    pub plots: Vec<PathBuf>,
    /// Why the plots were not drawn, if they were not (the rest was still written).
    pub plot_error: Option<String>,
    /// `index.html`: the summary, the plots and a 3D view of every problem.
    pub index: PathBuf,
}

/// Benchmarks the planners of `omcbsa plan` and the baselines ([`PlannerKind`]) on a suite.
pub fn run_bench(suite_dir: &Path, opts: &BenchOptions) -> Result<BenchReport, Error> {
    for p in &opts.planners {
        planners::parse_bench(p).map_err(Error::Options)?;
    }
    let approach = opts.approach;
    run_bench_with(
        suite_dir,
        opts,
        &move |name: &str, file: &ProblemFile, problem: &Problem<7>, timeout_s: f64| {
            plan_one(name, file, problem, timeout_s, approach)
        },
    )
}

thread_local! {
    /// Each worker's planner pools, made at its first run and reused: they are large.
    static POOLS: RefCell<Pools> = RefCell::new(Pools::default());
}

/// One run of a built-in planner (as [`run_bench`] makes it) on the problem of `entry`,
/// whose file holds `text` (`source` names it in messages): the row, and the solution of a
/// reported success. A planner that is not one of [`PlannerKind::BENCH`] is an error.
pub fn run_builtin(
    entry: &SuiteEntry,
    text: &str,
    source: &str,
    planner: &str,
    timeout_s: f64,
    approach: bool,
) -> Result<(Row, Option<SolutionFile>), String> {
    planners::parse_bench(planner)?;
    let solver = move |name: &str, file: &ProblemFile, problem: &Problem<7>, timeout_s: f64| {
        plan_one(name, file, problem, timeout_s, approach)
    };
    Ok(run_text(entry, text, source, planner, timeout_s, &solver))
}

/// One run of `omcbsa bench`: planner `name` on one problem, in this thread's pools, through
/// the path `omcbsa plan` takes ([`crate::plan::plan_loaded`]: validated before it is
/// reported), with or without the approach from where the arms stand.
pub fn plan_one(
    name: &str,
    file: &ProblemFile,
    problem: &Problem<7>,
    timeout_s: f64,
    approach: bool,
) -> Result<SolutionFile, String> {
    POOLS.with(|cell| {
        let mut pools = cell.borrow_mut();
        let storage = pools.for_horizon(problem.horizon());
        storage.with_approach = approach;
        // The path `omcbsa plan` takes, validation included.
        plan_loaded(storage, file, problem, planners::parse(name)?, timeout_s).map_err(
            |e| match e {
                InputOrPlanError::Input(e) => e.to_string(),
                InputOrPlanError::Plan(e) => e,
            },
        )
    })
}

/// [`run_bench`] with any planners behind `solver`.
pub fn run_bench_with(
    suite_dir: &Path,
    opts: &BenchOptions,
    solver: &dyn Solver,
) -> Result<BenchReport, Error> {
    check_options(opts)?;
    let timeout = opts.effective_timeout();
    let index = suite::read_index(suite_dir)?;
    let stride = if opts.quick { QUICK_STRIDE } else { 1 };
    let problems: Vec<&SuiteEntry> = index.problems.iter().step_by(stride).collect();
    let out_dir = opts
        .out
        .clone()
        .unwrap_or_else(|| suite_dir.join(if opts.quick { "bench-quick" } else { "bench" }));
    std::fs::create_dir_all(&out_dir).map_err(|source| Error::Io {
        path: out_dir.clone(),
        source,
    })?;
    let results_path = out_dir.join(RESULTS_FILE);
    let (mut rows, mut appender) = open_results(&results_path, timeout)?;
    let resumed = rows.len();
    let jobs = pending_jobs(&problems, opts, &rows);
    let dirs = (suite_dir, out_dir.as_path());
    let runs = run_jobs(dirs, &jobs, timeout, opts, solver, &mut rows, &mut appender)?;

    let summary = Summary::new(&rows, &opts.planners);
    let context =
        format!(
        "Suite `{}` ({} of its {} problems{}), timeout {timeout} s, {} job(s) at a time, {} runs.",
        suite_dir.display(),
        problems.len(),
        index.problems.len(),
        if opts.quick { format!(", every {QUICK_STRIDE}th: --quick") } else { String::new() },
        opts.jobs.max(1),
        rows.len()
    );
    let summary_path = out_dir.join(SUMMARY_FILE);
    let markdown = summary.markdown(&context);
    std::fs::write(&summary_path, &markdown).map_err(|source| Error::Io {
        path: summary_path.clone(),
        source,
    })?;
    let (plots, plot_error) = match plots::write_all(&out_dir, &summary, timeout) {
        Ok(p) => (p, None),
        Err(e) => (Vec::new(), Some(e)),
    };
    let index = index::write_index(
        &out_dir,
        suite_dir,
        &problems,
        &opts.planners,
        &rows,
        &markdown,
        &plots,
    )?;
    Ok(BenchReport {
        out_dir,
        runs,
        resumed,
        summary,
        summary_path,
        results_path,
        plots,
        plot_error,
        index,
    })
}

/// The options a bench cannot run with: no planner, a timeout that is not a number > 0.
fn check_options(opts: &BenchOptions) -> Result<(), Error> {
    if opts.planners.is_empty() {
        return Err(Error::Options("no planner selected".to_string()));
    }
    if !(opts.timeout_s.is_finite() && opts.timeout_s > 0.0) {
        return Err(Error::Options(format!(
            "timeout must be > 0 seconds, got {}",
            opts.timeout_s
        )));
    }
    Ok(())
}

/// The rows `results.csv` already holds and the appender of new ones; an error when those
/// rows ran with another timeout than `timeout` (their numbers would not compare).
fn open_results(results_path: &Path, timeout: f64) -> Result<(Vec<Row>, Appender), Error> {
    let (rows, appender) = results::open(results_path)?;
    if let Some(r) = rows.iter().find(|r| r.timeout_s != timeout) {
        return Err(Error::Options(format!(
            "{} holds runs with a timeout of {} s, this run uses {timeout} s: use another --out \
             directory or delete the file",
            results_path.display(),
            r.timeout_s
        )));
    }
    Ok((rows, appender))
}

/// The runs (problem x planner) still to make: those `rows` lack, none with `--report-only`.
fn pending_jobs<'a>(
    problems: &[&'a SuiteEntry],
    opts: &'a BenchOptions,
    rows: &[Row],
) -> Vec<(&'a SuiteEntry, &'a str)> {
    let done: std::collections::HashSet<(String, String)> = rows
        .iter()
        .map(|r| (r.problem.clone(), r.planner.clone()))
        .collect();
    (problems.iter())
        .flat_map(|e| opts.planners.iter().map(move |p| (*e, p.as_str())))
        .filter(|(e, p)| !done.contains(&(e.name.clone(), p.to_string())))
        .filter(|_| !opts.report_only)
        .collect()
}

/// Makes `jobs` on `opts.jobs` worker threads (`dirs`: the suite's folder and the output
/// folder), each row appended to `results.csv` and to `rows` as it comes; the number of runs
/// made. A row that cannot be written stops the runs not yet started and is the error.
fn run_jobs(
    dirs: (&Path, &Path),
    jobs: &[(&SuiteEntry, &str)],
    timeout: f64,
    opts: &BenchOptions,
    solver: &dyn Solver,
    rows: &mut Vec<Row>,
    appender: &mut Appender,
) -> Result<usize, Error> {
    let (suite_dir, out_dir) = dirs;
    let bar = progress_bar(opts.progress, jobs.len());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs.max(1))
        .stack_size(WORKER_STACK)
        .build()
        .map_err(|e| Error::Options(format!("cannot start {} worker threads: {e}", opts.jobs)))?;
    let stop = AtomicBool::new(false);
    let (tx, rx) = mpsc::channel::<Row>();
    let mut write_error = None;
    let runs = std::thread::scope(|scope| {
        scope.spawn(|| {
            pool.install(|| {
                jobs.par_iter().for_each_with(tx, |tx, &(entry, planner)| {
                    if !stop.load(Ordering::Relaxed) {
                        // The receiver only goes away after every job has ended.
                        let row = run_one(suite_dir, out_dir, entry, planner, timeout, solver);
                        let _ = tx.send(row);
                    }
                })
            })
        });
        let mut runs = 0;
        for row in rx {
            if row.valid == Some(false) {
                bar.suspend(|| {
                    eprintln!(
                        "INVALID SOLUTION: planner {} reported success on {} but the validator refuses it: {}",
                        row.planner, row.problem, row.message
                    )
                });
            }
            if let Err(e) = appender.append(&row) {
                stop.store(true, Ordering::Relaxed);
                write_error.get_or_insert(e);
            }
            bar.set_message(format!("{} {}", row.planner, row.problem));
            bar.inc(1);
            rows.push(row);
            runs += 1;
        }
        runs
    });
    bar.finish_and_clear();
    match write_error {
        Some(e) => Err(e),
        None => Ok(runs),
    }
}

/// The bench's progress bar over `len` runs (hidden without `progress`).
fn progress_bar(progress: bool, len: usize) -> ProgressBar {
    let bar = if progress {
        ProgressBar::new(len as u64)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} runs, eta {eta} {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// Keeps a solved run's solution (`solutions/PLANNER/PROBLEM.json`) for its 3D view.
fn save_solution(
    out_dir: &Path,
    problem: &str,
    planner: &str,
    solution: &SolutionFile,
) -> Result<(), String> {
    let path = index::solution_path(out_dir, planner, problem);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let text = serde_json::to_string(solution).map_err(|e| e.to_string())?;
    std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// One run: read, plan and check ([`run_text`]), keep a success's solution for its view.
fn run_one(
    suite_dir: &Path,
    out_dir: &Path,
    entry: &SuiteEntry,
    planner: &str,
    timeout_s: f64,
    solver: &dyn Solver,
) -> Row {
    let path = suite_dir.join(&entry.file);
    let source = path.display().to_string();
    let (mut row, solution) = match load::read_text(&path) {
        Ok(text) => run_text(entry, &text, &source, planner, timeout_s, solver),
        Err(e) => {
            let mut row = blank_row(entry, planner, timeout_s);
            row.message = format!("{source}: {}", e.to_string().replace('\n', "; "));
            (row, None)
        }
    };
    if let Some(solution) = solution {
        if let Err(e) = save_solution(out_dir, &entry.name, planner, &solution) {
            row.message = format!("{} (solution not saved: {e})", row.message);
        }
    }
    row
}

/// A run's row before it runs: what the index says of the problem, status `error`.
fn blank_row(entry: &SuiteEntry, planner: &str, timeout_s: f64) -> Row {
    Row {
        problem: entry.name.clone(),
        family: entry.family.clone(),
        layout: entry.layout.clone(),
        robots: entry.robots,
        trajectories: entry.trajectories,
        horizon: entry.horizon,
        known_solvable: entry.known_solvable,
        planner: planner.to_string(),
        timeout_s,
        status: "error".to_string(),
        ..Row::default()
    }
}

/// One run on a problem file's `text` (`source` names it in messages): load, plan (a panic is
/// caught and reported), re-validate a reported success. The row, and the solution of a
/// reported success (valid or not).
fn run_text(
    entry: &SuiteEntry,
    text: &str,
    source: &str,
    planner: &str,
    timeout_s: f64,
    solver: &dyn Solver,
) -> (Row, Option<SolutionFile>) {
    let mut row = blank_row(entry, planner, timeout_s);
    let loaded = load::parse_problem(text)
        .and_then(|file| load::problem::<Fleet, DOF>(&file).map(|p| (file, Box::new(p))));
    let (file, mut problem) = match loaded {
        Ok(x) => x,
        Err(e) => {
            row.message = format!("{source}: {}", e.to_string().replace('\n', "; "));
            return (row, None);
        }
    };
    // A problem set that says which arm goes where is planned under that assignment.
    let rule = (entry.assignment.clone()).map_or(AssignmentRule::Free, AssignmentRule::Fixed);
    let (robots, hands) = (problem.robots.len(), problem.trajectories.len());
    if let Err(e) = rule.check("assignment", robots, hands) {
        let e = e.to_string().replace('\n', "; ");
        row.message = format!("{}: {}: {e}", suite::INDEX_FILE, entry.name);
        return (row, None);
    }
    AssignmentRule::apply(rule.list(), &mut problem);
    let start = Instant::now();
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        solver.solve(planner, &file, &problem, timeout_s)
    }));
    row.wall_s = start.elapsed().as_secs_f64();
    let solution = match outcome {
        Ok(Ok(s)) => s,
        Ok(Err(e)) => {
            row.message = e;
            return (row, None);
        }
        Err(_) => {
            row.message = "the planner panicked".to_string();
            return (row, None);
        }
    };
    row.status = solution.status.as_str().to_string();
    row.time_s = solution.planning_time_s;
    let stat = |k: &str| solution.stats.get(k);
    row.expansions = stat("expansions").and_then(|v| v.as_u64());
    row.planner_runs = stat("planner_runs").and_then(|v| v.as_u64());
    if solution.status == Status::Solved {
        row.approach_steps = stat("approach_steps").and_then(|v| v.as_u64());
        row.approach_duration_s = stat("approach_duration_s").and_then(|v| v.as_f64());
        row.approach_time_ms = stat("approach_planning_time_ms").and_then(|v| v.as_f64());
        row.approach_method = stat("approach_method")
            .and_then(|v| v.as_str())
            .unwrap_or_default()
            .to_string();
    }
    row.message = solution.message.clone();
    if solution.status != Status::Solved {
        return (row, None);
    }
    let report = validate::validate::<Fleet, DOF>(&file, &problem, &solution);
    row.valid = Some(report.is_valid());
    row.success = report.is_valid();
    if !report.is_valid() {
        row.message = report.summary();
    } else if let Some(fixed) = (entry.assignment.as_ref()).filter(|f| **f != solution.assignment) {
        row.valid = Some(false);
        row.success = false;
        row.message = format!(
            "the plan's assignment {:?} is not the fixed {fixed:?}",
            solution.assignment
        );
    } else if let Some(paths) = solution.joint_paths.as_ref().and_then(|p| config_paths(p)) {
        row.set_quality(&path_quality::<Fleet, DOF>(
            &problem,
            &solution.assignment,
            &paths,
        ));
    }
    (row, Some(solution))
}

/// A valid solution's joint paths as configurations (`None` if one has the wrong length,
/// which validation has ruled out).
fn config_paths(paths: &[Vec<Vec<f64>>]) -> Option<Vec<Vec<[f64; DOF]>>> {
    paths
        .iter()
        .map(|p| {
            p.iter()
                .map(|q| <[f64; DOF]>::try_from(q.as_slice()).ok())
                .collect()
        })
        .collect()
}
