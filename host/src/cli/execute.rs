//! `omcbsa execute`: streams a solution's joint paths to the arms, over CAN or Kortex.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Duration;

use omcbsa::error::InputError;
use omcbsa::execute::CheckedSolution;
use omcbsa::load;
use omcbsa_hw::kortex::Credentials;
use omcbsa_hw::port::{self, ArmPorts};
use omcbsa_hw::Progress;
use omcbsa_hw::{ExecConfig, ExecError, Executor, Plan, PlanValidator, Report};

use super::watch::WatchArgs;
use super::{bad_input, negative, note, print};

/// Streams a solution to the arms, one CAN bus or Kortex connection per arm, at the control
/// rate: refuses to start unless the solution validates against the problem. Exit code 0 done,
/// 1 stopped by a fault (every arm quick-stopped; the report says why), 2 bad input, a bus that
/// cannot be opened or an arm that does not answer at start-up (nothing moved).
#[derive(clap::Args)]
pub struct Args {
    /// Problem file (omcbsa.problem.v1).
    problem: PathBuf,
    /// Solution file (omcbsa.solution.v1).
    solution: PathBuf,
    /// How the problem's robot NAME is reached: slcan:/dev/ttyACM0 (serial-line CAN adapter),
    /// socketcan:can0, or kortex:HOST (a Kinova Gen3 on Ethernet, TCP 10000 and UDP 10001;
    /// kortex:HOST:TCP_PORT:UDP_PORT for other ports). Once per arm; every robot that moves
    /// needs one.
    #[arg(long = "arm", value_name = "NAME=SPEC", value_parser = parse_arm)]
    arms: Vec<(String, String)>,
    #[command(flatten)]
    kortex: KortexArgs,
    /// Interpolate and check every command, send nothing (the buses are not opened).
    #[arg(long)]
    dry_run: bool,
    /// Write every command sent (or, in a dry run, that would be sent) here, as JSON lines.
    #[arg(long, value_name = "FILE")]
    log: Option<PathBuf>,
    /// Control rate, Hz, within [100, 1000]; by default 1000 (the Gen3's own rate) when an arm
    /// is on Kortex, else 500.
    #[arg(long, value_name = "HZ")]
    rate: Option<f64>,
    /// SCHED_FIFO priority (1 to 99) of the streaming threads, or `off` for normal scheduling.
    /// Refused by the system (no CAP_SYS_NICE), the run goes on at normal priority and says so.
    #[arg(long, value_name = "PRIO|off", default_value = "50", value_parser = parse_priority)]
    rt_priority: RtPriority,
    #[command(flatten)]
    watch: WatchArgs,
}

/// Who Kortex arms are reached as, for the commands that drive arms.
#[derive(clap::Args)]
pub struct KortexArgs {
    /// Kortex user name (else the environment's OMCBSA_KORTEX_USER).
    #[arg(long, value_name = "USER")]
    kortex_user: Option<String>,
    /// A file whose first line is the Kortex password (else the environment's
    /// OMCBSA_KORTEX_PASSWORD). Never printed or logged.
    #[arg(long, value_name = "FILE")]
    kortex_password_file: Option<PathBuf>,
}

/// `--rt-priority`: a `SCHED_FIFO` priority, or none.
#[derive(Clone, Copy, Debug)]
pub struct RtPriority(pub Option<u8>);

pub fn parse_priority(s: &str) -> Result<RtPriority, String> {
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

/// The control rates `--rate` accepts, Hz. At most 1 kHz: the Gen3's own control rate (a CAN
/// bus is checked for its load at the rate asked: `omcbsa_hw::bus`). At least 100 Hz: cyclic
/// synchronous position needs cycles of a few ms, and the per-cycle accounting reacts within a
/// few periods.
pub const RATE_RANGE: std::ops::RangeInclusive<f64> = 100.0..=1000.0;

fn parse_arm(s: &str) -> Result<(String, String), String> {
    match s.split_once('=') {
        // The spec is checked here, so that a dry run accepts only arms a live run could reach.
        Some((name, spec)) if !name.is_empty() && !spec.is_empty() => (port::check_spec(spec)
            .map(|()| (name.to_string(), spec.to_string())))
        .map_err(|e| e.to_string()),
        _ => Err(format!(
            "expected NAME=SPEC (e.g. left=slcan:/dev/ttyACM0 or left=kortex:192.168.1.10), \
             got {s:?}"
        )),
    }
}

pub fn run(args: &Args) -> ExitCode {
    let kortex = args.arms.iter().any(|(_, s)| s.starts_with("kortex:"));
    // The slowest default of the arms (specs were checked when parsed).
    let slowest = (args.arms.iter())
        .filter_map(|(_, s)| port::ArmUrl::parse(s).ok())
        .map(|u| u.default_period())
        .max()
        .unwrap_or(omcbsa_hw::bus::CAN_PERIOD);
    let rate = args.rate.unwrap_or(1.0 / slowest.as_secs_f64());
    if !RATE_RANGE.contains(&rate) {
        return bad_input(format!(
            "--rate: must be within [{}, {}] Hz, got {rate}",
            RATE_RANGE.start(),
            RATE_RANGE.end(),
        ));
    }
    let watch = match args.watch.settings() {
        Ok(w) => w,
        Err(e) => return bad_input(e),
    };
    let (checked, plan) = match load_plan(args) {
        Ok(loaded) => loaded,
        Err(e) => return bad_input(e),
    };
    let mut ports = Vec::new();
    if !args.dry_run {
        let credentials = match args.kortex.credentials(kortex) {
            Ok(c) => c,
            Err(e) => return bad_input(e),
        };
        for (name, spec) in &args.arms {
            match port::open(spec, &credentials) {
                Ok(p) => ports.push((name.clone(), p)),
                Err(e) => return bad_input(format!("arm {name:?}: {e}")),
            }
        }
    }
    let config = ExecConfig {
        period: Duration::from_secs_f64(1.0 / rate),
        dry_run: args.dry_run,
        log_path: args.log.clone(),
        realtime_priority: args.rt_priority.0,
        watch,
        ..ExecConfig::default()
    };
    if let Err(code) = print(&config.watch) {
        return code;
    }
    match stream(plan, ports, config, &checked) {
        Ok(_) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}

impl KortexArgs {
    /// The Kortex credentials from the options, else the environment; none needed without a
    /// Kortex arm.
    pub fn credentials(&self, kortex: bool) -> Result<Credentials, String> {
        if !kortex {
            return Ok(Credentials {
                username: String::new(),
                password: String::new(),
            });
        }
        let password = (self.kortex_password_file.as_ref())
            .map(|path| {
                load::read_text(path)
                    .map(|t| t.lines().next().unwrap_or("").to_string())
                    .map_err(|e| format!("--kortex-password-file {}: {e}", path.display()))
            })
            .transpose()?;
        Credentials::resolve(self.kortex_user.clone(), password, |k| {
            std::env::var(k).ok()
        })
        .map_err(|e| e.to_string())
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
    buses: ArmPorts,
    config: ExecConfig,
    checked: &CheckedSolution,
) -> Result<Report, ExitCode> {
    let names = plan.arms.iter().map(|a| a.name.clone()).collect();
    let limits = checked.joint_limits(&plan).map_err(bad_input)?;
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
