//! The fault-detection settings of a run: one set, taken by `omcbsa execute`, `demo` and
//! `online` (the command line's defaults are [`WatchSettings::default`]) and by the tests that
//! measure the reactions.
//!
//! - Per-cycle accounting (`watchdog`): a drive that has not answered SYNC k when SYNC
//!   k + m is due, or whose answer is more than m periods stale, is a fault.
//! - Heartbeat: the producer time written into every drive (0x1017) and the consumer time
//!   derived from it, `factor` times it (CiA 301 practice: 1.5 to 2).
//! - Following error, the CiA 402 way: every drive watches its own following error against the
//!   window (0x6065) for the time-out (0x6066) and raises the fault itself (statusword bit 13,
//!   EMCY 0x8611). The window of each joint is its plan's peak speed times twice the time the
//!   drive's actual position trails its target (the drive's lag plus a period); a lag that
//!   grows at speed v crosses it after W / v, and the drive reports it after the time-out.
//!   The executor's own bound on |target - actual| stays as a second line.

use std::fmt;
use std::time::Duration;

/// The default `m`: an answer may lag its cycle by up to two periods (one for the source to
/// answer, one for jitter).
pub const DEFAULT_MISSED_CYCLES: u32 = 2;
/// The largest `m` accepted: beyond it the accounting no longer bounds a reaction usefully.
pub const MAX_MISSED_CYCLES: u32 = 1000;

/// The smallest following-error window, rad: a joint at rest still has encoder noise and
/// rounding, and a window of a few counts would fault on them.
pub const MIN_FOLLOWING_ERROR_WINDOW: f64 = 1e-3;

/// How faults are detected: see the module.
///
/// ```
/// use omcbsa_hw::WatchSettings;
/// use std::time::Duration;
///
/// let w = WatchSettings::default();
/// assert!(w.check().is_ok());
/// assert_eq!(w.heartbeat_consumer_time(), Duration::from_millis(150));
/// // A joint at 0.5 rad/s streamed every 4 ms: 0.5 x 2 x (10 ms + 4 ms) = 14 mrad.
/// let window = w.following_error_window(0.5, Duration::from_millis(4));
/// assert!((window - 0.014).abs() < 1e-12);
/// let bad = WatchSettings { missed_cycles: 0, ..w };
/// assert_eq!(bad.check(), Err(omcbsa_hw::run::watch::SettingsError::MissedCycles(0)));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct WatchSettings {
    /// m: a drive that has not answered SYNC k when SYNC k + m is due is a fault.
    pub missed_cycles: u32,
    /// Heartbeat producer time written into every drive (0x1017), ms.
    pub heartbeat_ms: u16,
    /// Heartbeat consumer time / producer time.
    pub heartbeat_factor: f64,
    /// Following error time-out written into every drive (0x6066), ms.
    pub following_error_timeout_ms: u16,
    /// How long a drive's actual position trails its target in normal motion (its position
    /// loop's lag), for the following-error window.
    pub drive_lag: Duration,
    /// The executor's own check, second line: largest allowed |target - actual|, rad.
    pub following_error_bound: f64,
    /// Backstop on the wall clock, behind the per-cycle accounting: a SYNC unanswered for
    /// longer is a fault, and so is an arm that keeps the others waiting longer on the common
    /// schedule (its thread stalled, its bus full).
    pub feedback_timeout: Duration,
}

impl Default for WatchSettings {
    fn default() -> Self {
        Self {
            missed_cycles: DEFAULT_MISSED_CYCLES,
            heartbeat_ms: 100,
            heartbeat_factor: 1.5,
            following_error_timeout_ms: 10,
            drive_lag: Duration::from_millis(10),
            following_error_bound: 0.05,
            feedback_timeout: Duration::from_millis(50),
        }
    }
}

impl WatchSettings {
    /// A node silent for longer than this is a fault.
    pub fn heartbeat_consumer_time(&self) -> Duration {
        Duration::from_millis(u64::from(self.heartbeat_ms)).mul_f64(self.heartbeat_factor)
    }

    /// The following-error window (rad; written to a drive's 0x6065) of a joint whose commands
    /// move at up to `speed` rad/s, streamed every `period`: at least
    /// [`MIN_FOLLOWING_ERROR_WINDOW`].
    pub fn following_error_window(&self, speed: f64, period: Duration) -> f64 {
        let trail = 2.0 * (self.drive_lag + period).as_secs_f64();
        (speed.abs() * trail).max(MIN_FOLLOWING_ERROR_WINDOW)
    }

    /// Every setting within its range, or which is not.
    pub fn check(&self) -> Result<(), SettingsError> {
        use SettingsError as E;
        if !(1..=MAX_MISSED_CYCLES).contains(&self.missed_cycles) {
            return Err(E::MissedCycles(self.missed_cycles));
        }
        if self.heartbeat_ms == 0 {
            return Err(E::HeartbeatMs);
        }
        if !(self.heartbeat_factor.is_finite() && (1.0..=10.0).contains(&self.heartbeat_factor)) {
            return Err(E::HeartbeatFactor(self.heartbeat_factor));
        }
        if self.following_error_timeout_ms == 0 {
            return Err(E::FollowingErrorTimeout);
        }
        if self.drive_lag > Duration::from_secs(1) {
            return Err(E::DriveLag(self.drive_lag));
        }
        if self.feedback_timeout.is_zero() || self.feedback_timeout > Duration::from_secs(10) {
            return Err(E::FeedbackTimeout(self.feedback_timeout));
        }
        if !(self.following_error_bound.is_finite() && self.following_error_bound > 0.0) {
            return Err(E::FollowingErrorBound(self.following_error_bound));
        }
        Ok(())
    }
}

/// A fault-detection setting out of its range ([`WatchSettings::check`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// [`WatchSettings::missed_cycles`].
    #[error("missed cycles must be within [1, {MAX_MISSED_CYCLES}], got {0}")]
    MissedCycles(u32),
    /// [`WatchSettings::heartbeat_ms`].
    #[error("heartbeat producer time must be at least 1 ms")]
    HeartbeatMs,
    /// [`WatchSettings::heartbeat_factor`].
    #[error("heartbeat factor must be within [1, 10] (CiA 301 practice: 1.5 to 2), got {0}")]
    HeartbeatFactor(f64),
    /// [`WatchSettings::following_error_timeout_ms`].
    #[error("following error time-out must be at least 1 ms")]
    FollowingErrorTimeout,
    /// [`WatchSettings::drive_lag`].
    #[error("drive lag must be at most 1 s, got {0:?}")]
    DriveLag(Duration),
    /// [`WatchSettings::feedback_timeout`].
    #[error("feedback time-out must be within (0, 10] s, got {0:?}")]
    FeedbackTimeout(Duration),
    /// [`WatchSettings::following_error_bound`].
    #[error("following error bound must be a positive number of rad, got {0}")]
    FollowingErrorBound(f64),
}

/// One line, as the commands print it at start.
impl fmt::Display for WatchSettings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "watchdog: fault when a drive has not answered SYNC k at SYNC k+{}; heartbeat {} ms, \
             consumer {:?} ({}x); drive following-error time-out {} ms, window = peak speed x \
             2 x (drive lag {:?} + period), at least {} rad; executor's bound {} rad; backstop: \
             an answer missing, or an arm behind the common schedule, for {:?}",
            self.missed_cycles,
            self.heartbeat_ms,
            self.heartbeat_consumer_time(),
            self.heartbeat_factor,
            self.following_error_timeout_ms,
            self.drive_lag,
            MIN_FOLLOWING_ERROR_WINDOW,
            self.following_error_bound,
            self.feedback_timeout
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn consumer_time_and_window_follow_the_settings() {
        let w = WatchSettings::default();
        w.check().unwrap();
        assert_eq!(w.heartbeat_consumer_time(), Duration::from_millis(150));
        let period = Duration::from_millis(4);
        // 0.5 rad/s x 2 x 14 ms = 14 mrad
        assert!((w.following_error_window(0.5, period) - 0.014).abs() < 1e-15);
        // a joint at rest gets the smallest window
        assert_eq!(w.following_error_window(0.0, period), 1e-3);
    }

    #[test]
    fn settings_out_of_range_are_named() {
        let bad = |f: fn(&mut WatchSettings)| {
            let mut w = WatchSettings::default();
            f(&mut w);
            w.check().unwrap_err().to_string()
        };
        assert!(bad(|w| w.missed_cycles = 0).contains("missed cycles"));
        assert!(bad(|w| w.heartbeat_ms = 0).contains("heartbeat producer"));
        assert!(bad(|w| w.heartbeat_factor = 0.5).contains("heartbeat factor"));
        assert!(bad(|w| w.heartbeat_factor = f64::NAN).contains("heartbeat factor"));
        assert!(bad(|w| w.following_error_timeout_ms = 0).contains("time-out"));
        assert!(bad(|w| w.drive_lag = Duration::from_secs(5)).contains("drive lag"));
        assert!(bad(|w| w.following_error_bound = -1.0).contains("bound"));
        assert!(bad(|w| w.feedback_timeout = Duration::ZERO).contains("feedback time-out"));
    }
}
