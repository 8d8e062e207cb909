//! `omcbsa bench-online SUITE`: per-chunk planning latency of online embodiment on the suite's
//! trajectories (see `omcbsa::online::bench`), as a markdown table.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::online::bench::{bench_online, table};
use omcbsa::online::OnlineOptions;

use super::{bad_input, negative};

/// Per-chunk planning latency of online embodiment on the suite's trajectories (chunks
/// planned from where the previous chunk left the arms), as a Markdown table per arm count.
/// Exit code 0 done, 1 a suite that cannot be read or planned, 2 bad options
#[derive(clap::Args)]
pub struct Args {
    /// The suite directory (from `omcbsa gen-bench`).
    suite: PathBuf,
    /// Arm counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "2,3,4,6")]
    arms: Vec<usize>,
    /// Later chunks to attempt per arm count, at least.
    #[arg(long, default_value_t = 200)]
    chunks: usize,
    /// Poses per chunk (H).
    #[arg(long, default_value_t = 16)]
    chunk_len: usize,
    /// Poses between chunk starts.
    #[arg(long, default_value_t = 8)]
    stride: usize,
    /// omcbsa or pp.
    #[arg(long, default_value = "omcbsa")]
    planner: String,
}

pub fn run(args: &Args) -> ExitCode {
    if args.chunk_len == 0 || args.stride == 0 {
        return bad_input("--chunk-len and --stride must be at least 1");
    }
    let options = OnlineOptions {
        planner: args.planner.clone(),
        ..OnlineOptions::default()
    };
    match bench_online(
        &args.suite,
        &args.arms,
        args.chunks,
        &options,
        args.chunk_len,
        args.stride,
        &mut |l| eprintln!("{l}"),
    ) {
        Ok(rows) => {
            print!("{}", table(&rows));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            negative()
        }
    }
}
