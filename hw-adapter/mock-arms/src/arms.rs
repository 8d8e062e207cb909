//! Mock arms of either kind for runs that start their own (`omcbsa demo`, `omcbsa online`,
//! tests): the CAN mock (`mock.rs`, SLCAN on Unix sockets) or the Kortex mock Gen3 (`mock_gen3.rs`, loopback
//! TCP and UDP), started, connected, and their records checked, the same way for both.

use crate::mock::{self, MockArm, MockArmOptions};
use crate::mock_gen3::{self, MockGen3};
use crate::record;
use omcbsa_hw::plan::JointLimits;
use omcbsa_hw::port::{ArmPort, ArmPorts};
use omcbsa_hw::run::{Command, JOINTS};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Which mock arms, and so which transport.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MockKind {
    /// CiA 402 drives behind an SLCAN adapter.
    Can,
    /// A Gen3 on Kortex over TCP and UDP.
    Kortex,
}

impl MockKind {
    /// How many motion commands (with the settle cycles) a record shows.
    pub fn motion_commands(self, record: &[Value]) -> Result<usize, String> {
        Ok(match self {
            MockKind::Can => record::targets(record)?[0]
                .iter()
                .filter(|t| t.controlword == omcbsa_hw::cia402::CW_ENABLE_OPERATION)
                .count(),
            // Every Refresh after the seed.
            MockKind::Kortex => (record.iter())
                .filter(|e| e["event"] == "refresh")
                .count()
                .saturating_sub(1),
        })
    }

    /// Checks a mock's record against the commands streamed to it (see the kinds' own
    /// `check_followed`); returns the number of commands checked.
    pub fn check_followed(
        self,
        record: &[Value],
        cmds: &[Command],
        settle_cycles: usize,
        limits: &[JointLimits; JOINTS],
        period: f64,
    ) -> Result<usize, String> {
        match self {
            MockKind::Can => record::check_followed(record, cmds, settle_cycles, limits, period),
            MockKind::Kortex => {
                mock_gen3::check_followed(record, cmds, settle_cycles, limits, period)
            }
        }
    }
}

/// Running mock arms, one per arm; killed when dropped.
pub enum MockArms {
    /// CAN mocks.
    Can(Vec<MockArm>),
    /// Kortex mocks.
    Kortex(Vec<MockGen3>),
}

impl MockArms {
    /// Starts one mock per `(name, start)`, recording to `record(name)` (a CAN mock logs its
    /// bus next to it), mock i with the further flags `extra[i]` (fault injection); a Kortex
    /// mock steps its actuators once per command of `period`.
    pub fn spawn(
        kind: MockKind,
        python: &Path,
        period: Duration,
        arms: &[(String, [f64; JOINTS])],
        record: impl Fn(&str) -> PathBuf,
        extra: &[Vec<String>],
    ) -> Result<Self, String> {
        let paths: Vec<PathBuf> = arms.iter().map(|(n, _)| record(n)).collect();
        for p in &paths {
            // A stale record from an earlier run must not pass for this run's.
            let _ = std::fs::remove_file(p);
            let _ = std::fs::remove_file(mock::bus_log_path(p));
        }
        let flags = |i: usize| extra.get(i).cloned().unwrap_or_default();
        let each = arms.iter().zip(&paths).enumerate();
        Ok(match kind {
            MockKind::Can => MockArms::Can(
                each.map(|(i, ((name, start), path))| {
                    let opts = MockArmOptions {
                        initial: *start,
                        record: Some(path.clone()),
                        bus_log: Some(mock::bus_log_path(path)),
                        extra_args: flags(i),
                    };
                    MockArm::spawn(python, &mock::script_path(), name, &opts)
                })
                .collect::<Result<_, _>>()?,
            ),
            MockKind::Kortex => MockArms::Kortex(
                each.map(|(i, ((name, start), path))| {
                    MockGen3::spawn(python, name, start, period, path, &flags(i))
                })
                .collect::<Result<_, _>>()?,
            ),
        })
    }

    /// The mocks' buses or connections, in order, with their arm names.
    pub fn ports(&self) -> Result<ArmPorts, String> {
        match self {
            MockArms::Can(m) => (m.iter())
                .map(|m| {
                    Ok((
                        m.name.clone(),
                        ArmPort::from(m.open_bus().map_err(|e| e.to_string())?),
                    ))
                })
                .collect(),
            MockArms::Kortex(m) => (m.iter())
                .map(|m| Ok((m.name.clone(), ArmPort::from(m.connect()?))))
                .collect(),
        }
    }

    /// Waits for every mock to exit (they do once their connections are closed) and returns
    /// their records, in order, with the arms' names.
    pub fn finish(self) -> Result<Vec<(String, Vec<Value>)>, String> {
        match self {
            MockArms::Can(m) => (m.into_iter())
                .map(|m| Ok((m.name.clone(), m.finish()?)))
                .collect(),
            MockArms::Kortex(m) => (m.into_iter())
                .map(|m| Ok((m.name.clone(), m.finish()?)))
                .collect(),
        }
    }
}
