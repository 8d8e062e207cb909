//! SLCAN: the ASCII serial protocol of Lawicel-compatible USB-CAN adapters (CANable, CANUSB...).
//!
//! Host to adapter: `C\r` close, `Sn\r` bitrate, `O\r` open, `tIIILDD..\r` transmit a standard
//! frame. The adapter answers a command with `\r` (ok) or `\x07` (bell: error), may acknowledge a
//! transmission with `z\r`, and reports received frames as `tIIILDD..\r`. Works on any serial
//! device or pseudo-terminal ([`SlcanTransport::open`]), and on a Unix socket
//! ([`SlcanTransport::connect`]: an adapter simulated by another process, such as the mock arms;
//! unlike a pseudo-terminal, whose bytes cross the kernel in a worker thread that a loaded
//! machine delays by tens of milliseconds, a socket hands them over at once).

use super::{Transport, TransportError};
use crate::frame::CanFrame;
use serialport::SerialPort;
use std::io::{self, ErrorKind, Read, Write};
use std::os::unix::net::UnixStream;
use std::time::{Duration, Instant};

/// The bitrate `slcan:` buses are opened at, bit/s.
pub const DEFAULT_BITRATE: u32 = 500_000;

/// Time the adapter gets to acknowledge each set-up command.
const COMMAND_ACK_TIMEOUT: Duration = Duration::from_millis(500);

/// The `Sn` command of a bitrate in bit/s.
fn bitrate_command(bitrate: u32) -> Option<&'static str> {
    Some(match bitrate {
        10_000 => "S0",
        20_000 => "S1",
        50_000 => "S2",
        100_000 => "S3",
        125_000 => "S4",
        250_000 => "S5",
        500_000 => "S6",
        800_000 => "S7",
        1_000_000 => "S8",
        _ => return None,
    })
}

/// `tIIILDD..\r` for a frame.
pub fn encode(frame: &CanFrame) -> String {
    let mut s = format!("t{:03X}{}", frame.id(), frame.data().len());
    for b in frame.data() {
        s.push_str(&format!("{b:02X}"));
    }
    s.push('\r');
    s
}

/// What one line from the adapter (without its `\r`) says.
#[derive(Debug, PartialEq, Eq)]
pub enum Reply {
    /// `\r` alone, `z` or `Z`: a command or transmission was accepted.
    Ack,
    /// A received standard data frame.
    Frame(CanFrame),
    /// Extended or remote frames: valid SLCAN, but nothing CANopen uses.
    Ignored,
}

/// Parses one line from the adapter.
pub fn decode(line: &[u8]) -> Result<Reply, String> {
    let text = std::str::from_utf8(line).map_err(|_| format!("non-ASCII line {line:?}"))?;
    let bad = || format!("malformed SLCAN line {text:?}");
    match text.as_bytes().first() {
        None | Some(b'z') | Some(b'Z') => Ok(Reply::Ack),
        Some(b'T') | Some(b'r') | Some(b'R') => Ok(Reply::Ignored),
        Some(b't') => {
            let id = text
                .get(1..4)
                .and_then(|h| u16::from_str_radix(h, 16).ok())
                .ok_or_else(bad)?;
            let len = text
                .get(4..5)
                .and_then(|h| h.parse::<usize>().ok())
                .filter(|&l| l <= 8)
                .ok_or_else(bad)?;
            // Some adapters append a 4-digit timestamp: accept and ignore it.
            let hex = text.get(5..).ok_or_else(bad)?;
            if hex.len() != 2 * len && hex.len() != 2 * len + 4 {
                return Err(bad());
            }
            let mut data = [0u8; 8];
            for (i, d) in data.iter_mut().take(len).enumerate() {
                *d = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16).map_err(|_| bad())?;
            }
            CanFrame::new(id, &data[..len])
                .map(Reply::Frame)
                .ok_or_else(bad)
        }
        Some(_) => Err(bad()),
    }
}

/// The byte stream an adapter is reached on: a serial line or a Unix socket.
trait Line: Read + Write + Send {
    /// The longest a read or a write may wait from here on.
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()>;
}

impl Line for Box<dyn SerialPort> {
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        SerialPort::set_timeout(self.as_mut(), timeout).map_err(io::Error::other)
    }
}

/// A Unix socket with a time-out kept by `poll(2)` before each read and write: a socket's own
/// time-outs (`SO_RCVTIMEO`) count in the kernel's ticks, so a 1 ms wait lasts up to 4-10 ms,
/// and a thread polling its bus would see the other arms' faults that much later.
struct Socket {
    stream: UnixStream,
    timeout: Duration,
}

impl Socket {
    fn new(stream: UnixStream) -> io::Result<Self> {
        stream.set_nonblocking(true)?;
        Ok(Self {
            stream,
            timeout: COMMAND_ACK_TIMEOUT,
        })
    }

    /// Waits until the socket is ready for `events`, at most the time-out.
    fn ready(&self, events: libc::c_short) -> io::Result<()> {
        use std::os::fd::AsRawFd;
        let mut fd = libc::pollfd {
            fd: self.stream.as_raw_fd(),
            events,
            revents: 0,
        };
        let ms = self
            .timeout
            .as_micros()
            .div_ceil(1000)
            .min(i32::MAX as u128) as i32;
        // SAFETY: one valid pollfd, for the duration of the call.
        match unsafe { libc::poll(&mut fd, 1, ms) } {
            -1 => Err(io::Error::last_os_error()),
            0 => Err(io::Error::from(ErrorKind::TimedOut)),
            _ => Ok(()),
        }
    }
}

impl Read for Socket {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.ready(libc::POLLIN)?;
        self.stream.read(buf)
    }
}

impl Write for Socket {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.ready(libc::POLLOUT)?;
        self.stream.write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.stream.flush()
    }
}

impl Line for Socket {
    fn set_timeout(&mut self, timeout: Duration) -> io::Result<()> {
        self.timeout = timeout;
        Ok(())
    }
}

/// A CAN bus behind an SLCAN adapter on a serial line or a Unix socket.
pub struct SlcanTransport {
    name: String,
    bitrate: u32,
    port: Box<dyn Line>,
    /// Bytes read but not yet split into lines.
    pending: Vec<u8>,
}

impl SlcanTransport {
    /// Opens the adapter at `path` (serial device or pty), sets `bitrate` and opens the channel.
    pub fn open(path: &str, bitrate: u32) -> Result<Self, TransportError> {
        let name = format!("slcan:{path}");
        let speed = speed_command(&name, bitrate)?;
        // The serial baud rate is irrelevant for USB adapters and ptys; 115200 is customary.
        let port = serialport::new(path, 115_200)
            .timeout(COMMAND_ACK_TIMEOUT)
            .open()
            .map_err(|e| open_error(&name, e.to_string()))?;
        Self::start(name, Box::new(port), speed, bitrate)
    }

    /// Connects to the adapter listening on the Unix socket `path`, sets `bitrate` and opens
    /// the channel.
    pub fn connect(path: &str, bitrate: u32) -> Result<Self, TransportError> {
        let name = format!("slcan-unix:{path}");
        let speed = speed_command(&name, bitrate)?;
        let socket = UnixStream::connect(path)
            .and_then(Socket::new)
            .map_err(|e| open_error(&name, e.to_string()))?;
        Self::start(name, Box::new(socket), speed, bitrate)
    }

    /// Sets the adapter at the other end of `port` up: closed, at `bitrate` (its command
    /// `speed`), opened.
    fn start(
        name: String,
        port: Box<dyn Line>,
        speed: &str,
        bitrate: u32,
    ) -> Result<Self, TransportError> {
        let mut t = Self {
            name,
            bitrate,
            port,
            pending: Vec::new(),
        };
        // Close first in case a previous user left the channel open; a closed adapter answers
        // this with a bell, which is fine. Its one reply is awaited (a late one would be taken
        // for the next command's), then anything else left is drained.
        t.write_all(b"C\r", COMMAND_ACK_TIMEOUT)?;
        let _closed_or_bell = t.next_line(Instant::now() + COMMAND_ACK_TIMEOUT);
        t.drain_replies(Duration::from_millis(20))?;
        t.command(speed)?;
        t.command("O")?;
        Ok(t)
    }

    /// Sends a set-up command and waits for the adapter's acknowledgement.
    fn command(&mut self, cmd: &str) -> Result<(), TransportError> {
        self.write_all(format!("{cmd}\r").as_bytes(), COMMAND_ACK_TIMEOUT)?;
        let deadline = Instant::now() + COMMAND_ACK_TIMEOUT;
        loop {
            match self.next_line(deadline) {
                Ok(Some(line)) if line.is_empty() => return Ok(()),
                Ok(Some(_)) => continue,
                Ok(None) => {
                    return Err(TransportError::Open {
                        bus: self.name.clone(),
                        reason: format!(
                            "adapter did not acknowledge `{cmd}` within {COMMAND_ACK_TIMEOUT:?} \
                             (is an SLCAN adapter attached?)"
                        ),
                    })
                }
                Err(e) => {
                    return Err(TransportError::Open {
                        bus: self.name.clone(),
                        reason: format!("adapter rejected `{cmd}`: {e}"),
                    })
                }
            }
        }
    }

    fn drain_replies(&mut self, wait: Duration) -> Result<(), TransportError> {
        let deadline = Instant::now() + wait;
        while let Ok(Some(_)) = self.next_line(deadline) {}
        self.pending.clear();
        Ok(())
    }

    fn write_all(&mut self, bytes: &[u8], timeout: Duration) -> Result<(), TransportError> {
        self.port
            .set_timeout(timeout)
            .map_err(|e| self.io(e.to_string()))?;
        self.port
            .write_all(bytes)
            .map_err(|e| self.io(e.to_string()))
    }

    fn io(&self, reason: String) -> TransportError {
        TransportError::Io {
            bus: self.name.clone(),
            reason,
        }
    }

    /// The next line from the adapter (without `\r`), `None` at the deadline. A bell is an
    /// error: the adapter refused the last command or transmission.
    fn next_line(&mut self, deadline: Instant) -> Result<Option<Vec<u8>>, TransportError> {
        loop {
            if let Some(pos) = self.pending.iter().position(|&b| b == b'\r' || b == 7) {
                let bell = self.pending[pos] == 7;
                let line: Vec<u8> = self.pending.drain(..=pos).take(pos).collect();
                if bell {
                    return Err(self.io("adapter answered with a bell (error)".into()));
                }
                return Ok(Some(line));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            // A zero timeout would block forever in some serial backends: poll for 1 ms at least.
            self.port
                .set_timeout(left.max(Duration::from_millis(1)))
                .map_err(|e| self.io(e.to_string()))?;
            let mut buf = [0u8; 512];
            match self.port.read(&mut buf) {
                Ok(0) => {
                    return Err(TransportError::Closed {
                        bus: self.name.clone(),
                    })
                }
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => {
                    if Instant::now() >= deadline {
                        return Ok(None);
                    }
                }
                Err(e) => return Err(self.io(e.to_string())),
            }
        }
    }
}

/// The `Sn` command of `bitrate`, or the error that names the bus.
fn speed_command(bus: &str, bitrate: u32) -> Result<&'static str, TransportError> {
    bitrate_command(bitrate)
        .ok_or_else(|| open_error(bus, format!("unsupported bitrate {bitrate} bit/s")))
}

fn open_error(bus: &str, reason: String) -> TransportError {
    TransportError::Open {
        bus: bus.to_string(),
        reason,
    }
}

impl Transport for SlcanTransport {
    fn name(&self) -> &str {
        &self.name
    }

    fn bitrate(&self) -> u32 {
        self.bitrate
    }

    fn send(&mut self, frame: &CanFrame, timeout: Duration) -> Result<(), TransportError> {
        self.port
            .set_timeout(timeout)
            .map_err(|e| self.io(e.to_string()))?;
        match self.port.write_all(encode(frame).as_bytes()) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == ErrorKind::TimedOut => Err(TransportError::SendTimeout {
                bus: self.name.clone(),
                frame: *frame,
                timeout,
            }),
            Err(e) => Err(self.io(e.to_string())),
        }
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, TransportError> {
        let deadline = Instant::now() + timeout;
        while let Some(line) = self.next_line(deadline)? {
            match decode(&line).map_err(|e| self.io(e))? {
                Reply::Frame(f) => return Ok(Some(f)),
                Reply::Ack | Reply::Ignored => {}
            }
        }
        Ok(None)
    }
}

impl Drop for SlcanTransport {
    fn drop(&mut self) {
        // Best effort: leave the adapter's channel closed.
        let _ = self.port.write_all(b"C\r");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_decode_round_trip() {
        let f = CanFrame::new(0x203, &[0x10, 0x00, 0xFF, 0x7F, 0x0F, 0x00]).unwrap();
        let line = encode(&f);
        assert_eq!(line, "t20361000FF7F0F00\r");
        assert_eq!(decode(line.trim_end().as_bytes()).unwrap(), Reply::Frame(f));
        let empty = CanFrame::new(0x080, &[]).unwrap();
        assert_eq!(decode(b"t0800").unwrap(), Reply::Frame(empty));
    }

    #[test]
    fn decode_acks_ignores_and_rejects() {
        assert_eq!(decode(b"").unwrap(), Reply::Ack);
        assert_eq!(decode(b"z").unwrap(), Reply::Ack);
        assert_eq!(decode(b"T123456780").unwrap(), Reply::Ignored);
        // timestamped frame
        assert!(matches!(decode(b"t1812AABB1234").unwrap(), Reply::Frame(_)));
        for bad in [&b"t18"[..], b"t1819AA", b"t181AAB", b"t18G0", b"x"] {
            assert!(decode(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn unsupported_bitrate_and_missing_device_are_clear_errors() {
        let e = SlcanTransport::open("/dev/null", 42)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("unsupported bitrate 42"), "{e}");
        let e = SlcanTransport::open("/dev/does-not-exist", DEFAULT_BITRATE)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("slcan:/dev/does-not-exist"), "{e}");
    }
}
