//! `omcbsa execute`: streams a solution's joint paths to the arms over CAN.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Duration;

use omcbsa::error::InputError;
use omcbsa::execute::CheckedSolution;
use omcbsa::load;
use omcbsa_hw::executor::Progress;
use omcbsa_hw::transport::{self, ArmBuses, BusSpec};
use omcbsa_hw::{ExecConfig, ExecError, Executor, Plan, PlanValidator, Report};

use super::{bad_input, negative, note, print};

/// Streams a solution to the arms, one CAN bus per arm, at the control rate: refuses to start
/// unless the solution validates against the problem. Exit code 0 done, 1 stopped by a fault
/// (every arm quick-stopped; the report says why), 2 bad input, a bus that cannot be opened or
/// an arm that does not answer at start-up (nothing moved).
#[derive(clap::Args)]
pub struct Args {
    /// Problem file (omcbsa.problem.v1).
    problem: PathBuf,
    /// Solution file (omcbsa.solution.v1).
    solution: PathBuf,
    /// The bus of the problem's robot NAME: slcan:/dev/ttyACM0 (serial-line CAN adapter) or
    /// socketcan:can0. Once per arm; every robot that moves needs one.
    #[arg(long = "arm", value_name = "NAME=BUS", value_parser = parse_arm)]
    arms: Vec<(String, String)>,
    /// Interpolate and check every command, send nothing (the buses are not opened).
    #[arg(long)]
    dry_run: bool,
    /// Write every command sent (or, in a dry run, that would be sent) here, as JSON lines.
    #[arg(long, value_name = "FILE")]
    log: Option<PathBuf>,
    /// Control rate, Hz, within [100, 1000].
    #[arg(long, value_name = "HZ", default_value_t = 500.0)]
    rate: f64,
    /// SCHED_FIFO priority (1 to 99) of the streaming threads, or `off` for normal scheduling.
    /// Refused by the system (no CAP_SYS_NICE), the run goes on at normal priority and says so.
    #[arg(long, value_name = "PRIO|off", default_value = "50", value_parser = parse_priority)]
    rt_priority: RtPriority,
}

/// `--rt-priority`: a `SCHED_FIFO` priority, or none.
#[derive(Clone, Copy, Debug)]
struct RtPriority(Option<u8>);

fn parse_priority(s: &str) -> Result<RtPriority, String> {
    if s == "off" {
        return Ok(RtPriority(None));
    }
    match s.parse::<u8>() {
        Ok(p) if (1..=99).contains(&p) => Ok(RtPriority(Some(p))),
        _ => Err(format!(
            "expected a priority from 1 to 99 or `off`, got {s:?}"
        )),
    }
}

/// The control rates `--rate` accepts, Hz. At most 1 kHz: the Gen3's own control rate, and
/// about what a 1 Mbit/s bus carries with 8 frames per arm and cycle. At least 100 Hz: cyclic
/// synchronous position needs cycles of a few ms, and each drive's feedback (one TPDO per
/// SYNC) must be fresher than the feedback timeout (50 ms).
pub const RATE_RANGE: std::ops::RangeInclusive<f64> = 100.0..=1000.0;

fn parse_arm(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        // The bus is checked here, so that a dry run accepts only buses a live run could open.
        Some((name, bus)) if !name.is_empty() && !bus.is_empty() => match BusSpec::parse(bus) {
            Ok(_) => Ok((name.to_string(), bus.to_string())),
            Err(e) => Err(e.to_string()),
        },
        _ => Err(format!(
            "expected NAME=BUS (e.g. left=slcan:/dev/ttyACM0), got {s:?}"
        )),
    }
}

pub fn run(args: &Args) -> ExitCode {
    if !RATE_RANGE.contains(&args.rate) {
        return bad_input(format!(
            "--rate: must be within [{}, {}] Hz, got {}",
            RATE_RANGE.start(),
            RATE_RANGE.end(),
            args.rate
        ));
    }
    let (checked, plan) = match load_plan(args) {
        Ok(loaded) => loaded,
        Err(e) => return bad_input(e),
    };
    let mut buses = Vec::new();
    if !args.dry_run {
        for (name, bus) in &args.arms {
            match transport::open(bus) {
                Ok(b) => buses.push((name.clone(), b)),
                Err(e) => return bad_input(format!("arm {name:?}: {e}")),
            }
        }
    }
    let config = ExecConfig {
        period: Duration::from_secs_f64(1.0 / args.rate),
        dry_run: args.dry_run,
        log_path: args.log.clone(),
        realtime_priority: args.rt_priority.0,
        ..ExecConfig::default()
    };
    match stream(plan, buses, config, &checked) {
        Ok(_) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}

/// Reads both files, validates the solution, and builds the plan for the `--arm` names.
fn load_plan(args: &Args) -> Result<(CheckedSolution, Plan), String> {
    fn read<T>(path: &Path, parse: fn(&str) -> Result<T, InputError>) -> Result<T, String> {
        load::read_text(path)
            .and_then(|t| parse(&t))
            .map_err(|e| format!("{}: {e}", path.display()))
    }
    let problem = read(&args.problem, load::parse_problem)?;
    let solution = read(&args.solution, load::parse_solution)?;
    let checked = CheckedSolution::new(problem, solution)
        .map_err(|e| format!("{}: {e}", args.problem.display()))?;
    let names: Vec<&str> = args.arms.iter().map(|(n, _)| n.as_str()).collect();
    let plan = checked.plan(&names).map_err(|e| format!("--arm: {e}"))?;
    // The executor checks again before it sends anything; checking here too means a solution
    // that cannot run never opens a bus.
    checked
        .validate(&plan)
        .map_err(|e| ExecError::Refused(e).to_string())?;
    Ok((checked, plan))
}

/// Runs the executor with progress output and prints its report; on failure, prints why and
/// returns the exit code ([`failure`]).
fn stream(
    plan: Plan,
    buses: ArmBuses,
    config: ExecConfig,
    checked: &CheckedSolution,
) -> Result<Report, ExitCode> {
    let names = plan.arms.iter().map(|a| a.name.clone()).collect();
    let limits = checked.joint_limits().map_err(bad_input)?;
    let report = Executor::new(plan, limits, buses, config)
        .and_then(|e| e.on_progress(progress_printer(names)).run(checked))
        .map_err(failure)?;
    print(&report)?;
    Ok(report)
}

/// Prints why the executor failed; exit code 1 for a fault stop, 2 for a refusal before any
/// motion (bad plan, start-up failure).
pub fn failure(e: ExecError) -> ExitCode {
    match e {
        ExecError::Fault(report) => {
            note(format_args!("error: stopped by a fault\n{report}"));
            negative()
        }
        e => bad_input(e),
    }
}

/// Prints a line each time every arm has streamed another tenth of the run.
pub fn progress_printer(names: Vec<String>) -> impl Fn(Progress) + Send + Sync {
    let state = Mutex::new((vec![0usize; names.len()], 0usize));
    move |p: Progress| {
        let mut state = state.lock().unwrap_or_else(|e| e.into_inner());
        let (cycles, printed) = &mut *state;
        if let Some(i) = names.iter().position(|n| n == p.arm) {
            cycles[i] = p.cycle;
        }
        let done = cycles.iter().copied().min().unwrap_or(0);
        let tenth = done * 10 / p.cycles.max(1);
        if tenth > *printed {
            *printed = tenth;
            note(format_args!(
                "streaming: {:3}% ({done}/{} cycles on every arm)",
                tenth * 10,
                p.cycles
            ));
        }
    }
}
