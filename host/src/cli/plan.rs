//! `omcbsa plan`: plans a problem file and writes the solution file.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::format::Status;
use omcbsa::load;
use omcbsa::planners::{plan_file, InputOrPlanError, PLANNERS};

use super::{bad_input, negative};

/// Plans a problem: which robot tracks which trajectory and every robot's joint path.
/// Exit code 0 solved, 1 not solved (no_solution, timeout, out_of_memory), 2 bad input or
/// usage.
#[derive(clap::Args)]
pub struct Args {
    /// Problem file (omcbsa.problem.v1).
    problem: PathBuf,
    /// Where to write the solution (omcbsa.solution.v1); standard output if absent.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// omcbsa, pp, pp-single, ik-tracking, descartes, composite-astar, or omega-astar (one
    /// robot only).
    #[arg(long, default_value = "omcbsa")]
    planner: String,
    /// Planning time limit, seconds.
    #[arg(long, default_value_t = 5.0)]
    timeout: f64,
}

pub fn run(args: &Args) -> ExitCode {
    if !PLANNERS.contains(&args.planner.as_str()) && args.planner != "omega-astar" {
        return bad_input(format!(
            "--planner: unknown planner {:?} (known: omega-astar, {})",
            args.planner,
            PLANNERS.join(", ")
        ));
    }
    if !(args.timeout > 0.0 && args.timeout.is_finite()) {
        return bad_input(format!(
            "--timeout: must be a positive number of seconds, got {}",
            args.timeout
        ));
    }
    let path = args.problem.display();
    let file = match load::read_text(&args.problem).and_then(|t| load::parse_problem(&t)) {
        Ok(f) => f,
        Err(e) => return bad_input(format!("{path}: {e}")),
    };
    let solution = match plan_file(&file, &args.planner, args.timeout) {
        Ok(s) => s,
        Err(InputOrPlanError::Input(e)) => return bad_input(format!("{path}: {e}")),
        Err(InputOrPlanError::Plan(e)) => return bad_input(e),
    };
    let text = match serde_json::to_string_pretty(&solution) {
        Ok(t) => t,
        Err(e) => return bad_input(format!("cannot encode the solution: {e}")),
    };
    match &args.output {
        Some(out) => {
            if let Err(e) = std::fs::write(out, text + "\n") {
                return bad_input(format!("cannot write {}: {e}", out.display()));
            }
        }
        None => println!("{text}"),
    }
    eprintln!(
        "{}: {} in {:.1} ms{}",
        args.planner,
        solution.status.as_str(),
        solution.planning_time_s * 1e3,
        if solution.message.is_empty() {
            String::new()
        } else {
            format!(" ({})", solution.message)
        }
    );
    if solution.status == Status::Solved {
        ExitCode::SUCCESS
    } else {
        negative()
    }
}
