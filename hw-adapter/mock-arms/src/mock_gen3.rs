//! The Python mock Gen3 on Kortex (`hw-adapter/mock/mock_gen3.py`), for tests and `omcbsa demo
//! --transport kortex`: starting it (it prints `PORTS <tcp> <udp>`, free loopback ports), and
//! what its record shows (runs on it use the CAN mocks' settings, [`crate::mock::exec_config`]:
//! the command line's fault detection at a 10 ms period): the commands it took, checked against the streamed trajectory, and
//! how soon every arm was stopped after a fault's first sign.

use crate::record::{self, TOLERANCE};
use omcbsa_hw::kortex::{self, Connection, Credentials, KortexSpec};
use omcbsa_hw::plan::check_commands;
use omcbsa_hw::plan::{JointLimits, JOINTS};
use omcbsa_hw::run::Command;
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command as Process, Stdio};
use std::time::Duration;

/// The mock script, `hw-adapter/mock/mock_gen3.py`.
pub fn script_path() -> PathBuf {
    crate::mock::mock_dir().join("mock_gen3.py")
}

/// The mocks' user and password (the password is one no log may show).
pub fn credentials() -> Credentials {
    Credentials {
        username: "admin".into(),
        password: "mock-secret-7351".into(),
    }
}

/// A running mock Gen3; killed when dropped.
pub struct MockGen3 {
    /// The arm's name.
    pub name: String,
    /// Its TCP port on 127.0.0.1.
    pub tcp_port: u16,
    /// Its UDP port on 127.0.0.1.
    pub udp_port: u16,
    /// Where it writes its record at exit.
    pub record: PathBuf,
    child: Child,
}

impl MockGen3 {
    /// Starts the mock at `initial` (rad), stepping once per command of `period`, recording
    /// to `record`, with further flags `extra` (fault injection).
    pub fn spawn(
        python: &Path,
        name: &str,
        initial: &[f64; JOINTS],
        period: Duration,
        record: &Path,
        extra: &[String],
    ) -> Result<Self, String> {
        let initial: Vec<String> = initial.iter().map(|q| format!("{q:.17e}")).collect();
        let mut child = Process::new(python)
            .arg(script_path())
            // `--flag=value`: a negative first position would otherwise read as a flag.
            .arg(format!("--initial={}", initial.join(",")))
            .arg(format!("--period-ms={}", period.as_secs_f64() * 1e3))
            .arg(format!("--user={}", credentials().username))
            .arg(format!("--password={}", credentials().password))
            .arg("--record")
            .arg(record)
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .spawn()
            .map_err(|e| {
                format!(
                    "cannot start mock Gen3 {name:?} ({}): {e}",
                    python.display()
                )
            })?;
        let mut line = String::new();
        let read = (child.stdout.take()).map(|out| BufReader::new(out).read_line(&mut line));
        let ports = line.trim().strip_prefix("PORTS ").and_then(|p| {
            let (t, u) = p.split_once(' ')?;
            Some((t.parse().ok()?, u.parse().ok()?))
        });
        match (read, ports) {
            (Some(Ok(_)), Some((tcp_port, udp_port))) => Ok(Self {
                name: name.to_string(),
                tcp_port,
                udp_port,
                record: record.to_path_buf(),
                child,
            }),
            _ => {
                let _ = child.kill();
                let status = child.wait().map(|s| s.to_string()).unwrap_or_default();
                Err(format!(
                    "mock Gen3 {name:?} did not report its ports (first line {:?}, {status})",
                    line.trim()
                ))
            }
        }
    }

    /// `kortex:127.0.0.1:TCP:UDP`.
    pub fn spec(&self) -> String {
        format!("kortex:127.0.0.1:{}:{}", self.tcp_port, self.udp_port)
    }

    /// Opens a connection to it (with the mocks' [`credentials`]).
    pub fn connect(&self) -> Result<Connection, String> {
        let spec = KortexSpec::parse(&self.spec()).map_err(|e| e.to_string())?;
        Connection::open(&spec, &credentials()).map_err(|e| e.to_string())
    }

    /// Waits for the mock to exit (it does once its client has closed the TCP connection)
    /// and returns its record.
    pub fn finish(mut self) -> Result<Vec<Value>, String> {
        crate::mock::wait_exit(&mut self.child).map_err(|()| {
            format!(
                "mock Gen3 {:?} did not exit after its connection was closed",
                self.name
            )
        })?;
        record::read(&self.record)
    }
}

impl Drop for MockGen3 {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Function uid of Base.ApplyEmergencyStop, as the record shows it.
const APPLY_EMERGENCY_STOP: u64 = kortex::header::uid::APPLY_EMERGENCY_STOP as u64;

fn time(e: &Value) -> Result<f64, String> {
    e["t"]
        .as_f64()
        .ok_or_else(|| format!("record entry {e}: no time"))
}

fn refreshes(record: &[Value]) -> impl Iterator<Item = &Value> {
    record.iter().filter(|e| e["event"] == "refresh")
}

/// Positions (degrees) of a recorded Refresh.
fn degrees(e: &Value) -> Result<[f64; JOINTS], String> {
    let p = e["positions"]
        .as_array()
        .filter(|p| p.len() == JOINTS)
        .ok_or_else(|| format!("record entry {e}: not {JOINTS} positions"))?;
    let mut out = [0.0; JOINTS];
    for (o, v) in out.iter_mut().zip(p) {
        *o = v
            .as_f64()
            .ok_or_else(|| format!("record entry {e}: a position is no number"))?;
    }
    Ok(out)
}

/// Checks that the mock took every command of `cmds` and then `settle_cycles` holds at the
/// last, each within [`TOLERANCE`] rad of the plan (degrees on the wire), after the seed (the
/// first Refresh, holding where the arm was measured); that it refused nothing; that the
/// received commands keep within `limits`; and that the run ended by leaving low-level servoing
/// and closing both sessions. Returns the number of commands checked.
pub fn check_followed(
    record: &[Value],
    cmds: &[Command],
    settle_cycles: usize,
    limits: &[JointLimits; JOINTS],
    period: f64,
) -> Result<usize, String> {
    let last = cmds.last().ok_or("the trajectory is empty")?;
    if let Some(e) = record.iter().find(|e| e["event"] == "refused") {
        return Err(format!("the mock refused a request: {e}"));
    }
    let taken: Vec<&Value> = refreshes(record).collect();
    let want = cmds.len() + settle_cycles;
    if taken.len() != want + 1 {
        return Err(format!(
            "the mock took {} Refresh commands, the seed and {want} were streamed",
            taken.len()
        ));
    }
    for (k, e) in taken[1..].iter().enumerate() {
        let planned = cmds.get(k).unwrap_or(last);
        let deg = degrees(e)?;
        for j in 0..JOINTS {
            let want_rad = omcbsa_hw::cia402::counts_to_rad(planned[j]);
            let rad = kortex::arm::from_wire(deg[j] as f32, want_rad);
            if (rad - want_rad).abs() > TOLERANCE {
                return Err(format!(
                    "joint {} cycle {k}: received {rad} rad ({} degrees), planned {want_rad} rad",
                    j + 1,
                    deg[j]
                ));
            }
            if let Some((lo, hi)) = limits[j].position {
                if rad < lo - TOLERANCE || rad > hi + TOLERANCE {
                    return Err(format!(
                        "joint {} cycle {k}: received {rad} rad, past its limits [{lo}, {hi}]",
                        j + 1
                    ));
                }
            }
        }
    }
    // Speeds and accelerations of what was received are those of the plan's commands, which
    // it matches to TOLERANCE: checked on the plan's, since f32 degrees (3e-5 degrees of
    // rounding) make a second difference over 1 or 2 ms meaningless.
    let streamed = (0..want).map(|k| cmds.get(k).unwrap_or(last));
    check_commands(limits, streamed, period)
        .map_err(|(k, e)| format!("command of cycle {k} breaks a limit: {e}"))?;
    let events: Vec<&str> = (record.iter())
        .filter_map(|e| e["event"].as_str())
        .filter(|e| ["servoing", "close_session"].contains(e))
        .collect();
    let end = &events[events.len().saturating_sub(3)..];
    if end != ["servoing", "close_session", "close_session"]
        || record
            .iter()
            .rev()
            .find(|e| e["event"] == "servoing")
            .map(|e| &e["mode"])
            != Some(&Value::from(2))
    {
        return Err(format!(
            "the run did not end by SetServoingMode(SINGLE_LEVEL_SERVOING) and CloseSession on \
             both links (last events {end:?})"
        ));
    }
    Ok(want)
}

/// Events that are a fault's first sign in a mock's record.
const FIRST_SIGNS: [&str; 4] = [
    "silent_from",
    "late_from",
    "fault_injected",
    "session_dropped",
];

/// The time of the first sign of a fault in `record`, if it shows one.
pub fn first_sign(record: &[Value]) -> Result<Option<f64>, String> {
    (record.iter())
        .find(|e| FIRST_SIGNS.iter().any(|s| e["event"] == *s))
        .map(time)
        .transpose()
}

/// How one arm was stopped, from its mock's record.
#[derive(Clone, Debug)]
pub struct Stop {
    /// Refresh commands the arm received after the first sign and before its emergency stop.
    pub cycles: usize,
    /// From the first sign to the arm's emergency stop, s.
    pub after: f64,
    /// Refresh commands received after the emergency stop.
    pub targets_after_stop: usize,
}

/// When the mock with `record` got its emergency stop (Base.ApplyEmergencyStop, answered or
/// not), relative to a fault's first sign at `sign` (same clock: every mock stamps with the
/// system's monotonic clock).
pub fn stop_after(record: &[Value], sign: f64) -> Result<Stop, String> {
    let stop = (record.iter())
        .find(|e| e["uid"].as_u64() == Some(APPLY_EMERGENCY_STOP))
        .ok_or("the arm got no emergency stop")?;
    let t_stop = time(stop)?;
    let mut cycles = 0;
    let mut targets_after_stop = 0;
    for e in refreshes(record) {
        let t = time(e)?;
        if t > t_stop {
            targets_after_stop += 1;
        } else if t > sign {
            cycles += 1;
        }
    }
    Ok(Stop {
        cycles,
        after: t_stop - sign,
        targets_after_stop,
    })
}
