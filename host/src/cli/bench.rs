//! `omcbsa bench`: runs planners on a suite; CSV, summary, plots and index.html.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::bench::{run_bench, BenchOptions};
use omcbsa::planners::{parse_bench, PlannerKind};

use super::{bad_input, note, positive_seconds, print};

/// Runs every planner on every problem of SUITE_DIR (made by gen-bench), re-validating every
/// reported success, and writes results.csv (resumable), summary.md, plots and index.html.
/// Exit code 0 done, 1 if some reported success failed validation, 2 on an error.
#[derive(clap::Args)]
pub struct Args {
    suite_dir: PathBuf,
    /// Comma-separated planners.
    #[arg(long, value_delimiter = ',', value_parser = parse_bench,
          default_values_t = PlannerKind::BENCH)]
    planners: Vec<PlannerKind>,
    /// Per run, seconds.
    #[arg(long, default_value = "5", value_parser = positive_seconds)]
    timeout: f64,
    /// Runs at a time, 1 to 1024 (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=1024))]
    jobs: Option<u16>,
    /// A subset that finishes in under two minutes.
    #[arg(long)]
    quick: bool,
    /// Output directory (default SUITE_DIR/bench, or SUITE_DIR/bench-quick).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Plan without the approach from `initial`: each planner alone, its plan beginning where
    /// it chose. Only to measure what the approach costs (the peer of a default run).
    #[arg(long)]
    no_approach: bool,
    /// Run nothing: write summary.md, the plots and index.html from the runs already in the
    /// output directory's results.csv (a sweep's, e.g. `python -m omcbsa.sweep`).
    #[arg(long)]
    report_only: bool,
}

pub fn run(args: &Args) -> ExitCode {
    let defaults = BenchOptions::default();
    let opts = BenchOptions {
        planners: args.planners.iter().map(|p| p.to_string()).collect(),
        timeout_s: args.timeout,
        jobs: args.jobs.map_or(defaults.jobs, usize::from),
        quick: args.quick,
        out: args.out.clone(),
        progress: true,
        approach: !args.no_approach,
        report_only: args.report_only,
    };
    match run_bench(&args.suite_dir, &opts) {
        Ok(report) => {
            let mut lines = vec![
                std::fs::read_to_string(&report.summary_path).unwrap_or_default(),
                format!("results: {}", report.results_path.display()),
            ];
            lines.extend(
                report
                    .plots
                    .iter()
                    .map(|p| format!("plot: {}", p.display())),
            );
            if let Err(code) = print(lines.join("\n")) {
                return code;
            }
            println!(
                "index: {} (summary, plots, a 3D view of every problem)",
                report.index.display()
            );
            if let Some(e) = &report.plot_error {
                note(format_args!("plots not drawn: {e}"));
            }
            if !report.summary.invalid.is_empty() {
                note(format_args!(
                    "error: {} reported successes failed validation",
                    report.summary.invalid.len()
                ));
                return ExitCode::from(1);
            }
            ExitCode::SUCCESS
        }
        Err(e) => bad_input(e),
    }
}
