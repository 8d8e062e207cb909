//! `omcbsa view`: writes the 3D page of a problem and, when given, its solution.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::load;
use omcbsa::view::{write_html, ViewError};

use super::{bad_input, in_file};

/// Writes one self-contained HTML page (works offline) showing the problem in 3D: the arms
/// with Kinova's meshes (or their collision capsules), the obstacles, each hand trajectory in
/// its arm's colour, and with a solution the plan step by step (play, pause, time slider) and
/// the validator's findings (clashing links marked at their step). Exit code 0 written, 2 bad
/// input.
#[derive(clap::Args)]
pub struct Args {
    /// Problem file (omcbsa.problem.v1).
    problem: PathBuf,
    /// Solution file (omcbsa.solution.v1); without it the arms are shown at their initial
    /// configurations.
    solution: Option<PathBuf>,
    /// The page to write.
    #[arg(short, long, default_value = "plan.html")]
    out: PathBuf,
}

pub fn run(args: &Args) -> ExitCode {
    let read_problem = load::read_text(&args.problem)
        .and_then(|t| load::parse_problem(&t))
        .map_err(|e| in_file(&args.problem, e));
    let problem = match read_problem {
        Ok(p) => p,
        Err(e) => return bad_input(e),
    };
    let solution = match &args.solution {
        None => None,
        Some(path) => match load::read_text(path)
            .and_then(|t| load::parse_solution(&t))
            .map_err(|e| in_file(path, e))
        {
            Ok(s) => Some(s),
            Err(e) => return bad_input(e),
        },
    };
    match write_html(&problem, solution.as_ref(), None, &args.out) {
        Ok(()) => {
            println!("wrote {}", args.out.display());
            ExitCode::SUCCESS
        }
        Err(ViewError::Input(e)) => bad_input(in_file(&args.problem, e)),
        Err(e) => bad_input(e),
    }
}
