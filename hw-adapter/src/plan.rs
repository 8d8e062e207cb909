//! The executor's input: a multi-arm joint-space plan on a common time grid, joint limits (and
//! the check of each command against them), and the validation hook the host implements with
//! the real validator.

use crate::cia402::{counts_to_rad, COUNTS_PER_RAD};
use crate::run::Command;
pub use crate::run::JOINTS;

/// A multi-arm joint-space plan: every arm's waypoints on one time grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Time between consecutive waypoints, s.
    pub dt: f64,
    /// The arms, each with a unique name.
    pub arms: Vec<ArmPlan>,
}

/// One arm of a plan.
#[derive(Clone, Debug, PartialEq)]
pub struct ArmPlan {
    /// The arm's name (what its port is given for).
    pub name: String,
    /// Waypoints, rad; waypoint i is reached at time i·dt (before any uniform slow-down).
    pub joint_path: Vec<[f64; JOINTS]>,
}

/// One arm's limits, per joint: each arm of a plan has its own (a mixed fleet's arms are of
/// different models).
pub type ArmLimits = [JointLimits; JOINTS];

/// One joint's limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    /// Position bounds, rad; `None` for a continuous joint.
    pub position: Option<(f64, f64)>,
    /// rad/s
    pub velocity: f64,
    /// rad/s²
    pub acceleration: f64,
    /// rad/s³ (`f64::INFINITY` where none is known): the executor's commands change
    /// acceleration by at most this times the period per cycle.
    pub jerk: f64,
}

/// Proof that a plan solves its problem (collision-free, constraints met). The host implements
/// it with the full validator; the executor refuses to start when it returns an error.
pub trait PlanValidator {
    /// `Ok` if the plan is valid, else what is wrong with it.
    fn validate(&self, plan: &Plan) -> Result<(), String>;
}

impl Plan {
    /// Checks the plan's shape: a positive time step, at least one arm, unique names, the same
    /// non-zero number of finite waypoints for every arm.
    pub fn check_shape(&self) -> Result<(), String> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(format!(
                "dt must be a positive number of seconds, got {}",
                self.dt
            ));
        }
        let first = self.arms.first().ok_or("the plan has no arms")?;
        let n = first.joint_path.len();
        if n == 0 {
            return Err(format!("arm {:?} has an empty joint path", first.name));
        }
        for (i, arm) in self.arms.iter().enumerate() {
            if self.arms[..i].iter().any(|a| a.name == arm.name) {
                return Err(format!("arm name {:?} is used twice", arm.name));
            }
            if arm.joint_path.len() != n {
                return Err(format!(
                    "arm {:?} has {} waypoints but arm {:?} has {n}: all arms share one time grid",
                    arm.name,
                    arm.joint_path.len(),
                    first.name
                ));
            }
            for (w, q) in arm.joint_path.iter().enumerate() {
                if let Some(j) = q.iter().position(|v| !v.is_finite()) {
                    return Err(format!(
                        "arm {:?} waypoint {w} joint {}: not a finite number",
                        arm.name,
                        j + 1
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Checks a run of commands sent one period apart, from rest at the first, with
/// [`check_command`]: the first failure, with its cycle.
pub fn check_commands<'a>(
    limits: &ArmLimits,
    cmds: impl IntoIterator<Item = &'a Command>,
    period: f64,
) -> Result<(), (usize, String)> {
    let mut prev: Option<[Command; 2]> = None;
    for (k, cmd) in cmds.into_iter().enumerate() {
        let [p2, p1] = *prev.get_or_insert([*cmd; 2]);
        check_command(limits, &p2, &p1, cmd, period).map_err(|e| (k, e))?;
        prev = Some([p1, *cmd]);
    }
    Ok(())
}

/// Checks `cmd` against the position limits, and the velocity and acceleration it implies after
/// the two previous commands `prev2`, `prev1` sent one period apart.
///
/// ```
/// use omcbsa_hw::plan::check_command;
/// use omcbsa_hw::{JointLimits, JOINTS};
///
/// let limits = [JointLimits { position: Some((-1.0, 1.0)), velocity: 1.0, acceleration: 10.0, jerk: f64::INFINITY }; JOINTS];
/// let rest = [0; JOINTS];
/// let mut cmd = rest;
/// cmd[2] = 100; // 1e-5 rad in 2 ms: 0.005 rad/s, 2.5 rad/s² from rest
/// assert!(check_command(&limits, &rest, &rest, &cmd, 0.002).is_ok());
/// cmd[2] = 1_000; // 25 rad/s² from rest
/// let e = check_command(&limits, &rest, &rest, &cmd, 0.002).unwrap_err();
/// assert!(e.starts_with("joint 3: acceleration 25.0000 rad/s² exceeds the limit 10"));
/// ```
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
        // In i64: commands span the whole i32 range.
        let (c, p1, p2) = (i64::from(cmd[j]), i64::from(prev1[j]), i64::from(prev2[j]));
        let v = (c - p1) as f64 / COUNTS_PER_RAD / period;
        if v.abs() > l.velocity {
            return Err(format!(
                "joint {}: velocity {v:.4} rad/s exceeds the limit {}",
                j + 1,
                l.velocity
            ));
        }
        let a = (c - 2 * p1 + p2) as f64 / COUNTS_PER_RAD / (period * period);
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

    fn plan(paths: &[(&str, usize)]) -> Plan {
        Plan {
            dt: 0.1,
            arms: paths
                .iter()
                .map(|(n, len)| ArmPlan {
                    name: n.to_string(),
                    joint_path: vec![[0.0; JOINTS]; *len],
                })
                .collect(),
        }
    }

    #[test]
    fn shape_errors_name_the_problem() {
        assert!(plan(&[("a", 3), ("b", 3)]).check_shape().is_ok());
        let e = plan(&[("a", 3), ("b", 2)]).check_shape().unwrap_err();
        assert!(e.contains("\"b\" has 2 waypoints"), "{e}");
        let e = plan(&[("a", 3), ("a", 3)]).check_shape().unwrap_err();
        assert!(e.contains("used twice"), "{e}");
        let mut p = plan(&[("a", 2)]);
        p.arms[0].joint_path[1][2] = f64::NAN;
        let e = p.check_shape().unwrap_err();
        assert!(e.contains("waypoint 1 joint 3"), "{e}");
        p.dt = 0.0;
        assert!(p.check_shape().unwrap_err().contains("dt"));
        assert!(plan(&[]).check_shape().is_err());
    }

    #[test]
    fn check_command_names_the_broken_limit() {
        // The Gen3's joint 1: 0.8727 rad/s, 1 rad/s²
        let l = [JointLimits {
            position: None,
            velocity: 0.8727,
            acceleration: 1.0,
            jerk: f64::INFINITY,
        }; JOINTS];
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
