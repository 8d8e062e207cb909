//! Linux SocketCAN (`can0`, `vcan0`, ...) through the `socketcan` crate.

use super::{Transport, TransportError};
use crate::frame::CanFrame;
use socketcan::{CanSocket, EmbeddedFrame, Id, Socket, StandardId};
use std::io::ErrorKind;
use std::time::Duration;

/// A Linux SocketCAN interface.
pub struct SocketCanTransport {
    name: String,
    socket: CanSocket,
}

impl SocketCanTransport {
    /// Opens interface `iface` (it must be up).
    pub fn open(iface: &str) -> Result<Self, TransportError> {
        let name = format!("socketcan:{iface}");
        let socket = CanSocket::open(iface).map_err(|e| TransportError::Open {
            bus: name.clone(),
            reason: format!("{e} (is the interface up? `ip link set {iface} up`)"),
        })?;
        Ok(Self { name, socket })
    }

    fn io(&self, e: std::io::Error) -> TransportError {
        TransportError::Io {
            bus: self.name.clone(),
            reason: e.to_string(),
        }
    }
}

impl Transport for SocketCanTransport {
    fn name(&self) -> &str {
        &self.name
    }

    /// The interface's bitrate is set outside the process (`ip link set can0 type can bitrate
    /// 1000000`) and read back only through netlink, which this transport does not speak:
    /// counted as [`crate::bus::DEFAULT_BITRATE`] (1 Mbit/s, classic CAN's fastest), so an
    /// interface set slower is loaded more than the load check says.
    fn bitrate(&self) -> u32 {
        crate::bus::DEFAULT_BITRATE
    }

    fn send(&mut self, frame: &CanFrame, timeout: Duration) -> Result<(), TransportError> {
        let id = StandardId::new(frame.id()).ok_or_else(|| TransportError::Io {
            bus: self.name.clone(),
            reason: format!("identifier {:#x} is not 11-bit", frame.id()),
        })?;
        let out = socketcan::CanFrame::new(id, frame.data()).ok_or_else(|| TransportError::Io {
            bus: self.name.clone(),
            reason: format!("cannot build frame {frame}"),
        })?;
        // SO_SNDTIMEO of zero means "block forever": wait at least 1 ms.
        self.socket
            .set_write_timeout(timeout.max(Duration::from_millis(1)))
            .map_err(|e| self.io(e))?;
        match self.socket.write_frame(&out) {
            Ok(()) => Ok(()),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                Err(TransportError::SendTimeout {
                    bus: self.name.clone(),
                    frame: *frame,
                    timeout,
                })
            }
            Err(e) => Err(self.io(e)),
        }
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, TransportError> {
        loop {
            let frame = match self.socket.read_frame_timeout(timeout) {
                Ok(f) => f,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Ok(None)
                }
                Err(e) => return Err(self.io(e)),
            };
            match frame {
                socketcan::CanFrame::Data(d) => {
                    // Extended-id frames are not CANopen traffic: skip them.
                    if let Id::Standard(id) = d.id() {
                        return Ok(CanFrame::new(id.as_raw(), d.data()));
                    }
                }
                socketcan::CanFrame::Remote(_) => {}
                socketcan::CanFrame::Error(e) => {
                    return Err(TransportError::Io {
                        bus: self.name.clone(),
                        reason: format!("bus error frame: {e:?}"),
                    })
                }
            }
        }
    }
}
