//! CAN frame transports: one bus per arm. Implementations: SLCAN over a serial line or
//! pseudo-terminal, Linux SocketCAN (feature `socketcan`), and an in-process mock.

pub mod mock;
pub mod slcan;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;

use crate::frame::CanFrame;
use std::time::Duration;

#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    #[error("cannot open CAN bus {bus}: {reason}")]
    Open { bus: String, reason: String },
    #[error("CAN bus {bus}: sending {frame} timed out after {timeout:?}")]
    SendTimeout {
        bus: String,
        frame: CanFrame,
        timeout: Duration,
    },
    #[error("CAN bus {bus}: {reason}")]
    Io { bus: String, reason: String },
    #[error("CAN bus {bus} is closed")]
    Closed { bus: String },
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

/// Opens a bus from a spec `slcan:PATH` or `socketcan:IFACE` (the `--arm NAME=SPEC` syntax).
pub fn open(spec: &str) -> Result<Box<dyn Transport>, TransportError> {
    let bad = |reason: &str| TransportError::Open {
        bus: spec.to_string(),
        reason: reason.to_string(),
    };
    match spec.split_once(':') {
        Some(("slcan", path)) if !path.is_empty() => Ok(Box::new(slcan::SlcanTransport::open(
            path,
            slcan::DEFAULT_BITRATE,
        )?)),
        #[cfg(all(feature = "socketcan", target_os = "linux"))]
        Some(("socketcan", iface)) if !iface.is_empty() => {
            Ok(Box::new(socketcan::SocketCanTransport::open(iface)?))
        }
        #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
        Some(("socketcan", _)) => Err(bad(
            "SocketCAN support is not built in (Linux with the `socketcan` feature only)",
        )),
        _ => Err(bad(
            "expected `slcan:/dev/ttyXXX` or `socketcan:IFACE` (e.g. socketcan:can0)",
        )),
    }
}
