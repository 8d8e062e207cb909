//! One arm behind the executor's loop, whatever carries its commands: the [`ArmLink`] trait
//! that the loop ([`crate::live`]) drives, with its two implementations, an arm of CiA 402
//! drives on a CAN bus ([`crate::arm::ArmBus`]) and a Kinova Gen3 over Ethernet
//! ([`crate::kortex::KortexArm`]); and [`ArmPort`], what a caller hands the executor per arm.

use crate::arm::{ArmBus, Span};
use crate::executor::{ExecConfig, Fault};
use crate::interpolate::Command;
use crate::kortex;
use crate::log::LogSink;
use crate::plan::JOINTS;
use crate::transport::{self, Transport};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// One arm, as the executor's loop drives it: two start-up phases that every arm finishes
/// before the next begins, then one command per control cycle with the feedback watched in
/// between, and a stop.
pub trait ArmLink: Send {
    fn name(&self) -> &str;
    /// Frames (CAN frames or Kortex frames) sent so far.
    fn frames_sent(&self) -> usize;
    /// Phase 1: checks the arm and reads back what must hold before any motion (start
    /// position within [`ExecConfig::start_tolerance`] of `start`, every command within `span`;
    /// `speed`: the joints' peak speeds, rad/s), enabling nothing. Returns `Ok` early, sending
    /// nothing more, once `stop` is raised.
    fn configure(
        &mut self,
        cfg: &ExecConfig,
        plan: (&Command, &Span, &[f64; JOINTS]),
        stop: &AtomicBool,
    ) -> Result<(), String>;
    /// Phase 2: puts the arm where it follows one command per cycle; sends no motion command.
    fn enable(&mut self, cfg: &ExecConfig) -> Result<(), String>;
    /// Handles everything received so far.
    fn poll(&mut self) -> Result<(), String>;
    /// The first fault visible in the feedback, given the last command sent (`target`); also
    /// returns the largest following error seen, rad.
    fn check_feedback(
        &self,
        now: Instant,
        cfg: &ExecConfig,
        target: &Command,
    ) -> Result<f64, Fault>;
    /// Whether the next cycle may be sent, by the per-cycle accounting ([`crate::watchdog`]):
    /// called when it is due.
    fn check_cycle(&self) -> Result<(), Fault>;
    /// The first cycle this arm's answers do not yet allow any arm to send.
    fn clear_until(&self) -> u64;
    /// Sends one control cycle's command.
    fn send_cycle(&mut self, cmd: &Command) -> Result<(), String>;
    /// Stops the arm at once after a fault (here or on another arm), holding `hold`. Tries every
    /// step even if one fails; returns the first failure.
    fn quick_stop(&mut self, hold: &Command) -> Result<(), String>;
    /// Normal end, holding `hold`.
    fn finish(&mut self, hold: &Command) -> Result<(), String>;
    /// After a failed start-up elsewhere: leaves the arm as it was, without moving it.
    fn abort(&mut self) -> Result<(), String>;
}

/// What carries one arm's commands, opened: a CAN bus or a Kortex connection.
pub enum ArmPort {
    Can(Box<dyn Transport>),
    Kortex(Box<kortex::Connection>),
}

impl From<Box<dyn Transport>> for ArmPort {
    fn from(t: Box<dyn Transport>) -> Self {
        ArmPort::Can(t)
    }
}

impl From<kortex::Connection> for ArmPort {
    fn from(c: kortex::Connection) -> Self {
        ArmPort::Kortex(Box::new(c))
    }
}

/// Ports paired with the names of their arms, as [`crate::Executor::new`] takes them.
pub type ArmPorts = Vec<(String, ArmPort)>;

impl ArmPort {
    pub(crate) fn into_link(
        self,
        name: String,
        clock: Instant,
        cfg: &ExecConfig,
        log: Option<LogSink>,
    ) -> Box<dyn ArmLink> {
        match self {
            ArmPort::Can(t) => Box::new(ArmBus::new(name, t, clock, cfg, log)),
            ArmPort::Kortex(c) => Box::new(kortex::KortexArm::new(name, *c, clock, cfg, log)),
        }
    }
}

/// An arm's port spec, checked: `slcan:PATH`, `socketcan:IFACE` or `kortex:HOST[:TCP:UDP]`.
/// A dry run checks its arms' specs with this.
pub fn check_spec(spec: &str) -> Result<(), String> {
    if spec.starts_with("kortex:") {
        kortex::KortexSpec::parse(spec).map(|_| ())
    } else {
        transport::BusSpec::parse(spec)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}

/// Opens an arm's port from its spec ([`check_spec`]); a Kortex arm is reached with
/// `credentials`.
pub fn open(spec: &str, credentials: &kortex::Credentials) -> Result<ArmPort, String> {
    if spec.starts_with("kortex:") {
        let s = kortex::KortexSpec::parse(spec)?;
        Ok(kortex::Connection::open(&s, credentials)?.into())
    } else {
        Ok(ArmPort::Can(
            transport::open(spec).map_err(|e| e.to_string())?,
        ))
    }
}
