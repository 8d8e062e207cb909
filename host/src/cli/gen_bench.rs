//! `omcbsa gen-bench`: writes the deterministic benchmark suite.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::suite::{gen_bench, gen_refine, Family, GenOptions, RefineOptions, Tightness};

use super::{bad_input, print};

/// Writes the benchmark suite (problems, witnesses and suite.json) into OUTDIR.
/// Exit code 0 written, 2 on an error.
#[derive(clap::Args)]
pub struct Args {
    outdir: PathBuf,
    /// Problems per motion family, 1 to 10000 (the published suite: 76, 608 problems in all).
    #[arg(long, default_value_t = GenOptions::default().per_family as u16,
          value_parser = clap::value_parser!(u16).range(1..=10_000))]
    per_family: u16,
    /// Comma-separated families to generate (default: all); each gets the same problems as
    /// in the whole suite.
    #[arg(long, value_delimiter = ',', value_parser = Family::parse)]
    families: Vec<Family>,
    /// Seed of the suite (of the refinement family: its own by default).
    #[arg(long)]
    seed: Option<u64>,
    /// Instead of the suite, the refinement family: N problems with a validated witness on
    /// which Ω-CBSA's first refinement level finds no plan (1 to 1000).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=1000))]
    refine: Option<u16>,
    /// With --refine: fixtures 2 cm from the witness instead of the suite's 5 cm, and more of
    /// them.
    #[arg(long, requires = "refine")]
    tight: bool,
}

pub fn run(args: &Args) -> ExitCode {
    let written = match args.refine {
        Some(n) => {
            let defaults = RefineOptions::default();
            let opts = RefineOptions {
                seed: args.seed.unwrap_or(defaults.seed),
                problems: usize::from(n),
                max_candidates: defaults.max_candidates.max(100 * usize::from(n)),
                traps: if args.tight {
                    Tightness::TIGHT
                } else {
                    Tightness::SUITE
                },
            };
            gen_refine(&args.outdir, &opts)
        }
        None => gen_bench(
            &args.outdir,
            &GenOptions {
                seed: args.seed.unwrap_or(GenOptions::default().seed),
                per_family: usize::from(args.per_family),
                families: if args.families.is_empty() {
                    Family::ALL.to_vec()
                } else {
                    args.families.clone()
                },
            },
        ),
    };
    match written {
        Ok(r) => match print(format_args!(
            "{} problems ({} known solvable, {} drawn again from a later seed) in {} ({:.1} s){}",
            r.problems,
            r.known_solvable,
            r.redrawn,
            args.outdir.display(),
            r.seconds,
            if r.undrawn.is_empty() {
                String::new()
            } else {
                format!(
                    "\nleft out, no seed drew them (listed in suite.json): {}",
                    r.undrawn.join(", ")
                )
            }
        )) {
            Ok(()) => ExitCode::SUCCESS,
            Err(code) => code,
        },
        Err(e) => bad_input(e),
    }
}
