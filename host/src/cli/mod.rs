//! The subcommands, one module each. Exit codes are shared: 0 success (solved, valid, every
//! line answered), 1 a negative answer (not solved, invalid, some line failed), 2 bad input
//! or usage (clap exits with 2 on usage errors too), or an output that cannot be written (a
//! full disk, `> /dev/full`, a closed pipe). Nothing on the command line panics: output goes
//! through [`print`] and [`note`], never `println!`, which panics when stdout fails.

pub mod bench;
pub mod bench_online;
pub mod demo;
pub mod doctor;
pub mod execute;
pub mod fk;
pub mod gen_bench;
pub mod ik;
pub mod import;
mod lines;
mod live;
pub mod online;
pub mod plan;
pub mod validate;
pub mod view;
pub mod watch;

use std::fmt::Display;
use std::io::{self, Write};
use std::path::Path;
use std::process::ExitCode;

use omcbsa::error::{Errors, InputError};
use omcbsa::load;
use omcbsa_core::model::Models;

/// Exit code 1.
pub fn negative() -> ExitCode {
    ExitCode::from(1)
}

/// Prints an input error and returns exit code 2.
pub fn bad_input(message: impl Display) -> ExitCode {
    note(format_args!("error: {message}"));
    ExitCode::from(2)
}

/// Writes `text` and a newline to standard output, flushed. If stdout is full or closed: an
/// error line on stderr and `Err` with exit code 2.
pub fn print(text: impl Display) -> Result<(), ExitCode> {
    let mut out = io::stdout().lock();
    writeln!(out, "{text}")
        .and_then(|()| out.flush())
        .map_err(|e| bad_input(format!("cannot write standard output: {e}")))
}

/// Writes a line to standard error. If even that fails there is nowhere left to say so; the
/// exit code still tells.
pub fn note(text: impl Display) {
    let _ = writeln!(io::stderr(), "{text}");
}

/// A `--timeout`-like flag: a finite number of seconds > 0.
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(_) => Err("must be a finite number of seconds > 0".to_string()),
        Err(e) => Err(format!("not a number: {e}")),
    }
}

/// `--max-input-mib`: the size cap on problem and solution files, in MiB.
#[derive(clap::Args, Clone, Copy)]
pub struct InputLimit {
    /// Largest problem or solution file read, MiB (1 to 4096).
    #[arg(long, value_name = "MIB", default_value_t = load::DEFAULT_MAX_INPUT_BYTES >> 20,
          value_parser = clap::value_parser!(u64).range(1..=4096))]
    max_input_mib: u64,
}

impl InputLimit {
    pub fn bytes(self) -> u64 {
        self.max_input_mib << 20
    }
}

/// Parses a JSON array of joint values of model `model` of `M` (length, finite, within
/// limits); errors name the value as `{name}[j]`.
pub fn configuration<M: Models<D>, const D: usize>(
    model: u8,
    text: &str,
    name: &str,
) -> Result<[f64; D], String> {
    let values: Vec<f64> = serde_json::from_str(text)
        .map_err(|e| format!("{name}: not a JSON array of {D} numbers: {e}"))?;
    let mut errors = Errors::default();
    let q = load::joint_values::<M, D>(model, &values, name, &mut errors);
    errors
        .finish()
        .map_err(|e| e.to_string().replace('\n', "; "))?;
    q.ok_or_else(|| format!("{name}: invalid configuration"))
}

/// Every error of `e`, one per line, prefixed with the file's name.
pub fn in_file(path: &Path, e: InputError) -> String {
    let lines: Vec<String> = e
        .errors
        .iter()
        .map(|f| format!("{}: {f}", path.display()))
        .collect();
    lines.join("\n")
}
