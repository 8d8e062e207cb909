//! `omcbsa demo`: plans the built-in 3-arm box flip with Ω-CBSA, validates it, and streams it
//! to three mock arms that it starts itself.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use omcbsa::demo::{box_flip, run_on_mock_arms, MockRunError, DT, ROBOTS, STEPS};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::Status;
use omcbsa::planners::{plan_file, InputOrPlanError};
use omcbsa_hw::mock::ensure_venv;
use omcbsa_hw::record::TOLERANCE;
use serde::Serialize;

use super::execute::{failure, progress_printer};
use super::{bad_input, negative};

/// The README's main command: three Kinova Gen3 arms around a box, hands on three of its faces
/// while it flips. Plans it with Ω-CBSA, validates the plan, writes problem.json and
/// solution.json, starts three Python mock arms (on SLCAN pseudo-terminals, creating their
/// venv if needed) and streams the plan to them. Exit code 0 done, 1 not solved or stopped by
/// a fault, 2 the mock arms or the output directory are not available.
#[derive(clap::Args)]
pub struct Args {
    /// Where to write problem.json, solution.json and the mock arms' records.
    #[arg(long, default_value = "demo-out")]
    out: PathBuf,
    /// Planning time limit, seconds.
    #[arg(long, default_value_t = 5.0)]
    timeout: f64,
}

pub fn run(args: &Args) -> ExitCode {
    if !(args.timeout > 0.0 && args.timeout.is_finite()) {
        return bad_input(format!(
            "--timeout: must be a positive number of seconds, got {}",
            args.timeout
        ));
    }
    println!("demo: 3 Kinova Gen3 arms around a box, hands on three faces while it flips");
    let demo = match box_flip() {
        Ok(d) => d,
        Err(e) => return failed(e),
    };
    let problem = demo.problem;
    println!(
        "problem {:?}: {} robots, {} trajectories of {STEPS} poses every {DT} s",
        problem.name,
        problem.robots.len(),
        problem.trajectories.len()
    );
    let solution = match plan_file(&problem, "omcbsa", args.timeout) {
        Ok(s) => s,
        Err(InputOrPlanError::Input(e)) => return failed(e),
        Err(InputOrPlanError::Plan(e)) => return failed(e),
    };
    println!(
        "planned with Ω-CBSA in {:.1} ms: {}",
        solution.planning_time_s * 1e3,
        solution.status.as_str()
    );
    if solution.status != Status::Solved {
        return failed(format!("not solved: {}", solution.message));
    }
    let checked = match CheckedSolution::new(problem, solution) {
        Ok(c) => c,
        Err(e) => return failed(e),
    };
    println!("validated: {}", checked.report().summary());
    if !checked.report().is_valid() {
        return negative();
    }
    if let Err(e) = write_files(&args.out, &checked) {
        return bad_input(e);
    }
    let python = match ensure_venv() {
        Ok(p) => p,
        Err(e) => return bad_input(e),
    };
    let plan = match checked.plan(&ROBOTS) {
        Ok(p) => p,
        Err(e) => return failed(e),
    };
    println!(
        "starting {} mock arms, each at its first configuration",
        plan.arms.len()
    );
    let names = ROBOTS.map(String::from).to_vec();
    let report = match run_on_mock_arms(&python, plan, &checked, &args.out, progress_printer(names))
    {
        Ok(r) => r,
        Err(MockRunError::Exec(e)) => return failure(e),
        Err(e @ MockRunError::Mocks(_)) => return bad_input(e),
        Err(e @ MockRunError::Record { .. }) => return failed(e),
    };
    println!("{report}");
    summary(&checked, &report);
    println!(
        "  bus logs              {}/mock-*.log (candump -L: every frame, both directions)",
        args.out.display()
    );
    ExitCode::SUCCESS
}

fn failed(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    negative()
}

fn write_files(out: &Path, checked: &CheckedSolution) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    write_json(&out.join("problem.json"), checked.problem())?;
    write_json(&out.join("solution.json"), checked.solution())
}

fn write_json(path: &Path, value: &impl Serialize) -> Result<(), String> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| format!("cannot encode {}: {e}", path.display()))?;
    std::fs::write(path, text + "\n")
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

fn summary(checked: &CheckedSolution, report: &omcbsa_hw::Report) {
    let (problem, solution) = (checked.problem(), checked.solution());
    let assignment: Vec<String> = (problem.robots.iter().zip(&solution.assignment))
        .map(|(r, a)| match a.and_then(|j| problem.trajectories.get(j)) {
            Some(t) => format!("{} -> {}", r.name, t.name),
            None => format!("{} holds", r.name),
        })
        .collect();
    let max_error = report
        .arms
        .iter()
        .map(|a| a.max_following_error)
        .fold(0.0, f64::max);
    println!("summary");
    println!(
        "  planning time         {:.1} ms (Ω-CBSA)",
        solution.planning_time_s * 1e3
    );
    println!("  assignment            {}", assignment.join(", "));
    println!(
        "  cycles streamed       {} per arm at {:.0} Hz ({:.2} s), {} frames",
        report.cycles,
        1.0 / report.period.as_secs_f64(),
        report.cycles as f64 * report.period.as_secs_f64(),
        report.frames_sent
    );
    println!("  max following error   {max_error:.2e} rad");
    println!(
        "  mock arms' records    every command as planned (within {TOLERANCE:.0e} rad), none \
         beyond a joint limit"
    );
}
