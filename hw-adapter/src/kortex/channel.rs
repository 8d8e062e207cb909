//! One Kortex link to an arm, TCP or UDP, with its own session: sends requests, receives frames
//! without blocking, and calls an rpc (request, then the response with the same message id).

use super::codec::{self, Frame, TcpDecoder};
use super::header::{uid, FrameType, Header, MessageIds};
use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::time::{Duration, Instant};

/// How long a TCP connection may take to open.
const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);
/// How often a waiting call looks for its answer.
const CALL_POLL: Duration = Duration::from_micros(100);

enum Io {
    Tcp { stream: TcpStream, rx: TcpDecoder },
    Udp(UdpSocket),
}

/// Why a link to an arm could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The TCP connection (configuration rpcs) could not be made or set up.
    #[error("cannot connect to {addr} (TCP): {source}")]
    Tcp {
        /// The arm's TCP address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
    /// The UDP socket (cyclic rpcs) could not be opened or connected.
    #[error("cannot open a UDP socket to {addr}: {source}")]
    Udp {
        /// The arm's UDP address.
        addr: SocketAddr,
        /// Why.
        source: std::io::Error,
    },
}

/// One link to an arm, TCP or UDP, non-blocking.
pub struct Channel {
    io: Io,
    /// The arm's address, for messages.
    pub addr: SocketAddr,
    /// Set by the CreateSession response (0 before).
    pub session: u16,
    ids: MessageIds,
    /// When this link last sent a frame (KeepAlive is due when it has been idle too long).
    pub last_sent: Instant,
    /// A frame received while a call waited for another; handed out by the next [`Channel::recv`].
    stash: Vec<Frame>,
}

impl Channel {
    /// Connects to the arm's TCP port (at most 2 s).
    pub fn tcp(addr: SocketAddr) -> Result<Self, OpenError> {
        let fail = |source| OpenError::Tcp { addr, source };
        let stream = TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT).map_err(fail)?;
        stream
            .set_nodelay(true)
            .and_then(|()| stream.set_nonblocking(true))
            .map_err(fail)?;
        Ok(Self::new(
            Io::Tcp {
                stream,
                rx: TcpDecoder::default(),
            },
            addr,
        ))
    }

    /// A UDP socket connected to the arm's UDP port.
    pub fn udp(addr: SocketAddr) -> Result<Self, OpenError> {
        let local: SocketAddr = if addr.is_ipv4() {
            ([0, 0, 0, 0], 0).into()
        } else {
            (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
        };
        let socket = UdpSocket::bind(local)
            .and_then(|s| s.connect(addr).map(|()| s))
            .and_then(|s| s.set_nonblocking(true).map(|()| s))
            .map_err(|source| OpenError::Udp { addr, source })?;
        Ok(Self::new(Io::Udp(socket), addr))
    }

    fn new(io: Io, addr: SocketAddr) -> Self {
        Self {
            io,
            addr,
            session: 0,
            ids: MessageIds::default(),
            last_sent: Instant::now(),
            stash: Vec::new(),
        }
    }

    /// "TCP" or "UDP", for messages.
    pub fn kind(&self) -> &'static str {
        match self.io {
            Io::Tcp { .. } => "TCP",
            Io::Udp(_) => "UDP",
        }
    }

    /// Sends a request for `function_uid` with `payload`; returns its message id.
    pub fn send(&mut self, function_uid: u32, payload: &[u8]) -> Result<u16, String> {
        let id = self.ids.next_id();
        let frame =
            codec::encode_frame(Header::request(self.session, id, function_uid, 0), payload);
        let (kind, addr) = (self.kind(), self.addr);
        let fail =
            |e: std::io::Error| format!("{kind} {addr}: sending {}: {e}", uid::name(function_uid));
        match &mut self.io {
            Io::Tcp { stream, .. } => {
                write_all(stream, &codec::tcp_framed(&frame)).map_err(fail)?
            }
            Io::Udp(s) => {
                let n = s.send(&frame).map_err(fail)?;
                if n != frame.len() {
                    return Err(format!("{kind} {addr}: datagram truncated"));
                }
            }
        }
        self.last_sent = Instant::now();
        Ok(id)
    }

    /// The next frame received, if any (does not wait).
    pub fn recv(&mut self) -> Result<Option<Frame>, String> {
        if !self.stash.is_empty() {
            return Ok(Some(self.stash.remove(0)));
        }
        let (kind, addr) = (self.kind(), self.addr);
        let mut buf = [0u8; 65536];
        match &mut self.io {
            Io::Tcp { stream, rx } => loop {
                if let Some(f) = rx.next_frame().map_err(|e| format!("{kind} {addr}: {e}"))? {
                    return Ok(Some(f));
                }
                match stream.read(&mut buf) {
                    Ok(0) => return Err(format!("the arm closed the TCP connection ({addr})")),
                    Ok(n) => rx.push(&buf[..n]),
                    Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(None),
                    Err(e) if e.kind() == ErrorKind::Interrupted => {}
                    Err(e) => return Err(format!("{kind} {addr}: {e}")),
                }
            },
            Io::Udp(s) => match s.recv(&mut buf) {
                Ok(n) => codec::decode_frame(&buf[..n])
                    .map(Some)
                    .map_err(|e| format!("{kind} {addr}: {e}")),
                Err(e) if e.kind() == ErrorKind::WouldBlock => Ok(None),
                Err(e) => Err(format!("{kind} {addr}: {e}")),
            },
        }
    }

    /// Calls an rpc and waits at most `timeout` for its response: its payload, or the error the
    /// arm answered with (no answer is an error too). Other frames received meanwhile are kept
    /// for [`Channel::recv`].
    pub fn call(
        &mut self,
        function_uid: u32,
        payload: &[u8],
        timeout: Duration,
    ) -> Result<(Header, Vec<u8>), String> {
        let id = self.send(function_uid, payload)?;
        self.answer(id, timeout)?.ok_or_else(|| {
            format!(
                "the arm did not answer {} on {} {} within {timeout:?}",
                uid::name(function_uid),
                self.kind(),
                self.addr
            )
        })
    }

    /// Waits at most `timeout` (zero: looks once) for the response to request `id`: its
    /// payload, `None` if none came, or the error the arm answered with. Other frames received
    /// meanwhile are kept for [`Channel::recv`].
    pub fn answer(
        &mut self,
        id: u16,
        timeout: Duration,
    ) -> Result<Option<(Header, Vec<u8>)>, String> {
        let deadline = Instant::now() + timeout;
        let mut others = Vec::new();
        let result = loop {
            match self.recv() {
                Ok(Some(f))
                    if f.header.message_id == id
                        && f.header.kind() == Some(FrameType::Response) =>
                {
                    let h = f.header;
                    break codec::response_payload(f)
                        .map(|p| Some((h, p)))
                        .map_err(|e| e.to_string());
                }
                Ok(Some(f)) => others.push(f),
                Ok(None) if Instant::now() >= deadline => break Ok(None),
                Ok(None) => std::thread::sleep(CALL_POLL),
                Err(e) => break Err(e),
            }
        };
        // Frames received while waiting come first, in order, before any later ones.
        others.append(&mut self.stash);
        self.stash = others;
        result
    }
}

/// Writes all of `bytes` to a non-blocking stream, waiting out a full send buffer.
fn write_all(stream: &mut TcpStream, mut bytes: &[u8]) -> std::io::Result<()> {
    let deadline = Instant::now() + Duration::from_millis(100);
    while !bytes.is_empty() {
        match stream.write(bytes) {
            Ok(0) => return Err(ErrorKind::WriteZero.into()),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::WouldBlock && Instant::now() < deadline => {
                std::thread::sleep(CALL_POLL)
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(())
}
