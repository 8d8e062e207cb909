//! The subcommands, one module each. Exit codes are shared: 0 success (solved, valid, every
//! line answered), 1 a negative answer (not solved, invalid, some line failed), 2 bad input
//! or usage (clap exits with 2 on usage errors too).

pub mod bench;
pub mod bench_online;
pub mod demo;
pub mod execute;
pub mod fk;
pub mod gen_bench;
pub mod ik;
mod lines;
pub mod online;
pub mod plan;
pub mod validate;

use std::fmt::Display;
use std::process::ExitCode;

use omcbsa::error::Errors;
use omcbsa::load;
use omcbsa_core::model::Model;

/// Exit code 1.
pub fn negative() -> ExitCode {
    ExitCode::from(1)
}

/// Prints an input error and returns exit code 2.
pub fn bad_input(message: impl Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(2)
}

/// Parses a JSON array of joint values of model `M` (length, finite, within limits); errors
/// name the value as `{name}[j]`.
pub fn configuration<M: Model<D>, const D: usize>(
    text: &str,
    name: &str,
) -> Result<[f64; D], String> {
    let values: Vec<f64> = serde_json::from_str(text)
        .map_err(|e| format!("{name}: not a JSON array of {D} numbers: {e}"))?;
    let mut errors = Errors::default();
    let q = load::joint_values::<M, D>(&values, name, &mut errors);
    errors
        .finish()
        .map_err(|e| e.to_string().replace('\n', "; "))?;
    q.ok_or_else(|| format!("{name}: invalid configuration"))
}
