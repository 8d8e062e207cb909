//! Interpolation of a plan's waypoints to the control rate, and the per-command limit check.
//!
//! Each joint follows a cubic Hermite spline through its waypoints (C1: continuous position and
//! velocity), at rest at both ends. Interior tangents are the harmonic mean of the neighbouring
//! slopes, or zero where the path turns (Fritsch–Butland): the spline is monotone between
//! waypoints, so it never leaves the waypoints' range and thus the position limits. If the
//! plan's `dt` is too short for the velocity or acceleration limits, the whole plan (every arm
//! alike, so the arms stay coordinated) is slowed down uniformly.

use crate::plan::{ArmLimits, Plan};
use crate::run::{Command, JOINTS};
use crate::spline::segment;
use crate::stream::{Generator, PushError};

/// The fraction of each velocity and acceleration limit the interpolation aims for; the rest
/// absorbs the rounding of commands to bus counts (see `cia402`).
pub const LIMIT_MARGIN: f64 = 0.9;

/// Every command of a plan, collected (see [`interpolate`]).
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// Control period, s.
    pub period: f64,
    /// Uniform slow-down applied to the plan: waypoint i is reached at i·dt·time_scale.
    pub time_scale: f64,
    /// Per arm (in plan order), one command per control cycle, the first at the first waypoint.
    pub commands: Vec<Vec<Command>>,
}

/// The smallest uniform slow-down `s` that keeps every joint of every path (waypoints `dt`
/// apart, each at rest at both ends) within [`LIMIT_MARGIN`] of its arm's velocity and
/// acceleration limits (`limits[i]` for path `i`): with segment duration h = dt·s, velocity =
/// slope/h and acceleration = curvature/h². At least 1.
pub fn min_time_scale<'a>(
    paths: impl IntoIterator<Item = &'a [[f64; JOINTS]]>,
    limits: &[ArmLimits],
    dt: f64,
) -> f64 {
    let mut s_min: f64 = 1.0;
    for (path, limits) in paths.into_iter().zip(limits) {
        for (j, l) in limits.iter().enumerate() {
            for i in 0..path.len().saturating_sub(1) {
                let seg = segment(path, j, i);
                s_min = s_min
                    .max(seg.max_slope() / (dt * LIMIT_MARGIN * l.velocity))
                    .max(
                        (seg.max_curvature() / (dt.powi(2) * LIMIT_MARGIN * l.acceleration)).sqrt(),
                    );
            }
        }
    }
    s_min
}

/// Per arm (in plan order) and joint, the peak speed of the interpolated path, rad/s, with
/// waypoints `step_time` apart.
pub fn peak_speeds(plan: &Plan, step_time: f64) -> Vec<[f64; JOINTS]> {
    (plan.arms.iter())
        .map(|a| {
            let path = &a.joint_path;
            std::array::from_fn(|j| {
                (0..path.len().saturating_sub(1))
                    .map(|i| segment(path, j, i).max_slope() / step_time)
                    .fold(0.0, f64::max)
            })
        })
        .collect()
}

/// How `plan` (whose shape must be valid) is timed at `period`: the uniform slow-down, with
/// the duration rounded up to whole control periods so that the last command lands exactly on
/// the last waypoint, and the resulting time per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// The uniform slow-down (1 = as planned).
    pub time_scale: f64,
    /// Seconds per step (the plan's dt times `time_scale`).
    pub step_time: f64,
    /// Control cycles from the first waypoint to the last.
    pub cycles: f64,
}

/// `limits` holds one table per arm of the plan.
pub fn timing(plan: &Plan, limits: &[ArmLimits], period: f64) -> Result<Timing, String> {
    if !(period.is_finite() && period > 0.0) {
        return Err(format!("control period must be positive, got {period} s"));
    }
    if limits.len() != plan.arms.len() {
        return Err(format!(
            "{} tables of joint limits for {} arms: one per arm",
            limits.len(),
            plan.arms.len()
        ));
    }
    let paths = plan.arms.iter().map(|a| a.joint_path.as_slice());
    let s_min = min_time_scale(paths, limits, plan.dt);
    let n_seg = plan
        .arms
        .first()
        .map_or(0, |a| a.joint_path.len().saturating_sub(1));
    let cycles = (n_seg as f64 * plan.dt * s_min / period - 1e-9)
        .ceil()
        .max(0.0);
    let (time_scale, step_time) = if n_seg == 0 {
        (1.0, plan.dt)
    } else {
        let s = cycles * period / (n_seg as f64 * plan.dt);
        (s, plan.dt * s)
    };
    if !(cycles.is_finite() && time_scale.is_finite() && step_time.is_finite() && step_time > 0.0) {
        return Err(format!(
            "cannot time the plan: dt {} s with a slow-down of {s_min} does not give a finite \
             number of {period} s control cycles",
            plan.dt
        ));
    }
    Ok(Timing {
        time_scale,
        step_time,
        cycles,
    })
}

/// The generator streaming `plan` (whose shape must be valid): holding at the first
/// waypoints, with the rest queued and checked in full (nothing is sent before that).
pub fn plan_generator(
    plan: &Plan,
    limits: &[ArmLimits],
    period: f64,
) -> Result<(Generator, Timing), String> {
    let timing = timing(plan, limits, period)?;
    let starts: Vec<[f64; JOINTS]> = plan.arms.iter().map(|a| a.joint_path[0]).collect();
    let mut generator = Generator::new(&starts, limits, period, timing.step_time)?;
    if plan.arms[0].joint_path.len() > 1 {
        let rest: Vec<&[[f64; JOINTS]]> = plan.arms.iter().map(|a| &a.joint_path[1..]).collect();
        generator.push(1, &rest).map_err(|e| match e {
            PushError::Limits { arm, error, .. } => {
                format!("arm {:?}: {error}", plan.arms[arm].name)
            }
            e => e.to_string(),
        })?;
    }
    Ok((generator, timing))
}

/// Every command of `plan` (whose shape must be valid) interpolated to `period`, slowed down if
/// needed, from the first waypoint to the last: the commands the executor streams, collected
/// (for checks and tests; the executor itself never holds them all: memory here grows with
/// the plan's duration).
///
/// ```
/// use omcbsa_hw::interpolate::interpolate;
/// use omcbsa_hw::{ArmPlan, Plan, JOINTS};
///
/// // 0.5 rad in 0.1 s is far beyond 0.8727 rad/s: the plan is slowed down to fit.
/// let plan = Plan {
///     dt: 0.1,
///     arms: vec![ArmPlan { name: "a".into(), joint_path: vec![[0.0; JOINTS], [0.5; JOINTS]] }],
/// };
/// let t = interpolate(&plan, &omcbsa_mock::testing::fleet_limits(1), 0.002)?;
/// assert!(t.time_scale > 10.0);
/// let cmds = &t.commands[0];
/// assert_eq!((cmds[0][0], cmds[cmds.len() - 1][0]), (0, 5_000_000)); // 0 to 0.5 rad, in counts
/// # Ok::<(), String>(())
/// ```
pub fn interpolate(plan: &Plan, limits: &[ArmLimits], period: f64) -> Result<Trajectory, String> {
    let (mut generator, timing) = plan_generator(plan, limits, period)?;
    let mut commands = vec![Vec::new(); plan.arms.len()];
    let mut out = vec![[0; JOINTS]; plan.arms.len()];
    loop {
        let tick = generator.next(&mut out).map_err(|e| e.to_string())?;
        for (c, o) in commands.iter_mut().zip(&out) {
            c.push(*o);
        }
        if tick.holding {
            break;
        }
    }
    Ok(Trajectory {
        period,
        time_scale: timing.time_scale,
        commands,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cia402::{counts_to_rad, rad_to_counts};
    use crate::plan::{check_command, ArmPlan, JointLimits};

    fn one_arm(dt: f64, path: Vec<[f64; JOINTS]>) -> Plan {
        Plan {
            dt,
            arms: vec![ArmPlan {
                name: "a".into(),
                joint_path: path,
            }],
        }
    }

    fn wave(n: usize) -> Vec<[f64; JOINTS]> {
        (0..n)
            .map(|i| std::array::from_fn(|j| 0.4 * ((i as f64) * 0.7 + j as f64).sin()))
            .collect()
    }

    #[test]
    fn fast_plan_is_slowed_down_and_respects_limits() {
        let limits = crate::testing::arm_limits();
        let plan = one_arm(0.05, wave(12));
        let t = interpolate(&plan, &[limits], 0.002).unwrap();
        assert!(t.time_scale > 1.0, "{}", t.time_scale);
        let cmds = &t.commands[0];
        // lands exactly on the last waypoint after whole periods
        let last = plan.arms[0].joint_path[11];
        for j in 0..JOINTS {
            assert!((counts_to_rad(cmds[cmds.len() - 1][j]) - last[j]).abs() <= 1e-7);
            assert_eq!(
                cmds[0][j],
                rad_to_counts(plan.arms[0].joint_path[0][j]).unwrap()
            );
        }
        // waypoint 5 is reached at 5·dt·s
        let k = 5.0 * 0.05 * t.time_scale / 0.002;
        if (k - k.round()).abs() < 1e-6 {
            let q = counts_to_rad(cmds[k.round() as usize][0]);
            assert!((q - plan.arms[0].joint_path[5][0]).abs() <= 1e-7);
        }
        let mut held = vec![cmds[0]; 2];
        held.extend(cmds.iter().copied());
        held.extend([cmds[cmds.len() - 1]; 2]);
        for w in held.windows(3) {
            check_command(&limits, &w[0], &w[1], &w[2], 0.002).unwrap();
        }
        // and the slow-down is not excessive: some joint uses over half its acceleration or
        // velocity budget
        let max_v = cmds
            .windows(2)
            .map(|w| counts_to_rad(w[1][0] - w[0][0]).abs() / 0.002)
            .fold(0.0, f64::max);
        assert!(max_v > 0.1, "{max_v}");
    }

    #[test]
    fn slow_plan_keeps_its_timing() {
        let plan = one_arm(2.0, wave(3));
        let t = interpolate(&plan, &crate::testing::fleet_limits(1), 0.002).unwrap();
        assert_eq!(t.time_scale, 1.0);
        assert_eq!(t.commands[0].len(), 2001);
    }

    #[test]
    fn single_waypoint_is_a_hold() {
        let plan = one_arm(0.1, vec![[0.1; JOINTS]]);
        let t = interpolate(&plan, &crate::testing::fleet_limits(1), 0.002).unwrap();
        assert_eq!(t.commands[0], vec![[1_000_000; JOINTS]]);
    }

    #[test]
    fn out_of_range_waypoint_is_refused() {
        let mut path = wave(3);
        path[1][1] = 2.5; // joint 2 limited to ±2.24
        let e =
            interpolate(&one_arm(1.0, path), &crate::testing::fleet_limits(1), 0.002).unwrap_err();
        assert!(e.contains("joint 2: position"), "{e}");
    }

    /// Each arm is held to its own limits (a mixed fleet): a waypoint within one arm's range
    /// and outside the other's is refused only on the other, and the slower arm slows the
    /// plan down.
    #[test]
    fn each_arm_keeps_its_own_limits() {
        let mut path = wave(3);
        path[1][1] = 2.5;
        let mut plan = one_arm(1.0, path);
        plan.arms.push(ArmPlan {
            name: "b".into(),
            joint_path: wave(3),
        });
        let wide = crate::testing::arm_limits().map(|l| JointLimits {
            position: None,
            ..l
        });
        let narrow = crate::testing::arm_limits();
        assert!(interpolate(&plan, &[wide, narrow], 0.002).is_ok());
        let e = interpolate(&plan, &[narrow, wide], 0.002).unwrap_err();
        assert!(e.contains("joint 2: position"), "{e}");
        let slow = wide.map(|l| JointLimits {
            velocity: l.velocity / 10.0,
            ..l
        });
        let (fast, slowed) = (
            timing(&plan, &[wide, wide], 0.002).unwrap(),
            timing(&plan, &[wide, slow], 0.002).unwrap(),
        );
        assert!(slowed.time_scale > fast.time_scale);
        let e = timing(&plan, &[wide], 0.002).unwrap_err();
        assert!(e.contains("1 tables of joint limits for 2 arms"), "{e}");
    }
}
