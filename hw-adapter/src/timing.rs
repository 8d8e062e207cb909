//! Whether this machine can hold a control rate: a thread at the arm threads' scheduling
//! sleeps until each period's deadline for a while, and the lateness of its wake-ups says how
//! close to the schedule a cycle goes out ([`measure`]). `omcbsa doctor` prints it for every
//! transport's default rate; `execute`, `online` and `demo` measure it for their rate before
//! any arm is set up and refuse a rate the machine does not hold ([`Jitter::holds`]).
//!
//! The loop tolerates a late wake-up (the schedule slips rather than bursting, see `live`),
//! but every late wake-up delays the arms' commands: a rate is held when 99 % of the wake-ups
//! come within one period ([`HELD_SHARE`] of [`HELD_FRACTION`]), the jitter the watchdog
//! is stated to tolerate (an answer up to one period late).
//!
//! Cost: one thread for the measurement's duration, one `Duration` per period (8 ms of
//! 1 kHz is 8 kB for a second).

pub use crate::run::TimingError;
use std::fmt;
use std::time::{Duration, Instant};

/// A held rate: this share of the wake-ups within [`HELD_FRACTION`] of a period.
pub const HELD_SHARE: f64 = 0.99;
/// A held rate: [`HELD_SHARE`] of the wake-ups within this fraction of a period.
pub const HELD_FRACTION: f64 = 1.0;
/// The longest measurement taken ([`measure`] refuses longer): bounds its memory.
pub const MAX_MEASURE: Duration = Duration::from_secs(60);

/// The lateness of a thread's wake-ups at a period, measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Jitter {
    /// The period slept to.
    pub period: Duration,
    /// How many wake-ups were measured.
    pub wakeups: usize,
    /// The median lateness.
    pub p50: Duration,
    /// The 99th percentile.
    pub p99: Duration,
    /// The largest.
    pub max: Duration,
    /// The scheduling the thread ran under: `SCHED_FIFO N`, or why not.
    pub scheduling: String,
}

impl Jitter {
    /// `Ok` if the rate is held (see the module), else why not.
    pub fn holds(&self) -> Result<(), TimingError> {
        let limit = self.period.mul_f64(HELD_FRACTION);
        if self.p99 <= limit {
            return Ok(());
        }
        Err(TimingError::RateNotHeld {
            hz: 1.0 / self.period.as_secs_f64(),
            period: self.period,
            p99: self.p99,
            p50: self.p50,
            max: self.max,
            limit,
            scheduling: self.scheduling.clone(),
        })
    }
}

impl fmt::Display for Jitter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:.0} Hz: {} wake-ups, late by {:?} (median), {:?} (99 %), {:?} (worst); {}",
            1.0 / self.period.as_secs_f64(),
            self.wakeups,
            self.p50,
            self.p99,
            self.max,
            self.scheduling
        )
    }
}

/// Sleeps to every deadline of `period` for `duration` on a new thread, under `SCHED_FIFO`
/// `priority` where the system grants it (as the arm threads run), and measures how late each
/// wake-up came.
pub fn measure(
    period: Duration,
    duration: Duration,
    priority: Option<u8>,
) -> Result<Jitter, TimingError> {
    if period.is_zero() || period > Duration::from_secs(1) {
        return Err(TimingError::Arguments("the period must be within (0, 1] s"));
    }
    if duration < period || duration > MAX_MEASURE {
        return Err(TimingError::Arguments(
            "the duration must be at least a period and at most 60 s",
        ));
    }
    let wakeups = (duration.as_secs_f64() / period.as_secs_f64()) as usize;
    let run = move || {
        let scheduling = match priority.map(crate::priority::make_realtime) {
            None => "normal scheduling".to_string(),
            Some(Ok(())) => format!("SCHED_FIFO {}", priority.unwrap_or_default()),
            Some(Err(why)) => format!("{why}: normal scheduling"),
        };
        let mut late = Vec::with_capacity(wakeups);
        let start = Instant::now() + period;
        for k in 0..wakeups {
            let due = start + period * k as u32;
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }
            late.push(Instant::now().saturating_duration_since(due));
        }
        (late, scheduling)
    };
    let (mut late, scheduling) = std::thread::spawn(run)
        .join()
        .map_err(|_| TimingError::Arguments("the measuring thread panicked"))?;
    late.sort();
    let at = |q: f64| late[((late.len() - 1) as f64 * q).round() as usize];
    Ok(Jitter {
        period,
        wakeups: late.len(),
        p50: at(0.5),
        p99: at(HELD_SHARE),
        max: at(1.0),
        scheduling,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn jitter(p99_us: u64) -> Jitter {
        Jitter {
            period: Duration::from_millis(1),
            wakeups: 1000,
            p50: Duration::from_micros(10),
            p99: Duration::from_micros(p99_us),
            max: Duration::from_millis(3),
            scheduling: "SCHED_FIFO 50".into(),
        }
    }

    #[test]
    fn a_rate_is_held_when_99_percent_of_wakeups_are_within_a_period() {
        assert_eq!(jitter(1000).holds(), Ok(()));
        let refused = jitter(1001).holds().unwrap_err();
        assert!(matches!(refused, TimingError::RateNotHeld { .. }));
        let text = refused.to_string();
        assert!(
            text.contains("1000 Hz") && text.contains("1.001ms"),
            "{text}"
        );
        assert!(text.contains("lower the rate"), "{text}");
    }

    #[test]
    fn a_measurement_counts_its_wakeups_and_refuses_bad_arguments() {
        let j = measure(Duration::from_millis(10), Duration::from_millis(100), None).unwrap();
        assert_eq!(j.wakeups, 10);
        assert!(j.p50 <= j.p99 && j.p99 <= j.max);
        assert!(measure(Duration::ZERO, Duration::from_secs(1), None).is_err());
        assert!(measure(Duration::from_millis(1), Duration::from_secs(61), None).is_err());
    }
}
