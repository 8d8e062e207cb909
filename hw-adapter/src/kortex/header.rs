//! The Kortex frame header: four fixed32 fields, each bit-packed (Kortex API 2.x, Frame.proto).

use super::proto;

/// Header version the Gen3 speaks (frame_info and service_info bits 31-28).
pub const HEADER_VERSION: u8 = 1;

/// Frame types (frame_info bits 27-24).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameType {
    /// A call.
    Request = 1,
    /// The answer to a call (with the request's message id), or an error frame.
    Response = 3,
    /// Sent by the arm unasked.
    Notification = 5,
    /// A ping.
    Ping = 7,
    /// The answer to a ping.
    Pong = 8,
}

impl FrameType {
    /// The frame type of 4 bits of `frame_info`, if they name one.
    pub fn from_bits(bits: u8) -> Option<Self> {
        Some(match bits {
            1 => FrameType::Request,
            3 => FrameType::Response,
            5 => FrameType::Notification,
            7 => FrameType::Ping,
            8 => FrameType::Pong,
            _ => return None,
        })
    }
}

/// Function uids (service << 16 | rpc) of the rpcs omcbsa calls.
pub mod uid {
    /// Session.CreateSession.
    pub const CREATE_SESSION: u32 = 0x1_0001;
    /// Session.CloseSession.
    pub const CLOSE_SESSION: u32 = 0x1_0002;
    /// Session.KeepAlive.
    pub const KEEP_ALIVE: u32 = 0x1_0003;
    /// Base.ApplyEmergencyStop.
    pub const APPLY_EMERGENCY_STOP: u32 = 0x2_0091;
    /// Base.ClearFaults.
    pub const CLEAR_FAULTS: u32 = 0x2_0092;
    /// Base.SetServoingMode.
    pub const SET_SERVOING_MODE: u32 = 0x2_0098;
    /// BaseCyclic.Refresh: one cyclic command, answered by the feedback.
    pub const REFRESH: u32 = 0x3_0001;
    /// BaseCyclic.RefreshFeedback: the feedback alone.
    pub const REFRESH_FEEDBACK: u32 = 0x3_0003;

    /// The rpc's name, for messages and logs.
    pub fn name(uid: u32) -> &'static str {
        match uid {
            CREATE_SESSION => "Session.CreateSession",
            CLOSE_SESSION => "Session.CloseSession",
            KEEP_ALIVE => "Session.KeepAlive",
            APPLY_EMERGENCY_STOP => "Base.ApplyEmergencyStop",
            CLEAR_FAULTS => "Base.ClearFaults",
            SET_SERVOING_MODE => "Base.SetServoingMode",
            REFRESH => "BaseCyclic.Refresh",
            REFRESH_FEEDBACK => "BaseCyclic.RefreshFeedback",
            _ => "unknown rpc",
        }
    }
}

/// A header, unpacked. Each field holds only as many bits as the wire has for it; [`Header::pack`]
/// masks the excess off.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Header version (4 bits, [`HEADER_VERSION`]).
    pub version: u8,
    /// Raw frame type bits (4); [`FrameType::from_bits`] names them.
    pub frame_type: u8,
    /// Device id (0: the base).
    pub device_id: u8,
    /// Error code (4 bits, Kinova.Api.ErrorCodes); non-zero in an error frame.
    pub error: u8,
    /// Sub-error code (12 bits, Kinova.Api.SubErrorCodes).
    pub sub_error: u16,
    /// The session (0 before CreateSession has answered).
    pub session_id: u16,
    /// Matches a response to its request ([`MessageIds`]).
    pub message_id: u16,
    /// Service version (4 bits).
    pub service_version: u8,
    /// service << 16 | rpc (28 bits).
    pub function_uid: u32,
    /// Payload length, bytes (24 bits).
    pub payload_len: u32,
}

impl Header {
    /// A request header for `function_uid`.
    pub fn request(session_id: u16, message_id: u16, function_uid: u32, payload_len: u32) -> Self {
        Header {
            version: HEADER_VERSION,
            frame_type: FrameType::Request as u8,
            device_id: 0,
            error: 0,
            sub_error: 0,
            session_id,
            message_id,
            service_version: HEADER_VERSION,
            function_uid,
            payload_len,
        }
    }

    /// The frame type, if the bits name one.
    pub fn kind(&self) -> Option<FrameType> {
        FrameType::from_bits(self.frame_type)
    }

    /// The header as sent: four fixed32 fields, bit-packed.
    pub fn pack(&self) -> proto::Header {
        proto::Header {
            frame_info: (u32::from(self.version & 0xF) << 28)
                | (u32::from(self.frame_type & 0xF) << 24)
                | (u32::from(self.device_id) << 16)
                | (u32::from(self.error & 0xF) << 12)
                | u32::from(self.sub_error & 0xFFF),
            message_info: (u32::from(self.session_id) << 16) | u32::from(self.message_id),
            service_info: (u32::from(self.service_version & 0xF) << 28)
                | (self.function_uid & 0x0FFF_FFFF),
            payload_info: self.payload_len & 0x00FF_FFFF,
        }
    }

    /// The fields of a header as received.
    pub fn unpack(h: &proto::Header) -> Self {
        Header {
            version: (h.frame_info >> 28) as u8,
            frame_type: ((h.frame_info >> 24) & 0xF) as u8,
            device_id: (h.frame_info >> 16) as u8,
            error: ((h.frame_info >> 12) & 0xF) as u8,
            sub_error: (h.frame_info & 0xFFF) as u16,
            session_id: (h.message_info >> 16) as u16,
            message_id: h.message_info as u16,
            service_version: (h.service_info >> 28) as u8,
            function_uid: h.service_info & 0x0FFF_FFFF,
            payload_len: h.payload_info & 0x00FF_FFFF,
        }
    }
}

/// Message ids: 1 to 65535, then 1 again (0 is never used).
#[derive(Clone, Debug, Default)]
pub struct MessageIds {
    last: u16,
}

impl MessageIds {
    /// Continues after `last`.
    pub fn after(last: u16) -> Self {
        Self { last }
    }

    /// The next id.
    pub fn next_id(&mut self) -> u16 {
        self.last = if self.last == u16::MAX {
            1
        } else {
            self.last + 1
        };
        self.last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_header_bit_field_round_trips() {
        // Each field alone at its largest and at an odd pattern, so that a shift or mask that
        // spills into a neighbour shows up as a changed neighbour.
        let zero = Header {
            version: 0,
            frame_type: 0,
            device_id: 0,
            error: 0,
            sub_error: 0,
            session_id: 0,
            message_id: 0,
            service_version: 0,
            function_uid: 0,
            payload_len: 0,
        };
        type Set = fn(&mut Header, u32);
        let fields: [(&str, u32, Set); 10] = [
            ("version", 0xF, |h, v| h.version = v as u8),
            ("frame_type", 0xF, |h, v| h.frame_type = v as u8),
            ("device_id", 0xFF, |h, v| h.device_id = v as u8),
            ("error", 0xF, |h, v| h.error = v as u8),
            ("sub_error", 0xFFF, |h, v| h.sub_error = v as u16),
            ("session_id", 0xFFFF, |h, v| h.session_id = v as u16),
            ("message_id", 0xFFFF, |h, v| h.message_id = v as u16),
            ("service_version", 0xF, |h, v| h.service_version = v as u8),
            ("function_uid", 0x0FFF_FFFF, |h, v| h.function_uid = v),
            ("payload_len", 0x00FF_FFFF, |h, v| h.payload_len = v),
        ];
        for (name, max, set) in fields {
            for v in [max, 0x5A5A_5A5A & max, 1] {
                let mut h = zero;
                set(&mut h, v);
                assert_eq!(Header::unpack(&h.pack()), h, "{name} = {v:#x}");
            }
        }
        let mut all = zero;
        for (_, max, set) in fields {
            set(&mut all, max);
        }
        let packed = all.pack();
        assert_eq!(
            [
                packed.frame_info,
                packed.message_info,
                packed.service_info,
                packed.payload_info
            ],
            [u32::MAX, u32::MAX, u32::MAX, 0x00FF_FFFF]
        );
        assert_eq!(Header::unpack(&packed), all);
        // The table of the issue: frame type REQUEST, version 1, uid 0x10001.
        let h = Header::request(0x1234, 7, uid::CREATE_SESSION, 21).pack();
        assert_eq!(h.frame_info, 0x1100_0000);
        assert_eq!(h.message_info, 0x1234_0007);
        assert_eq!(h.service_info, 0x1001_0001);
    }

    #[test]
    fn the_message_id_starts_at_1_and_wraps_past_65535_to_1() {
        let mut ids = MessageIds::default();
        assert_eq!(ids.next_id(), 1);
        assert_eq!(ids.next_id(), 2);
        let mut ids = MessageIds::after(65534);
        assert_eq!(ids.next_id(), 65535);
        assert_eq!(ids.next_id(), 1);
        assert_eq!(ids.next_id(), 2);
    }
}
