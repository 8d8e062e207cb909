//! In-process simulated arms at the frame level, for tests, examples and doc-tests: the same
//! links the executor drives real arms with, on the far end of an in-process CAN bus
//! ([`can`]: seven CiA 402 drives) or of loopback sockets ([`kortex`]: a Gen3 on Kortex),
//! answering from their own threads (under real-time scheduling where the system grants it, as
//! a real arm's own processor would answer).
//!
//! Unlike the Python mocks (hw-adapter/mock, the protocol check, run at 10 ms), they keep up at
//! the default rates (4 ms CAN, one 1 Mbit/s bus per arm; 1 ms Kortex), so the watchdog's
//! bound can be measured there.
//! Each can inject one fault (`can::Injected`, `kortex::Injected`) and records, on the
//! machine's monotonic clock, the fault's first sign and when the arm's stop reached it
//! ([`SimRecord`]). Memory grows with the run: every command taken is kept.

pub mod can;
pub mod kortex;
pub mod matrix;

use omcbsa_hw::run::{Command, JOINTS};
use std::time::{Duration, Instant};

/// The real-time priority the simulators' threads ask for (below the executor's default, 50,
/// so that they never hold up the loop they answer). Refused, they run at normal priority.
const SIM_PRIORITY: u8 = 40;

/// What a simulated arm saw, stamped on the machine's monotonic clock.
#[derive(Clone, Debug, Default)]
pub struct SimRecord {
    /// Every motion command it took, in order (CAN: the targets applied at each SYNC with
    /// operation enabled; Kortex: every Refresh after the seed), until its stop.
    pub commands: Vec<Command>,
    /// When each cycle's frame (CAN: SYNC; Kortex: Refresh) arrived, answered or not, from
    /// the first motion command to the stop: entry c is cycle c of the executor's count.
    pub cycle_times: Vec<Instant>,
    /// The injected fault's first sign: the first cycle left unanswered or answered late, the
    /// EMCY, the first faulty feedback, the heartbeat announcing the stop, the first error
    /// frame.
    pub first_sign: Option<Instant>,
    /// When the arm's stop reached it (CAN: the SYNC after its first quick-stop RPDO; Kortex:
    /// ApplyEmergencyStop).
    pub stopped: Option<Instant>,
    /// Motion commands sent after the stop (Kortex: arrived after it on the UDP link, behind
    /// a marker its TCP side queues there when the stop arrives; a Refresh sent just before the
    /// stop may cross it on the other link, and is not counted).
    pub commands_after_stop: usize,
    /// Kortex: the servoing and cyclic requests in the order handled, `"low"` and `"single"`
    /// for SetServoingMode, `"refresh"` for each Refresh (for the shutdown's order).
    pub sequence: Vec<&'static str>,
}

impl SimRecord {
    /// The stop's delay after the fault's first sign, in periods of `period` (`None` without
    /// either).
    pub fn periods_to_stop(&self, period: Duration) -> Option<f64> {
        let (sign, stop) = (self.first_sign?, self.stopped?);
        Some(stop.saturating_duration_since(sign).as_secs_f64() / period.as_secs_f64())
    }

    /// The deviations of the intervals between consecutive cycles from `period`, sorted, in
    /// seconds.
    pub fn jitter(&self, period: Duration) -> Vec<f64> {
        let mut j: Vec<f64> = (self.cycle_times.windows(2))
            .map(|w| (w[1].duration_since(w[0]).as_secs_f64() - period.as_secs_f64()).abs())
            .collect();
        j.sort_by(f64::total_cmp);
        j
    }
}

/// Position model of a simulated joint: first order toward its target with time constant
/// `tau` (zero: it is where it was told at once), advanced in time.
#[derive(Clone, Copy, Debug)]
struct Joint {
    position: f64,
    target: f64,
    tau: Duration,
}

impl Joint {
    fn new(position: f64, tau: Duration) -> Self {
        Self {
            position,
            target: position,
            tau,
        }
    }

    /// Moves `dt` on.
    fn advance(&mut self, dt: Duration) {
        if self.tau.is_zero() {
            self.position = self.target;
        } else {
            let k = 1.0 - (-dt.as_secs_f64() / self.tau.as_secs_f64()).exp();
            self.position += (self.target - self.position) * k;
        }
    }
}

/// Joints of one arm, advanced together on the clock.
#[derive(Clone, Debug)]
struct Joints {
    joints: [Joint; JOINTS],
    at: Instant,
}

impl Joints {
    fn new(initial: [f64; JOINTS], tau: Duration) -> Self {
        Self {
            joints: initial.map(|q| Joint::new(q, tau)),
            at: Instant::now(),
        }
    }

    /// Positions now, rad.
    fn positions(&mut self) -> [f64; JOINTS] {
        let now = Instant::now();
        let dt = now.saturating_duration_since(self.at);
        self.at = now;
        for j in &mut self.joints {
            j.advance(dt);
        }
        self.joints.map(|j| j.position)
    }

    /// New targets from now on, rad.
    fn command(&mut self, targets: [f64; JOINTS]) {
        self.positions();
        for (j, t) in self.joints.iter_mut().zip(targets) {
            j.target = t;
        }
    }
}

/// How an arm's answers go out: not at all once it is silent, or held back by a delay.
#[derive(Clone, Copy, Debug, Default)]
struct Answers {
    silent: bool,
    delay: Duration,
}

impl Answers {
    /// From `now` on, no answers (`late`: `None`) or every answer `late`; `now` is the fault's
    /// first sign (its cycle is the first left unanswered, or answered late).
    fn disturb(&mut self, late: Option<Duration>, now: Instant, record: &mut SimRecord) {
        match late {
            None => self.silent = true,
            Some(d) => self.delay = d,
        }
        record.first_sign = Some(now);
    }
}

/// Asks for real-time scheduling for the calling simulator thread (best effort).
fn realtime() {
    let _ = omcbsa_hw::priority::make_realtime(SIM_PRIORITY);
}
