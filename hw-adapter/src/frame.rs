//! A classic CAN 2.0A data frame (11-bit identifier, up to 8 data bytes): all CANopen needs.

use std::fmt;

/// Largest 11-bit CAN identifier.
pub const MAX_STANDARD_ID: u16 = 0x7FF;

/// A classic CAN frame, checked at construction.
///
/// ```
/// use omcbsa_hw::CanFrame;
///
/// let f = CanFrame::new(0x18B, &[1, 2, 0xA0]).unwrap();
/// assert_eq!((f.id(), f.data()), (0x18B, &[1, 2, 0xA0][..]));
/// assert_eq!(f.to_string(), "18B#0102A0");
/// assert!(CanFrame::new(0x800, &[]).is_none()); // not an 11-bit id
/// assert!(CanFrame::new(0x100, &[0; 9]).is_none()); // more than 8 bytes
/// ```
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct CanFrame {
    id: u16,
    len: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// A frame with identifier `id` and payload `data`; `None` if the id is not 11-bit or the
    /// payload is longer than 8 bytes.
    pub fn new(id: u16, data: &[u8]) -> Option<Self> {
        if id > MAX_STANDARD_ID || data.len() > 8 {
            return None;
        }
        let mut buf = [0u8; 8];
        buf[..data.len()].copy_from_slice(data);
        Some(Self {
            id,
            len: data.len() as u8,
            data: buf,
        })
    }

    /// The 11-bit identifier.
    pub fn id(&self) -> u16 {
        self.id
    }

    /// The payload (0 to 8 bytes).
    pub fn data(&self) -> &[u8] {
        &self.data[..usize::from(self.len)]
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self}")
    }
}

/// `candump` style: `18B#0102A0FF`.
impl fmt::Display for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:03X}#", self.id)?;
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_extended_ids_and_long_payloads() {
        assert!(CanFrame::new(0x800, &[]).is_none());
        assert!(CanFrame::new(0x100, &[0; 9]).is_none());
        let f = CanFrame::new(0x18B, &[1, 2, 0xA0]).unwrap();
        assert_eq!(f.data(), &[1, 2, 0xA0]);
        assert_eq!(f.to_string(), "18B#0102A0");
    }
}
