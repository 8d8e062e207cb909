//! `omcbsa online --arm NAME=URL ... --hands -|FILE`: a policy's hand chunks, each planned as
//! it comes (from where the arms will be) and streamed to the arms while they move: JSON lines
//! from stdin (a policy in any language pipes into it), a file of them replayed at the
//! policy's rate, or a recorded aloha-sim episode cut into chunks.

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use omcbsa::format::Pose;
use omcbsa::live::lines::{parse_line, ChunkLine};
use omcbsa::live::{LiveCell, LiveError, LiveOptions, LivePush, LiveStatus};
use omcbsa::load;
use omcbsa::online::aloha::{self, FleetKind, Layout};
use omcbsa::online::{Embodier, OnlineError, OnlineOptions, Setup};
use omcbsa::planners::PlannerKind;
use omcbsa_hw::port::ArmUrl;
use omcbsa_hw::{Event, ExecConfig};
use omcbsa_mock::connect::ArmOrMockUrl;

use super::execute::{parse_priority, KortexArgs, RtPriority, RATE_RANGE};
use super::watch::WatchArgs;
use super::{bad_input, negative, note, positive_seconds, print};

/// The longest line read from `--hands`: a chunk of 64 poses for 6 hands is about 40 kB.
const MAX_LINE_BYTES: u64 = 1 << 20;

/// How often the arms are watched (faults, events, Ctrl-C) while waiting.
const POLL: Duration = Duration::from_millis(5);

/// Set by SIGINT or SIGTERM.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// The options of a run on arms (without `--demo`).
#[derive(clap::Args)]
pub struct LiveArgs {
    /// How the setup's robot NAME is reached: kortex://HOST (a Gen3), socketcan://IFACE or
    /// slcan:///dev/ttyX (CiA 402 drives), or mock-kortex / mock-can (the project's mock arms,
    /// started for the run; flags as a query, mock-can?emcy-at-sync=60). Once per robot.
    #[arg(long = "arm", value_name = "NAME=URL", value_parser = parse_arm)]
    arms: Vec<(String, ArmOrMockUrl)>,
    /// The policy's hand chunks: `-` reads JSON lines from stdin and plans each as it comes
    /// ({"start_step": S, "hands": [[{"position": [x,y,z], "quat_xyzw": [x,y,z,w]}, ...],
    /// ...]}); a .jsonl file of such lines is replayed at the policy's rate as the arms keep
    /// it (each line at its start_step times dt times the time scale); a recorded aloha-sim
    /// episode (.json.gz beside its index.json) is cut into chunks of --chunk-len poses every
    /// --stride poses, replayed likewise.
    #[arg(long, value_name = "-|FILE")]
    hands: Option<String>,
    /// The robots (each with its initial configuration, where its arm stands), obstacles,
    /// tolerance and dt, as a problem file whose trajectories are not used. For an aloha-sim
    /// episode, by default the family's cell: one Gen3 per --arm, placed by --layout.
    #[arg(long, value_name = "FILE")]
    setup: Option<PathBuf>,
    /// Where an aloha-sim episode's arms stand: corners or rows.
    #[arg(long, default_value = "corners")]
    layout: String,
    /// An aloha-sim episode's chunks: poses per chunk.
    #[arg(long, default_value_t = 16)]
    chunk_len: usize,
    /// An aloha-sim episode's chunks: poses between chunk starts (less than --chunk-len: each
    /// chunk replaces the tail of the one before).
    #[arg(long, default_value_t = 8)]
    stride: usize,
    /// An aloha-sim episode's first N steps only.
    #[arg(long, value_name = "N")]
    steps: Option<usize>,
    /// A replayed chunk (file or episode) is pushed this many policy steps before its first
    /// step is due, as a policy that infers ahead would send it (the cell keeps the next steps
    /// after the one being streamed, at least two, out of a new plan's reach: a chunk pushed
    /// later has its first poses dropped as late).
    #[arg(long, value_name = "STEPS", default_value_t = 4)]
    lead: u64,
    /// Planning time per chunk, seconds.
    #[arg(long, default_value = "1", value_parser = positive_seconds)]
    chunk_timeout: f64,
    /// Uniform slow-down of the arms against the policy's rate (at least 1) [default: the
    /// models' joint speed limits over the executor's].
    #[arg(long, value_name = "X")]
    time_scale: Option<f64>,
    /// Control rate, Hz, within [100, 1000] [default: the arms' slowest: Kortex 1000, SocketCAN 250, SLCAN 200,
    /// the mocks 100].
    #[arg(long, value_name = "HZ")]
    rate: Option<f64>,
    /// Longest wait for one answer at start-up (an SDO, a Kortex rpc), ms.
    #[arg(long, value_name = "MS", default_value_t = ExecConfig::default().sdo_timeout.as_millis() as u64)]
    sdo_timeout_ms: u64,
    /// Where mock arms write their records (NAME.jsonl; a CAN mock's bus log NAME.log)
    /// [default: a new directory under the system's temporary directory].
    #[arg(long, value_name = "DIR")]
    records: Option<PathBuf>,
    /// SCHED_FIFO priority (1 to 99) of the streaming threads, or `off` for normal scheduling.
    #[arg(long, value_name = "PRIO|off", default_value = "50", value_parser = parse_priority)]
    rt_priority: RtPriority,
    #[command(flatten)]
    kortex: KortexArgs,
}

impl LiveArgs {
    /// Any option of a run on arms was given.
    pub fn given(&self) -> bool {
        !self.arms.is_empty() || self.hands.is_some() || self.setup.is_some()
    }
}

fn parse_arm(s: &str) -> Result<(String, ArmOrMockUrl), String> {
    match s.split_once('=') {
        Some((name, url)) if !name.is_empty() && !url.is_empty() => {
            Ok((name.to_string(), ArmOrMockUrl::parse(url)?))
        }
        _ => Err(format!(
            "expected NAME=URL (e.g. left=kortex://192.168.1.10 or right=mock-can), got {s:?}"
        )),
    }
}

/// Where the chunks come from.
enum Source {
    /// Lines from stdin, read by a thread of their own (so that the arms are watched while
    /// waiting): (line number, the line or why it could not be read).
    Stdin(Receiver<(usize, Result<String, String>)>),
    /// A file of lines, replayed at the policy's rate as the arms keep it.
    Lines(BufReader<std::fs::File>, usize),
    /// An episode's chunks, replayed likewise.
    Episode(std::vec::IntoIter<ChunkLine>),
}

/// A chunk read and the line it came from (0 for an episode's), or why the line is not one.
type NumberedChunk = (usize, Result<ChunkLine, String>);

/// Why the run stops early.
enum Stop {
    Fault(String),
    Interrupted,
    Ended(String),
}

/// One line of at most [`MAX_LINE_BYTES`] (without its newline); `None` at the end.
fn read_line(input: &mut impl BufRead) -> Result<Option<String>, String> {
    let mut buf = Vec::new();
    let n = (input.take(MAX_LINE_BYTES + 1))
        .read_until(b'\n', &mut buf)
        .map_err(|e| format!("cannot read: {e}"))?;
    if n == 0 {
        return Ok(None);
    }
    if buf.last() == Some(&b'\n') {
        buf.pop();
    } else if n as u64 > MAX_LINE_BYTES {
        return Err(format!("longer than {MAX_LINE_BYTES} bytes"));
    }
    String::from_utf8(buf)
        .map(Some)
        .map_err(|_| "not UTF-8 text".to_string())
}

impl Source {
    /// Paced by the chunks' steps (a file), or taken as they come (stdin).
    fn paced(&self) -> bool {
        !matches!(self, Source::Stdin(_))
    }

    /// The next chunk and its line number (0 for an episode's), waiting for stdin with
    /// `watch` called meanwhile; `Ok(None)` at the end.
    fn next(
        &mut self,
        watch: &mut dyn FnMut() -> Result<(), Stop>,
    ) -> Result<Option<NumberedChunk>, Stop> {
        let parsed = |n: usize, line: Result<String, String>| {
            Some((
                n,
                line.and_then(|l| parse_line(&l).map_err(|e| e.to_string())),
            ))
        };
        match self {
            Source::Stdin(lines) => loop {
                watch()?;
                match lines.recv_timeout(POLL) {
                    Ok((n, line)) => return Ok(parsed(n, line)),
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => return Ok(None),
                }
            },
            Source::Lines(reader, n) => {
                *n += 1;
                Ok(match read_line(reader).transpose() {
                    Some(line) => parsed(*n, line),
                    None => None,
                })
            }
            Source::Episode(chunks) => Ok(chunks.next().map(|c| (0, Ok(c)))),
        }
    }
}

/// Stdin's lines, read by a thread, one at a time (memory stays one line).
fn stdin_lines() -> Receiver<(usize, Result<String, String>)> {
    let (tx, rx) = mpsc::sync_channel(1);
    std::thread::spawn(move || {
        let mut input = std::io::stdin().lock();
        for n in 1.. {
            match read_line(&mut input) {
                Ok(None) => break,
                Ok(Some(line)) if line.trim().is_empty() => continue,
                Ok(Some(line)) => {
                    if tx.send((n, Ok(line))).is_err() {
                        break;
                    }
                }
                Err(why) => {
                    let _ = tx.send((n, Err(why)));
                    break;
                }
            }
        }
    });
    rx
}

/// An episode's poses as chunks of `len` poses every `stride` poses.
fn episode_chunks(hands: &[Vec<Pose>], len: usize, stride: usize) -> Vec<ChunkLine> {
    let steps = hands.first().map_or(0, Vec::len);
    (0..steps)
        .step_by(stride)
        .map(|s| ChunkLine {
            start_step: s as u64,
            hands: hands
                .iter()
                .map(|h| h[s..steps.min(s + len)].to_vec())
                .collect(),
        })
        .collect()
}

/// The chunks' source and the setup (from `--setup`, or an episode's own).
fn source(args: &LiveArgs) -> Result<(Source, Setup), String> {
    let hands = (args.hands.as_deref())
        .ok_or("--hands: give - (JSON lines from stdin) or a file of chunks or an episode")?;
    let setup_file = || -> Result<Setup, String> {
        let path = (args.setup.as_ref())
            .ok_or("--setup: the robots, where they stand and dt are needed (a problem file)")?;
        let text = load::read_text(path).map_err(|e| super::in_file(path, e))?;
        let file = load::parse_problem(&text).map_err(|e| super::in_file(path, e))?;
        Ok(Setup::of_problem(&file))
    };
    if hands == "-" {
        return Ok((Source::Stdin(stdin_lines()), setup_file()?));
    }
    let path = Path::new(hands);
    if hands.ends_with(".jsonl") {
        let file = std::fs::File::open(path)
            .map_err(|e| format!("--hands {}: cannot read: {e}", path.display()))?;
        return Ok((Source::Lines(BufReader::new(file), 0), setup_file()?));
    }
    if !(hands.ends_with(".json") || hands.ends_with(".json.gz")) {
        return Err(format!(
            "--hands {hands}: expected -, a .jsonl file of chunks, or an aloha-sim episode \
             (.json.gz)"
        ));
    }
    if args.chunk_len == 0 || args.stride == 0 {
        return Err("--chunk-len and --stride: at least 1 pose".to_string());
    }
    let family = aloha::read_episode(path)?;
    let cell = aloha::Cell {
        layout: Layout::parse(&args.layout).map_err(|e| format!("--layout: {e}"))?,
        fleet: FleetKind::Gen3,
        arms: args.arms.len(),
    };
    if !(1..=omcbsa::online::bimanual::MAX_ARMS).contains(&cell.arms) {
        return Err(format!(
            "an aloha-sim episode's cell has 1 to {} arms: give an --arm for each",
            omcbsa::online::bimanual::MAX_ARMS
        ));
    }
    let mut episode = family.episode(0, &cell);
    if let Some(n) = args.steps {
        if n == 0 {
            return Err("--steps: at least 1".to_string());
        }
        episode.hands.iter_mut().for_each(|h| h.truncate(n));
    }
    let setup = match &args.setup {
        Some(_) => setup_file()?,
        None => episode.setup,
    };
    let chunks = episode_chunks(&episode.hands, args.chunk_len, args.stride);
    Ok((Source::Episode(chunks.into_iter()), setup))
}

pub fn run(args: &LiveArgs, planner: PlannerKind, watch: &WatchArgs) -> ExitCode {
    live(args, planner, watch).unwrap_or_else(|code| code)
}

fn live(args: &LiveArgs, planner: PlannerKind, watch: &WatchArgs) -> Result<ExitCode, ExitCode> {
    if args.arms.is_empty() {
        return Err(bad_input(
            "--arm NAME=URL: every robot needs an arm (or --demo for the scripted demo on mock \
             arms)",
        ));
    }
    if let Some(rate) = args.rate.filter(|r| !RATE_RANGE.contains(r)) {
        return Err(bad_input(format!(
            "--rate: must be within [{}, {}] Hz, got {rate}",
            RATE_RANGE.start(),
            RATE_RANGE.end()
        )));
    }
    let watch = watch.settings().map_err(bad_input)?;
    let (mut source, setup) = source(args).map_err(bad_input)?;
    let options = OnlineOptions {
        planner,
        chunk_timeout_s: args.chunk_timeout,
        ..OnlineOptions::default()
    };
    let mut embodier =
        Embodier::new(&setup, options).map_err(|e| bad_input(format!("--setup: {e}")))?;
    let kortex = (args.arms.iter()).any(|(_, u)| matches!(u, ArmOrMockUrl::Arm(ArmUrl::Kortex(_))));
    let credentials = args.kortex.credentials(kortex).map_err(bad_input)?;
    let options = LiveOptions {
        time_scale: args.time_scale,
        period: args.rate.map(|r| Duration::from_secs_f64(1.0 / r)),
        config: ExecConfig {
            watch: watch.clone(),
            sdo_timeout: Duration::from_millis(args.sdo_timeout_ms),
            realtime_priority: args.rt_priority.0,
            ..ExecConfig::default()
        },
        credentials: kortex.then_some(credentials),
        records: args.records.clone(),
    };
    // Ctrl-C and SIGTERM stop the arms (the process would otherwise end with them moving).
    ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst))
        .map_err(|e| bad_input(format!("cannot handle Ctrl-C: {e}")))?;
    let mut cell = LiveCell::start(&embodier, &args.arms, options).map_err(|e| match e {
        LiveError::Fault(r) => {
            note(format_args!("error: stopped by a fault\n{r}"));
            negative()
        }
        e => bad_input(e),
    })?;
    let _ = print(format_args!(
        "online: {} arms ({}), control period {:?}, the arms {:.2}x slower than the policy \
         (dt {} s); mock records in {}",
        cell.names().len(),
        (args.arms.iter())
            .map(|(n, u)| format!("{n}={u}"))
            .collect::<Vec<_>>()
            .join(", "),
        cell.period(),
        cell.time_scale(),
        setup.dt,
        cell.records().display()
    ));
    let _ = print(&watch);
    // A replay keeps the policy's rate as the arms do: a step lasts dt times the time scale,
    // so that the queue stays a chunk or two ahead of the arms (a policy that observes the arms
    // runs at their pace), not the whole episode.
    let step_time = setup.dt * cell.time_scale();
    match stream(
        &mut cell,
        &mut embodier,
        &mut source,
        Pace {
            step_time,
            lead: args.lead,
        },
    ) {
        Ok(outcome) => finish(cell, outcome),
        Err(stop) => Err(stopped(cell, stop)),
    }
}

/// How the chunks went.
#[derive(Default)]
struct Outcome {
    pushed: usize,
    /// Chunks not executed (not planned, refused), with why.
    failed: usize,
    /// A line that is not a chunk: the run ends there (exit 2).
    bad_line: Option<String>,
}

/// When a replayed chunk is pushed: `lead` policy steps before its first step is due, a step
/// lasting `step_time` seconds.
#[derive(Clone, Copy)]
struct Pace {
    step_time: f64,
    lead: u64,
}

/// Plans and pushes every chunk of `source`; a file's at `pace`.
fn stream(
    cell: &mut LiveCell,
    embodier: &mut Embodier,
    source: &mut Source,
    pace: Pace,
) -> Result<Outcome, Stop> {
    let mut outcome = Outcome::default();
    let paced = source.paced();
    let mut clock: Option<(Instant, u64)> = None;
    while let Some((n, chunk)) = source.next(&mut || watch_arms(cell).map(drop))? {
        let at = match n {
            0 => "chunk".to_string(),
            n => format!("line {n}"),
        };
        let chunk = match chunk {
            Ok(c) => c,
            Err(why) => {
                outcome.bad_line = Some(format!("{at}: {why}"));
                break;
            }
        };
        if paced {
            let (t0, s0) = *clock.get_or_insert((Instant::now(), chunk.start_step));
            let steps = chunk
                .start_step
                .saturating_sub(s0)
                .saturating_sub(pace.lead);
            let due = t0 + Duration::from_secs_f64(steps as f64 * pace.step_time);
            while Instant::now() < due {
                watch_arms(cell)?;
                std::thread::sleep(POLL.min(due.saturating_duration_since(Instant::now())));
            }
        }
        match cell.push(embodier, chunk.start_step, &chunk.hands) {
            Ok(p) => {
                outcome.pushed += 1;
                let _ = print(pushed_line(&at, &chunk, &p));
            }
            Err(LiveError::Chunk(OnlineError::Input(e))) => {
                let lines: Vec<String> = e.errors.iter().map(|f| format!("{at}: {f}")).collect();
                outcome.bad_line = Some(lines.join("\n"));
                break;
            }
            Err(LiveError::Fault(r)) => return Err(Stop::Fault(r.to_string())),
            Err(LiveError::Ended(why)) => return Err(Stop::Ended(why)),
            Err(e) => {
                outcome.failed += 1;
                note(format_args!(
                    "{at} (steps from {}): not executed: {e}",
                    chunk.start_step
                ));
            }
        }
    }
    Ok(outcome)
}

fn pushed_line(at: &str, chunk: &ChunkLine, p: &LivePush) -> String {
    let r = &p.report;
    let recovery = r
        .recovery
        .map_or(String::new(), |w| format!(", {}", w.name()));
    let late = match p.late {
        0 => String::new(),
        n => format!(", its first {n} poses late (passed)"),
    };
    format!(
        "{at} (steps {}..{}): planned in {:.1} ms{recovery}{late}, streamed from waypoint {} \
         (cycle {}); the arms {:.2} s behind the policy",
        chunk.start_step,
        chunk.start_step + chunk.hands.first().map_or(0, Vec::len) as u64,
        1e3 * r.planning_time_s,
        p.from,
        p.cycle,
        r.total_lag_s
    )
}

/// Ctrl-C, a fault, the events since the last call (printed); the cell's status.
fn watch_arms(cell: &mut LiveCell) -> Result<LiveStatus, Stop> {
    if INTERRUPTED.load(Ordering::SeqCst) {
        return Err(Stop::Interrupted);
    }
    match cell.status() {
        Ok(s) => {
            for e in &s.cell.events {
                let _ = print(match e {
                    Event::QueueDry { step, .. } => {
                        format!("the queue ran dry: the arms hold at waypoint {step}")
                    }
                    Event::Resumed { step, .. } => format!("moving on from waypoint {step}"),
                });
            }
            Ok(s)
        }
        Err(LiveError::Fault(r)) => Err(Stop::Fault(r.to_string())),
        Err(e) => Err(Stop::Ended(e.to_string())),
    }
}

/// Lets the queue run out (the arms watched meanwhile) and ends the run: 0 every chunk
/// executed, 1 some not, 2 a bad line.
fn finish(mut cell: LiveCell, outcome: Outcome) -> Result<ExitCode, ExitCode> {
    loop {
        match watch_arms(&mut cell) {
            Err(stop) => return Err(stopped(cell, stop)),
            Ok(s) if s.cell.progress.holding => break,
            Ok(_) => std::thread::sleep(POLL),
        }
    }
    let end = cell.finish().map_err(|e| match e {
        LiveError::Fault(r) => {
            note(format_args!("error: stopped by a fault\n{r}"));
            negative()
        }
        e => {
            note(format_args!("error: {e}"));
            negative()
        }
    })?;
    let _ = print(format_args!(
        "done: {} chunks streamed, {} not; {}",
        outcome.pushed, outcome.failed, end.report
    ));
    if let Some(why) = outcome.bad_line {
        return Err(bad_input(why));
    }
    Ok(if outcome.failed == 0 {
        ExitCode::SUCCESS
    } else {
        negative()
    })
}

/// Ends a run stopped early: every arm stopped; the exit code (1 a fault, 130 Ctrl-C).
fn stopped(cell: LiveCell, stop: Stop) -> ExitCode {
    match stop {
        Stop::Fault(report) => {
            drop(cell);
            note(format_args!("error: stopped by a fault\n{report}"));
            negative()
        }
        Stop::Ended(why) => {
            drop(cell);
            note(format_args!("error: {why}"));
            negative()
        }
        Stop::Interrupted => {
            let how = match cell.stop() {
                Ok(end) => end.report.to_string(),
                Err(e) => e.to_string(),
            };
            note(format_args!("interrupted: every arm stopped; {how}"));
            ExitCode::from(130)
        }
    }
}
