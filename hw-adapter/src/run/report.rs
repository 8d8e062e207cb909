//! What a run that completed reports, and the progress it reports while it streams.

use std::fmt;
use std::time::Duration;

/// One arm of a completed run.
#[derive(Clone, Debug)]
pub struct ArmReport {
    /// The arm's name.
    pub name: String,
    /// Control cycles streamed to it (with the settle cycles).
    pub cycles_sent: usize,
    /// Largest |target - actual| seen in its feedback, rad (0 in a dry run).
    pub max_following_error: f64,
}

/// A completed run (or dry run).
#[derive(Clone, Debug)]
pub struct Report {
    /// Nothing was sent: the commands were computed, checked and logged only.
    pub dry_run: bool,
    /// The control period.
    pub period: Duration,
    /// Uniform slow-down applied to the plan (1 = as planned).
    pub time_scale: f64,
    /// Control cycles of the trajectory (without the settle cycles).
    pub cycles: usize,
    /// Frames sent to every arm together (CAN frames or Kortex frames).
    pub frames_sent: usize,
    /// One entry per arm, in plan order.
    pub arms: Vec<ArmReport>,
    /// Largest delay of a cycle behind its schedule.
    pub max_lateness: Duration,
    /// Online execution: times the queue ran dry and the arms held.
    pub holds: usize,
    /// Stopped on request before its end (every arm quick-stopped, no fault).
    pub halted: bool,
    /// The arm threads' scheduling: `Ok` under the asked-for real-time priority (or none
    /// asked), else why it was refused.
    pub realtime: Result<(), super::RealtimeRefused>,
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mode = if self.dry_run { "dry run" } else { "executed" };
        write!(
            f,
            "{mode}: {} arms, {} cycles at {:?} ({:.3} s), {} frames",
            self.arms.len(),
            self.cycles,
            self.period,
            self.cycles as f64 * self.period.as_secs_f64(),
            self.frames_sent
        )?;
        if self.time_scale > 1.0 {
            write!(
                f,
                "\nplan slowed down {:.3}x to stay within velocity/acceleration limits",
                self.time_scale
            )?;
        }
        for a in &self.arms {
            write!(
                f,
                "\n  {}: {} cycles, max following error {:.2e} rad",
                a.name, a.cycles_sent, a.max_following_error
            )?;
        }
        if self.halted {
            write!(f, "\nstopped on request: every arm quick-stopped")?;
        }
        if self.holds > 0 {
            write!(
                f,
                "\nthe queue ran dry {} times (the arms held)",
                self.holds
            )?;
        }
        if !self.dry_run {
            write!(f, "\nlargest cycle lateness {:?}", self.max_lateness)?;
            if let Err(why) = &self.realtime {
                write!(f, "\nstreamed at normal priority: {why}")?;
            }
        }
        Ok(())
    }
}

/// Progress of one arm, passed to the progress callback about every 0.1 s of streaming.
#[derive(Clone, Debug)]
pub struct Progress<'a> {
    /// The arm's name.
    pub arm: &'a str,
    /// Cycles streamed so far.
    pub cycle: usize,
    /// Cycles of the whole run with its settle cycles (0 when not known in advance: online).
    pub cycles: usize,
}
