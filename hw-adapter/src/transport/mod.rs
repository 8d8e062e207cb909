//! CAN frame transports: one bus per arm. Implementations: SLCAN over a serial line or
//! pseudo-terminal, and Linux SocketCAN (feature `socketcan`); the in-process bus of the
//! simulated arms is `omcbsa_mock::transport`.

pub mod slcan;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan;
mod spec;

pub use spec::{open, BusSpec};

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
    /// The bus's bitrate, bit/s: what the load check ([`crate::bus`]) counts its capacity
    /// with.
    fn bitrate(&self) -> u32;
    /// Queues `frame` for transmission, waiting at most `timeout` for room.
    fn send(&mut self, frame: &CanFrame, timeout: Duration) -> Result<(), TransportError>;
    /// The next received frame, or `None` if none arrived within `timeout` (a zero timeout polls).
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, TransportError>;
}

/// Buses paired with the names of the arms on them, as [`crate::Executor::new`] takes them.
pub type ArmBuses = Vec<(String, Box<dyn Transport>)>;
