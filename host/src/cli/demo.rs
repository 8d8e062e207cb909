//! `omcbsa demo`: plans the built-in 3-arm box flip with Ω-CBSA, validates it, and streams it
//! to three mock arms that it starts itself.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use omcbsa::demo::{box_flip, run_on_mock_arms_watched, MockRunError, DT, ROBOTS, STEPS};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::Status;
use omcbsa::plan::{plan_file, InputOrPlanError};
use omcbsa::planners::PlannerKind;
use omcbsa::view::write_html;
use omcbsa_mock::arms::MockKind;
use omcbsa_mock::mock::ensure_venv;
use omcbsa_mock::record::TOLERANCE;
use serde::Serialize;

use super::execute::{failure, progress_printer};
use super::watch::WatchArgs;
use super::{bad_input, negative, note, positive_seconds, print};

/// The README's main command: three Kinova Gen3 arms around a box, hands on three of its faces
/// while it flips. Plans it with Ω-CBSA, validates the plan, writes problem.json and
/// solution.json, starts three Python mock arms (creating their venv if needed: on SLCAN
/// pseudo-terminals, or mock Gen3s on Kortex over loopback TCP and UDP with `--transport
/// kortex`) and streams the plan to them. Exit code 0 done, 1 not solved or stopped by
/// a fault, 2 the mock arms or the output directory are not available.
#[derive(clap::Args)]
pub struct Args {
    /// Where to write problem.json, solution.json, plan.html (the 3D view) and the mock arms'
    /// records.
    #[arg(long, default_value = "demo-out")]
    out: PathBuf,
    /// Planning time limit, seconds.
    #[arg(long, default_value = "5", value_parser = positive_seconds)]
    timeout: f64,
    /// How the mock arms are reached: can (CiA 402 over SLCAN) or kortex (Kinova's Kortex over
    /// TCP and UDP).
    #[arg(long, value_enum, default_value = "can")]
    transport: TransportArg,
    #[command(flatten)]
    watch: WatchArgs,
}

/// `--transport` of the commands that start their own mock arms.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum TransportArg {
    Can,
    Kortex,
}

impl From<TransportArg> for MockKind {
    fn from(t: TransportArg) -> Self {
        match t {
            TransportArg::Can => MockKind::Can,
            TransportArg::Kortex => MockKind::Kortex,
        }
    }
}

pub fn run(args: &Args) -> ExitCode {
    demo(args).unwrap_or_else(|code| code)
}

fn demo(args: &Args) -> Result<ExitCode, ExitCode> {
    let watch = args.watch.settings().map_err(bad_input)?;
    print("demo: 3 Kinova Gen3 arms around a box, hands on three faces while it flips")?;
    print(&watch)?;
    let problem = box_flip().map_err(failed)?.problem;
    print(format_args!(
        "problem {:?}: {} robots, {} trajectories of {STEPS} poses every {DT} s",
        problem.name,
        problem.robots.len(),
        problem.trajectories.len()
    ))?;
    let solution = plan_file(&problem, PlannerKind::OmCbsa, args.timeout).map_err(|e| match e {
        InputOrPlanError::Input(e) => failed(e),
        InputOrPlanError::Plan(e) => failed(e),
    })?;
    print(format_args!(
        "planned with Ω-CBSA in {:.1} ms: {}",
        solution.planning_time_s * 1e3,
        solution.status.as_str()
    ))?;
    if solution.status != Status::Solved {
        return Err(failed(format!("not solved: {}", solution.message)));
    }
    let checked = CheckedSolution::new(problem, solution).map_err(failed)?;
    print(format_args!("validated: {}", checked.report().summary()))?;
    if !checked.report().is_valid() {
        return Err(negative());
    }
    write_files(&args.out, &checked)?;
    let python = ensure_venv().map_err(bad_input)?;
    let plan = checked.plan(&ROBOTS).map_err(failed)?;
    print(format_args!(
        "starting {} mock arms ({}), each at its first configuration",
        plan.arms.len(),
        match args.transport {
            TransportArg::Can => "CiA 402 over SLCAN",
            TransportArg::Kortex => "Gen3 on Kortex over loopback TCP and UDP",
        }
    ))?;
    let names = ROBOTS.map(String::from).to_vec();
    let kind = MockKind::from(args.transport);
    let progress = progress_printer(names);
    let dir = &args.out;
    let report = run_on_mock_arms_watched(&python, kind, plan, &checked, dir, &watch, progress)
        .map_err(|e| match e {
            MockRunError::Exec(e) => failure(e),
            e @ MockRunError::Mocks(_) => bad_input(e),
            e @ MockRunError::Record { .. } => failed(e),
        })?;
    print(&report)?;
    summary(&checked, &report)?;
    if kind == MockKind::Can {
        print(format_args!(
            "  bus logs              {}/mock-*.log (candump -L: every frame, both directions)",
            args.out.display()
        ))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn failed(e: impl std::fmt::Display) -> ExitCode {
    note(format_args!("error: {e}"));
    negative()
}

fn write_files(out: &Path, checked: &CheckedSolution) -> Result<(), ExitCode> {
    std::fs::create_dir_all(out)
        .map_err(|e| bad_input(format!("cannot create {}: {e}", out.display())))?;
    write_json(&out.join("problem.json"), checked.problem())?;
    write_json(&out.join("solution.json"), checked.solution())?;
    let page = out.join("plan.html");
    let (problem, solution, report) = (checked.problem(), checked.solution(), checked.report());
    write_html(problem, Some(solution), Some(report), &page).map_err(bad_input)?;
    print(format_args!(
        "wrote {} (open it in a browser to see the plan)",
        page.display()
    ))
}

fn write_json(path: &Path, value: &impl Serialize) -> Result<(), ExitCode> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| bad_input(format!("cannot encode {}: {e}", path.display())))?;
    std::fs::write(path, text + "\n")
        .map_err(|e| bad_input(format!("cannot write {}: {e}", path.display())))?;
    print(format_args!("wrote {}", path.display()))
}

fn summary(checked: &CheckedSolution, report: &omcbsa_hw::Report) -> Result<(), ExitCode> {
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
    let lines = [
        "summary".to_string(),
        format!(
            "  planning time         {:.1} ms (Ω-CBSA)",
            solution.planning_time_s * 1e3
        ),
        format!("  assignment            {}", assignment.join(", ")),
        format!(
            "  cycles streamed       {} per arm at {:.0} Hz ({:.2} s), {} frames",
            report.cycles,
            1.0 / report.period.as_secs_f64(),
            report.cycles as f64 * report.period.as_secs_f64(),
            report.frames_sent
        ),
        format!("  max following error   {max_error:.2e} rad"),
        format!(
            "  mock arms' records    every command as planned (within {TOLERANCE:.0e} rad), \
             none beyond a joint limit"
        ),
    ];
    print(lines.join("\n"))
}
