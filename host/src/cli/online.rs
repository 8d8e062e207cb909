//! `omcbsa online`: a policy's chunks streamed to arms (`super::live`), or with `--demo` the
//! scripted box-flip policy against three mock arms: chunks of hand poses emitted as the arms
//! move, each planned as it arrives (from where the arms will be, the assignment kept) and
//! streamed without stopping; then what the mocks received is compared with the planned stream
//! and the whole sent timeline validated.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use omcbsa::online::run::{run_on_mock_arms, RunOutcome, RunScript};
use omcbsa::planners::{self, PlannerKind};
use omcbsa::view::write_html;
use omcbsa_hw::Event;
use omcbsa_mock::mock::ensure_venv;

use super::demo::TransportArg;
use super::live::{self, LiveArgs};
use super::watch::WatchArgs;
use super::{bad_input, negative, note, print};

/// Online embodiment: a policy's chunks of hand poses, each planned as it comes (from where the
/// arms will be, the assignment kept) and streamed to the arms while they move. With --arm
/// NAME=URL for every robot and --hands: real arms or the project's mock arms, the chunks from
/// stdin (JSON lines), a file of them, or a recorded episode. With --demo: a scripted box-flip
/// policy on three mock arms, the sent timeline validated afterwards. Exit code 0 every chunk
/// streamed and the run finished (--demo: and the timeline valid), 1 a fault stopped the arms
/// or a chunk was not executed, 2 bad input (options, setup, a line that is not a chunk: the
/// queued motion is finished first) or arms that cannot be set up, 130 Ctrl-C (every arm
/// stopped)
#[derive(clap::Args)]
pub struct Args {
    /// Run the scripted box-flip demo on three mock arms instead of a policy's chunks.
    #[arg(long)]
    demo: bool,
    #[command(flatten)]
    demo_args: DemoArgs,
    #[command(flatten)]
    live: LiveArgs,
    /// Planner per chunk: omcbsa or pp.
    #[arg(long, default_value_t = PlannerKind::DEFAULT, value_parser = planners::parse)]
    planner: PlannerKind,
    #[command(flatten)]
    watch: WatchArgs,
}

/// The options of `--demo`.
#[derive(clap::Args)]
struct DemoArgs {
    /// --demo: chunks the policy emits (16 poses each, every 8 poses, at dt = 0.1 s).
    #[arg(long, default_value_t = 12, requires = "demo")]
    chunks: usize,
    /// --demo: make this chunk arrive late (after the queue ran dry).
    #[arg(long, requires = "demo")]
    late_chunk: Option<usize>,
    /// --demo: give this chunk a hand pose no arm can reach.
    #[arg(long, requires = "demo")]
    unreachable_chunk: Option<usize>,
    /// --demo: where the mock arms write their records.
    #[arg(long, default_value = "online-out", requires = "demo")]
    out: PathBuf,
    /// --demo: how the mock arms are reached: can (CiA 402 over SLCAN) or kortex (Kinova's
    /// Kortex over TCP and UDP).
    #[arg(long, value_enum, default_value = "can", requires = "demo")]
    transport: TransportArg,
}

pub fn run(args: &Args) -> ExitCode {
    if !args.demo {
        return live::run(&args.live, args.planner, &args.watch);
    }
    online(args).unwrap_or_else(|code| code)
}

fn online(args: &Args) -> Result<ExitCode, ExitCode> {
    let d = &args.demo_args;
    if args.live.given() {
        return Err(bad_input(
            "--demo runs the scripted policy on its own mock arms: it takes no --arm, --hands \
             or --setup",
        ));
    }
    if d.chunks == 0 {
        return Err(bad_input("--chunks: at least 1"));
    }
    std::fs::create_dir_all(&d.out)
        .map_err(|e| bad_input(format!("--out {}: {e}", d.out.display())))?;
    let python = ensure_venv().map_err(|e| bad_input(format!("mock arms: {e}")))?;
    let mut script = RunScript {
        watch: args.watch.settings().map_err(bad_input)?,
        chunks: d.chunks,
        late_chunk: d.late_chunk,
        unreachable_chunk: d.unreachable_chunk,
        transport: d.transport.into(),
        ..RunScript::default()
    };
    script.options.planner = args.planner;
    print(format_args!(
        "online: box flip policy, {} chunks of {} poses every {} poses, 3 mock arms",
        script.chunks, script.policy.chunk_len, script.policy.stride
    ))?;
    print(&script.watch)?;
    // Progress lines are best effort: a closed stdout must not stop the arms mid-run.
    let outcome = run_on_mock_arms(&script, &python, &d.out, &mut |l| {
        let _ = print(l);
    })
    .map_err(|e| {
        note(format!("error: {e}"));
        negative()
    })?;
    for e in &outcome.events {
        match e {
            Event::QueueDry { step, .. } => {
                print(format_args!("queue ran dry: the arms held at step {step}"))?
            }
            Event::Resumed { step, .. } => print(format_args!("resumed from step {step}"))?,
        }
    }
    let mut ms: Vec<f64> = outcome.latencies.iter().map(|s| s * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    if let (Some(median), Some(max)) = (ms.get(ms.len() / 2), ms.last()) {
        print(format_args!(
            "{} chunks planned ({} not), latency median {median:.1} ms, max {max:.1} ms; {}",
            ms.len(),
            outcome.chunk_errors.len(),
            outcome.exec
        ))?;
    }
    print(format_args!(
        "every mock received the planned stream (to 1e-6 rad, within limits): {:?} cycles",
        outcome.cycles
    ))?;
    print(format_args!(
        "sent timeline: {}",
        outcome.validation.summary()
    ))?;
    write_run(&d.out, &outcome)?;
    Ok(
        if outcome.validation.is_valid() && outcome.chunk_errors.is_empty() {
            ExitCode::SUCCESS
        } else {
            negative()
        },
    )
}

/// The sent timeline as problem.json and solution.json, and its page (plan.html), in `out`.
fn write_run(out: &Path, outcome: &RunOutcome) -> Result<(), ExitCode> {
    for (name, text) in [
        (
            "problem.json",
            serde_json::to_string_pretty(&outcome.problem),
        ),
        (
            "solution.json",
            serde_json::to_string_pretty(&outcome.solution),
        ),
    ] {
        let path = out.join(name);
        let text = text.map_err(|e| bad_input(format!("cannot encode {}: {e}", path.display())))?;
        std::fs::write(&path, text)
            .map_err(|e| bad_input(format!("cannot write {}: {e}", path.display())))?;
    }
    let page = out.join("plan.html");
    write_html(
        &outcome.problem,
        Some(&outcome.solution),
        Some(&outcome.validation),
        &page,
    )
    .map_err(bad_input)?;
    print(format_args!(
        "wrote {} (open it in a browser to see the run)",
        page.display()
    ))
}
