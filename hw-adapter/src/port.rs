//! What a caller hands the executor per arm ([`ArmPort`]: an open CAN bus or Kortex connection),
//! where an arm is ([`ArmUrl`], parsed in one place, and [`open`]ed), and the link the executor
//! drives it through ([`crate::arm::ArmBus`] or [`crate::kortex::KortexArm`]).

use crate::arm::{ArmBus, SetupOverride};
use crate::kortex;
use crate::link::ArmLink;
use crate::log::LogSink;
use crate::run::ExecConfig;
use crate::transport::{self, Transport, TransportError};
use std::fmt;
use std::time::{Duration, Instant};

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

impl ArmPort {
    /// The CAN bus this port's arm is on (`None` for a Kortex arm).
    pub(crate) fn can_transport(&self) -> Option<&dyn Transport> {
        match self {
            ArmPort::Can(t) | ArmPort::CanSetupOverride(t, _) => Some(t.as_ref()),
            ArmPort::Kortex(_) => None,
        }
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

/// The forms of a real arm's URL, for messages.
const FORMS: &str = "kortex://HOST, socketcan://IFACE or slcan:///dev/ttyX";

/// An arm URL that cannot be read: what is wrong, naming the URL.
#[derive(Debug, thiserror::Error)]
pub enum UrlError {
    /// A Kortex arm's URL with something wrong in it.
    #[error(transparent)]
    Kortex(#[from] kortex::SpecError),
    /// A CAN arm's URL whose bus cannot be named so.
    #[error(transparent)]
    Bus(TransportError),
    /// Neither a URL nor a bus spec (the bus spec's own error says what it expected).
    #[error("{source}; or an arm URL: {FORMS}")]
    NotAUrl {
        /// Why it is no bus spec either.
        source: TransportError,
    },
    /// A URL of no kind this reads.
    #[error("unknown arm URL {url:?}: expected {FORMS}")]
    Unknown {
        /// The URL.
        url: String,
    },
}

/// Why an arm's port could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// Its URL cannot be read.
    #[error(transparent)]
    Url(#[from] UrlError),
    /// A Kortex arm that could not be reached.
    #[error(transparent)]
    Kortex(#[from] kortex::ReachError),
    /// A CAN bus that could not be opened.
    #[error(transparent)]
    Bus(#[from] TransportError),
}

/// Where a real arm is, parsed in one place: `kortex://HOST` (or `kortex://HOST:TCP:UDP`),
/// `socketcan://IFACE`, `slcan:///dev/ttyX` (a serial device path). The command line's older
/// forms `kortex:HOST[:TCP:UDP]`, `socketcan:IFACE` and `slcan:PATH` are read too. (Stand-in
/// arms have URLs of their own, read by the crate `omcbsa-mock`.)
///
/// ```
/// use omcbsa_hw::port::{ArmUrl, UrlError};
///
/// let u = ArmUrl::parse("kortex://192.168.1.10")?;
/// assert_eq!(u.to_string(), "kortex://192.168.1.10:10000:10001");
/// assert_eq!(ArmUrl::parse("slcan:///dev/ttyACM0")?, ArmUrl::Slcan("/dev/ttyACM0".into()));
/// let e = ArmUrl::parse("tcp://host").unwrap_err();
/// assert!(matches!(e, UrlError::Unknown { .. }));
/// assert!(e.to_string().contains("expected kortex://HOST"));
/// # Ok::<(), UrlError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub enum ArmUrl {
    /// A Gen3 on Kortex.
    Kortex(kortex::KortexSpec),
    /// CiA 402 drives on a SocketCAN interface.
    SocketCan(String),
    /// CiA 402 drives behind an SLCAN adapter at this device path.
    Slcan(String),
}

impl ArmUrl {
    /// Parses an arm URL; the error names the URL and what is wrong with it.
    pub fn parse(url: &str) -> Result<Self, UrlError> {
        let bus = |spec: String| transport::BusSpec::parse(&spec).map(|_| ());
        if let Some(rest) = url.strip_prefix("kortex://") {
            return Ok(ArmUrl::Kortex(kortex::KortexSpec::parse(&format!(
                "kortex:{rest}"
            ))?));
        }
        if url.starts_with("kortex:") {
            return Ok(ArmUrl::Kortex(kortex::KortexSpec::parse(url)?));
        }
        if let Some(iface) = (url.strip_prefix("socketcan://")).or(url.strip_prefix("socketcan:")) {
            bus(format!("socketcan:{iface}")).map_err(UrlError::Bus)?;
            return Ok(ArmUrl::SocketCan(iface.to_string()));
        }
        if let Some(path) = (url.strip_prefix("slcan://")).or(url.strip_prefix("slcan:")) {
            bus(format!("slcan:{path}")).map_err(UrlError::Bus)?;
            return Ok(ArmUrl::Slcan(path.to_string()));
        }
        // Not a URL: the bus spec's own error names the command line's forms.
        Err(match bus(url.to_string()) {
            Err(source) if !url.contains("://") => UrlError::NotAUrl { source },
            _ => UrlError::Unknown {
                url: url.to_string(),
            },
        })
    }

    /// The control period this arm runs at by default: Kortex 1 ms; CAN the shortest at which
    /// the arm fits alone on its bus ([`crate::bus::one_arm_period`]): SocketCAN (counted at
    /// 1 Mbit/s) 4 ms, SLCAN (opened at 500 kbit/s) 5 ms.
    pub fn default_period(&self) -> Duration {
        match self {
            ArmUrl::Kortex(_) => Duration::from_millis(1),
            ArmUrl::SocketCan(_) => crate::bus::CAN_PERIOD,
            ArmUrl::Slcan(_) => crate::bus::one_arm_period(transport::slcan::DEFAULT_BITRATE),
        }
    }

    /// Opens the arm's port (a Kortex arm is reached with `credentials`).
    pub fn open(&self, credentials: &kortex::Credentials) -> Result<ArmPort, OpenError> {
        match self {
            ArmUrl::Kortex(spec) => Ok(kortex::Connection::open(spec, credentials)?.into()),
            ArmUrl::SocketCan(_) | ArmUrl::Slcan(_) => {
                Ok(ArmPort::Can(transport::open(&self.bus_spec())?))
            }
        }
    }

    /// The transport's own spec of a CAN arm (`socketcan:IFACE`, `slcan:PATH`).
    fn bus_spec(&self) -> String {
        match self {
            ArmUrl::SocketCan(iface) => format!("socketcan:{iface}"),
            ArmUrl::Slcan(path) => format!("slcan:{path}"),
            ArmUrl::Kortex(_) => self.to_string(),
        }
    }
}

impl fmt::Display for ArmUrl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ArmUrl::Kortex(s) => write!(f, "kortex://{}:{}:{}", s.host, s.tcp_port, s.udp_port),
            ArmUrl::SocketCan(iface) => write!(f, "socketcan://{iface}"),
            ArmUrl::Slcan(path) => write!(f, "slcan://{path}"),
        }
    }
}

/// An arm's port spec or URL, checked ([`ArmUrl::parse`]). A dry run checks its arms with this.
pub fn check_spec(spec: &str) -> Result<(), UrlError> {
    ArmUrl::parse(spec).map(|_| ())
}

/// Opens a real arm's port from its spec or URL ([`ArmUrl`]); a Kortex arm is reached with
/// `credentials`.
pub fn open(spec: &str, credentials: &kortex::Credentials) -> Result<ArmPort, OpenError> {
    ArmUrl::parse(spec)?.open(credentials)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arm_urls_in_both_forms_and_bad_ones_named() {
        let k = ArmUrl::parse("kortex://10.0.0.2:4000:4001").unwrap();
        assert_eq!(k, ArmUrl::parse("kortex:10.0.0.2:4000:4001").unwrap());
        assert_eq!(k.default_period(), Duration::from_millis(1));
        let can = |url| ArmUrl::parse(url).unwrap().default_period();
        assert_eq!(can("socketcan://can0"), Duration::from_millis(4));
        assert_eq!(can("slcan:///dev/ttyACM0"), Duration::from_millis(5));
        assert_eq!(
            ArmUrl::parse("slcan:/dev/ttyUSB0").unwrap(),
            ArmUrl::Slcan("/dev/ttyUSB0".into())
        );
        for (bad, why) in [
            ("kortex://", "cannot reach arm kortex:"),
            ("slcan://", "the serial device path is empty"),
            ("tcp://host", "unknown arm URL"),
            ("can0", "expected `slcan:/dev/ttyXXX` or `socketcan:IFACE`"),
        ] {
            let e = ArmUrl::parse(bad).unwrap_err().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }
}
