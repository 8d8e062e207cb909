//! From a solved problem to the hardware adapter (`omcbsa_hw`): the adapter's [`Plan`] for
//! the robots that have an arm, and its validation gate backed by the host validator.

use omcbsa_core::model::Models;
use omcbsa_hw::{ArmLimits, ArmPlan, JointLimits, Plan, PlanValidator, JOINTS};

use crate::error::{quoted, InputError};
use crate::format::{ProblemFile, SolutionFile};
use crate::load;
use crate::models::{Fleet, ModelKind, DOF};
use crate::validate::{validate, Report};

/// The joint speed the executor keeps to, rad/s, below the arms' own velocity limits: Kinova's
/// MoveIt configuration (`joint_limits.yaml`) uses it, and so do the mock drives
/// (`hw-adapter/mock`). A named setting, not a second table: every other limit is the model's.
pub const CAUTIOUS_SPEED: f64 = 0.8727;

// The executor drives arms of the planned models' joint count.
const _: () = assert!(JOINTS == DOF);

/// The executor's joint limits for `kind`: the model's position and acceleration limits and
/// its velocity limits capped at `speed_cap` rad/s.
pub fn joint_limits(kind: ModelKind, speed_cap: f64) -> ArmLimits {
    let m = kind.id();
    let (lower, upper) = (Fleet::lower(m), Fleet::upper(m));
    std::array::from_fn(|j| JointLimits {
        position: (lower[j].is_finite() || upper[j].is_finite()).then_some((lower[j], upper[j])),
        velocity: Fleet::velocity(m)[j].min(speed_cap),
        acceleration: Fleet::acceleration(m)[j],
        // The models carry no jerk limit yet: none, until they do.
        jerk: f64::INFINITY,
    })
}

/// A solution validated against its problem. As a [`PlanValidator`] it accepts exactly the
/// plans that stream this solution (when it is valid) to every robot that moves.
pub struct CheckedSolution {
    problem: ProblemFile,
    solution: SolutionFile,
    report: Report,
}

impl CheckedSolution {
    /// Checks `problem` and validates `solution` against it; an error only for a problem
    /// file that breaks the spec (an invalid solution is a [`Report`] with violations).
    pub fn new(problem: ProblemFile, solution: SolutionFile) -> Result<Self, InputError> {
        let core = load::problem::<Fleet, DOF>(&problem)?;
        let report = validate::<Fleet, DOF>(&problem, &core, &solution);
        Ok(CheckedSolution {
            problem,
            solution,
            report,
        })
    }

    /// The executor's limits for each arm of `plan` (made by [`CheckedSolution::plan`]), in
    /// its order: each arm's own model's ([`joint_limits`] at [`CAUTIOUS_SPEED`]).
    pub fn joint_limits(&self, plan: &Plan) -> Result<Vec<ArmLimits>, String> {
        let kinds = load::models(&self.problem).map_err(|e| e.to_string())?;
        (plan.arms.iter())
            .map(|a| {
                let i = (self.problem.robots.iter())
                    .position(|r| r.name == a.name)
                    .ok_or_else(|| format!("arm {} is no robot of the problem", quoted(&a.name)))?;
                Ok(joint_limits(kinds[i], CAUTIOUS_SPEED))
            })
            .collect()
    }

    /// The validator's report on the solution (valid: checked before a plan is made).
    pub fn report(&self) -> &Report {
        &self.report
    }

    /// The problem.
    pub fn problem(&self) -> &ProblemFile {
        &self.problem
    }

    /// The solution.
    pub fn solution(&self) -> &SolutionFile {
        &self.solution
    }

    /// The problem and the solution, taken back.
    pub fn into_parts(self) -> (ProblemFile, SolutionFile) {
        (self.problem, self.solution)
    }

    /// The plan streaming the solution's joint paths to the robots `arms` names (in the
    /// problem's order). Errors name unknown or repeated names; whether every robot that
    /// moves has an arm is the gate's question ([`PlanValidator::validate`]).
    pub fn plan(&self, arms: &[&str]) -> Result<Plan, String> {
        let robots = &self.problem.robots;
        let unknown: Vec<String> = (arms.iter())
            .filter(|a| !robots.iter().any(|r| r.name == **a))
            .map(|a| quoted(a))
            .collect();
        if !unknown.is_empty() {
            let known: Vec<String> = robots.iter().map(|r| quoted(&r.name)).collect();
            return Err(format!(
                "unknown arm name {}: the problem's robots are {}",
                unknown.join(", "),
                known.join(", ")
            ));
        }
        if let Some((_, a)) = (arms.iter().enumerate()).find(|(i, a)| arms[..*i].contains(a)) {
            return Err(format!("arm {} is given twice", quoted(a)));
        }
        let paths = self.timelines()?;
        let arms = (robots.iter().zip(&paths))
            .enumerate()
            .filter(|(_, (r, _))| arms.contains(&r.name.as_str()))
            .map(|(i, (r, path))| {
                let joint_path = (path.iter().enumerate())
                    .map(|(t, q)| {
                        <[f64; JOINTS]>::try_from(q.as_slice()).map_err(|_| {
                            format!(
                                "joint_paths[{i}][{t}]: expected {JOINTS} joint values, got {}",
                                q.len()
                            )
                        })
                    })
                    .collect::<Result<_, _>>()?;
                Ok(ArmPlan {
                    name: r.name.clone(),
                    joint_path,
                })
            })
            .collect::<Result<_, String>>()?;
        Ok(Plan {
            dt: self.problem.dt,
            arms,
        })
    }

    /// Every robot's executed timeline: with an approach, `initial`, the approach, then the
    /// joint path (so the arms must stand at `initial`); without one, the joint path.
    fn timelines(&self) -> Result<Vec<Vec<Vec<f64>>>, String> {
        let paths = self.solution.joint_paths.as_ref().ok_or_else(|| {
            format!(
                "the solution has no joint paths (status {}): nothing to execute",
                self.solution.status.as_str()
            )
        })?;
        let Some(approach) = &self.solution.approach else {
            return Ok(paths.clone());
        };
        Ok((paths.iter().enumerate())
            .map(|(i, path)| {
                let robot = self.problem.robots.get(i);
                (robot.and_then(|r| r.initial.clone()).into_iter())
                    .chain(approach.get(i).into_iter().flatten().cloned())
                    .chain(path.iter().cloned())
                    .collect()
            })
            .collect())
    }
}

impl PlanValidator for CheckedSolution {
    fn validate(&self, plan: &Plan) -> Result<(), String> {
        if !self.report.is_valid() {
            return Err(self.report.summary());
        }
        if plan.dt != self.problem.dt {
            return Err(format!(
                "the plan's time step {} s is not the problem's dt {} s",
                plan.dt, self.problem.dt
            ));
        }
        let paths = self.timelines()?;
        for arm in &plan.arms {
            let i = (self.problem.robots.iter())
                .position(|r| r.name == arm.name)
                .ok_or_else(|| {
                    format!("arm {} is not a robot of the problem", quoted(&arm.name))
                })?;
            let same = paths.get(i).is_some_and(|p| {
                p.len() == arm.joint_path.len()
                    && p.iter().zip(&arm.joint_path).all(|(a, b)| a == b)
            });
            if !same {
                return Err(format!(
                    "arm {}: the joint path is not the solution's path for robot {i}",
                    quoted(&arm.name)
                ));
            }
        }
        // An arm left out would stand still where the solution has it move: a collision.
        for (r, path) in self.problem.robots.iter().zip(&paths) {
            let moves = path.windows(2).any(|w| w[0] != w[1]);
            if moves && !plan.arms.iter().any(|a| a.name == r.name) {
                return Err(format!(
                    "robot {} moves in the solution but has no arm: every robot that moves \
                     needs one",
                    quoted(&r.name)
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_executor_limits_are_the_models_with_the_speed_capped() {
        // The Gen3's are exactly the table the executor had (Kinova's joint_limits.yaml).
        let gen3 = joint_limits(ModelKind::default(), CAUTIOUS_SPEED);
        assert_eq!(gen3, omcbsa_mock::testing::arm_limits());
        let panda = ModelKind::parse("franka_panda").unwrap();
        let panda = joint_limits(panda, CAUTIOUS_SPEED);
        assert_eq!(panda[3].position, Some((-3.0718, -0.0698)));
        assert_eq!(panda[1].acceleration, 7.5);
        assert!(panda.iter().all(|l| l.velocity == CAUTIOUS_SPEED));
        let fast = joint_limits(ModelKind::parse("panda").unwrap(), 10.0);
        assert_eq!(fast[6].velocity, 2.61);
    }
}
