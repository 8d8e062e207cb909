//! One arm behind the executor's loop, whatever carries its commands: the [`ArmLink`] trait that
//! the loop (`live`) drives. Its implementations are an arm of CiA 402 drives on a CAN bus
//! (`arm::ArmBus`) and a Kinova Gen3 over Ethernet (`kortex::KortexArm`); `port` opens them.

use crate::run::{Command, ExecConfig, Fault, LinkError, Measured, Span, JOINTS};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// What an arm's start-up checks it against, before anything moves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartPlan {
    /// The command the arm holds first: where it must stand (within
    /// [`ExecConfig::start_tolerance`]).
    pub first: Command,
    /// The range (bus counts) every command of the run stays in, per joint.
    pub span: Span,
    /// The joints' peak commanded speeds, rad/s (the drives' following-error windows).
    pub speed: [f64; JOINTS],
}

/// One arm, as the executor's loop drives it: two start-up phases that every arm finishes
/// before the next begins, then one command per control cycle with the feedback watched in
/// between, and a stop.
///
/// Each arm's link runs on its own thread; nothing in it may block for long outside the
/// start-up phases (the loop calls [`ArmLink::poll`] and [`ArmLink::check_feedback`] many times
/// a period).
pub trait ArmLink: Send {
    /// The arm's name.
    fn name(&self) -> &str;
    /// Frames (CAN frames or Kortex frames) sent so far.
    fn frames_sent(&self) -> usize;
    /// Phase 1: checks the arm and reads back what must hold before any motion (`plan`: where
    /// it starts, the range of its commands, its joints' peak speeds), enabling nothing.
    /// Returns `Ok` early, sending nothing more, once `stop` is raised.
    fn configure(
        &mut self,
        cfg: &ExecConfig,
        plan: &StartPlan,
        stop: &AtomicBool,
    ) -> Result<(), LinkError>;
    /// Phase 2: puts the arm where it follows one command per cycle; sends no motion command.
    fn enable(&mut self, cfg: &ExecConfig) -> Result<(), LinkError>;
    /// Handles everything received so far.
    fn poll(&mut self) -> Result<(), LinkError>;
    /// The latest feedback: where the joints were measured, and the cycle it answers.
    fn measured(&self) -> Option<Measured>;
    /// The first fault visible in the feedback, given the last command sent (`target`); also
    /// returns the largest following error seen, rad.
    fn check_feedback(
        &self,
        now: Instant,
        cfg: &ExecConfig,
        target: &Command,
    ) -> Result<f64, Fault>;
    /// Whether the next cycle may be sent, by the per-cycle accounting (`watchdog`): called
    /// when it is due.
    fn check_cycle(&self) -> Result<(), Fault>;
    /// The first cycle this arm's answers do not yet allow any arm to send.
    fn clear_until(&self) -> u64;
    /// Sends one control cycle's command.
    fn send_cycle(&mut self, cmd: &Command) -> Result<(), LinkError>;
    /// Stops the arm at once after a fault (here or on another arm), holding `hold`: sends the
    /// stop frames without waiting for answers ([`ArmLink::leave`] does). Tries every frame even
    /// if one fails; returns the first that could not be sent.
    fn quick_stop(&mut self, hold: &Command) -> Result<(), LinkError>;
    /// Normal end, holding `hold`: sends the frames that end the motion (none may be needed).
    fn finish(&mut self, hold: &Command) -> Result<(), LinkError>;
    /// After a failed start-up elsewhere: leaves the arm as it was, without moving it.
    fn abort(&mut self) -> Result<(), LinkError>;
    /// After [`ArmLink::quick_stop`], [`ArmLink::finish`] or [`ArmLink::abort`]: waits, for a
    /// bounded time, for the arm to answer what was sent, then leaves it (Kortex: the last
    /// cyclic command answered, the servoing mode back to single-level, the sessions closed).
    /// `Ok`: every frame of the stop that got no answer (each also in the command log);
    /// `Err`: one that could not be sent or that the arm refused ([`LinkError::StopFailed`]).
    fn leave(&mut self) -> Result<Vec<String>, LinkError>;
}
