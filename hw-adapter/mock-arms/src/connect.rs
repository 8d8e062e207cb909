//! A cell's connector that also understands mock arms ([`MockConnector`]): the URLs
//! `mock-can` and `mock-kortex` ([`ArmOrMockUrl`]) start a Python mock at the arm's start for
//! the cell's life (the CAN mock, [`crate::mock`], or the Kortex mock Gen3,
//! [`crate::mock_gen3`]), recording what it receives; every other URL is a real arm's, reached
//! by [`RealArms`].
//!
//! ```
//! use omcbsa_mock::connect::ArmOrMockUrl;
//!
//! let mock = ArmOrMockUrl::parse("mock-can?emcy-at-sync=60")?;
//! assert!(mock.is_mock());
//! assert_eq!(mock.to_string(), "mock-can?emcy-at-sync=60");
//! assert!(ArmOrMockUrl::parse("mock-can?wings=2").unwrap_err().contains("wings"));
//! assert!(!ArmOrMockUrl::parse("kortex://192.168.1.10")?.is_mock());
//! # Ok::<(), String>(())
//! ```

use crate::mock::{self, MockArm, MockArmOptions, MOCK_PERIOD};
use crate::mock_gen3::MockGen3;
use omcbsa_hw::cell::CellArm;
use omcbsa_hw::connect::{ArmGuard, ConnectError, Connected, Connector, GuardError, RealArms};
use omcbsa_hw::port::ArmUrl;
use omcbsa_hw::ExecConfig;
use serde_json::Value;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// Where an arm is: a real arm's URL ([`ArmUrl`]), or one of the project's Python mocks,
/// started for the run: `mock-kortex` and `mock-can`, each with optional mock flags as a query
/// (`mock-can?emcy-at-sync=60`, `mock-kortex?tau-ms=20`; see [`MOCK_CAN_FLAGS`] and
/// [`MOCK_KORTEX_FLAGS`]).
#[derive(Clone, Debug, PartialEq)]
pub enum ArmOrMockUrl {
    /// A real arm.
    Arm(ArmUrl),
    /// The Python mock Gen3 on Kortex (`hw-adapter/mock/mock_gen3.py`), with its flags.
    MockKortex(Vec<(String, String)>),
    /// The Python mock arm on CAN (`hw-adapter/mock/mock_arm.py`), with its flags.
    MockCan(Vec<(String, String)>),
}

/// The flags `mock-can?...` may set (`hw-adapter/mock/mock_arm.py`: fault injection, the
/// joints' time constant).
pub const MOCK_CAN_FLAGS: [&str; 9] = [
    "stop-after-syncs",
    "late-after-syncs",
    "late-ms",
    "emcy-at-sync",
    "fault-at-sync",
    "nmt-stop-at-sync",
    "heartbeat-stop-at-sync",
    "lag-after-syncs",
    "tau",
];

/// The flags `mock-kortex?...` may set (`hw-adapter/mock/mock_gen3.py`: fault injection, the
/// actuators' time constant, a slow UDP path).
pub const MOCK_KORTEX_FLAGS: [&str; 8] = [
    "silent-at",
    "late-at",
    "late-ms",
    "fault-at",
    "drop-session-at",
    "tau-ms",
    "udp-delay-ms",
    "seed",
];

impl ArmOrMockUrl {
    /// Parses a mock's URL, or else a real arm's ([`ArmUrl::parse`]); the error names the URL
    /// and what is wrong with it.
    pub fn parse(url: &str) -> Result<Self, String> {
        let (kind, query) = url.split_once('?').unwrap_or((url, ""));
        let allowed: &[&str] = match kind {
            "mock-kortex" => &MOCK_KORTEX_FLAGS,
            "mock-can" => &MOCK_CAN_FLAGS,
            _ => return (ArmUrl::parse(url).map(ArmOrMockUrl::Arm)).map_err(|e| e.to_string()),
        };
        let mut flags = Vec::new();
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair.split_once('=').unwrap_or((pair, ""));
            if !allowed.contains(&key) {
                return Err(format!(
                    "arm URL {url:?}: {kind} has no flag {key:?} (it has {})",
                    allowed.join(", ")
                ));
            }
            if !value.parse::<f64>().is_ok_and(f64::is_finite) {
                return Err(format!("arm URL {url:?}: {key}={value:?} is not a number"));
            }
            flags.push((key.to_string(), value.to_string()));
        }
        Ok(match kind {
            "mock-kortex" => ArmOrMockUrl::MockKortex(flags),
            _ => ArmOrMockUrl::MockCan(flags),
        })
    }

    /// A Python mock, started for the run.
    pub fn is_mock(&self) -> bool {
        !matches!(self, ArmOrMockUrl::Arm(_))
    }

    /// The control period this arm runs at by default: a real arm's
    /// ([`ArmUrl::default_period`]), or [`MOCK_PERIOD`] for the Python mocks (they cannot keep
    /// up faster).
    pub fn default_period(&self) -> Duration {
        match self {
            ArmOrMockUrl::Arm(url) => url.default_period(),
            ArmOrMockUrl::MockKortex(_) | ArmOrMockUrl::MockCan(_) => MOCK_PERIOD,
        }
    }
}

impl fmt::Display for ArmOrMockUrl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mock = |f: &mut fmt::Formatter<'_>, kind: &str, flags: &[(String, String)]| {
            write!(f, "{kind}")?;
            for (i, (k, v)) in flags.iter().enumerate() {
                write!(f, "{}{k}={v}", if i == 0 { "?" } else { "&" })?;
            }
            Ok(())
        };
        match self {
            ArmOrMockUrl::Arm(url) => write!(f, "{url}"),
            ArmOrMockUrl::MockKortex(flags) => mock(f, "mock-kortex", flags),
            ArmOrMockUrl::MockCan(flags) => mock(f, "mock-can", flags),
        }
    }
}

/// Cells connected by this process (their records' directories are numbered).
static CELLS: AtomicUsize = AtomicUsize::new(0);

/// A cell's connector: mock arms started, real ones reached by [`RealArms`]. See the module.
#[derive(Clone, Debug)]
pub struct MockConnector {
    /// How real arms are reached.
    pub real: RealArms,
    records: PathBuf,
}

impl MockConnector {
    /// Reaches real arms with `real`; the mocks write their records (`NAME.jsonl`, and a CAN
    /// mock's bus log `NAME.log`) to `records`, or with `None` to a directory of its own under
    /// the system's temporary directory.
    pub fn new(real: RealArms, records: Option<PathBuf>) -> Self {
        let records = records.unwrap_or_else(|| {
            std::env::temp_dir().join(format!(
                "omcbsa-cell-{}-{}",
                std::process::id(),
                CELLS.fetch_add(1, Ordering::SeqCst)
            ))
        });
        Self { real, records }
    }

    /// Where the mocks write their records.
    pub fn records(&self) -> &Path {
        &self.records
    }

    /// Starts the mock of `arm` with the URL's `flags`.
    fn start_mock(
        &self,
        arm: &CellArm<ArmOrMockUrl>,
        flags: &[(String, String)],
        config: &ExecConfig,
    ) -> Result<Connected, String> {
        // A cell's mock lives as long as the cell: it exits when the cell closes its
        // connection, not after the mocks' own backstop for a test that leaks one (a minute
        // or ten). The URL's flags come after, so that a query may still set one.
        let own = flags.iter().map(|(k, v)| format!("--{k}={v}"));
        let flags: Vec<String> = std::iter::once("--max-seconds=inf".to_string())
            .chain(own)
            .collect();
        let record = self.records.join(format!("{}.jsonl", arm.name));
        std::fs::create_dir_all(&self.records).map_err(|e| e.to_string())?;
        let python = mock::ensure_venv()?;
        if let ArmOrMockUrl::MockKortex(_) = arm.url {
            let m = MockGen3::spawn(
                &python,
                &arm.name,
                &arm.start,
                config.period,
                &record,
                &flags,
            )?;
            let port = m.connect()?.into();
            return Ok(Connected {
                port,
                guard: Some(Box::new(KortexGuard(m))),
            });
        }
        let opts = MockArmOptions {
            initial: arm.start,
            record: Some(record.clone()),
            bus_log: Some(mock::bus_log_path(&record)),
            extra_args: flags,
        };
        let m = MockArm::spawn(&python, &mock::script_path(), &arm.name, &opts)?;
        let port = m.open_bus().map_err(|e| e.to_string())?.into();
        Ok(Connected {
            port,
            guard: Some(Box::new(CanGuard(m))),
        })
    }
}

impl Connector for MockConnector {
    type Url = ArmOrMockUrl;

    fn default_period(&self, url: &ArmOrMockUrl) -> Duration {
        url.default_period()
    }

    fn check(&self, arm: &CellArm<ArmOrMockUrl>, config: &ExecConfig) -> Result<(), ConnectError> {
        if arm.url.is_mock() && config.period < MOCK_PERIOD {
            return Err(ConnectError::TooFast {
                what: "a Python mock",
                fastest: MOCK_PERIOD,
                period: config.period,
            });
        }
        Ok(())
    }

    fn connect(
        &self,
        arm: &CellArm<ArmOrMockUrl>,
        config: &ExecConfig,
    ) -> Result<Connected, ConnectError> {
        match &arm.url {
            ArmOrMockUrl::Arm(url) => self.real.connect(
                &CellArm {
                    name: arm.name.clone(),
                    url: url.clone(),
                    start: arm.start,
                    limits: arm.limits,
                },
                config,
            ),
            ArmOrMockUrl::MockCan(flags) | ArmOrMockUrl::MockKortex(flags) => {
                (self.start_mock(arm, flags, config)).map_err(ConnectError::Start)
            }
        }
    }
}

/// A started CAN mock: it exits once the cell has closed its bus.
struct CanGuard(MockArm);

impl ArmGuard for CanGuard {
    fn finish(self: Box<Self>) -> Result<Vec<Value>, GuardError> {
        Ok(self.0.finish()?)
    }
}

/// A started Kortex mock: it exits once the cell has closed its connection.
struct KortexGuard(MockGen3);

impl ArmGuard for KortexGuard {
    fn finish(self: Box<Self>) -> Result<Vec<Value>, GuardError> {
        Ok(self.0.finish()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mock_urls_with_their_flags_and_bad_ones_named() {
        let m = ArmOrMockUrl::parse("mock-kortex?fault-at=100&tau-ms=20").unwrap();
        assert_eq!(m.to_string(), "mock-kortex?fault-at=100&tau-ms=20");
        assert_eq!(m.default_period(), MOCK_PERIOD);
        assert_eq!(
            ArmOrMockUrl::parse("mock-can").unwrap(),
            ArmOrMockUrl::MockCan(Vec::new())
        );
        let real = ArmOrMockUrl::parse("slcan:/dev/ttyACM0").unwrap();
        assert_eq!(
            real,
            ArmOrMockUrl::Arm(ArmUrl::Slcan("/dev/ttyACM0".into()))
        );
        assert_eq!(real.to_string(), "slcan:///dev/ttyACM0");
        for (bad, why) in [
            ("mock-kortex?fault-at=soon", "is not a number"),
            ("mock-kortex?emcy-at-sync=1", "has no flag \"emcy-at-sync\""),
            ("tcp://host", "unknown arm URL"),
        ] {
            let e = ArmOrMockUrl::parse(bad).unwrap_err();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }
}
