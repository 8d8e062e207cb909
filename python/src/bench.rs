//! `bench_run`, `bench_csv_header` and `bench_report`: one run of `omcbsa bench` (the same
//! code: load, plan with the bench's pools, re-validate a success, path quality), and its
//! summary, plots and index of a `results.csv`, for sweeps that spread the runs over many
//! processes or machines (`omcbsa.sweep`).

use std::path::PathBuf;

use omcbsa::bench::{csv_header, csv_line, run_bench, run_builtin, BenchOptions};
use omcbsa::planners::PlannerKind;
use omcbsa::suite::SuiteEntry;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

use crate::convert::field_error;
use crate::guard;

/// The planners `omcbsa bench` runs by default (every one it can run), by name.
#[pyfunction]
pub fn bench_planners() -> Vec<&'static str> {
    PlannerKind::BENCH.iter().map(|p| p.name()).collect()
}

/// The header line of `results.csv` (no line end).
#[pyfunction]
pub fn bench_csv_header() -> PyResult<String> {
    csv_header().map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// One run of `planner` on a suite's problem, exactly as `omcbsa bench` makes it: `entry` is
/// the problem's entry of `suite.json` (JSON text), `problem` the text of its file. Returns
/// the run's `results.csv` record (its line end included) and, when the planner reported a
/// success, the solution file's JSON text (`omcbsa bench` keeps it for the 3D views).
#[pyfunction]
#[pyo3(signature = (entry, problem, planner, timeout, approach=true))]
pub fn bench_run(
    py: Python<'_>,
    entry: &str,
    problem: &str,
    planner: &str,
    timeout: f64,
    approach: bool,
) -> PyResult<(String, Option<String>)> {
    if !(timeout > 0.0 && timeout.is_finite()) {
        let why = format!("must be a positive number of seconds, got {timeout}");
        return Err(field_error(py, "timeout", why));
    }
    let entry: SuiteEntry =
        serde_json::from_str(entry).map_err(|e| field_error(py, "entry", e.to_string()))?;
    let source = entry.file.clone();
    let run = py.detach(|| {
        guard("bench_run", || {
            run_builtin(&entry, problem, &source, planner, timeout, approach)
        })
    })?;
    let (row, solution) = run.map_err(|e| field_error(py, "planner", e))?;
    let record = csv_line(&row).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let solution = (solution.as_ref())
        .map(serde_json::to_string)
        .transpose()
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok((record, solution))
}

/// `omcbsa bench SUITE --out OUT --report-only`: the summary (returned as markdown), plots and
/// index of the runs in `OUT/results.csv`, made by `planners` with `timeout` seconds each
/// (`jobs`: how many ran at a time, for the summary's first line). Runs nothing.
#[pyfunction]
#[pyo3(signature = (suite, out, planners, timeout, approach=true, jobs=1))]
pub fn bench_report(
    py: Python<'_>,
    suite: PathBuf,
    out: PathBuf,
    planners: Vec<String>,
    timeout: f64,
    approach: bool,
    jobs: usize,
) -> PyResult<String> {
    let opts = BenchOptions {
        planners,
        timeout_s: timeout,
        jobs,
        quick: false,
        out: Some(out),
        progress: false,
        approach,
        report_only: true,
    };
    let report = py
        .detach(|| guard("bench_report", || run_bench(&suite, &opts)))?
        .map_err(|e| field_error(py, "", e.to_string()))?;
    if let Some(e) = &report.plot_error {
        return Err(PyRuntimeError::new_err(format!("plots not drawn: {e}")));
    }
    std::fs::read_to_string(&report.summary_path)
        .map_err(|e| PyRuntimeError::new_err(format!("{}: {e}", report.summary_path.display())))
}
