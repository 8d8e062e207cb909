//! `omcbsa doctor`: whether this machine can drive arms at the default control rates. Measures
//! the timer's wake-up lateness at each rate under the arm threads' scheduling
//! (`omcbsa_hw::timing`, the same check `execute`, `online` and `demo` make before any arm is
//! set up) and prints it with the verdict. Exit code 0 when every rate asked for is held, 1
//! when one is not.

use std::process::ExitCode;
use std::time::Duration;

use omcbsa_hw::timing;

use super::execute::{parse_priority, RtPriority};
use super::{bad_input, negative, positive_seconds, print};

/// The default control rates: Kortex 1 kHz, SocketCAN 250 Hz, SLCAN 200 Hz, the Python mock
/// arms 100 Hz.
const RATES: [(&str, f64); 4] = [
    ("Kortex", 1000.0),
    ("SocketCAN", 250.0),
    ("SLCAN", 200.0),
    ("mock arms", 100.0),
];

#[derive(clap::Args)]
pub struct Args {
    /// How long each rate is measured, seconds (at most 60).
    #[arg(long, default_value = "1", value_parser = positive_seconds)]
    seconds: f64,
    /// Only this rate, Hz [default: each transport's default rate].
    #[arg(long, value_name = "HZ")]
    rate: Option<f64>,
    /// SCHED_FIFO priority (1 to 99) the arm threads ask for, or `off`.
    #[arg(long, value_name = "PRIO|off", default_value = "50", value_parser = parse_priority)]
    rt_priority: RtPriority,
}

pub fn run(args: &Args) -> ExitCode {
    doctor(args).unwrap_or_else(|code| code)
}

fn doctor(args: &Args) -> Result<ExitCode, ExitCode> {
    let rates: Vec<(&str, f64)> = match args.rate {
        Some(hz) if hz.is_finite() && (1.0..=10_000.0).contains(&hz) => vec![("asked", hz)],
        Some(hz) => {
            return Err(bad_input(format!(
                "--rate: must be 1 to 10000 Hz, got {hz}"
            )))
        }
        None => RATES.to_vec(),
    };
    let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
    print(format_args!(
        "{cores} cores; a rate is held when {:.0} % of a timer's wake-ups come within {} \
         period(s) of their deadline",
        timing::HELD_SHARE * 100.0,
        timing::HELD_FRACTION
    ))?;
    let mut all_held = true;
    for (what, hz) in rates {
        let period = Duration::from_secs_f64(1.0 / hz);
        let jitter = timing::measure(
            period,
            Duration::from_secs_f64(args.seconds),
            args.rt_priority.0,
        )
        .map_err(bad_input)?;
        let verdict = match jitter.holds() {
            Ok(()) => "held".to_string(),
            Err(e) => {
                all_held = false;
                format!("NOT HELD: {e}")
            }
        };
        print(format_args!("{what}: {jitter}: {verdict}"))?;
    }
    Ok(if all_held {
        ExitCode::SUCCESS
    } else {
        negative()
    })
}
