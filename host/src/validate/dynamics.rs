//! Rules 6 to 8: what the arms' joints must do to follow a plan, against their acceleration
//! and jerk limits (each robot's model's, under its cell's scale; jerk is not scaled).
//!
//! Each robot's executed timeline is checked: its joint path, or with an approach `initial`,
//! the approach, then the joint path (what the executor streams).
//!
//! - Rule 6, at the plan's steps: `(q[t+1] - 2 q[t] + q[t-1]) / dt²` at every step `t` with a
//!   step on either side in the same phase (the approach, the path). The ends are not taken at
//!   rest: a policy's hands are already moving when a plan begins and still moving when it
//!   ends, and bringing the arms from and to rest is the executor's (its time law starts and
//!   ends at rest, slower where it must: rules 7 and 8). This is the rule the planners keep
//!   (`omcbsa_core::pace`).
//! - Rules 7 and 8, at the control rate: the timelines streamed as the executor streams them
//!   (`omcbsa_hw::interpolate`: the same spline, time law, jerk filter and rounding to bus
//!   counts, under the robots' velocity, acceleration and jerk limits) at [`CONTROL_PERIOD`];
//!   second and third differences of the commanded positions, at rest before the first
//!   command and after the last. A violation names the plan step the stream's mean pace is at
//! (the law is slower in places, so it can name a step early); a plan the
//!   executor refuses to stream is a violation of rule 7. The rounding of each command to a bus
//!   count (1e-7 rad) is not the plan's: its worst effect on a difference (2 counts on a
//!   second, 4 on a third) is allowed.
//!
//! One violation per robot, joint and step, with the worst value there. Cost: one pass over
//! the steps, and for rules 7 and 8 the commands of the whole plan (one `i32` per joint, arm
//! and control period: 28 kB per arm and second at 1 kHz).

use omcbsa_core::model::Models;
use omcbsa_core::problem::Problem;
use omcbsa_hw::cia402::COUNTS_PER_RAD;
use omcbsa_hw::{ArmPlan, JointLimits, Plan, JOINTS};

use super::report::{Measured, Phase, Report, Rule, Violation, MAX_VIOLATIONS};
use crate::format::SolutionFile;
use crate::pose::short;

/// The control period the plan is streamed at for rules 7 and 8, s: 1 kHz, the Gen3's own
/// rate and the executor's default for an arm on Kortex (`omcbsa_hw::port::ArmUrl`), its
/// shortest default period (a shorter period makes the stream's differences largest).
pub const CONTROL_PERIOD: f64 = 0.001;

/// Relative slack on the limits of rule 6, for float rounding.
const RELATIVE_SLACK: f64 = 1e-9;

/// One robot's executed timeline and where its steps count.
struct Timeline<const D: usize> {
    robot: usize,
    q: Vec<[f64; D]>,
    /// Steps before the joint path (0 without an approach; else `initial` and the approach).
    lead: usize,
}

impl<const D: usize> Timeline<D> {
    /// The phase and step of timeline step `k`.
    fn step(&self, k: usize) -> (Phase, usize) {
        if k < self.lead {
            (Phase::Approach, k)
        } else {
            (Phase::Path, k - self.lead)
        }
    }
}

/// Rules 6 to 8 on every robot's executed timeline. `paths` are the checked joint paths (one
/// per robot, of the horizon); an approach whose shape is wrong (reported by rule 5) leaves
/// the rules unchecked.
pub(super) fn check<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    solution: &SolutionFile,
    paths: &[Vec<[f64; D]>],
    report: &mut Report,
) {
    let Some(timelines) = timelines(problem, solution, paths) else {
        return;
    };
    check_steps::<M, D>(problem, &timelines, report);
    check_stream::<M, D>(problem, &timelines, report);
}

/// The executed timelines, or `None` when the approach is malformed.
fn timelines<const D: usize>(
    problem: &Problem<D>,
    solution: &SolutionFile,
    paths: &[Vec<[f64; D]>],
) -> Option<Vec<Timeline<D>>> {
    let Some(approach) = &solution.approach else {
        let each = paths.iter().enumerate();
        return Some(
            each.map(|(robot, p)| Timeline {
                robot,
                q: p.clone(),
                lead: 0,
            })
            .collect(),
        );
    };
    let a = approach.first().map_or(0, Vec::len);
    (paths.iter().zip(&problem.robots).zip(approach).enumerate())
        .map(|(robot, ((path, r), list))| {
            let mut q = vec![r.initial?];
            for c in list {
                q.push(<[f64; D]>::try_from(c.as_slice()).ok()?);
            }
            (list.len() == a).then_some(())?;
            q.extend_from_slice(path);
            Some(Timeline {
                robot,
                q,
                lead: a + 1,
            })
        })
        .collect()
}

/// The worst value per joint and step of one robot, then reported in step order.
struct Worst {
    /// `(step index, joint) -> (value, limit)`, only where over.
    over: std::collections::BTreeMap<(usize, usize), (f64, f64)>,
}

impl Worst {
    fn new() -> Self {
        Worst {
            over: Default::default(),
        }
    }

    fn note(&mut self, k: usize, j: usize, value: f64, limit: f64) {
        let e = self.over.entry((k, j)).or_insert((value, limit));
        if value.abs() > e.0.abs() {
            e.0 = value;
        }
    }

    fn report<M: Models<D>, const D: usize>(
        self,
        rule: Rule,
        what: &str,
        timeline: &Timeline<D>,
        model: u8,
        report: &mut Report,
    ) {
        for ((k, j), (value, limit)) in self.over {
            let (phase, step) = timeline.step(k);
            let detail = format!(
                "joint {} reaches {} {}, over its limit {}",
                M::joint_names(model)[j],
                what,
                short(value),
                short(limit)
            );
            push(
                report,
                rule,
                timeline.robot,
                step,
                phase,
                detail,
                (j, value, limit),
            );
        }
    }
}

fn push(
    report: &mut Report,
    rule: Rule,
    robot: usize,
    step: usize,
    phase: Phase,
    detail: String,
    (joint, value, limit): (usize, f64, f64),
) {
    if report.violations.len() == MAX_VIOLATIONS {
        report.omitted += 1;
        return;
    }
    report.violations.push(Violation {
        rule,
        robot: Some(robot),
        step: Some(step),
        phase,
        detail,
        links: Vec::new(),
        measured: Some(Measured {
            joint,
            value,
            limit,
        }),
    });
}

/// Rule 6: second differences of the timeline at the plan's steps.
fn check_steps<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    timelines: &[Timeline<D>],
    report: &mut Report,
) {
    let dt2 = problem.dt * problem.dt;
    for timeline in timelines {
        let robot = &problem.robots[timeline.robot];
        let limit = robot.acceleration::<M>();
        let q = &timeline.q;
        let mut worst = Worst::new();
        // Interior steps of each phase only: [0, lead) the approach, [lead, len) the path.
        let interior = |t: usize| {
            let (start, end) = if t < timeline.lead {
                (0, timeline.lead)
            } else {
                (timeline.lead, q.len())
            };
            t > start && t + 1 < end
        };
        for t in (0..q.len()).filter(|&t| interior(t)) {
            let (prev, next) = (&q[t - 1], &q[t + 1]);
            for j in 0..D {
                let a = (next[j] - 2.0 * q[t][j] + prev[j]) / dt2;
                if a.abs() > limit[j] * (1.0 + RELATIVE_SLACK) {
                    worst.note(t, j, a, limit[j]);
                }
            }
        }
        let what = "an acceleration (rad/s², at the plan's steps)";
        worst.report::<M, D>(Rule::Acceleration, what, timeline, robot.model, report);
    }
}

/// Rules 7 and 8: the timelines streamed at [`CONTROL_PERIOD`] and the plan's timing.
fn check_stream<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    timelines: &[Timeline<D>],
    report: &mut Report,
) {
    let Some(first) = timelines.first() else {
        return;
    };
    if D != JOINTS {
        report.add(
            Rule::StreamAcceleration,
            Some(first.robot),
            None,
            format!("the executor streams arms of {JOINTS} joints, not {D}: not checked"),
        );
        return;
    }
    let arms = (timelines.iter())
        .map(|t| ArmPlan {
            name: t.robot.to_string(),
            joint_path: t.q.iter().map(|q| std::array::from_fn(|j| q[j])).collect(),
        })
        .collect();
    let plan = Plan {
        dt: problem.dt,
        arms,
    };
    // The robots' own limits (positions are rule 1's): the executor paces the stream by them.
    let limits: Vec<_> = (timelines.iter())
        .map(|t| {
            let robot = &problem.robots[t.robot];
            let (v, a, jerk) = (
                robot.velocity::<M>(),
                robot.acceleration::<M>(),
                M::jerk(robot.model),
            );
            std::array::from_fn(|j| JointLimits {
                position: None,
                velocity: v[j],
                acceleration: a[j],
                jerk: jerk[j],
            })
        })
        .collect();
    let streamed = (plan.check_shape())
        .and_then(|()| omcbsa_hw::interpolate::interpolate(&plan, &limits, CONTROL_PERIOD));
    let trajectory = match streamed {
        Ok(t) => t,
        Err(e) => {
            report.add(
                Rule::StreamAcceleration,
                None,
                None,
                format!("the executor cannot stream the plan within the limits: {e}"),
            );
            return;
        }
    };
    let step_time = problem.dt * trajectory.time_scale;
    for (timeline, commands) in timelines.iter().zip(&trajectory.commands) {
        let robot = &problem.robots[timeline.robot];
        let (acceleration, jerk) = (robot.acceleration::<M>(), *M::jerk(robot.model));
        let last_step = timeline.q.len().saturating_sub(2);
        let step_of = |k: usize| ((k as f64 * CONTROL_PERIOD / step_time) as usize).min(last_step);
        let (mut worst_a, mut worst_j) = (Worst::new(), Worst::new());
        for (k, j, a, jk) in differences(commands) {
            if a.abs() > acceleration[j] + ACCELERATION_ROUNDING {
                worst_a.note(step_of(k), j, a, acceleration[j]);
            }
            if jk.abs() > jerk[j] + JERK_ROUNDING {
                worst_j.note(step_of(k), j, jk, jerk[j]);
            }
        }
        let what = "an acceleration (rad/s², streamed at the control rate)";
        worst_a.report::<M, D>(
            Rule::StreamAcceleration,
            what,
            timeline,
            robot.model,
            report,
        );
        let what = "a jerk (rad/s³, streamed at the control rate)";
        worst_j.report::<M, D>(Rule::StreamJerk, what, timeline, robot.model, report);
    }
}

/// The rounding of commands to bus counts, at its worst on a second difference, rad/s².
const ACCELERATION_ROUNDING: f64 = 2.0 / COUNTS_PER_RAD / (CONTROL_PERIOD * CONTROL_PERIOD);
/// The same on a third difference, rad/s³.
const JERK_ROUNDING: f64 =
    4.0 / COUNTS_PER_RAD / (CONTROL_PERIOD * CONTROL_PERIOD * CONTROL_PERIOD);

/// Per command `k` and joint `j`: the second difference centred at `k` and the third from
/// `k - 1` to `k + 2`, at rest (the first and last command repeated) beyond both ends.
fn differences(commands: &[[i32; JOINTS]]) -> impl Iterator<Item = (usize, usize, f64, f64)> + '_ {
    let n = commands.len();
    let at = move |k: isize, j: usize| {
        let k = k.clamp(0, n as isize - 1) as usize;
        f64::from(commands[k][j]) / COUNTS_PER_RAD
    };
    let p = CONTROL_PERIOD;
    (0..n).flat_map(move |k| {
        let k_ = k as isize;
        (0..JOINTS).map(move |j| {
            let (q0, q1, q2, q3) = (at(k_ - 1, j), at(k_, j), at(k_ + 1, j), at(k_ + 2, j));
            let a = (q2 - 2.0 * q1 + q0) / (p * p);
            let jerk = (q3 - 3.0 * q2 + 3.0 * q1 - q0) / (p * p * p);
            (k, j, a, jerk)
        })
    })
}
