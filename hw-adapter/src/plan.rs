//! The executor's input: a multi-arm joint-space plan on a common time grid, joint limits, and
//! the validation hook the host implements with the real validator.

/// Joints per arm (the Kinova Gen3 7-DoF).
pub const JOINTS: usize = 7;

#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Time between consecutive waypoints, s.
    pub dt: f64,
    pub arms: Vec<ArmPlan>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ArmPlan {
    pub name: String,
    /// Waypoints, rad; waypoint i is reached at time i·dt (before any uniform slow-down).
    pub joint_path: Vec<[f64; JOINTS]>,
}

/// One arm's limits, per joint: each arm of a plan has its own (a mixed fleet's arms are of
/// different models).
pub type ArmLimits = [JointLimits; JOINTS];

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    /// Position bounds, rad; `None` for a continuous joint.
    pub position: Option<(f64, f64)>,
    /// rad/s
    pub velocity: f64,
    /// rad/s²
    pub acceleration: f64,
}

/// Proof that a plan solves its problem (collision-free, constraints met). The host implements
/// it with the full validator; the executor refuses to start when it returns an error.
pub trait PlanValidator {
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
}
