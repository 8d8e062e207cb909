//! A policy driving arms: an [`crate::online::Embodier`] and the arms it plans for, streamed
//! together while the policy runs ([`LiveCell`]: the Python `Cell` and `omcbsa online --arm`
//! drive it), what is checked of a plan before it is sent ([`check`]), and the chunks' line
//! format ([`lines`]). See docs/HARDWARE.md.

mod cell;
pub mod check;
pub mod lines;

pub use cell::{speed_ratio, LiveCell, LiveError, LiveOptions, LivePush, LiveStatus, ATTEMPTS};
