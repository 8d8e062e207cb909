//! `omcbsa bench-online`: online embodiment measured as a policy drives it, as markdown tables:
//! on a suite's trajectories (per-chunk latency against planning each problem whole, see
//! `omcbsa::online::bench`), or on long bimanual episodes at the policy's own rate
//! (`--family bimanual`, drawn; `--family aloha-sim`, recorded in ALOHA's simulation: chunks
//! and whole episodes embodied, latency, and the same episodes planned in whole windows as
//! the reference).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use omcbsa::online::aloha::{self, Cell, FleetKind, Layout};
use omcbsa::online::bench::{
    bench_episodes, bench_online, episode_table, table, Chunking, EpisodeRow,
};
use omcbsa::online::bimanual::{family, Episode, MAX_ARMS};
use omcbsa::online::OnlineOptions;
use omcbsa::planners::{self, PlannerKind};
use omcbsa_core::problem::MAX_STEPS;

use super::{bad_input, negative, note, print};

/// Online embodiment as a policy drives it, as Markdown tables per arm count. Exit code 0
/// done, 1 a suite that cannot be read or planned, 2 bad options
#[derive(clap::Args)]
pub struct Args {
    /// The suite directory (from `omcbsa gen-bench`); or give --family.
    suite: Option<PathBuf>,
    /// Long bimanual episodes (pick, hand over; pick, insert) instead of a suite: `bimanual`
    /// (drawn, at --hz) or `aloha-sim` (ALOHA's scripted tasks recorded in its simulation at
    /// 50 Hz, read from --dir).
    #[arg(long)]
    family: Option<String>,
    /// The aloha-sim family's directory [default: data/aloha_sim].
    #[arg(long)]
    dir: Option<PathBuf>,
    /// Where the arms of the aloha-sim family stand, comma-separated: corners (at the table's
    /// corners, facing its centre), rows (side by side along its two long edges, facing
    /// across it) [default: corners,rows].
    #[arg(long, value_delimiter = ',')]
    layouts: Vec<String>,
    /// The aloha-sim family's fleets, comma-separated: gen3 (every arm a Gen3), mixed (Gen3s
    /// and Pandas alternating) [default: gen3,mixed].
    #[arg(long, value_delimiter = ',')]
    fleets: Vec<String>,
    /// Plan the family's episodes online only, not also in whole windows.
    #[arg(long)]
    no_reference: bool,
    /// Policy rate of the family's episodes, Hz [default: 50] (a suite's problems keep their
    /// own dt).
    #[arg(long)]
    hz: Option<f64>,
    /// Episodes of each task per arm count (--family) [default: 10 drawn ones; every recorded
    /// one of aloha-sim, else its first ones by seed].
    #[arg(long)]
    episodes: Option<usize>,
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
    /// Weight of the joints' speed headroom for the hands' motion in the chunks' plans (0:
    /// none).
    #[arg(long, default_value_t = omcbsa::online::HEADROOM_WEIGHT)]
    headroom_weight: f64,
    /// Weight of the joints' reserve for any motion of the hands in the chunks' plans (0:
    /// none).
    #[arg(long, default_value_t = omcbsa::online::RESERVE_WEIGHT)]
    reserve_weight: f64,
    /// Start the arms of a first chunk of at least 1 s where their joints' reserve is
    /// largest, not nearest where they stand (the Embodier's `rank_starts`).
    #[arg(long)]
    rank_starts: bool,
    /// Slow a chunk the arms cannot follow at the policy's rate instead of failing it (the
    /// Embodier's `time_scaling`; off by default here, so that the rows measure the policy's
    /// rate).
    #[arg(long)]
    time_scaling: bool,
    /// omcbsa or pp.
    #[arg(long, default_value_t = PlannerKind::DEFAULT, value_parser = planners::parse)]
    planner: PlannerKind,
}

impl Args {
    /// The arm counts asked for (`--arms`), by default 2, 3, 4 and 6.
    fn arm_counts(&self) -> Vec<usize> {
        match self.arms.as_slice() {
            [] => vec![2, 3, 4, 6],
            a => a.to_vec(),
        }
    }
}

pub fn run(args: &Args) -> ExitCode {
    let (options, chunking) = match read_options(args) {
        Ok(read) => read,
        Err(code) => return code,
    };
    match (&args.suite, args.family.as_deref()) {
        (Some(_), None) if args.hz.is_some() => {
            bad_input("--hz is for --family: a suite's problems keep their own dt")
        }
        (Some(suite), None) => on_suite(args, suite, &options, chunking.stride),
        (None, Some("bimanual")) => {
            let hz = args.hz.unwrap_or(50.0);
            if !(hz.is_finite() && hz > 0.0) {
                return bad_input("--hz must be a positive rate");
            }
            let arms = args.arm_counts();
            if let Some(n) = arms.iter().find(|&&n| !(2..=MAX_ARMS).contains(&n)) {
                return bad_input(format!(
                    "--arms {n}: the bimanual family has 2 to {MAX_ARMS} arms"
                ));
            }
            bimanual(args, &arms, &options, chunking)
        }
        (None, Some(ALOHA)) => aloha_sim(args, &options, chunking),
        (None, Some(other)) => bad_input(format!(
            "--family {other:?}: the families are bimanual and {ALOHA}"
        )),
        (Some(_), Some(_)) => bad_input("give a suite or --family, not both"),
        (None, None) => bad_input(format!(
            "give a suite directory or --family (bimanual or {ALOHA})"
        )),
    }
}

/// The Embodier's options and the chunking the flags ask for, checked (a flag out of range
/// or given without its family is bad input).
fn read_options(args: &Args) -> Result<(OnlineOptions, Chunking), ExitCode> {
    let stride = args.stride.unwrap_or(match args.family {
        Some(_) => args.chunk_len,
        None => 8,
    });
    if args.chunk_len == 0 || stride == 0 || stride > args.chunk_len {
        return Err(bad_input(
            "--chunk-len and --stride must be at least 1, --stride at most --chunk-len",
        ));
    }
    for (flag, w) in [
        ("--axis-weight", args.axis_weight),
        ("--headroom-weight", args.headroom_weight),
        ("--reserve-weight", args.reserve_weight),
    ] {
        if !(w.is_finite() && w >= 0.0) {
            return Err(bad_input(format!(
                "{flag} must be a finite number, 0 or more"
            )));
        }
    }
    if args.chunk_len >= MAX_STEPS {
        return Err(bad_input(format!(
            "--chunk-len must be below {MAX_STEPS} (MAX_STEPS)"
        )));
    }
    let defaults = OnlineOptions::default();
    let options = OnlineOptions {
        planner: args.planner,
        reassign: args.reassign,
        axis_weight: args.axis_weight,
        headroom_weight: args.headroom_weight,
        reserve_weight: args.reserve_weight,
        rank_starts: args.rank_starts,
        time_scaling: args.time_scaling,
        max_chunk_len: defaults.max_chunk_len.max(args.chunk_len),
        ..defaults
    };
    let chunking = Chunking {
        len: args.chunk_len,
        stride,
        lead: args.lead,
    };
    let family_only = [
        ("--dir", args.dir.is_some()),
        ("--layouts", !args.layouts.is_empty()),
        ("--fleets", !args.fleets.is_empty()),
    ];
    if let Some((flag, _)) = (family_only.iter())
        .find(|(_, given)| *given)
        .filter(|_| args.family.as_deref() != Some(ALOHA))
    {
        return Err(bad_input(format!("{flag} is for --family {ALOHA}")));
    }
    Ok((options, chunking))
}

/// The suite's problems planned whole and through the Embodier in chunks of `stride` steps,
/// as a markdown table.
fn on_suite(args: &Args, suite: &Path, options: &OnlineOptions, stride: usize) -> ExitCode {
    let arms = args.arm_counts();
    match bench_online(
        suite,
        &arms,
        args.chunks,
        options,
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

const ALOHA: &str = "aloha-sim";

/// The family's episodes through the Embodier with `chunking`, then in whole windows.
fn bimanual(args: &Args, arms: &[usize], options: &OnlineOptions, chunking: Chunking) -> ExitCode {
    let mut rows = Vec::new();
    for &n in arms {
        let episodes = family(&[n], args.episodes.unwrap_or(10), args.hz.unwrap_or(50.0));
        if let Err(code) = add_rows(&mut rows, episodes.into_iter(), n, args, options, chunking) {
            return code;
        }
    }
    print!("{}", episode_table(&rows));
    ExitCode::SUCCESS
}

/// Runs `episodes` of `n` arms ([`bench_episodes`]), says how many were embodied, and adds
/// the rows (the reference's too, unless `--no-reference`).
fn add_rows(
    rows: &mut Vec<EpisodeRow>,
    episodes: impl Iterator<Item = Episode>,
    n: usize,
    args: &Args,
    options: &OnlineOptions,
    chunking: Chunking,
) -> Result<(), ExitCode> {
    let with_reference = !args.no_reference;
    let (online, reference) =
        bench_episodes(episodes, n, options, chunking, with_reference, &mut |l| {
            note(l)
        })
        .map_err(|e| {
            note(format_args!("error: {e}"));
            negative()
        })?;
    let whole = match with_reference {
        true => format!(", {} in whole windows", reference.embodied),
        false => String::new(),
    };
    note(format_args!(
        "{} arms: {} episodes ({} out of reach), {} embodied online{whole}",
        online.arms, online.episodes, online.out_of_reach, online.embodied
    ));
    rows.push(online);
    rows.extend(with_reference.then_some(reference));
    Ok(())
}

/// The recorded family in every layout, fleet and arm count asked, one table per layout
/// and fleet.
fn aloha_sim(args: &Args, options: &OnlineOptions, chunking: Chunking) -> ExitCode {
    if args.hz.is_some() {
        return bad_input(format!(
            "--hz: the {ALOHA} family keeps the rate it was recorded at"
        ));
    }
    let parse = |names: &[String], all: &[&str]| -> Vec<String> {
        match names {
            [] => all.iter().map(|s| s.to_string()).collect(),
            given => given.to_vec(),
        }
    };
    let layouts: Result<Vec<Layout>, String> = parse(&args.layouts, &["corners", "rows"])
        .iter()
        .map(|l| Layout::parse(l))
        .collect();
    let fleets: Result<Vec<FleetKind>, String> = parse(&args.fleets, &["gen3", "mixed"])
        .iter()
        .map(|f| FleetKind::parse(f))
        .collect();
    let (layouts, fleets) = match (layouts, fleets) {
        (Ok(l), Ok(f)) => (l, f),
        (Err(e), _) => return bad_input(format!("--layouts: {e}")),
        (_, Err(e)) => return bad_input(format!("--fleets: {e}")),
    };
    let arms = args.arm_counts();
    if let Some(n) = arms.iter().find(|&&n| !(2..=MAX_ARMS).contains(&n)) {
        return bad_input(format!(
            "--arms {n}: the {ALOHA} family has 2 to {MAX_ARMS} arms"
        ));
    }
    let dir = args
        .dir
        .clone()
        .unwrap_or_else(|| aloha::DEFAULT_DIR.into());
    let family = match aloha::read_family(&dir) {
        Ok(f) => f,
        Err(e) => return bad_input(e),
    };
    // The first `--episodes` of each task, by seed (the index's order).
    let mut per_task = std::collections::HashMap::new();
    let chosen: Vec<usize> = (0..family.episodes.len())
        .filter(|&i| {
            let seen = per_task.entry(&family.episodes[i].entry.task).or_insert(0);
            *seen += 1;
            args.episodes.is_none_or(|n| *seen <= n)
        })
        .collect();
    for &layout in &layouts {
        for &fleet in &fleets {
            let mut rows = Vec::new();
            for &n in &arms {
                let cell = Cell {
                    layout,
                    fleet,
                    arms: n,
                };
                let episodes = chosen.iter().map(|&i| family.episode(i, &cell));
                note(format_args!("{} {}:", layout.name(), fleet.name()));
                if let Err(code) = add_rows(&mut rows, episodes, n, args, options, chunking) {
                    return code;
                }
            }
            let title = format!(
                "\n{ALOHA}, layout {}, fleet {}:\n",
                layout.name(),
                fleet.name()
            );
            if let Err(code) = print(format_args!("{title}\n{}", episode_table(&rows))) {
                return code;
            }
        }
    }
    ExitCode::SUCCESS
}
