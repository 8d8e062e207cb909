//! CANopen CiA 301 framing: NMT, SYNC, SDO expedited download and upload (with the abort codes),
//! PDO, heartbeat and EMCY.
//! Predefined connection set: the COB-ID of each service is its function code plus the node id.
//!
//! ```
//! use omcbsa_hw::canopen::{self, Message, NmtCommand, SdoValue};
//! use omcbsa_hw::CanFrame;
//!
//! // Write mode of operation 8 (cyclic synchronous position) to node 3: COB-ID 0x603.
//! let f = canopen::sdo_download(3, 0x6060, 0, SdoValue::U8(8));
//! assert_eq!(f.to_string(), "603#2F60600008000000");
//! assert_eq!(canopen::nmt(NmtCommand::Start, 0).to_string(), "000#0100");
//! assert_eq!(canopen::sync().to_string(), "080#");
//! // A heartbeat of node 5, operational.
//! let hb = CanFrame::new(0x705, &[0x05]).unwrap();
//! assert_eq!(
//!     canopen::decode(&hb),
//!     Message::Heartbeat { node: 5, state: canopen::NMT_STATE_OPERATIONAL }
//! );
//! ```

use crate::frame::CanFrame;

/// COB-ID of NMT commands.
pub const NMT_ID: u16 = 0x000;
/// COB-ID of SYNC.
pub const SYNC_ID: u16 = 0x080;
const EMCY_BASE: u16 = 0x080;
const TPDO1_BASE: u16 = 0x180;
const RPDO1_BASE: u16 = 0x200;
const SDO_RESPONSE_BASE: u16 = 0x580;
const SDO_REQUEST_BASE: u16 = 0x600;
const HEARTBEAT_BASE: u16 = 0x700;

/// NMT command specifiers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NmtCommand {
    /// Start remote node: to operational (PDOs flow).
    Start = 0x01,
    /// Stop remote node: to stopped (no PDOs, no SDOs).
    Stop = 0x02,
    /// To pre-operational (SDOs, no PDOs).
    EnterPreOperational = 0x80,
}

/// NMT state boot-up, as a heartbeat reports it (the boot-up message).
pub const NMT_STATE_BOOTUP: u8 = 0x00;
/// NMT state stopped.
pub const NMT_STATE_STOPPED: u8 = 0x04;
/// NMT state operational.
pub const NMT_STATE_OPERATIONAL: u8 = 0x05;
/// NMT state pre-operational.
pub const NMT_STATE_PRE_OPERATIONAL: u8 = 0x7F;

/// The name of an NMT state, as messages write it ("unknown" for a value that is none).
pub fn nmt_state_name(state: u8) -> &'static str {
    match state {
        NMT_STATE_BOOTUP => "boot-up",
        NMT_STATE_STOPPED => "stopped",
        NMT_STATE_OPERATIONAL => "operational",
        NMT_STATE_PRE_OPERATIONAL => "pre-operational",
        _ => "unknown",
    }
}

fn frame(id: u16, data: &[u8]) -> CanFrame {
    // Every caller passes a base id plus a node id <= 127 and at most 8 bytes.
    CanFrame::new(id, data).expect("CANopen frame within CAN 2.0A limits")
}

/// NMT command to `node` (0 addresses every node).
pub fn nmt(cmd: NmtCommand, node: u8) -> CanFrame {
    frame(NMT_ID, &[cmd as u8, node])
}

/// A SYNC frame (no data): every drive applies its last target and answers with TPDO1.
pub fn sync() -> CanFrame {
    frame(SYNC_ID, &[])
}

/// RPDO1 to `node` with `data` (at most 8 bytes, checked at compile time).
pub fn rpdo1<const N: usize>(node: u8, data: &[u8; N]) -> CanFrame {
    const { assert!(N <= 8, "a CAN frame carries at most 8 bytes") };
    frame(RPDO1_BASE + u16::from(node), data)
}

/// A node's TPDO1 with `data` (what a drive answers each SYNC with).
pub fn tpdo1<const N: usize>(node: u8, data: &[u8; N]) -> CanFrame {
    const { assert!(N <= 8, "a CAN frame carries at most 8 bytes") };
    frame(TPDO1_BASE + u16::from(node), data)
}

/// A node's heartbeat reporting NMT `state` (`NMT_STATE_*`).
pub fn heartbeat(node: u8, state: u8) -> CanFrame {
    frame(HEARTBEAT_BASE + u16::from(node), &[state])
}

/// COB-ID of a node's RPDO1 (for the PDO communication parameters).
pub fn rpdo1_cob_id(node: u8) -> u32 {
    u32::from(RPDO1_BASE + u16::from(node))
}

/// COB-ID of a node's TPDO1.
pub fn tpdo1_cob_id(node: u8) -> u32 {
    u32::from(TPDO1_BASE + u16::from(node))
}

/// A value written by SDO expedited download (1, 2 or 4 bytes, little endian on the bus).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoValue {
    /// UNSIGNED8.
    U8(u8),
    /// INTEGER8.
    I8(i8),
    /// UNSIGNED16.
    U16(u16),
    /// UNSIGNED32 (also INTEGER32 values, as their bits).
    U32(u32),
}

impl SdoValue {
    /// Size on the bus, bytes.
    pub fn size(self) -> usize {
        self.bytes().1
    }

    fn bytes(self) -> ([u8; 4], usize) {
        match self {
            SdoValue::U8(v) => ([v, 0, 0, 0], 1),
            SdoValue::I8(v) => ([v.to_le_bytes()[0], 0, 0, 0], 1),
            SdoValue::U16(v) => {
                let b = v.to_le_bytes();
                ([b[0], b[1], 0, 0], 2)
            }
            SdoValue::U32(v) => (v.to_le_bytes(), 4),
        }
    }
}

/// As written in messages: the value and its type, mapping entries and COB-IDs in hex.
impl std::fmt::Display for SdoValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SdoValue::U8(v) => write!(f, "{v} (u8)"),
            SdoValue::I8(v) => write!(f, "{v} (i8)"),
            SdoValue::U16(v) => write!(f, "{v} (u16)"),
            SdoValue::U32(v) => write!(f, "{v:#010x} (u32)"),
        }
    }
}

/// SDO expedited download request (client command specifier 1, e=1, s=1, n = unused bytes).
pub fn sdo_download(node: u8, index: u16, sub: u8, value: SdoValue) -> CanFrame {
    let (bytes, len) = value.bytes();
    let cmd = 0x23 | (((4 - len) as u8) << 2);
    let i = index.to_le_bytes();
    frame(
        SDO_REQUEST_BASE + u16::from(node),
        &[cmd, i[0], i[1], sub, bytes[0], bytes[1], bytes[2], bytes[3]],
    )
}

/// SDO initiate upload request (client command specifier 2): read `index:sub`.
pub fn sdo_upload(node: u8, index: u16, sub: u8) -> CanFrame {
    let i = index.to_le_bytes();
    frame(
        SDO_REQUEST_BASE + u16::from(node),
        &[0x40, i[0], i[1], sub, 0, 0, 0, 0],
    )
}

/// The meaning of an SDO abort code (CiA 301, table of SDO abort codes).
pub fn sdo_abort_text(code: u32) -> &'static str {
    match code {
        0x0503_0000 => "toggle bit not alternated",
        0x0504_0000 => "SDO protocol timed out",
        0x0504_0001 => "client/server command specifier not valid or unknown",
        0x0504_0005 => "out of memory",
        0x0601_0000 => "unsupported access to an object",
        0x0601_0001 => "attempt to read a write only object",
        0x0601_0002 => "attempt to write a read only object",
        0x0602_0000 => "object does not exist in the object dictionary",
        0x0604_0041 => "object cannot be mapped to the PDO",
        0x0604_0042 => {
            "the number and length of the objects to be mapped would exceed the PDO length"
        }
        0x0604_0043 => "general parameter incompatibility",
        0x0604_0047 => "general internal incompatibility in the device",
        0x0606_0000 => "access failed due to a hardware error",
        0x0607_0010 => "data type does not match, length of service parameter does not match",
        0x0607_0012 => "data type does not match, length of service parameter too high",
        0x0607_0013 => "data type does not match, length of service parameter too low",
        0x0609_0011 => "sub-index does not exist",
        0x0609_0030 => "invalid value for parameter",
        0x0609_0031 => "value of parameter written too high",
        0x0609_0032 => "value of parameter written too low",
        0x0609_0036 => "maximum value is less than minimum value",
        0x060A_0023 => "resource not available",
        0x0800_0000 => "general error",
        0x0800_0020 => "data cannot be transferred or stored to the application",
        0x0800_0021 => "data cannot be transferred or stored because of local control",
        0x0800_0022 => "data cannot be transferred or stored because of the present device state",
        0x0800_0023 => "no object dictionary is present",
        0x0800_0024 => "no data available",
        _ => "unknown abort code",
    }
}

/// What a node said, decoded from a frame on the bus.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Message {
    /// A heartbeat (or boot-up message).
    Heartbeat {
        /// The node.
        node: u8,
        /// Its NMT state (`NMT_STATE_*`).
        state: u8,
    },
    /// An emergency message.
    Emcy(Emcy),
    /// A node's TPDO1.
    Tpdo1 {
        /// The node.
        node: u8,
        /// The whole frame (its data decoded with the mapping written at set-up).
        data: CanFrame,
    },
    /// A node's answer to an SDO request.
    SdoResponse {
        /// The node.
        node: u8,
        /// What it answered.
        reply: SdoReply,
    },
    /// Anything else (including our own traffic echoed by some adapters).
    Other,
}

/// An emergency message (EMCY, CiA 301).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Emcy {
    /// The node that sent it.
    pub node: u8,
    /// The error code (0: error reset, no error).
    pub code: u16,
    /// The node's error register (0x1001).
    pub register: u8,
}

/// A node's answer to an SDO request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdoReply {
    /// A write (download) was done.
    DownloadAck {
        /// The object written.
        index: u16,
        /// Its sub-index.
        sub: u8,
    },
    /// Expedited upload: the first `len` bytes of `data` (little endian).
    Upload {
        /// The object read.
        index: u16,
        /// Its sub-index.
        sub: u8,
        /// Its value's bytes.
        data: [u8; 4],
        /// How many of them count.
        len: u8,
    },
    /// The node refused the request ([`sdo_abort_text`] names the code).
    Abort {
        /// The object of the request.
        index: u16,
        /// Its sub-index.
        sub: u8,
        /// The abort code.
        code: u32,
    },
    /// An answer this client does not speak (segmented transfers, block transfers).
    Unexpected {
        /// Its command byte.
        command: u8,
    },
}

/// What a frame from the bus says (frames of no node, and our own, are [`Message::Other`]).
pub fn decode(f: &CanFrame) -> Message {
    let id = f.id();
    let d = f.data();
    let node = (id & 0x7F) as u8;
    if node == 0 {
        return Message::Other;
    }
    match id & 0x780 {
        HEARTBEAT_BASE if d.len() == 1 => Message::Heartbeat {
            node,
            state: d[0] & 0x7F,
        },
        EMCY_BASE if d.len() == 8 => Message::Emcy(Emcy {
            node,
            code: u16::from_le_bytes([d[0], d[1]]),
            register: d[2],
        }),
        TPDO1_BASE => Message::Tpdo1 { node, data: *f },
        SDO_RESPONSE_BASE if d.len() == 8 => {
            let index = u16::from_le_bytes([d[1], d[2]]);
            let sub = d[3];
            let reply = match d[0] {
                0x60 => SdoReply::DownloadAck { index, sub },
                // server command specifier 2, expedited, size indicated: n = unused bytes
                c if c & 0xF3 == 0x43 => SdoReply::Upload {
                    index,
                    sub,
                    data: [d[4], d[5], d[6], d[7]],
                    len: 4 - ((c >> 2) & 0x03),
                },
                0x80 => SdoReply::Abort {
                    index,
                    sub,
                    code: u32::from_le_bytes([d[4], d[5], d[6], d[7]]),
                },
                command => SdoReply::Unexpected { command },
            };
            Message::SdoResponse { node, reply }
        }
        _ => Message::Other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sdo_download_layout() {
        let f = sdo_download(3, 0x6060, 0, SdoValue::U8(8));
        assert_eq!(f.id(), 0x603);
        assert_eq!(f.data(), &[0x2F, 0x60, 0x60, 0, 8, 0, 0, 0]);
        let f = sdo_download(1, 0x1017, 0, SdoValue::U16(100));
        assert_eq!(f.data(), &[0x2B, 0x17, 0x10, 0, 100, 0, 0, 0]);
        let f = sdo_download(7, 0x1600, 1, SdoValue::U32(0x607A_0020));
        assert_eq!(f.data(), &[0x23, 0x00, 0x16, 1, 0x20, 0, 0x7A, 0x60]);
        let f = sdo_download(2, 0x60C2, 2, SdoValue::I8(-3));
        assert_eq!(f.data(), &[0x2F, 0xC2, 0x60, 2, 0xFD, 0, 0, 0]);
    }

    #[test]
    fn sdo_upload_and_its_answers() {
        let f = sdo_upload(4, 0x6064, 0);
        assert_eq!(f.id(), 0x604);
        assert_eq!(f.data(), &[0x40, 0x64, 0x60, 0, 0, 0, 0, 0]);
        let answer = |d: &[u8]| decode(&CanFrame::new(0x584, d).unwrap());
        assert_eq!(
            answer(&[0x4F, 0x61, 0x60, 0, 8, 0, 0, 0]),
            Message::SdoResponse {
                node: 4,
                reply: SdoReply::Upload {
                    index: 0x6061,
                    sub: 0,
                    data: [8, 0, 0, 0],
                    len: 1
                }
            }
        );
        assert!(matches!(
            answer(&[0x43, 0x64, 0x60, 0, 1, 2, 3, 4]),
            Message::SdoResponse {
                reply: SdoReply::Upload { len: 4, .. },
                ..
            }
        ));
        // a segmented upload (e = 0) is not expedited
        assert!(matches!(
            answer(&[0x41, 0x08, 0x10, 0, 20, 0, 0, 0]),
            Message::SdoResponse {
                reply: SdoReply::Unexpected { command: 0x41 },
                ..
            }
        ));
        assert_eq!(
            sdo_abort_text(0x0601_0002),
            "attempt to write a read only object"
        );
    }

    #[test]
    fn decodes_node_messages() {
        let hb = CanFrame::new(0x705, &[0x05]).unwrap();
        assert_eq!(
            decode(&hb),
            Message::Heartbeat {
                node: 5,
                state: NMT_STATE_OPERATIONAL
            }
        );
        let emcy = CanFrame::new(0x082, &[0x10, 0x83, 0x01, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            decode(&emcy),
            Message::Emcy(Emcy {
                node: 2,
                code: 0x8310,
                register: 1
            })
        );
        let abort = CanFrame::new(0x581, &[0x80, 0x60, 0x60, 0, 0x11, 0, 0x09, 0x06]).unwrap();
        assert_eq!(
            decode(&abort),
            Message::SdoResponse {
                node: 1,
                reply: SdoReply::Abort {
                    index: 0x6060,
                    sub: 0,
                    code: 0x0609_0011
                }
            }
        );
        assert_eq!(decode(&sync()), Message::Other);
        assert_eq!(decode(&nmt(NmtCommand::Stop, 0)), Message::Other);
    }
}
