//! The streaming frame generator: joint commands computed cycle by cycle from a queue of
//! waypoints, for a whole plan (offline execution) and for segments pushed while the arms move
//! (online execution) alike. Memory is the queue and its time law (`PER_SEGMENT` grid points
//! of 32 bytes per queued step), whatever the run's duration.
//!
//! Waypoint `i` of every arm belongs to step `i`; a step lasts at least `step_time` seconds.
//! Each joint follows the cubic Hermite spline of [`crate::spline`] (Fritsch–Butland
//! tangents, at rest at the start). A waypoint's tangent is frozen when the segment ending at
//! it begins, from the waypoints queued at that moment (zero if it is the last one): what is
//! being executed never changes, and the spline stays C1 (continuous position and velocity)
//! across any later push.
//!
//! The pace along the spline is a time law, [`omcbsa_core::retime`]'s time-optimal one for all
//! arms together (one law: the arms stay coordinated as planned), computed at every push from
//! where the arms are and how fast they go, to rest at the queue's end within the velocity and
//! acceleration limits and never faster than a step per `step_time`. So a queued tail slows
//! down over as many waypoints as the limits need, instead of stopping within its last one.
//! The commands are the law's joint positions averaged over the last few cycles (as many as
//! `2 · acceleration / (jerk · period)` for the stiffest joint): a moving average turns the
//! law's steps in acceleration into ramps, so that acceleration changes by at most
//! jerk · period per cycle, and costs about that many cycles at the end of a stop.
//!
//! [`Generator::push`] replaces the queue's tail from a step that is not yet fixed and first
//! runs a copy of the generator over the whole new tail, checking every command it would send
//! (position, velocity, acceleration and jerk limits, bus range) up to the hold at its end: a
//! tail that breaks a limit anywhere, or too short to stop in from the current speed, is
//! refused and the queue is left as it was. Because every accepted tail ends at rest within
//! the limits, a queue that runs dry (no further push in time) brings the arms to a hold
//! within their limits; the generator then holds, reports it, and resumes smoothly when a
//! later push extends the queue.

use crate::cia402::{rad_to_counts, COUNTS_PER_RAD};
use crate::plan::{check_command, ArmLimits};
use crate::run::{Command, JOINTS};
use crate::spline::{fritsch_butland, Segment};
use omcbsa_core::retime::{retime, GridPoint, JointPath, Limits, Options, TimeLaw};
use std::collections::VecDeque;

/// Grid intervals per segment of the time law: its limits hold between grid points within
/// about 1 % (the core's retiming tests), which the command check at the control rate sees.
const PER_SEGMENT: usize = 20;

/// The share of a velocity or acceleration limit the time law plans with: the law's limits
/// hold between its grid points within about 1 %, and the commands check them at the control
/// rate after rounding to whole counts (see [`law_acceleration`]).
const LAW_SHARE: f64 = 0.98;

/// The acceleration the time law plans with for a limit of `limit`: [`LAW_SHARE`] of it, less
/// what rounding two commands to whole counts can add to a second difference at `period`
/// (but at least half the limit: at very short periods the check's rounding is the bound).
fn law_acceleration(limit: f64, period: f64) -> f64 {
    (LAW_SHARE * limit - 2.0 / COUNTS_PER_RAD / (period * period)).max(0.5 * limit)
}

/// One arm's queue and its frozen part.
#[derive(Clone, Debug)]
struct Track {
    /// Waypoint `base + i` of this arm, rad.
    queue: VecDeque<[f64; JOINTS]>,
    /// Tangents (rad per step) at waypoints `fixed - 1` and `fixed`.
    tangents: [[f64; JOINTS]; 2],
    /// The three commands sent before the next one.
    prev: [Command; 3],
    /// The law's last positions, averaged into the command (the jerk filter).
    recent: VecDeque<[f64; JOINTS]>,
    /// This arm's limits.
    limits: ArmLimits,
}

/// What one cycle was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tick {
    /// Control cycle, counted from 0.
    pub cycle: u64,
    /// The step being executed: the segment from waypoint `step` to `step + 1`, or the
    /// waypoint held.
    pub step: usize,
    /// The arms hold at waypoint `step`, the last one queued (nothing more to do).
    pub holding: bool,
    /// This cycle is the first of a hold: the queue ran dry.
    pub ran_dry: bool,
}

/// Why a push was refused; the queue is unchanged.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PushError {
    /// Not one list of waypoints per arm.
    #[error("expected waypoints for {expected} arms, got {got}")]
    Arms {
        /// Arms of the stream.
        expected: usize,
        /// Lists given.
        got: usize,
    },
    /// The arms' lists differ in length.
    #[error("arm {arm}: {got} waypoints, arm 0 has {expected}: all arms share one time grid")]
    Lengths {
        /// The first arm whose list differs from arm 0's.
        arm: usize,
        /// Arm 0's length.
        expected: usize,
        /// This arm's.
        got: usize,
    },
    /// No waypoints.
    #[error("a segment needs at least one waypoint")]
    Empty,
    /// A NaN or infinite joint value.
    #[error("arm {arm} waypoint {step} joint {joint}: not a finite number")]
    NotFinite {
        /// The arm.
        arm: usize,
        /// The waypoint's step.
        step: usize,
        /// The joint, from 1.
        joint: usize,
    },
    /// The stream passed, again and again, the cycle a push was being prepared for (a push
    /// is computed on the caller's thread beside the running stream, for a cycle a little
    /// ahead; the caller's thread got too little time on this machine).
    #[error(
        "the stream outran the push {attempts} times: the pushing thread gets too little time"
    )]
    Outrun {
        /// Attempts made.
        attempts: usize,
    },
    /// The push starts at a step the arms are already executing toward (or past).
    #[error(
        "start step {start} is already fixed: the arms are executing toward step {fixed}, \
         so a segment may start at step {} at the earliest", fixed + 1
    )]
    AlreadyFixed {
        /// The push's first step.
        start: usize,
        /// The last fixed step.
        fixed: usize,
    },
    /// The push starts after the queue's end plus one.
    #[error("start step {start} leaves a gap: the queue ends at step {end}")]
    Gap {
        /// The push's first step.
        start: usize,
        /// The queue's last step.
        end: usize,
    },
    /// The push would queue more than the stream allows ahead of the fixed step.
    #[error("the queue would reach step {end}, {steps} steps ahead of step {fixed}; at most {max} steps may be queued")]
    TooLong {
        /// The last step it would queue.
        end: usize,
        /// Steps ahead of the fixed one.
        steps: usize,
        /// The last fixed step.
        fixed: usize,
        /// The most allowed.
        max: usize,
    },
    /// The stream has stopped (a fault, or its end): nothing more is taken.
    #[error("the stream has stopped: {0}")]
    Stopped(String),
    /// The new tail is too short to stop in from the current speed.
    #[error("the arms cannot stop within the new tail: {0}")]
    CannotStop(String),
    /// A command the new tail leads to breaks a limit.
    #[error("arm {arm}, step {step} (cycle {cycle}): {error}")]
    Limits {
        /// The arm.
        arm: usize,
        /// The step being executed when it would.
        step: usize,
        /// The cycle it would be sent in.
        cycle: u64,
        /// The broken limit.
        error: String,
    },
}

/// Commands for every arm, one control cycle at a time. See the module documentation.
///
/// Memory: the queued waypoints (from the one the arms move from to the end), bounded by
/// [`Generator::with_max_queued`]; a push costs one pass over its whole new tail.
///
/// ```
/// use omcbsa_hw::stream::Generator;
/// use omcbsa_hw::cia402::counts_to_rad;
/// use omcbsa_hw::JOINTS;
///
/// let limits = omcbsa_mock::testing::fleet_limits(1);
/// // One arm at rest at 0, steps of 0.5 s, cycles of 2 ms.
/// let mut g = Generator::new(&[[0.0; JOINTS]], &limits, 0.002, 0.5)?;
/// g.push(1, &[&[[0.05; JOINTS], [0.1; JOINTS]]])?;
/// let mut out = [[0; JOINTS]];
/// let mut cycles = 0;
/// while !g.next(&mut out)?.holding {
///     cycles += 1;
/// }
/// // Two steps of 0.5 s at 2 ms (the law starts and stops as fast as the limits allow),
/// // and the arm holds at the last waypoint.
/// assert!((500..510).contains(&cycles), "{cycles}");
/// assert!((counts_to_rad(out[0][0]) - 0.1).abs() < 1e-7);
/// // Step 2 is where the arms hold: a push may start at step 3 at the earliest.
/// assert!(g.push(2, &[&[[0.0; JOINTS]]]).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct Generator {
    period: f64,
    /// The fastest pace, steps per second.
    max_speed: f64,
    tracks: Vec<Track>,
    /// Step of every track's `queue[0]`.
    base: usize,
    /// The last waypoint whose position and tangent are frozen: the arms move from
    /// `fixed - 1` to `fixed`, or hold at `fixed`.
    fixed: usize,
    holding: bool,
    /// The hold began this cycle, at the end of a motion.
    ran_dry: bool,
    /// The time law of the queue from the last push: its grid (steps from `law_from`) and
    /// the time along it.
    law: Vec<GridPoint>,
    law_from: usize,
    law_t: f64,
    /// Position on the timeline, in steps, and its speed, steps/s.
    x: f64,
    speed: f64,
    cycle: u64,
    /// Waypoints queued beyond `fixed` that a push may create, at most.
    max_queued: usize,
}

impl Generator {
    /// Arms holding still at `starts` (waypoint 0), each within its own `limits` (one table
    /// per arm), with steps of `step_time` s and control cycles of `period` s.
    pub fn new(
        starts: &[[f64; JOINTS]],
        limits: &[ArmLimits],
        period: f64,
        step_time: f64,
    ) -> Result<Self, String> {
        if !(period.is_finite() && period > 0.0) {
            return Err(format!(
                "the control period must be a positive number of seconds, got {period}"
            ));
        }
        if !(step_time.is_finite() && step_time > 0.0) {
            return Err(format!(
                "the time per step must be a positive number of seconds, got {step_time}"
            ));
        }
        let max_speed = 1.0 / step_time;
        if !(max_speed.is_finite() && max_speed > 0.0) {
            return Err(format!(
                "a step of {step_time} s cannot be streamed at a period of {period} s"
            ));
        }
        if starts.is_empty() {
            return Err("no arms".into());
        }
        if limits.len() != starts.len() {
            return Err(format!(
                "{} tables of joint limits for {} arms: one per arm",
                limits.len(),
                starts.len()
            ));
        }
        let tracks = (starts.iter().zip(limits).enumerate())
            .map(|(a, (q, limits))| {
                let counts = to_counts(q).map_err(|e| format!("arm {a} start: {e}"))?;
                for (j, l) in limits.iter().enumerate() {
                    if let Some((lo, hi)) = l.position {
                        if !(lo..=hi).contains(&q[j]) {
                            return Err(format!(
                                "arm {a} start: joint {}: position {} rad outside [{lo}, {hi}]",
                                j + 1,
                                q[j]
                            ));
                        }
                    }
                }
                let window =
                    filter_window(limits, period).map_err(|e| format!("arm {a} limits: {e}"))?;
                Ok(Track {
                    queue: VecDeque::from([*q]),
                    tangents: [[0.0; JOINTS]; 2],
                    prev: [counts; 3],
                    recent: VecDeque::from(vec![*q; window]),
                    limits: *limits,
                })
            })
            .collect::<Result<_, String>>()?;
        Ok(Self {
            period,
            max_speed,
            tracks,
            base: 0,
            fixed: 0,
            holding: true,
            ran_dry: false,
            law: Vec::new(),
            law_from: 0,
            law_t: 0.0,
            x: 0.0,
            speed: 0.0,
            cycle: 0,
            max_queued: usize::MAX,
        })
    }

    /// Refuses pushes that would queue more than `steps` waypoints beyond the fixed one (each
    /// push is checked over its whole tail, so this bounds a push's cost and the queue).
    pub fn with_max_queued(mut self, steps: usize) -> Self {
        self.max_queued = steps;
        self
    }

    /// Arms streamed.
    pub fn arms(&self) -> usize {
        self.tracks.len()
    }

    /// The last waypoint whose position is frozen: a push may start at the next step.
    pub fn fixed(&self) -> usize {
        self.fixed
    }

    /// The last queued step.
    pub fn end(&self) -> usize {
        self.base + self.tracks[0].queue.len() - 1
    }

    /// The step being executed (see [`Tick::step`]).
    pub fn step(&self) -> usize {
        if self.holding {
            self.fixed
        } else {
            self.fixed - 1
        }
    }

    /// Whether the arms hold (at [`Generator::fixed`]) rather than move.
    pub fn holding(&self) -> bool {
        self.holding
    }

    /// Every arm's last command (before the first cycle: its start).
    pub fn held(&self) -> impl Iterator<Item = Command> + '_ {
        self.tracks.iter().map(|t| t.prev[2])
    }

    /// Cycles produced so far.
    pub fn cycle(&self) -> u64 {
        self.cycle
    }

    /// Replaces every arm's waypoints from step `start` on by `waypoints[arm]` (waypoint `i`
    /// at step `start + i`), after checking every command the new tail leads to.
    pub fn push(&mut self, start: usize, waypoints: &[&[[f64; JOINTS]]]) -> Result<(), PushError> {
        self.check_shape(start, waypoints)?;
        let mut next = self.clone();
        next.replace_tail(start, waypoints)?;
        next.clone().run_to_hold()?;
        *self = next;
        Ok(())
    }

    fn check_shape(&self, start: usize, waypoints: &[&[[f64; JOINTS]]]) -> Result<(), PushError> {
        if waypoints.len() != self.tracks.len() {
            return Err(PushError::Arms {
                expected: self.tracks.len(),
                got: waypoints.len(),
            });
        }
        let n = waypoints[0].len();
        if n == 0 {
            return Err(PushError::Empty);
        }
        for (arm, w) in waypoints.iter().enumerate() {
            if w.len() != n {
                return Err(PushError::Lengths {
                    arm,
                    expected: n,
                    got: w.len(),
                });
            }
            for (i, q) in w.iter().enumerate() {
                if let Some(j) = q.iter().position(|v| !v.is_finite()) {
                    return Err(PushError::NotFinite {
                        arm,
                        step: start.saturating_add(i),
                        joint: j + 1,
                    });
                }
            }
        }
        if start <= self.fixed {
            return Err(PushError::AlreadyFixed {
                start,
                fixed: self.fixed,
            });
        }
        let end = self.end();
        if start > end + 1 {
            return Err(PushError::Gap { start, end });
        }
        let steps = start - 1 - self.fixed + n;
        if steps > self.max_queued {
            return Err(PushError::TooLong {
                end: start - 1 + n,
                steps,
                fixed: self.fixed,
                max: self.max_queued,
            });
        }
        Ok(())
    }

    fn replace_tail(
        &mut self,
        start: usize,
        waypoints: &[&[[f64; JOINTS]]],
    ) -> Result<(), PushError> {
        for (t, w) in self.tracks.iter_mut().zip(waypoints) {
            t.queue.truncate(start - self.base);
            t.queue.extend(w.iter().copied());
        }
        self.retime()
    }

    /// Runs until the first cycle of the hold at the queue's end, checking every command.
    fn run_to_hold(&mut self) -> Result<(), PushError> {
        let mut out = vec![[0; JOINTS]; self.tracks.len()];
        loop {
            let tick = self.next(&mut out)?;
            if tick.holding {
                return Ok(());
            }
        }
    }

    /// Recomputes the time law from where the arms are (step `x` at `speed`) to rest at the
    /// queue's end: every arm's joints side by side, one law.
    fn retime(&mut self) -> Result<(), PushError> {
        // The path starts at the waypoint the arms move from, with the tangents frozen there.
        let from = if self.holding {
            self.fixed
        } else {
            self.fixed - 1
        };
        let arms = self.tracks.len();
        let dof = arms * JOINTS;
        let n = self.end() + 1 - from;
        let mut points = vec![0.0; n * dof];
        let (mut at0, mut at1) = (vec![0.0; dof], vec![0.0; dof]);
        let (mut velocity, mut acceleration) = (vec![0.0; dof], vec![0.0; dof]);
        for (a, t) in self.tracks.iter().enumerate() {
            for (k, q) in t.queue.iter().skip(from - self.base).enumerate() {
                points[k * dof + a * JOINTS..][..JOINTS].copy_from_slice(q);
            }
            for j in 0..JOINTS {
                let c = a * JOINTS + j;
                (at0[c], at1[c]) = (t.tangents[0][j], t.tangents[1][j]);
                velocity[c] = LAW_SHARE * t.limits[j].velocity;
                acceleration[c] = law_acceleration(t.limits[j].acceleration, self.period);
            }
        }
        self.law_from = from;
        self.law_t = 0.0;
        self.law.clear();
        if n < 2 {
            return Ok(());
        }
        let cannot = |e: omcbsa_core::retime::RetimeError| PushError::CannotStop(e.to_string());
        let mut path = JointPath::new(&points, dof).map_err(cannot)?;
        if !self.holding {
            path = path.with_frozen_tangents(&at0, &at1).map_err(cannot)?;
        }
        let options = Options {
            per_segment: PER_SEGMENT,
            max_speed: self.max_speed,
            start: self.x - from as f64,
            start_speed: self.speed,
        };
        let limits = Limits {
            velocity: &velocity,
            acceleration: &acceleration,
        };
        self.law = vec![GridPoint::default(); omcbsa_core::retime::grid_len(&path, &options)];
        retime(&path, &limits, &options, &mut self.law).map_err(cannot)?;
        Ok(())
    }

    /// The commands of the next cycle (one per arm, into `out`), checked against the limits.
    /// A refused command is an error and leaves the generator where it was (it happens only
    /// if the limits changed since the push; pushed tails are checked in full).
    pub fn next(&mut self, out: &mut [Command]) -> Result<Tick, PushError> {
        let tick = Tick {
            cycle: self.cycle,
            step: self.step(),
            holding: self.holding && self.end() == self.fixed,
            ran_dry: self.ran_dry,
        };
        let mut recent = Vec::with_capacity(self.tracks.len());
        for (arm, (t, o)) in self.tracks.iter().zip(out.iter_mut()).enumerate() {
            let error = |error: String| PushError::Limits {
                arm,
                step: tick.step,
                cycle: self.cycle,
                error,
            };
            let mut window = t.recent.clone();
            window.pop_front();
            window.push_back(self.position(t));
            let q = average(&window);
            *o = to_counts(&q).map_err(error)?;
            check_command(&t.limits, &t.prev[1], &t.prev[2], o, self.period).map_err(error)?;
            check_jerk(&t.limits, &t.prev, o, self.period).map_err(error)?;
            recent.push(window);
        }
        for ((t, o), w) in self.tracks.iter_mut().zip(out.iter()).zip(recent) {
            t.prev = [t.prev[1], t.prev[2], *o];
            t.recent = w;
        }
        self.cycle += 1;
        self.advance();
        Ok(tick)
    }

    /// Position of a track at the current `x`.
    fn position(&self, t: &Track) -> [f64; JOINTS] {
        let at = |step: usize| t.queue[step - self.base];
        if self.holding || self.fixed == 0 {
            return at(self.fixed);
        }
        let (p0, p1) = (at(self.fixed - 1), at(self.fixed));
        let u = self.x - (self.fixed - 1) as f64;
        std::array::from_fn(|j| {
            Segment {
                p0: p0[j],
                p1: p1[j],
                m0: t.tangents[0][j],
                m1: t.tangents[1][j],
            }
            .position(u)
        })
    }

    /// Whether the next command is the last waypoint: the filter's window, once the
    /// oldest position leaves it, holds only that.
    fn settled(&self) -> bool {
        self.tracks.iter().all(|t| {
            let last = t.queue.back();
            t.recent.iter().skip(1).all(|q| Some(q) == last)
        })
    }

    /// Moves the timeline one cycle on.
    fn advance(&mut self) {
        let end = self.end();
        self.ran_dry = false;
        if self.holding {
            if end == self.fixed {
                return;
            }
            self.holding = false;
            self.enter_next();
        }
        self.law_t += self.period;
        // The last cycle of a law lands on its end up to rounding: snap to it.
        let done = self.law.last().is_none_or(|p| self.law_t >= p.t - 1e-9);
        if done {
            (self.x, self.speed) = (end as f64, 0.0);
        } else {
            let state = TimeLaw::from_points(&self.law).sample(self.law_t);
            self.x = self.law_from as f64 + state.s;
            self.speed = state.speed;
        }
        while self.x >= self.fixed as f64 && self.fixed < end {
            self.enter_next();
        }
        // The law is done and the commands have caught up with the last waypoint: hold.
        if done && self.fixed == end && self.settled() {
            (self.x, self.speed, self.holding, self.ran_dry) = (end as f64, 0.0, true, true);
        }
    }

    /// Starts the segment toward waypoint `fixed + 1`, freezing its tangent there.
    fn enter_next(&mut self) {
        self.fixed += 1;
        let w = self.fixed;
        for t in &mut self.tracks {
            let at = |step: usize| t.queue.get(step - self.base).copied();
            let (prev, here, next) = (at(w - 1), at(w), at(w + 1));
            t.tangents[0] = t.tangents[1];
            t.tangents[1] = match (prev, here, next) {
                (Some(a), Some(b), Some(c)) => {
                    std::array::from_fn(|j| fritsch_butland(b[j] - a[j], c[j] - b[j]))
                }
                _ => [0.0; JOINTS],
            };
        }
        // Waypoints before `fixed - 1` are no longer needed.
        while self.base + 1 < self.fixed {
            for t in &mut self.tracks {
                t.queue.pop_front();
            }
            self.base += 1;
        }
    }
}

/// Cycles the jerk filter averages over: enough that a full swing of acceleration spread
/// over them stays within the jerk limit, `2 · acceleration / (jerk · period)` for the joint
/// that needs most (1 for limits without jerk).
fn filter_window(limits: &ArmLimits, period: f64) -> Result<usize, String> {
    let mut n = 1.0_f64;
    for (j, l) in limits.iter().enumerate() {
        if l.jerk.is_nan() || l.jerk <= 0.0 {
            return Err(format!(
                "joint {}: jerk limit {} is not a positive number",
                j + 1,
                l.jerk
            ));
        }
        // (less a hair, so that an exact ratio is not rounded up to one cycle more)
        n = n.max((2.0 * l.acceleration / (l.jerk * period) - 1e-9).ceil());
    }
    // A bound on the window, so that a tiny jerk limit cannot ask for an unbounded buffer.
    if n > 10_000.0 {
        return Err(format!(
            "the jerk limits need an average over {n} cycles of {period} s: too small"
        ));
    }
    Ok(n as usize)
}

/// The mean of the filter's window.
fn average(window: &VecDeque<[f64; JOINTS]>) -> [f64; JOINTS] {
    let n = window.len() as f64;
    std::array::from_fn(|j| window.iter().map(|q| q[j]).sum::<f64>() / n)
}

/// Checks the jerk `cmd` implies after the three previous commands, one period apart, with
/// room for the commands' rounding to whole counts (up to 4 counts in a third difference).
fn check_jerk(
    limits: &ArmLimits,
    prev: &[Command; 3],
    cmd: &Command,
    period: f64,
) -> Result<(), String> {
    let rounding = 4.0 / COUNTS_PER_RAD / period.powi(3);
    for (j, l) in limits.iter().enumerate() {
        let [p3, p2, p1] = prev.map(|p| i64::from(p[j]));
        let d = i64::from(cmd[j]) - 3 * p1 + 3 * p2 - p3;
        let jerk = d as f64 / COUNTS_PER_RAD / period.powi(3);
        if jerk.abs() > l.jerk + rounding {
            return Err(format!(
                "joint {}: jerk {jerk:.1} rad/s³ exceeds the limit {}",
                j + 1,
                l.jerk
            ));
        }
    }
    Ok(())
}

fn to_counts(q: &[f64; JOINTS]) -> Result<Command, String> {
    let mut c = [0; JOINTS];
    for (j, (&v, c)) in q.iter().zip(c.iter_mut()).enumerate() {
        *c = rad_to_counts(v)
            .ok_or_else(|| format!("joint {}: {v} rad is outside the bus range", j + 1))?;
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cia402::counts_to_rad;
    use crate::plan::JointLimits;

    const PERIOD: f64 = 0.002;

    /// One arm from `from`, `n` waypoints moving joint 1 (and 5) by `step` rad each.
    fn ramp(from: f64, step: f64, n: usize) -> Vec<[f64; JOINTS]> {
        (1..=n)
            .map(|i| {
                let mut q = [0.1; JOINTS];
                q[0] = from + step * i as f64;
                q[4] = q[0] / 2.0;
                q
            })
            .collect()
    }

    fn generator() -> Generator {
        let mut start = [0.1; JOINTS];
        (start[0], start[4]) = (0.0, 0.0);
        Generator::new(&[start], &crate::testing::fleet_limits(1), PERIOD, 0.5).unwrap()
    }

    /// Runs `cycles` cycles (or until the hold at the end); the commands and ticks.
    fn run(g: &mut Generator, cycles: usize) -> Vec<(Tick, Command)> {
        let mut out = [[0; JOINTS]];
        let mut seen = Vec::new();
        for _ in 0..cycles {
            let tick = g.next(&mut out).unwrap();
            seen.push((tick, out[0]));
            if tick.holding && tick.cycle > 0 {
                break;
            }
        }
        seen
    }

    #[test]
    fn replacing_the_tail_keeps_what_runs_and_lands_on_the_new_end() {
        let (mut a, mut b) = (generator(), generator());
        let path = ramp(0.0, 0.02, 10);
        a.push(1, &[&path]).unwrap();
        b.push(1, &[&path]).unwrap();
        let before = run(&mut a, 700);
        assert_eq!(run(&mut b, 700), before);
        assert_eq!(a.step(), 2); // 700 cycles of 2 ms at 0.5 s per step
        assert_eq!(a.fixed(), 3);
        // turn back from step 4 on
        let back = ramp(a.tracks[0].queue[3 - a.base][0], -0.02, 6);
        a.push(4, &[&back]).unwrap();
        let (after, unchanged) = (run(&mut a, 100_000), run(&mut b, 100_000));
        // what was executing (up to waypoint 3, frozen) is the same until step 3 is reached
        let reach3 = (3.0 * 0.5 / PERIOD) as usize - 700;
        for k in 0..reach3 {
            assert_eq!(after[k], unchanged[k], "cycle {k}");
        }
        let end = |s: &[(Tick, Command)]| counts_to_rad(s[s.len() - 1].1[0]);
        assert!((end(&after) - back[5][0]).abs() < 1e-7, "{}", end(&after));
        assert!((end(&unchanged) - path[9][0]).abs() < 1e-7);
        // every command of the spliced run passed the check (`run` unwraps `next`), and the
        // splice is smooth: no cycle-to-cycle velocity change above the acceleration limit
        let all: Vec<Command> = before.iter().chain(&after).map(|s| s.1).collect();
        for w in all.windows(3) {
            let acc = counts_to_rad(w[2][0] - 2 * w[1][0] + w[0][0]) / PERIOD / PERIOD;
            assert!(acc.abs() <= 1.0 + 1e-9, "{acc}");
        }
    }

    #[test]
    fn pushes_into_the_fixed_past_or_past_a_gap_are_refused() {
        let mut g = generator();
        g.push(1, &[&ramp(0.0, 0.02, 10)]).unwrap();
        run(&mut g, 700);
        let e = g.push(3, &[&ramp(0.0, 0.0, 2)]).unwrap_err();
        assert_eq!(e, PushError::AlreadyFixed { start: 3, fixed: 3 });
        assert!(e.to_string().contains("at step 4 at the earliest"), "{e}");
        let e = g.push(12, &[&ramp(0.0, 0.0, 2)]).unwrap_err();
        assert_eq!(e, PushError::Gap { start: 12, end: 10 });
        let e = g.push(5, &[&[[f64::NAN; JOINTS]]]).unwrap_err();
        assert!(e.to_string().contains("waypoint 5 joint 1"), "{e}");
        let e = g.push(5, &[]).unwrap_err();
        assert_eq!(
            e,
            PushError::Arms {
                expected: 1,
                got: 0
            }
        );
    }

    #[test]
    fn segment_breaking_a_limit_is_refused_and_changes_nothing() {
        let mut g = generator();
        let path = ramp(0.0, 0.02, 10);
        g.push(1, &[&path]).unwrap();
        run(&mut g, 300);
        let queued = g.clone();
        // joint 2 beyond its position limit (±2.24 rad), however slowly
        let mut far = ramp(0.0, 0.02, 10);
        let last = far[9];
        far.extend((1..=300).map(|i| {
            let mut q = last;
            q[1] = 0.1 + 0.008 * i as f64;
            q
        }));
        let e = g.push(5, &[&far[4..]]).unwrap_err();
        assert!(matches!(e, PushError::Limits { arm: 0, .. }), "{e}");
        assert!(e.to_string().contains("joint 2: position 2.24"), "{e}");
        assert_eq!(format!("{g:?}"), format!("{queued:?}"));
        // A jump too fast for joint 1's velocity at the plan's pace is no longer refused:
        // the time law slows down to follow it within the limits.
        let mut jump = ramp(0.0, 0.02, 10);
        jump[6][0] += 1.0;
        g.push(5, &[&jump[4..]]).unwrap();
        let cycles = run(&mut g, 1_000_000).len();
        assert!(cycles as f64 * PERIOD > 10.0 * 0.5, "{cycles}");
    }

    #[test]
    fn dry_queue_holds_at_rest_and_resumes_on_a_later_push() {
        let mut g = generator();
        let path = ramp(0.0, 0.02, 3);
        g.push(1, &[&path]).unwrap();
        let first = run(&mut g, 100_000);
        let (tick, last) = first[first.len() - 1];
        assert!(tick.holding && tick.ran_dry && tick.step == 3, "{tick:?}");
        assert!((counts_to_rad(last[0]) - path[2][0]).abs() < 1e-7);
        // it holds, reporting the dry queue once
        let held = run(&mut g, 10);
        assert!(held
            .iter()
            .all(|(t, c)| t.holding && !t.ran_dry && *c == last));
        // a late segment continues from the held waypoint
        let e = g.push(3, &[&ramp(0.06, 0.02, 3)]).unwrap_err();
        assert!(matches!(e, PushError::AlreadyFixed { .. }), "{e}");
        g.push(4, &[&ramp(0.06, 0.02, 3)]).unwrap();
        let resumed = run(&mut g, 100_000);
        assert!(!resumed[1].0.holding && resumed[1].0.step == 3);
        let end = resumed[resumed.len() - 1];
        assert!(end.0.holding && end.0.step == 6);
        assert!((counts_to_rad(end.1[0]) - 0.12).abs() < 1e-7);
    }

    /// Gen3-like limits with a jerk limit: 1.2 rad/s, 5 rad/s², 2500 rad/s³ (the filter
    /// averages 2·5/(2500·0.002) = 2 cycles).
    fn jerk_limits() -> ArmLimits {
        [JointLimits {
            position: None,
            velocity: 1.2,
            acceleration: 5.0,
            jerk: 2500.0,
        }; JOINTS]
    }

    /// A straight line for every joint, `n` waypoints of `step` rad from 0.
    fn line(n: usize, step: f64) -> Vec<[f64; JOINTS]> {
        (1..=n).map(|i| [step * i as f64; JOINTS]).collect()
    }

    /// Velocity, acceleration and jerk of joint 1 at the control rate, from commands.
    fn derivatives(cmds: &[Command]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let q: Vec<f64> = cmds.iter().map(|c| counts_to_rad(c[0])).collect();
        let d = |v: &[f64]| -> Vec<f64> { v.windows(2).map(|w| (w[1] - w[0]) / PERIOD).collect() };
        let v = d(&q);
        let a = d(&v);
        let j = d(&a);
        (v, a, j)
    }

    #[test]
    fn a_short_tail_at_speed_decelerates_over_several_waypoints_within_every_limit() {
        // Steps of 20 ms at 0.024 rad: 1.2 rad/s, the velocity limit, when on time.
        let mut g = Generator::new(&[[0.0; JOINTS]], &[jerk_limits()], PERIOD, 0.02).unwrap();
        g.push(1, &[&line(200, 0.024)]).unwrap();
        let cruise = run(&mut g, 500); // 1 s: up to speed
        let fixed = g.fixed();
        // Stop: 8 more waypoints (0.19 rad); a stop from 1.2 rad/s at 5 rad/s² needs 0.144 rad.
        let tail = line(fixed + 8, 0.024)[fixed..].to_vec();
        g.push(fixed + 1, &[&tail]).unwrap();
        let stop = run(&mut g, 100_000);
        let cmds: Vec<Command> = cruise.iter().chain(&stop).map(|s| s.1).collect();
        let (v, a, j) = derivatives(&cmds);
        // at full speed (the law plans with 98 % of the limits) before the push
        assert!(v[499].abs() > 1.17, "{}", v[499]);
        // within the limits (up to rounding to counts) at every cycle
        assert!(v.iter().all(|v| v.abs() <= 1.2 + 1e-4));
        assert!(a.iter().all(|a| a.abs() <= 5.0 + 0.1));
        assert!(
            j.iter().all(|j| j.abs() <= 2500.0 + 50.0),
            "{:?}",
            j.iter().fold(0.0f64, |m, j| m.max(j.abs()))
        );
        // It slows down over several steps (it used to stop within the last one), and lands
        // on the tail's end.
        let slowing = v.iter().skip(500).filter(|v| v.abs() < 1.17).count();
        let steps = slowing as f64 * PERIOD / 0.02;
        assert!(steps > 5.0, "{steps}");
        let end = stop[stop.len() - 1];
        assert!(end.0.holding && end.0.step == fixed + 8, "{:?}", end.0);
        assert!((counts_to_rad(end.1[0]) - 0.024 * (fixed + 8) as f64).abs() < 1e-7);
    }

    #[test]
    fn a_tail_too_short_to_stop_in_is_refused() {
        let mut g = Generator::new(&[[0.0; JOINTS]], &[jerk_limits()], PERIOD, 0.02).unwrap();
        g.push(1, &[&line(200, 0.024)]).unwrap();
        run(&mut g, 500);
        let before = format!("{g:?}");
        let fixed = g.fixed();
        // one more waypoint: 0.024 rad to stop from 1.2 rad/s, 0.144 rad needed
        let tail = line(fixed + 1, 0.024)[fixed..].to_vec();
        let e = g.push(fixed + 1, &[&tail]).unwrap_err();
        assert!(matches!(e, PushError::CannotStop(_)), "{e}");
        assert!(e.to_string().contains("cannot stop"), "{e}");
        assert_eq!(format!("{g:?}"), before);
    }

    #[test]
    fn limits_without_a_positive_jerk_are_refused() {
        let mut l = jerk_limits();
        l[3].jerk = 0.0;
        let e = Generator::new(&[[0.0; JOINTS]], &[l], PERIOD, 0.02).unwrap_err();
        assert!(e.contains("joint 4: jerk limit 0"), "{e}");
    }
}
