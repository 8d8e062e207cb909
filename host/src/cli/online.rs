//! `omcbsa online`: the scripted box-flip policy against three mock arms: chunks of hand poses
//! emitted as the arms move, each planned as it arrives (from where the arms will be, the
//! assignment kept) and streamed without stopping; then what the mocks received is compared
//! with the planned stream and the whole sent timeline validated.

use std::path::PathBuf;
use std::process::ExitCode;

use omcbsa::online::run::{run_on_mock_arms, RunScript};
use omcbsa_hw::mock::ensure_venv;
use omcbsa_hw::Event;

use super::{bad_input, negative};

#[derive(clap::Args)]
pub struct Args {
    /// Chunks the policy emits (16 poses each, every 8 poses, at dt = 0.1 s).
    #[arg(long, default_value_t = 12)]
    chunks: usize,
    /// Planner per chunk: omcbsa or pp.
    #[arg(long, default_value = "omcbsa")]
    planner: String,
    /// Make this chunk arrive late (after the queue ran dry).
    #[arg(long)]
    late_chunk: Option<usize>,
    /// Give this chunk a hand pose no arm can reach.
    #[arg(long)]
    unreachable_chunk: Option<usize>,
    /// Where the mock arms write their records.
    #[arg(long, default_value = "online-out")]
    out: PathBuf,
}

pub fn run(args: &Args) -> ExitCode {
    if args.chunks == 0 {
        return bad_input("--chunks: at least 1");
    }
    if let Err(e) = std::fs::create_dir_all(&args.out) {
        return bad_input(format!("--out {}: {e}", args.out.display()));
    }
    let python = match ensure_venv() {
        Ok(p) => p,
        Err(e) => return bad_input(format!("mock arms: {e}")),
    };
    let mut script = RunScript {
        chunks: args.chunks,
        late_chunk: args.late_chunk,
        unreachable_chunk: args.unreachable_chunk,
        ..RunScript::default()
    };
    script.options.planner = args.planner.clone();
    println!(
        "online: box flip policy, {} chunks of {} poses every {} poses, 3 mock arms",
        script.chunks, script.policy.chunk_len, script.policy.stride
    );
    let outcome = match run_on_mock_arms(&script, &python, &args.out, &mut |l| println!("{l}")) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return negative();
        }
    };
    for e in &outcome.events {
        match e {
            Event::QueueDry { step, .. } => {
                println!("queue ran dry: the arms held at step {step}")
            }
            Event::Resumed { step, .. } => println!("resumed from step {step}"),
        }
    }
    let mut ms: Vec<f64> = outcome.latencies.iter().map(|s| s * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    println!(
        "{} chunks planned ({} not), latency median {:.1} ms, max {:.1} ms; {}",
        ms.len(),
        outcome.chunk_errors.len(),
        ms[ms.len() / 2],
        ms[ms.len() - 1],
        outcome.exec
    );
    println!(
        "every mock received the planned stream (to 1e-6 rad, within limits): {:?} cycles",
        outcome.cycles
    );
    println!("sent timeline: {}", outcome.validation.summary());
    if outcome.validation.is_valid() && outcome.chunk_errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        negative()
    }
}
