//! The streaming frame generator: joint commands computed cycle by cycle from a queue of
//! waypoints, for a whole plan (offline execution) and for segments pushed while the arms move
//! (online execution) alike. Memory is the queue only, whatever the run's duration.
//!
//! Waypoint `i` of every arm belongs to step `i`; a step lasts `step_time` seconds. Each joint
//! follows the cubic Hermite spline of `interpolate` (Fritsch–Butland tangents, at rest at
//! the start). A waypoint's tangent is frozen when the segment ending at it begins, from the
//! waypoints queued at that moment (zero if it is the last one): what is being executed never
//! changes, and the spline stays C1 (continuous position and velocity) across any later push.
//!
//! [`Generator::push`] replaces the queue's tail from a step that is not yet fixed and first
//! runs a copy of the generator over the whole new tail, checking every command it would send
//! (position, velocity and acceleration limits, bus range) up to the hold at its end: a tail
//! that breaks a limit anywhere is refused and the queue is left as it was. Because every
//! accepted tail ends at rest within the limits, a queue that runs dry (no further push in
//! time) brings the arms to a hold within their limits; the generator then holds, reports it,
//! and resumes smoothly when a later push extends the queue.

use crate::cia402::rad_to_counts;
use crate::plan::{check_command, ArmLimits};
use crate::run::{Command, JOINTS};
use crate::spline::{fritsch_butland, Segment};
use std::collections::VecDeque;

/// One arm's queue and its frozen part.
#[derive(Clone, Debug)]
struct Track {
    /// Waypoint `base + i` of this arm, rad.
    queue: VecDeque<[f64; JOINTS]>,
    /// Tangents (rad per step) at waypoints `fixed - 1` and `fixed`.
    tangents: [[f64; JOINTS]; 2],
    /// The two commands sent before the next one.
    prev: [Command; 2],
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
/// // Two steps of 0.5 s at 2 ms, and the arm holds at the last waypoint.
/// assert_eq!(cycles, 500);
/// assert!((counts_to_rad(out[0][0]) - 0.1).abs() < 1e-7);
/// // Step 2 is where the arms hold: a push may start at step 3 at the earliest.
/// assert!(g.push(2, &[&[[0.0; JOINTS]]]).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct Generator {
    period: f64,
    /// Steps per control cycle.
    rate: f64,
    tracks: Vec<Track>,
    /// Step of every track's `queue[0]`.
    base: usize,
    /// The last waypoint whose position and tangent are frozen: the arms move from
    /// `fixed - 1` to `fixed`, or hold at `fixed`.
    fixed: usize,
    holding: bool,
    /// The hold began this cycle, at the end of a motion.
    ran_dry: bool,
    /// Step position of the current motion's start and cycles since it.
    origin: f64,
    since: u64,
    /// Position on the timeline, in steps.
    x: f64,
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
        let rate = period / step_time;
        if !(rate.is_finite() && rate > 0.0) {
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
                Ok(Track {
                    queue: VecDeque::from([*q]),
                    tangents: [[0.0; JOINTS]; 2],
                    prev: [counts; 2],
                    limits: *limits,
                })
            })
            .collect::<Result<_, String>>()?;
        Ok(Self {
            period,
            rate,
            tracks,
            base: 0,
            fixed: 0,
            holding: true,
            ran_dry: false,
            origin: 0.0,
            since: 0,
            x: 0.0,
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
        self.tracks.iter().map(|t| t.prev[1])
    }

    /// Cycles produced so far.
    pub fn cycle(&self) -> u64 {
        self.cycle
    }

    /// Replaces every arm's waypoints from step `start` on by `waypoints[arm]` (waypoint `i`
    /// at step `start + i`), after checking every command the new tail leads to.
    pub fn push(&mut self, start: usize, waypoints: &[&[[f64; JOINTS]]]) -> Result<(), PushError> {
        self.check_shape(start, waypoints)?;
        let mut trial = self.clone();
        trial.replace_tail(start, waypoints);
        trial.run_to_hold()?;
        self.replace_tail(start, waypoints);
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

    fn replace_tail(&mut self, start: usize, waypoints: &[&[[f64; JOINTS]]]) {
        for (t, w) in self.tracks.iter_mut().zip(waypoints) {
            t.queue.truncate(start - self.base);
            t.queue.extend(w.iter().copied());
        }
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
        for (arm, (t, o)) in self.tracks.iter().zip(out.iter_mut()).enumerate() {
            let error = |error: String| PushError::Limits {
                arm,
                step: tick.step,
                cycle: self.cycle,
                error,
            };
            let q = self.position(t);
            *o = to_counts(&q).map_err(error)?;
            check_command(&t.limits, &t.prev[0], &t.prev[1], o, self.period).map_err(error)?;
        }
        for (t, o) in self.tracks.iter_mut().zip(out.iter()) {
            t.prev = [t.prev[1], *o];
        }
        self.cycle += 1;
        self.advance();
        Ok(tick)
    }

    /// Position of a track at the current `x`.
    fn position(&self, t: &Track) -> [f64; JOINTS] {
        let at = |step: usize| t.queue[step - self.base];
        if self.holding {
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

    /// Moves the timeline one cycle on.
    fn advance(&mut self) {
        let end = self.end();
        self.ran_dry = false;
        if self.holding {
            if end == self.fixed {
                return;
            }
            self.holding = false;
            (self.origin, self.since) = (self.fixed as f64, 0);
        }
        self.since += 1;
        self.x = self.origin + self.since as f64 * self.rate;
        // The last cycle of a plan lands on its last waypoint up to rounding: snap to it.
        if self.x >= end as f64 - 1e-9 {
            while self.fixed < end {
                self.enter_next();
            }
            (self.x, self.holding, self.ran_dry) = (end as f64, true, true);
            return;
        }
        while self.x >= self.fixed as f64 {
            self.enter_next();
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
        // a jump too fast for joint 1's velocity and acceleration
        let mut jump = ramp(0.0, 0.02, 10);
        jump[6][0] += 1.0;
        let e = g.push(5, &[&jump[4..]]).unwrap_err();
        assert!(e.to_string().contains("joint 1: "), "{e}");
        assert_eq!(format!("{g:?}"), format!("{queued:?}"));
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
}
