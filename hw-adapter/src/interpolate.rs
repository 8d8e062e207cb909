//! Interpolation of a plan's waypoints to the control rate, and the per-command limit check.
//!
//! Each joint follows a cubic Hermite spline through its waypoints (C1: continuous position and
//! velocity), at rest at both ends. Interior tangents are the harmonic mean of the neighbouring
//! slopes, or zero where the path turns (Fritsch–Butland): the spline is monotone between
//! waypoints, so it never leaves the waypoints' range and thus the position limits. If the
//! plan's `dt` is too short for the velocity or acceleration limits, the whole plan (every arm
//! alike, so the arms stay coordinated) is slowed down uniformly.

use crate::cia402::{counts_to_rad, rad_to_counts, COUNTS_PER_RAD};
use crate::plan::{JointLimits, Plan, JOINTS};

/// The fraction of each velocity and acceleration limit the interpolation aims for; the rest
/// absorbs the rounding of commands to bus counts (see `cia402`).
pub const LIMIT_MARGIN: f64 = 0.9;

/// Commands of one arm for one control cycle, in bus counts.
pub type Command = [i32; JOINTS];

#[derive(Clone, Debug)]
pub struct Trajectory {
    /// Control period, s.
    pub period: f64,
    /// Uniform slow-down applied to the plan: waypoint i is reached at i·dt·time_scale.
    pub time_scale: f64,
    /// Per arm (in plan order), one command per control cycle, the first at the first waypoint.
    pub commands: Vec<Vec<Command>>,
}

/// One cubic Hermite segment on u ∈ [0, 1]; tangents are per segment (rad per segment).
#[derive(Clone, Copy)]
struct Segment {
    p0: f64,
    p1: f64,
    m0: f64,
    m1: f64,
}

impl Segment {
    fn position(&self, u: f64) -> f64 {
        let (u2, u3) = (u * u, u * u * u);
        (2.0 * u3 - 3.0 * u2 + 1.0) * self.p0
            + (u3 - 2.0 * u2 + u) * self.m0
            + (-2.0 * u3 + 3.0 * u2) * self.p1
            + (u3 - u2) * self.m1
    }

    /// Largest |dp/du| on the segment: the derivative is a quadratic, so the maximum is at an
    /// end or at the vertex.
    fn max_slope(&self) -> f64 {
        let d = self.p1 - self.p0;
        let a = -6.0 * d + 3.0 * self.m0 + 3.0 * self.m1;
        let b = 6.0 * d - 4.0 * self.m0 - 2.0 * self.m1;
        let slope = |u: f64| a * u * u + b * u + self.m0;
        let mut m = slope(0.0).abs().max(slope(1.0).abs());
        if a != 0.0 {
            let v = -b / (2.0 * a);
            if (0.0..=1.0).contains(&v) {
                m = m.max(slope(v).abs());
            }
        }
        m
    }

    /// Largest |d²p/du²|: the second derivative is linear, so it is at an end.
    fn max_curvature(&self) -> f64 {
        let d = self.p1 - self.p0;
        let at0 = 6.0 * d - 4.0 * self.m0 - 2.0 * self.m1;
        let at1 = -6.0 * d + 2.0 * self.m0 + 4.0 * self.m1;
        at0.abs().max(at1.abs())
    }
}

/// The spline segments of one joint's waypoints.
fn segments(points: impl Iterator<Item = f64> + Clone) -> Vec<Segment> {
    let p: Vec<f64> = points.collect();
    let slope = |i: usize| p[i + 1] - p[i];
    let tangent = |i: usize| {
        if i == 0 || i + 1 == p.len() {
            return 0.0;
        }
        let (a, b) = (slope(i - 1), slope(i));
        if a * b <= 0.0 {
            0.0
        } else {
            2.0 * a * b / (a + b)
        }
    };
    (0..p.len().saturating_sub(1))
        .map(|i| Segment {
            p0: p[i],
            p1: p[i + 1],
            m0: tangent(i),
            m1: tangent(i + 1),
        })
        .collect()
}

/// Interpolates every arm of `plan` (whose shape must be valid) to `period`, slowing the plan
/// down if needed, and checks every resulting command against `limits`.
pub fn interpolate(
    plan: &Plan,
    limits: &[JointLimits; JOINTS],
    period: f64,
) -> Result<Trajectory, String> {
    if !(period.is_finite() && period > 0.0) {
        return Err(format!("control period must be positive, got {period} s"));
    }
    // splines[arm][joint]
    let splines: Vec<Vec<Vec<Segment>>> = plan
        .arms
        .iter()
        .map(|a| {
            (0..JOINTS)
                .map(|j| segments(a.joint_path.iter().map(|q| q[j])))
                .collect()
        })
        .collect();
    let n_seg = plan
        .arms
        .first()
        .map_or(0, |a| a.joint_path.len().saturating_sub(1));

    // Smallest uniform slow-down s that keeps every joint within LIMIT_MARGIN of its limits:
    // with segment duration h = dt·s, velocity = slope/h and acceleration = curvature/h².
    let mut s_min: f64 = 1.0;
    for arm in &splines {
        for (j, segs) in arm.iter().enumerate() {
            let l = &limits[j];
            for seg in segs {
                s_min = s_min
                    .max(seg.max_slope() / (plan.dt * LIMIT_MARGIN * l.velocity))
                    .max(
                        (seg.max_curvature() / (plan.dt.powi(2) * LIMIT_MARGIN * l.acceleration))
                            .sqrt(),
                    );
            }
        }
    }
    // Round the duration up to whole control periods so that the last command lands exactly on
    // the last waypoint.
    let cycles = (n_seg as f64 * plan.dt * s_min / period - 1e-9)
        .ceil()
        .max(0.0) as usize;
    let time_scale = if n_seg == 0 {
        1.0
    } else {
        cycles as f64 * period / (n_seg as f64 * plan.dt)
    };
    let h = plan.dt * time_scale;

    let mut commands = Vec::with_capacity(plan.arms.len());
    for (arm, joints) in plan.arms.iter().zip(&splines) {
        let mut cmds = Vec::with_capacity(cycles + 1);
        for k in 0..=cycles {
            let x = if n_seg == 0 {
                0.0
            } else {
                k as f64 * period / h
            };
            let i = (x.floor() as usize).min(n_seg.saturating_sub(1));
            let u = (x - i as f64).clamp(0.0, 1.0);
            let mut c = [0i32; JOINTS];
            for (j, segs) in joints.iter().enumerate() {
                let q = segs.get(i).map_or(arm.joint_path[0][j], |s| s.position(u));
                c[j] = rad_to_counts(q).ok_or_else(|| {
                    format!(
                        "arm {:?} joint {}: {q} rad is outside the bus range",
                        arm.name,
                        j + 1
                    )
                })?;
            }
            cmds.push(c);
        }
        check_sequence(&cmds, limits, period).map_err(|e| format!("arm {:?}: {e}", arm.name))?;
        commands.push(cmds);
    }
    Ok(Trajectory {
        period,
        time_scale,
        commands,
    })
}

/// Checks a whole command sequence, starting and ending at rest, as the executor will send it.
fn check_sequence(
    cmds: &[Command],
    limits: &[JointLimits; JOINTS],
    period: f64,
) -> Result<(), String> {
    let (Some(first), Some(last)) = (cmds.first(), cmds.last()) else {
        return Ok(());
    };
    let held = [*first, *first]
        .into_iter()
        .chain(cmds.iter().copied())
        .chain([*last, *last]);
    let seq: Vec<Command> = held.collect();
    for (k, w) in seq.windows(3).enumerate() {
        check_command(limits, &w[0], &w[1], &w[2], period)
            .map_err(|e| format!("cycle {}: {e}", k as isize - 1))?;
    }
    Ok(())
}

/// Checks `cmd` against the position limits, and the velocity and acceleration it implies after
/// the two previous commands `prev2`, `prev1` sent one period apart.
pub fn check_command(
    limits: &[JointLimits; JOINTS],
    prev2: &Command,
    prev1: &Command,
    cmd: &Command,
    period: f64,
) -> Result<(), String> {
    for (j, l) in limits.iter().enumerate() {
        let q = counts_to_rad(cmd[j]);
        if let Some((lo, hi)) = l.position {
            if !(lo..=hi).contains(&q) {
                return Err(format!(
                    "joint {}: position {q} rad outside [{lo}, {hi}]",
                    j + 1
                ));
            }
        }
        // In i64: near the ends of the bus range these differences overflow i32.
        let counts = |c: i64| c as f64 / COUNTS_PER_RAD;
        let (c0, c1, c2) = (i64::from(cmd[j]), i64::from(prev1[j]), i64::from(prev2[j]));
        let v = counts(c0 - c1) / period;
        if v.abs() > l.velocity {
            return Err(format!(
                "joint {}: velocity {v:.4} rad/s exceeds the limit {}",
                j + 1,
                l.velocity
            ));
        }
        let a = counts(c0 - 2 * c1 + c2) / (period * period);
        if a.abs() > l.acceleration {
            return Err(format!(
                "joint {}: acceleration {a:.4} rad/s² exceeds the limit {}",
                j + 1,
                l.acceleration
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::ArmPlan;

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
    fn hermite_passes_through_waypoints_with_continuous_slope() {
        let segs = segments([0.0, 1.0, 1.5, 0.5].into_iter());
        for w in segs.windows(2) {
            assert_eq!(w[0].position(1.0), w[1].position(0.0));
            assert_eq!(w[0].m1, w[1].m0);
        }
        assert_eq!(segs[0].m0, 0.0);
        assert_eq!(segs[2].m1, 0.0);
        // turning point at waypoint 2: zero tangent, no overshoot past 1.5
        assert_eq!(segs[1].m1, 0.0);
        let top = (0..=100)
            .map(|i| segs[1].position(i as f64 / 100.0))
            .fold(f64::MIN, f64::max);
        assert!(top <= 1.5);
    }

    #[test]
    fn fast_plan_is_slowed_down_and_respects_limits() {
        let limits = JointLimits::kinova_gen3();
        let plan = one_arm(0.05, wave(12));
        let t = interpolate(&plan, &limits, 0.002).unwrap();
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
        check_sequence(cmds, &limits, 0.002).unwrap();
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
        let t = interpolate(&plan, &JointLimits::kinova_gen3(), 0.002).unwrap();
        assert_eq!(t.time_scale, 1.0);
        assert_eq!(t.commands[0].len(), 2001);
    }

    #[test]
    fn single_waypoint_is_a_hold() {
        let plan = one_arm(0.1, vec![[0.1; JOINTS]]);
        let t = interpolate(&plan, &JointLimits::kinova_gen3(), 0.002).unwrap();
        assert_eq!(t.commands[0], vec![[1_000_000; JOINTS]]);
    }

    #[test]
    fn out_of_range_waypoint_is_refused() {
        let mut path = wave(3);
        path[1][1] = 2.5; // joint 2 limited to ±2.24
        let e = interpolate(&one_arm(1.0, path), &JointLimits::kinova_gen3(), 0.002).unwrap_err();
        assert!(e.contains("joint 2: position"), "{e}");
    }

    #[test]
    fn check_command_names_the_broken_limit() {
        let l = JointLimits::kinova_gen3();
        let z = [0; JOINTS];
        let mut c = z;
        c[0] = 20_000; // 2 mrad in 2 ms = 1 rad/s
        let e = check_command(&l, &z, &z, &c, 0.002).unwrap_err();
        assert!(e.contains("joint 1: velocity"), "{e}");
        c[0] = 10; // 1e-6 rad: 0.25 rad/s² from rest
        assert!(check_command(&l, &z, &z, &c, 0.002).is_ok());
        c[0] = 100; // 2.5 rad/s²
        let e = check_command(&l, &z, &z, &c, 0.002).unwrap_err();
        assert!(e.contains("joint 1: acceleration"), "{e}");
    }
}
