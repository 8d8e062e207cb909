//! Kortex framing: a UDP datagram is one serialized `Frame`; on TCP each frame is preceded by
//! the 8-byte magic and its length (4 bytes, big endian). Error frames surface as [`KortexError`].
//!
//! ```
//! use omcbsa_hw::kortex::codec::{decode_frame, encode_frame, tcp_framed, TcpDecoder};
//! use omcbsa_hw::kortex::header::{uid, Header};
//!
//! let frame = encode_frame(Header::request(7, 1, uid::KEEP_ALIVE, 0), &[]);
//! let back = decode_frame(&frame).unwrap(); // a UDP datagram is the frame alone
//! assert_eq!((back.header.session_id, back.header.function_uid), (7, uid::KEEP_ALIVE));
//! // On TCP, frames arrive in pieces of any size.
//! let wire = tcp_framed(&frame);
//! let mut rx = TcpDecoder::default();
//! rx.push(&wire[..5]);
//! assert_eq!(rx.next_frame().unwrap(), None);
//! rx.push(&wire[5..]);
//! assert_eq!(rx.next_frame().unwrap(), Some(back));
//! ```

use super::header::{FrameType, Header};
use super::proto;
use prost::Message;

/// Starts every frame on TCP.
pub const TCP_MAGIC: [u8; 8] = [0x07, 0x78, 0x45, 0x74, 0x52, 0x6F, 0x4B, 0x07];
/// Bytes before a frame on TCP: the magic and the length.
pub const TCP_PREFIX: usize = 12;
/// The longest frame accepted: the payload length field has 24 bits.
pub const MAX_FRAME: usize = (1 << 24) + 64;

/// A frame, decoded: its header unpacked and its payload.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The header, unpacked.
    pub header: Header,
    /// The payload (a serialized message).
    pub payload: Vec<u8>,
}

/// Bytes that are no Kortex frame.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CodecError {
    /// A TCP frame does not start with the magic.
    #[error("not a Kortex TCP frame: expected the magic 07 78 45 74 52 6F 4B 07, got {0:02x?}")]
    Magic([u8; 8]),
    /// A TCP frame's length is beyond any Kortex frame.
    #[error("a frame of {0} bytes is longer than any Kortex frame ({MAX_FRAME} bytes at most)")]
    TooLong(usize),
    /// The bytes are no `Frame` message.
    #[error("cannot decode a Kortex frame: {0}")]
    Decode(String),
    /// The frame has no header.
    #[error("the frame has no header")]
    NoHeader,
    /// The header's payload length disagrees with the payload.
    #[error("the header says {header} payload bytes, the frame has {actual}")]
    PayloadLength {
        /// The length the header gives.
        header: u32,
        /// The payload's length.
        actual: usize,
    },
}

/// A serialized frame with `header` (its payload length set from `payload`).
pub fn encode_frame(mut header: Header, payload: &[u8]) -> Vec<u8> {
    header.payload_len = payload.len() as u32;
    proto::Frame {
        header: Some(header.pack()),
        payload: payload.to_vec(),
    }
    .encode_to_vec()
}

/// `frame` (serialized) as sent on TCP.
pub fn tcp_framed(frame: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(TCP_PREFIX + frame.len());
    out.extend_from_slice(&TCP_MAGIC);
    out.extend_from_slice(&(frame.len() as u32).to_be_bytes());
    out.extend_from_slice(frame);
    out
}

/// Decodes one serialized frame (a UDP datagram, or a TCP frame without its prefix).
pub fn decode_frame(bytes: &[u8]) -> Result<Frame, CodecError> {
    let f = proto::Frame::decode(bytes).map_err(|e| CodecError::Decode(e.to_string()))?;
    let header = Header::unpack(f.header.as_ref().ok_or(CodecError::NoHeader)?);
    if header.payload_len as usize != f.payload.len() {
        return Err(CodecError::PayloadLength {
            header: header.payload_len,
            actual: f.payload.len(),
        });
    }
    Ok(Frame {
        header,
        payload: f.payload,
    })
}

/// Reassembles TCP frames from reads of any size: a frame split across reads, or several in one.
/// It holds the bytes not yet returned as frames: at most one frame ([`MAX_FRAME`]) and what
/// was pushed after it, as [`TcpDecoder::next_frame`] refuses a longer one.
#[derive(Default)]
pub struct TcpDecoder {
    buf: Vec<u8>,
}

impl TcpDecoder {
    /// Appends bytes read from the stream.
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// The next whole frame, if one has arrived. An error leaves the stream unusable (it has
    /// no way to find the next frame's start).
    pub fn next_frame(&mut self) -> Result<Option<Frame>, CodecError> {
        if self.buf.len() >= TCP_MAGIC.len() && self.buf[..8] != TCP_MAGIC {
            let mut got = [0; 8];
            got.copy_from_slice(&self.buf[..8]);
            return Err(CodecError::Magic(got));
        }
        if self.buf.len() < TCP_PREFIX {
            return Ok(None);
        }
        let len = u32::from_be_bytes([self.buf[8], self.buf[9], self.buf[10], self.buf[11]]);
        let len = len as usize;
        if len > MAX_FRAME {
            return Err(CodecError::TooLong(len));
        }
        if self.buf.len() < TCP_PREFIX + len {
            return Ok(None);
        }
        let frame = decode_frame(&self.buf[TCP_PREFIX..TCP_PREFIX + len]);
        self.buf.drain(..TCP_PREFIX + len);
        frame.map(Some)
    }
}

/// What the arm said was wrong: an error frame.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("the arm refused {rpc}: {} ({}), {} ({}){}", error_name(*.code), .code, sub_error_name(*.sub_code), .sub_code, if .text.is_empty() { String::new() } else { format!(": {}", .text) })]
pub struct KortexError {
    /// The rpc refused (its name).
    pub rpc: &'static str,
    /// Kinova.Api.ErrorCodes.
    pub code: u32,
    /// Kinova.Api.SubErrorCodes.
    pub sub_code: u32,
    /// The arm's own words.
    pub text: String,
}

/// The payload of a response, or the error its frame carries.
pub fn response_payload(frame: Frame) -> Result<Vec<u8>, KortexError> {
    let h = frame.header;
    if h.error == 0 && h.sub_error == 0 {
        return Ok(frame.payload);
    }
    let rpc = super::header::uid::name(h.function_uid);
    // The header's codes stand when the payload is no Error message.
    let e = proto::Error::decode(frame.payload.as_slice()).unwrap_or_default();
    Err(KortexError {
        rpc,
        code: if e.error_code != 0 {
            e.error_code
        } else {
            u32::from(h.error)
        },
        sub_code: if e.error_sub_code != 0 {
            e.error_sub_code
        } else {
            u32::from(h.sub_error)
        },
        text: e.error_sub_string,
    })
}

/// An error frame answering `request` (the mock's side, and tests).
pub fn error_frame(request: &Header, code: u32, sub_code: u32, text: &str) -> Vec<u8> {
    let mut h = *request;
    h.frame_type = FrameType::Response as u8;
    h.error = (code & 0xF) as u8;
    h.sub_error = (sub_code & 0xFFF) as u16;
    let payload = proto::Error {
        error_code: code,
        error_sub_code: sub_code,
        error_sub_string: text.to_string(),
    }
    .encode_to_vec();
    encode_frame(h, &payload)
}

/// Kinova.Api.ErrorCodes (Errors.proto).
pub fn error_name(code: u32) -> &'static str {
    match code {
        0 => "ERROR_NONE",
        1 => "ERROR_PROTOCOL_SERVER",
        2 => "ERROR_PROTOCOL_CLIENT",
        3 => "ERROR_DEVICE",
        4 => "ERROR_INTERNAL",
        _ => "unknown error code",
    }
}

/// Kinova.Api.SubErrorCodes (Errors.proto), the ones a streaming client meets.
pub fn sub_error_name(code: u32) -> &'static str {
    match code {
        0 => "SUB_ERROR_NONE",
        1 => "METHOD_FAILED",
        2 => "UNIMPLEMENTED",
        3 => "INVALID_PARAM",
        4 => "UNSUPPORTED_SERVICE",
        5 => "UNSUPPORTED_METHOD",
        8 => "FRAME_DECODING_ERR",
        12 => "INVALID_SESSION",
        13 => "PAYLOAD_DECODING_ERR",
        15 => "INVALID_PASSWORD",
        16 => "USER_NOT_FOUND",
        21 => "ROBOT_NOT_READY",
        22 => "ROBOT_IN_FAULT",
        25 => "ROBOT_IN_EMERGENCY_STOP",
        _ => "sub-error",
    }
}

#[cfg(test)]
mod tests {
    use super::super::header::uid;
    use super::*;

    /// Kinova's own client, CreateSession as message 1 with admin/admin, 60 s / 2 s.
    const GOLDEN: &str = "07784574526f4b070000002d0a140d0000001115010000001d01000110251500000012150a0561646d696e10e0d4031a0561646d696e20d00f";

    fn hex(bytes: &[u8]) -> String {
        bytes.iter().map(|b| format!("{b:02x}")).collect()
    }

    fn create_session(message_id: u16) -> Vec<u8> {
        let payload = proto::CreateSessionInfo {
            username: "admin".into(),
            password: "admin".into(),
            session_inactivity_timeout: 60000,
            connection_inactivity_timeout: 2000,
        }
        .encode_to_vec();
        encode_frame(
            Header::request(0, message_id, uid::CREATE_SESSION, 0),
            &payload,
        )
    }

    #[test]
    fn create_session_encodes_to_kinovas_golden_bytes_on_tcp_and_udp() {
        let frame = create_session(1);
        assert_eq!(hex(&tcp_framed(&frame)), GOLDEN);
        // A UDP datagram is the frame alone.
        assert_eq!(hex(&frame), GOLDEN[2 * TCP_PREFIX..]);
    }

    #[test]
    fn a_tcp_frame_split_across_reads_and_two_frames_in_one_read_both_decode() {
        let a = tcp_framed(&create_session(1));
        let b = tcp_framed(&create_session(2));
        // Split at every byte: nothing comes out before the last byte, then the frame.
        for cut in 1..a.len() {
            let mut d = TcpDecoder::default();
            d.push(&a[..cut]);
            assert_eq!(d.next_frame().unwrap(), None, "cut at {cut}");
            d.push(&a[cut..]);
            let f = d.next_frame().unwrap().expect("whole frame");
            assert_eq!(f.header.message_id, 1);
            assert_eq!(d.next_frame().unwrap(), None);
        }
        // Two frames and the start of a third in one read.
        let mut d = TcpDecoder::default();
        let mut read = [a.clone(), b.clone()].concat();
        read.extend_from_slice(&a[..5]);
        d.push(&read);
        assert_eq!(d.next_frame().unwrap().unwrap().header.message_id, 1);
        assert_eq!(d.next_frame().unwrap().unwrap().header.message_id, 2);
        assert_eq!(d.next_frame().unwrap(), None);
        d.push(&a[5..]);
        assert_eq!(d.next_frame().unwrap().unwrap().header.message_id, 1);
    }

    #[test]
    fn bad_tcp_bytes_are_errors_naming_what_is_wrong() {
        let mut d = TcpDecoder::default();
        d.push(b"GET / HTTP/1.1\r\n");
        let e = d.next_frame().unwrap_err().to_string();
        assert!(e.contains("expected the magic"), "{e}");
        let mut d = TcpDecoder::default();
        d.push(&TCP_MAGIC);
        d.push(&u32::MAX.to_be_bytes());
        assert!(matches!(d.next_frame(), Err(CodecError::TooLong(_))));
        // A payload length that disagrees with the payload.
        let mut h = Header::request(0, 1, uid::KEEP_ALIVE, 0);
        h.payload_len = 9;
        let f = proto::Frame {
            header: Some(h.pack()),
            payload: vec![1, 2],
        }
        .encode_to_vec();
        let e = decode_frame(&f).unwrap_err().to_string();
        assert!(e.contains("says 9 payload bytes, the frame has 2"), "{e}");
    }

    #[test]
    fn an_error_frame_surfaces_as_an_error_naming_its_code() {
        let request = Header::request(3, 42, uid::REFRESH, 0);
        let bytes = error_frame(&request, 3, 22, "actuator 4 in fault");
        let f = decode_frame(&bytes).unwrap();
        assert_eq!(f.header.kind(), Some(FrameType::Response));
        assert_eq!(f.header.message_id, 42);
        let e = response_payload(f).unwrap_err();
        assert_eq!((e.code, e.sub_code), (3, 22));
        let text = e.to_string();
        assert_eq!(
            text,
            "the arm refused BaseCyclic.Refresh: ERROR_DEVICE (3), ROBOT_IN_FAULT (22): \
             actuator 4 in fault"
        );
        // A plain response is its payload.
        let ok = encode_frame(
            Header {
                frame_type: FrameType::Response as u8,
                ..request
            },
            &[8, 1],
        );
        assert_eq!(response_payload(decode_frame(&ok).unwrap()), Ok(vec![8, 1]));
    }
}
