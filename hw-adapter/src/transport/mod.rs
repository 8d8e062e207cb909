//! CAN frame transports: one bus per arm. Implementations: SLCAN over a serial line or
//! pseudo-terminal, Linux SocketCAN (feature `socketcan`), and an in-process mock.

pub mod mock;
pub mod slcan;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;

use crate::frame::CanFrame;
use std::time::Duration;

/// What went wrong on a bus; each names the bus.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// The bus could not be opened (or its spec is wrong).
    #[error("cannot open CAN bus {bus}: {reason}")]
    Open {
        /// The bus.
        bus: String,
        /// Why.
        reason: String,
    },
    /// No room on the bus for a frame within the time allowed.
    #[error("CAN bus {bus}: sending {frame} timed out after {timeout:?}")]
    SendTimeout {
        /// The bus.
        bus: String,
        /// The frame not sent.
        frame: CanFrame,
        /// How long it waited.
        timeout: Duration,
    },
    /// Reading or writing the bus failed.
    #[error("CAN bus {bus}: {reason}")]
    Io {
        /// The bus.
        bus: String,
        /// Why.
        reason: String,
    },
    /// The other end is gone.
    #[error("CAN bus {bus} is closed")]
    Closed {
        /// The bus.
        bus: String,
    },
}

/// A CAN bus. `Send` so that each arm's bus can be driven by its own thread.
pub trait Transport: Send {
    /// The bus, as a person would name it (`slcan:/dev/ttyACM0`, `socketcan:can0`).
    fn name(&self) -> &str;
    /// Queues `frame` for transmission, waiting at most `timeout` for room.
    fn send(&mut self, frame: &CanFrame, timeout: Duration) -> Result<(), TransportError>;
    /// The next received frame, or `None` if none arrived within `timeout` (a zero timeout polls).
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, TransportError>;
}

/// Buses paired with the names of the arms on them, as [`crate::Executor::new`] takes them.
pub type ArmBuses = Vec<(String, Box<dyn Transport>)>;

/// A bus spec, checked: what [`open`] opens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusSpec<'a> {
    /// A serial-line CAN adapter at this device path.
    Slcan(&'a str),
    /// A SocketCAN interface.
    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    SocketCan(&'a str),
}

impl<'a> BusSpec<'a> {
    /// Parses `slcan:PATH` or `socketcan:IFACE` (the `--arm NAME=SPEC` syntax), refusing what
    /// no live run could open: an empty path, a path with a NUL byte, an interface name Linux
    /// would not accept (1 to 15 bytes, no `/`, `:`, whitespace, not `.` or `..`), SocketCAN
    /// in a build without it. A dry run checks its buses with this.
    pub fn parse(spec: &'a str) -> Result<Self, TransportError> {
        let bad = |reason: &str| TransportError::Open {
            bus: spec.to_string(),
            reason: reason.to_string(),
        };
        match spec.split_once(':') {
            Some(("slcan", "")) => Err(bad("the serial device path is empty")),
            Some(("slcan", path)) if path.contains('\0') => {
                Err(bad("the serial device path contains a NUL byte"))
            }
            Some(("slcan", path)) => Ok(BusSpec::Slcan(path)),
            #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
            Some(("socketcan", _)) => Err(bad(
                "SocketCAN support is not built in (Linux with the `socketcan` feature only)",
            )),
            #[cfg(all(feature = "socketcan", target_os = "linux"))]
            Some(("socketcan", iface)) => {
                let valid = (1..=15).contains(&iface.len())
                    && iface != "."
                    && iface != ".."
                    && !iface
                        .chars()
                        .any(|c| c == '/' || c == ':' || c == '\0' || c.is_whitespace());
                if valid {
                    Ok(BusSpec::SocketCan(iface))
                } else {
                    Err(bad(
                        "not a network interface name (1 to 15 bytes, no '/', ':' or spaces)",
                    ))
                }
            }
            _ => Err(bad(
                "expected `slcan:/dev/ttyXXX` or `socketcan:IFACE` (e.g. socketcan:can0)",
            )),
        }
    }
}

/// Opens a bus from a spec `slcan:PATH` or `socketcan:IFACE` ([`BusSpec::parse`]).
pub fn open(spec: &str) -> Result<Box<dyn Transport>, TransportError> {
    match BusSpec::parse(spec)? {
        BusSpec::Slcan(path) => Ok(Box::new(slcan::SlcanTransport::open(
            path,
            slcan::DEFAULT_BITRATE,
        )?)),
        #[cfg(all(feature = "socketcan", target_os = "linux"))]
        BusSpec::SocketCan(iface) => Ok(Box::new(socketcan::SocketCanTransport::open(iface)?)),
    }
}

#[cfg(test)]
mod spec_tests {
    use super::*;

    #[test]
    fn bus_specs_a_live_run_could_never_open_are_refused() {
        assert_eq!(
            BusSpec::parse("slcan:/dev/ttyACM0").unwrap(),
            BusSpec::Slcan("/dev/ttyACM0")
        );
        for bad in [
            "mock",
            "slcan:",
            "slcan:a\0b",
            "can0",
            "tcp:host",
            "socketcan:",
        ] {
            let e = BusSpec::parse(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("cannot open CAN bus {bad}:")), "{e}");
        }
        #[cfg(all(feature = "socketcan", target_os = "linux"))]
        {
            assert_eq!(
                BusSpec::parse("socketcan:can0").unwrap(),
                BusSpec::SocketCan("can0")
            );
            for bad in [
                "socketcan:a/b",
                "socketcan:..",
                "socketcan:can 0",
                "socketcan:abcdefghijklmnop",
            ] {
                assert!(BusSpec::parse(bad).is_err(), "{bad}");
            }
        }
    }
}
