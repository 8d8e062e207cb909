//! `omcbsa plan`: plans a problem file and writes the solution file.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::format::Status;
use omcbsa::load;
use omcbsa::plan::{plan_file, InputOrPlanError};
use omcbsa::planners::{self, PlannerKind};

use super::{bad_input, negative, note, positive_seconds, print, InputLimit};

/// Plans a problem: which robot tracks which trajectory and every robot's joint path.
/// Exit code 0 solved, 1 not solved (no_solution, timeout, out_of_memory), 2 bad input or
/// usage, or an output that cannot be written.
#[derive(clap::Args)]
pub struct Args {
    /// Problem file (omcbsa.problem.v1).
    problem: PathBuf,
    /// Where to write the solution (omcbsa.solution.v1); standard output if absent.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// omcbsa, pp, pp-single, ik-tracking, descartes, composite-astar, or omega-astar (one
    /// robot only).
    #[arg(long, default_value_t = PlannerKind::DEFAULT, value_parser = planners::parse,
          long_help = format!("The planner:\n{}", planners::descriptions()))]
    planner: PlannerKind,
    /// Planning time limit, seconds.
    #[arg(long, default_value = "5", value_parser = positive_seconds)]
    timeout: f64,
    #[command(flatten)]
    limit: InputLimit,
}

pub fn run(args: &Args) -> ExitCode {
    plan(args).unwrap_or_else(|code| code)
}

fn plan(args: &Args) -> Result<ExitCode, ExitCode> {
    let path = args.problem.display();
    let file = load::read_text_within(&args.problem, args.limit.bytes())
        .and_then(|t| load::parse_problem(&t))
        .map_err(|e| bad_input(format!("{path}: {e}")))?;
    // A usage error, not a property of the problem: the planner plans one robot.
    if args.planner.single_robot() && file.robots.len() != 1 {
        return Err(bad_input(format!(
            "--planner omega-astar plans one robot, but {path} has {}; use omcbsa, pp or \
             pp-single for several",
            file.robots.len()
        )));
    }
    let solution = plan_file(&file, args.planner, args.timeout).map_err(|e| match e {
        InputOrPlanError::Input(e) => bad_input(format!("{path}: {e}")),
        InputOrPlanError::Plan(e) => bad_input(e),
    })?;
    let text = serde_json::to_string_pretty(&solution)
        .map_err(|e| bad_input(format!("cannot encode the solution: {e}")))?;
    match &args.output {
        Some(out) => std::fs::write(out, text + "\n")
            .map_err(|e| bad_input(format!("cannot write {}: {e}", out.display())))?,
        None => print(text)?,
    }
    note(format_args!(
        "{}: {} in {:.1} ms{}",
        args.planner,
        solution.status.as_str(),
        solution.planning_time_s * 1e3,
        if solution.message.is_empty() {
            String::new()
        } else {
            format!(" ({})", solution.message)
        }
    ));
    Ok(if solution.status == Status::Solved {
        ExitCode::SUCCESS
    } else {
        negative()
    })
}
