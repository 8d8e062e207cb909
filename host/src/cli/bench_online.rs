//! `omcbsa bench-online`: online embodiment measured as a policy drives it, as markdown tables:
//! on a suite's trajectories (per-chunk latency against planning each problem whole, see
//! `omcbsa::online::bench`), or on the long bimanual episodes at the policy's own rate
//! (`--family bimanual`: chunks and whole episodes embodied, latency, and the same episodes
//! planned in whole windows as the reference).

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::online::bench::{
    bench_online, episode_table, run_episode, table, Chunking, EpisodeRow,
};
use omcbsa::online::bimanual::{family, MAX_ARMS};
use omcbsa::online::OnlineOptions;
use omcbsa::planners::{self, PlannerKind};
use omcbsa_core::problem::MAX_STEPS;

use super::{bad_input, negative};

/// Online embodiment as a policy drives it, as Markdown tables per arm count. Exit code 0
/// done, 1 a suite that cannot be read or planned, 2 bad options
#[derive(clap::Args)]
pub struct Args {
    /// The suite directory (from `omcbsa gen-bench`); or give --family.
    suite: Option<PathBuf>,
    /// `bimanual`: long bimanual episodes (pick, hand over; pick, insert) at --hz, instead of
    /// a suite.
    #[arg(long)]
    family: Option<String>,
    /// Policy rate of the family's episodes, Hz [default: 50] (a suite's problems keep their
    /// own dt).
    #[arg(long)]
    hz: Option<f64>,
    /// Episodes of each task per arm count (--family).
    #[arg(long, default_value_t = 10)]
    episodes: usize,
    /// Arm counts, comma-separated (default 2,3,4,6 on a suite and on the family).
    #[arg(long, value_delimiter = ',')]
    arms: Vec<usize>,
    /// Later chunks to attempt per arm count, at least (suite).
    #[arg(long, default_value_t = 200)]
    chunks: usize,
    /// Poses per chunk (H).
    #[arg(long, default_value_t = 16)]
    chunk_len: usize,
    /// Poses between chunk starts; less than --chunk-len for an action-chunking policy that
    /// sends more than it executes (default 8 on a suite, --chunk-len on the family).
    #[arg(long)]
    stride: Option<usize>,
    /// The family's chunks arrive when the arms have been sent everything up to this many
    /// steps before a chunk's first step (0: just in time).
    #[arg(long, default_value_t = 0)]
    lead: usize,
    /// A chunk that has no plan under the assignment may take a new one from where the arms
    /// stand (the Embodier's `reassign`).
    #[arg(long)]
    reassign: bool,
    /// Weight of the cost of two joint axes nearing one line in the chunks' plans (0: none,
    /// the chunks planned greedily, IK tracking first).
    #[arg(long, default_value_t = omcbsa::online::AXIS_WEIGHT)]
    axis_weight: f64,
    /// omcbsa or pp.
    #[arg(long, default_value_t = PlannerKind::DEFAULT, value_parser = planners::parse)]
    planner: PlannerKind,
}

pub fn run(args: &Args) -> ExitCode {
    let stride = args.stride.unwrap_or(match args.family {
        Some(_) => args.chunk_len,
        None => 8,
    });
    if args.chunk_len == 0 || stride == 0 || stride > args.chunk_len {
        return bad_input(
            "--chunk-len and --stride must be at least 1, --stride at most --chunk-len",
        );
    }
    if !(args.axis_weight.is_finite() && args.axis_weight >= 0.0) {
        return bad_input("--axis-weight must be a finite number, 0 or more");
    }
    if args.chunk_len >= MAX_STEPS {
        return bad_input(format!("--chunk-len must be below {MAX_STEPS} (MAX_STEPS)"));
    }
    let options = OnlineOptions {
        planner: args.planner,
        reassign: args.reassign,
        axis_weight: args.axis_weight,
        ..OnlineOptions::default()
    };
    match (&args.suite, args.family.as_deref()) {
        (Some(_), None) if args.hz.is_some() => {
            bad_input("--hz is for --family: a suite's problems keep their own dt")
        }
        (Some(suite), None) => {
            let arms = match args.arms.as_slice() {
                [] => vec![2, 3, 4, 6],
                a => a.to_vec(),
            };
            match bench_online(
                suite,
                &arms,
                args.chunks,
                &options,
                args.chunk_len,
                stride,
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
        (None, Some("bimanual")) => {
            let hz = args.hz.unwrap_or(50.0);
            if !(hz.is_finite() && hz > 0.0) {
                return bad_input("--hz must be a positive rate");
            }
            let arms = match args.arms.as_slice() {
                [] => vec![2, 3, 4, 6],
                a => a.to_vec(),
            };
            if let Some(n) = arms.iter().find(|&&n| !(2..=MAX_ARMS).contains(&n)) {
                return bad_input(format!(
                    "--arms {n}: the bimanual family has 2 to {MAX_ARMS} arms"
                ));
            }
            bimanual(
                args,
                &arms,
                &options,
                Chunking {
                    len: args.chunk_len,
                    stride,
                    lead: args.lead,
                },
            )
        }
        (None, Some(other)) => bad_input(format!("--family {other:?}: the family is bimanual")),
        (Some(_), Some(_)) => bad_input("give a suite or --family, not both"),
        (None, None) => bad_input("give a suite directory or --family bimanual"),
    }
}

/// The family's episodes through the Embodier with `chunking`, then in whole windows.
fn bimanual(args: &Args, arms: &[usize], options: &OnlineOptions, chunking: Chunking) -> ExitCode {
    let whole = Chunking {
        len: MAX_STEPS - 1,
        stride: MAX_STEPS - 1,
        lead: 0,
    };
    // As `omcbsa plan` would be given: 5 s per window.
    let whole_options = OnlineOptions {
        max_chunk_len: whole.len,
        chunk_timeout_s: 5.0,
        capacities: omcbsa::planners::Capacities::default(),
        ..options.clone()
    };
    let mut rows = Vec::new();
    for &n in arms {
        let episodes = family(&[n], args.episodes, args.hz.unwrap_or(50.0));
        let mut online = EpisodeRow {
            arms: n,
            chunking: Some(chunking),
            ..EpisodeRow::default()
        };
        let mut reference = EpisodeRow {
            arms: n,
            ..EpisodeRow::default()
        };
        for ep in &episodes {
            let runs = run_episode(ep, options, chunking)
                .and_then(|a| Ok((a, run_episode(ep, &whole_options, whole)?)));
            match runs {
                Ok((a, b)) => {
                    if let Some(err) = a.error.as_ref().filter(|_| !a.embodied) {
                        eprintln!("{}: {err}", ep.name);
                    }
                    if let Some(err) = b.error.as_ref().filter(|_| !b.embodied) {
                        eprintln!("{} (reference): {err}", ep.name);
                    }
                    online.add(&a);
                    reference.add(&b);
                }
                Err(e) => {
                    eprintln!("error: {}: {e}", ep.name);
                    return negative();
                }
            }
        }
        eprintln!(
            "{n} arms: {} episodes, {} embodied online, {} in whole windows",
            online.episodes, online.embodied, reference.embodied
        );
        rows.extend([online, reference]);
    }
    print!("{}", episode_table(&rows));
    ExitCode::SUCCESS
}
