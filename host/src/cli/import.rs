//! `omcbsa import-problems`: a published multi-arm problem set, read from the user's
//! checkout of it, written as a suite directory that `omcbsa bench` runs.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::import::vamp_mr::{self, Assignment, Options};

use super::{bad_input, positive_seconds, print};

/// The report of the import, also kept as `OUT/import.md`.
const REPORT_FILE: &str = "import.md";

/// Writes a problem set's problems (`OUT/NAME.json`) and index (`OUT/suite.json`); prints
/// what was imported and what was left out, and why. Exit code 0 done, 2 on a file that
/// cannot be read or holds what the importer does not support (named with the file).
#[derive(clap::Args)]
pub struct Args {
    /// The problem set.
    source: Source,
    /// Its checkout: a VAMP-MR repository (or its mr_planner_core directory).
    #[arg(long)]
    from: PathBuf,
    /// The suite directory to write.
    #[arg(long)]
    out: PathBuf,
    /// Environments, comma-separated (default: those VAMP-MR's planning benchmark runs,
    /// panda_two_rod, panda_four, panda_four_bins).
    #[arg(long, value_delimiter = ',')]
    env: Vec<String>,
    /// Let the planner choose which arm takes which goal (the problem set fixes it).
    #[arg(long)]
    free_assignment: bool,
    /// Seconds between steps.
    #[arg(long, default_value = "0.1", value_parser = positive_seconds)]
    dt: f64,
}

#[derive(clap::ValueEnum, Clone, Copy)]
enum Source {
    /// VAMP-MR's multi-Panda planning benchmark: every named pose of an environment's SRDF
    /// to every other.
    VampMr,
}

pub fn run(args: &Args) -> ExitCode {
    let Source::VampMr = args.source;
    let opts = Options {
        environments: args.env.clone(),
        assignment: if args.free_assignment {
            Assignment::Free
        } else {
            Assignment::Fixed
        },
        dt: args.dt,
    };
    let report = match vamp_mr::import(&args.from, &args.out, &opts) {
        Ok(r) => r,
        Err(e) => return bad_input(e),
    };
    let text = report.markdown();
    let path = args.out.join(REPORT_FILE);
    if let Err(e) = std::fs::write(&path, &text) {
        return bad_input(format!("cannot write {}: {e}", path.display()));
    }
    let done = format!(
        "{text}\n{} problems in {} (run them: omcbsa bench {})",
        report.problems(),
        args.out.display(),
        args.out.display()
    );
    match print(done) {
        Ok(()) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}
