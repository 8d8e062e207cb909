//! `omcbsa gen-bench`: writes the deterministic benchmark suite.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::suite::{gen_bench, GenOptions};

use super::{bad_input, print};

/// Writes the benchmark suite (problems, witnesses and suite.json) into OUTDIR.
/// Exit code 0 written, 2 on an error.
#[derive(clap::Args)]
pub struct Args {
    outdir: PathBuf,
    /// Problems per motion family, 1 to 10000 (the published suite: 76, 456 problems in all).
    #[arg(long, default_value_t = GenOptions::default().per_family as u16,
          value_parser = clap::value_parser!(u16).range(1..=10_000))]
    per_family: u16,
    /// Seed of the suite.
    #[arg(long, default_value_t = GenOptions::default().seed)]
    seed: u64,
}

pub fn run(args: &Args) -> ExitCode {
    let opts = GenOptions {
        seed: args.seed,
        per_family: usize::from(args.per_family),
    };
    match gen_bench(&args.outdir, &opts) {
        Ok(r) => match print(format_args!(
            "{} problems ({} known solvable) in {} ({:.1} s)",
            r.problems,
            r.known_solvable,
            args.outdir.display(),
            r.seconds
        )) {
            Ok(()) => ExitCode::SUCCESS,
            Err(code) => code,
        },
        Err(e) => bad_input(e),
    }
}
