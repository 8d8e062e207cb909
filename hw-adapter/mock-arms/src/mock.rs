//! Starting the Python mock Gen3 arm (`hw-adapter/mock/mock_arm.py`), for hardware-in-the-loop
//! tests and `omcbsa demo`. The mock opens a pseudo-terminal, prints `PTY <path>` on its first
//! line of output, and then plays an SLCAN adapter with seven CiA 402 drives behind it.

use crate::record;
use omcbsa_hw::plan::Plan;
use omcbsa_hw::transport::slcan::{self, SlcanTransport};
use omcbsa_hw::transport::{ArmBuses, Transport, TransportError};
use omcbsa_hw::ExecConfig;
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The folder of the Python mocks, `hw-adapter/mock`, beside this crate's.
pub fn mock_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("mock")
}

/// The mock arm script, `hw-adapter/mock/mock_arm.py`.
pub fn script_path() -> PathBuf {
    mock_dir().join("mock_arm.py")
}

/// The venv's python that `hw-adapter/mock/setup_venv.sh` creates at `<repo>/.venv`.
pub fn venv_python() -> Result<PathBuf, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join("..");
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

/// Whether the venv of `python` holds the Kortex mock's message code that setup_venv.sh
/// generates.
pub fn proto_code_ready(python: &Path) -> bool {
    (python.parent().and_then(Path::parent))
        .is_some_and(|venv| venv.join("kortex-proto").join("Frame_pb2.py").exists())
}

/// The venv's python, first creating the venv with `hw-adapter/mock/setup_venv.sh` if it is
/// missing, or lacks the Kortex mock's generated message code (the script's output goes to
/// this process's output).
pub fn ensure_venv() -> Result<PathBuf, String> {
    if let Ok(python) = venv_python() {
        if proto_code_ready(&python) {
            return Ok(python);
        }
    }
    let setup = script_path().with_file_name("setup_venv.sh");
    let status = Command::new("bash")
        .arg(&setup)
        .status()
        .map_err(|e| format!("cannot run {}: {e}", setup.display()))?;
    if !status.success() {
        return Err(format!(
            "{} failed ({status}): the mock arms need python3 with venv and pip, and access \
             to the Python package index",
            setup.display()
        ));
    }
    venv_python()
}

/// How a mock arm is started.
#[derive(Clone, Debug)]
pub struct MockArmOptions {
    /// Joint positions at power-on, rad.
    pub initial: [f64; omcbsa_hw::JOINTS],
    /// Where the mock writes every command it receives (JSON lines), at exit.
    pub record: Option<PathBuf>,
    /// Where the mock writes every frame on its bus, both directions (candump log).
    pub bus_log: Option<PathBuf>,
    /// Further flags, e.g. fault injection: `["--emcy-at-sync", "100"]`.
    pub extra_args: Vec<String>,
}

/// Executor settings for the mocks: the command line's defaults (the same fault detection,
/// [`omcbsa_hw::WatchSettings::default`]) but for the control period, [`MOCK_PERIOD`] (10 ms):
/// seven `canopen` nodes per arm in Python cost about 0.5 ms of CPU per cycle, so three mocks
/// at 500 Hz alone would need most of the machine (real drives have their own processors).
/// Detection bounds are in periods, so they hold at any period; [`crate::sim`] shows them at
/// the default rates.
pub fn exec_config() -> ExecConfig {
    ExecConfig {
        period: MOCK_PERIOD,
        ..ExecConfig::default()
    }
}

/// The control period of runs on the mock arms.
pub const MOCK_PERIOD: Duration = Duration::from_millis(10);

/// A running mock arm; killed when dropped.
pub struct MockArm {
    /// The arm's name.
    pub name: String,
    /// The Unix socket its SLCAN adapter listens on.
    pub socket: String,
    /// Where it writes its record at exit.
    pub record: Option<PathBuf>,
    child: Child,
}

impl MockArm {
    /// Starts the mock `script` with `python` and waits for it to report its socket.
    pub fn spawn(
        python: &Path,
        script: &Path,
        name: &str,
        opts: &MockArmOptions,
    ) -> Result<Self, String> {
        let initial: Vec<String> = opts.initial.iter().map(|q| format!("{q:.17e}")).collect();
        let mut cmd = Command::new(python);
        // `--flag=value`: a negative first position would otherwise read as a flag.
        cmd.arg(script)
            .arg(format!("--initial={}", initial.join(",")));
        if let Some(r) = &opts.record {
            cmd.arg("--record").arg(r);
        }
        if let Some(l) = &opts.bus_log {
            cmd.arg("--bus-log").arg(l);
        }
        cmd.args(&opts.extra_args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped());
        let mut child = cmd.spawn().map_err(|e| {
            format!(
                "cannot start mock arm {name:?} ({} {}): {e}",
                python.display(),
                script.display()
            )
        })?;
        let mut line = String::new();
        let read = child
            .stdout
            .take()
            .map(|out| BufReader::new(out).read_line(&mut line));
        match (read, line.trim().strip_prefix("SOCKET ")) {
            (Some(Ok(_)), Some(path)) => Ok(MockArm {
                name: name.to_string(),
                socket: path.to_string(),
                record: opts.record.clone(),
                child,
            }),
            _ => {
                let _ = child.kill();
                let status = child.wait().map(|s| s.to_string()).unwrap_or_default();
                Err(format!(
                    "mock arm {name:?} did not report its socket (first line {:?}, {status})",
                    line.trim()
                ))
            }
        }
    }

    /// Connects to the mock's SLCAN adapter as a bus.
    pub fn open_bus(&self) -> Result<Box<dyn Transport>, TransportError> {
        let bus = SlcanTransport::connect(&self.socket, slcan::DEFAULT_BITRATE)?;
        Ok(Box::new(bus))
    }

    /// Waits for the mock to exit (it does once its connection is closed) and returns its record
    /// (empty without one).
    pub fn finish(mut self) -> Result<Vec<Value>, String> {
        wait_exit(&mut self.child).map_err(|()| {
            format!(
                "mock arm {:?} did not exit after its connection was closed",
                self.name
            )
        })?;
        match &self.record {
            Some(path) => record::read(path),
            None => Ok(Vec::new()),
        }
    }
}

/// Waits up to 5 s for a mock's process to exit.
pub(crate) fn wait_exit(child: &mut Child) -> Result<(), ()> {
    let deadline = Instant::now() + Duration::from_secs(5);
    while child.try_wait().ok().flatten().is_none() {
        if Instant::now() > deadline {
            return Err(());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    Ok(())
}

impl Drop for MockArm {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The bus log written next to a mock's record: the same path with the extension `log`.
pub fn bus_log_path(record: &Path) -> PathBuf {
    record.with_extension("log")
}

/// Starts one mock arm per arm of `plan`, each at its arm's first waypoint, recording to
/// `record(name)` and logging its bus next to it ([`bus_log_path`]), with the further flags
/// `extra[i]` for arm i.
pub fn spawn_for_plan(
    python: &Path,
    plan: &Plan,
    record: impl Fn(&str) -> PathBuf,
    extra: &[Vec<String>],
) -> Result<Vec<MockArm>, String> {
    (plan.arms.iter().enumerate())
        .map(|(i, arm)| {
            let path = record(&arm.name);
            let log = bus_log_path(&path);
            // A stale record from an earlier run must not pass for this run's.
            let _ = std::fs::remove_file(&path);
            let _ = std::fs::remove_file(&log);
            let opts = MockArmOptions {
                initial: *arm
                    .joint_path
                    .first()
                    .ok_or_else(|| format!("arm {:?} has an empty joint path", arm.name))?,
                record: Some(path),
                bus_log: Some(log),
                extra_args: extra.get(i).cloned().unwrap_or_default(),
            };
            MockArm::spawn(python, &script_path(), &arm.name, &opts)
        })
        .collect()
}

/// The buses of `mocks`, paired with their arm names.
pub fn open_buses(mocks: &[MockArm]) -> Result<ArmBuses, TransportError> {
    mocks
        .iter()
        .map(|m| Ok((m.name.clone(), m.open_bus()?)))
        .collect()
}
