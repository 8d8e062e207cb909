//! `omcbsa validate`: checks a solution file against its problem file.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use omcbsa::load;
use omcbsa::models::{Fleet, DOF};
use omcbsa::validate::{validate, Report};

use super::{bad_input, in_file, negative, print, InputLimit};

/// Checks a solution against its problem: the five rules of docs/FORMATS.md with the
/// project's collision model. Prints `valid`, or every violation with its rule, robot and
/// step. Exit code 0 valid, 1 invalid, 2 bad input or an output that cannot be written.
#[derive(clap::Args)]
pub struct Args {
    /// Problem file (omcbsa.problem.v1).
    problem: PathBuf,
    /// Solution file (omcbsa.solution.v1).
    solution: PathBuf,
    /// Print the report as JSON: {"valid": bool, "summary": "...", "violations": [...],
    /// "omitted": n} (violations beyond the first 1000 are only counted).
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    limit: InputLimit,
}

pub fn run(args: &Args) -> ExitCode {
    let report = match check(args) {
        Ok(report) => report,
        Err(message) => return bad_input(message),
    };
    let text = if args.json {
        serde_json::json!({
            "valid": report.is_valid(),
            "summary": report.summary(),
            "violations": report.violations,
            "omitted": report.omitted,
        })
        .to_string()
    } else {
        let mut lines = vec![report.summary()];
        if report.violations.len() > 1 {
            lines.extend(report.violations.iter().map(|v| format!("  {v}")));
        }
        if report.omitted > 0 {
            lines.push(format!("  and {} more, not listed", report.omitted));
        }
        lines.join("\n")
    };
    if let Err(code) = print(text) {
        return code;
    }
    if report.is_valid() {
        ExitCode::SUCCESS
    } else {
        negative()
    }
}

fn check(args: &Args) -> Result<Report, String> {
    let read = |path: &Path| {
        load::read_text_within(path, args.limit.bytes()).map_err(|e| in_file(path, e))
    };
    let file = load::parse_problem(&read(&args.problem)?).map_err(|e| in_file(&args.problem, e))?;
    let solution =
        load::parse_solution(&read(&args.solution)?).map_err(|e| in_file(&args.solution, e))?;
    let problem = load::problem::<Fleet, DOF>(&file).map_err(|e| in_file(&args.problem, e))?;
    Ok(validate::<Fleet, DOF>(&file, &problem, &solution))
}
