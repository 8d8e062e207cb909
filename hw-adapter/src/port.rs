//! What a caller hands the executor per arm ([`ArmPort`]: an open CAN bus or Kortex connection),
//! how a port is opened from its spec ([`open`], [`check_spec`]), and the link the executor
//! drives it through ([`crate::arm::ArmBus`] or [`crate::kortex::KortexArm`]).

use crate::arm::{ArmBus, SetupOverride};
use crate::kortex;
use crate::link::ArmLink;
use crate::log::LogSink;
use crate::run::ExecConfig;
use crate::transport::{self, Transport};
use std::time::Instant;

/// What carries one arm's commands, opened: a CAN bus or a Kortex connection.
pub enum ArmPort {
    /// An arm of CiA 402 drives (nodes 1 to 7) on its own CAN bus.
    Can(Box<dyn Transport>),
    /// A Kinova Gen3 over Ethernet, its TCP and UDP links open.
    Kortex(Box<kortex::Connection>),
    /// Tests only: a CAN arm whose start-up has one SDO write changed on purpose.
    #[doc(hidden)]
    CanSetupOverride(Box<dyn Transport>, SetupOverride),
}

impl From<Box<dyn Transport>> for ArmPort {
    fn from(t: Box<dyn Transport>) -> Self {
        ArmPort::Can(t)
    }
}

impl From<kortex::Connection> for ArmPort {
    fn from(c: kortex::Connection) -> Self {
        ArmPort::Kortex(Box::new(c))
    }
}

/// Ports paired with the names of their arms, as [`crate::Executor::new`] takes them.
pub type ArmPorts = Vec<(String, ArmPort)>;

impl ArmPort {
    /// The link that drives this port's arm for a run with `cfg`, logging to `log` with time
    /// stamps from `clock`.
    pub(crate) fn into_link(
        self,
        name: String,
        clock: Instant,
        cfg: &ExecConfig,
        log: Option<LogSink>,
    ) -> Box<dyn ArmLink> {
        match self {
            ArmPort::Can(t) => Box::new(ArmBus::new(name, t, clock, cfg, log)),
            ArmPort::CanSetupOverride(t, o) => {
                Box::new(ArmBus::new(name, t, clock, cfg, log).with_setup_override(o))
            }
            ArmPort::Kortex(c) => Box::new(kortex::KortexArm::new(name, *c, clock, cfg, log)),
        }
    }
}

/// An arm's port spec, checked: `slcan:PATH`, `socketcan:IFACE` or `kortex:HOST[:TCP:UDP]`.
/// A dry run checks its arms' specs with this.
pub fn check_spec(spec: &str) -> Result<(), String> {
    if spec.starts_with("kortex:") {
        kortex::KortexSpec::parse(spec).map(|_| ())
    } else {
        transport::BusSpec::parse(spec)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}

/// Opens an arm's port from its spec ([`check_spec`]); a Kortex arm is reached with
/// `credentials`.
pub fn open(spec: &str, credentials: &kortex::Credentials) -> Result<ArmPort, String> {
    if spec.starts_with("kortex:") {
        let s = kortex::KortexSpec::parse(spec)?;
        Ok(kortex::Connection::open(&s, credentials)?.into())
    } else {
        Ok(ArmPort::Can(
            transport::open(spec).map_err(|e| e.to_string())?,
        ))
    }
}
