//! In-process mock bus: two connected ends, one for the host, one for a simulated device.

use super::{ArmBuses, Transport, TransportError};
use crate::frame::CanFrame;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::time::Duration;

/// One end of an in-process CAN bus; what one end sends, the other receives. Frames wait in
/// an unbounded queue until the other end reads them (memory grows with what it leaves
/// unread); once one end is dropped, the other's sends and receives are
/// [`TransportError::Closed`].
///
/// ```
/// use omcbsa_hw::transport::mock::MockTransport;
/// use omcbsa_hw::{CanFrame, Transport, TransportError};
/// use std::time::Duration;
///
/// let (mut host, mut drive) = MockTransport::pair("left");
/// let sync = CanFrame::new(0x080, &[]).unwrap();
/// host.send(&sync, Duration::ZERO)?;
/// assert_eq!(drive.recv(Duration::from_millis(10))?, Some(sync));
/// assert_eq!(drive.recv(Duration::ZERO)?, None); // nothing more: polls without waiting
/// drop(host);
/// assert!(matches!(drive.recv(Duration::ZERO), Err(TransportError::Closed { .. })));
/// # Ok::<(), TransportError>(())
/// ```
pub struct MockTransport {
    name: String,
    tx: Sender<CanFrame>,
    rx: Receiver<CanFrame>,
}

impl MockTransport {
    /// Two connected ends named `mock:NAME` (host side first).
    pub fn pair(name: &str) -> (Self, Self) {
        let (a_tx, b_rx) = channel();
        let (b_tx, a_rx) = channel();
        let name = format!("mock:{name}");
        (
            Self {
                name: name.clone(),
                tx: a_tx,
                rx: a_rx,
            },
            Self {
                name,
                tx: b_tx,
                rx: b_rx,
            },
        )
    }

    /// One mock bus per arm: the host ends, named after the arms (for an executor), and the
    /// device ends, in the same order (for the test to read or answer).
    pub fn buses(arms: &[&str]) -> (ArmBuses, Vec<MockTransport>) {
        arms.iter()
            .map(|name| {
                let (host, device) = Self::pair(name);
                (
                    (name.to_string(), Box::new(host) as Box<dyn Transport>),
                    device,
                )
            })
            .unzip()
    }

    /// Every frame received so far, without waiting.
    pub fn drain(&mut self) -> Vec<CanFrame> {
        self.rx.try_iter().collect()
    }

    fn closed(&self) -> TransportError {
        TransportError::Closed {
            bus: self.name.clone(),
        }
    }
}

impl Transport for MockTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, frame: &CanFrame, _timeout: Duration) -> Result<(), TransportError> {
        self.tx.send(*frame).map_err(|_| self.closed())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, TransportError> {
        if timeout.is_zero() {
            return match self.rx.try_recv() {
                Ok(f) => Ok(Some(f)),
                Err(TryRecvError::Empty) => Ok(None),
                Err(TryRecvError::Disconnected) => Err(self.closed()),
            };
        }
        match self.rx.recv_timeout(timeout) {
            Ok(f) => Ok(Some(f)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(self.closed()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_cross_between_ends() {
        let (mut host, mut dev) = MockTransport::pair("a");
        let f = CanFrame::new(0x80, &[]).unwrap();
        host.send(&f, Duration::ZERO).unwrap();
        assert_eq!(dev.recv(Duration::from_millis(10)).unwrap(), Some(f));
        assert_eq!(dev.recv(Duration::ZERO).unwrap(), None);
        drop(host);
        assert!(matches!(
            dev.recv(Duration::ZERO),
            Err(TransportError::Closed { .. })
        ));
    }
}
