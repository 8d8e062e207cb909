//! Starting the Python mock Gen3 arm (`hw-adapter/mock/mock_arm.py`), for hardware-in-the-loop
//! tests and `omcbsa demo`. The mock opens a pseudo-terminal, prints `PTY <path>` on its first
//! line of output, and then plays an SLCAN adapter with seven CiA 402 drives behind it.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The mock arm script in this crate's source tree.
pub fn script_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("mock")
        .join("mock_arm.py")
}

/// The venv's python that `hw-adapter/mock/setup_venv.sh` creates at `<repo>/.venv`.
pub fn venv_python() -> Result<PathBuf, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let python = root.join(".venv").join("bin").join("python");
    if python.exists() {
        Ok(python)
    } else {
        Err(format!(
            "the mock arms' Python venv is missing ({}): run `bash hw-adapter/mock/setup_venv.sh` first",
            python.display()
        ))
    }
}

#[derive(Clone, Debug)]
pub struct MockArmOptions {
    /// Joint positions at power-on, rad.
    pub initial: [f64; crate::JOINTS],
    /// Control period the mock assumes for its own limit checks, s.
    pub period: f64,
    /// Where the mock writes every command it receives (JSON lines), at exit.
    pub record: Option<PathBuf>,
    /// Further flags, e.g. fault injection: `["--emcy-at-sync", "100"]`.
    pub extra_args: Vec<String>,
}

/// Starts a mock arm; returns the pty path to open as an SLCAN adapter, and the process. The
/// mock exits when the pty is closed (or after its own safety timeout).
pub fn spawn_mock_arm(
    python: &Path,
    script: &Path,
    opts: &MockArmOptions,
) -> Result<(String, Child), String> {
    let initial: Vec<String> = opts.initial.iter().map(|q| format!("{q:.17e}")).collect();
    let mut cmd = Command::new(python);
    // `--flag=value`: a negative first position would otherwise read as a flag.
    cmd.arg(script)
        .arg(format!("--initial={}", initial.join(",")))
        .arg(format!("--period={}", opts.period));
    if let Some(r) = &opts.record {
        cmd.arg("--record").arg(r);
    }
    cmd.args(&opts.extra_args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped());
    let mut child = cmd.spawn().map_err(|e| {
        format!(
            "cannot start mock arm {} {}: {e}",
            python.display(),
            script.display()
        )
    })?;
    let mut line = String::new();
    let read = child
        .stdout
        .take()
        .map(|out| BufReader::new(out).read_line(&mut line));
    match (read, line.trim().strip_prefix("PTY ")) {
        (Some(Ok(_)), Some(path)) => Ok((path.to_string(), child)),
        _ => {
            let _ = child.kill();
            let status = child.wait().map(|s| s.to_string()).unwrap_or_default();
            Err(format!(
                "mock arm did not report its pty (first line {:?}, {status})",
                line.trim()
            ))
        }
    }
}
