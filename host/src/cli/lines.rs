//! The line protocol of `fk` and `ik`: one JSON value per line in, one per line out.

use std::io::{self, BufRead, Write};
use std::process::ExitCode;

use serde_json::{json, Value};

use super::{bad_input, negative};

/// Answers every line of stdin with one line of stdout: the value `answer` gives, or
/// `{"error":"line N: why"}` in its place. Exit code 0 if every line was answered, 1 if some
/// line failed, 2 if stdin or stdout failed.
pub fn answer_each(mut answer: impl FnMut(&str) -> Result<Value, String>) -> ExitCode {
    let mut input = io::stdin().lock();
    let mut output = io::stdout().lock();
    let mut buf = Vec::new();
    let mut failed = false;
    for n in 1.. {
        buf.clear();
        match input.read_until(b'\n', &mut buf) {
            Ok(0) => break,
            Ok(_) => {}
            Err(e) => return bad_input(format!("cannot read stdin: {e}")),
        }
        let reply = match std::str::from_utf8(&buf) {
            Ok(line) if line.trim().is_empty() => Err("empty line".to_string()),
            Ok(line) => answer(line),
            Err(_) => Err("not UTF-8 text".to_string()),
        };
        let reply = reply.unwrap_or_else(|why| {
            failed = true;
            json!({ "error": format!("line {n}: {why}") })
        });
        // Line by line (stdout is line-buffered), so a caller can converse over a pipe.
        if let Err(e) = writeln!(output, "{reply}") {
            return bad_input(format!("cannot write stdout: {e}"));
        }
    }
    if failed {
        negative()
    } else {
        ExitCode::SUCCESS
    }
}
