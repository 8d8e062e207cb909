//! Path quality of a plan, for `results.csv`: how long the joint paths are, how hard they use
//! the arms' speed and acceleration limits, how close the arms come to each other and to the
//! obstacles, and the planners' search cost.

use omcbsa_core::collision::ArmPose;
use omcbsa_core::model::Models;
use omcbsa_core::problem::Problem;

/// One plan's figures. `None` where a figure does not apply (no other arm, no obstacle, fewer
/// than three steps for an acceleration).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathQuality {
    /// Sum over robots and steps of the Euclidean joint-space step `|q(t+1) - q(t)|`, rad.
    pub path_length_rad: f64,
    /// Largest `|dq_j| / dt` over robots, steps and joints, as a fraction of joint j's limit.
    pub max_speed_frac: f64,
    /// Largest `|q(t+1) - 2 q(t) + q(t-1)| / dt^2`, as a fraction of joint j's limit.
    pub max_accel_frac: Option<f64>,
    /// Smallest distance between the capsules of two arms over the steps, m (negative when
    /// they overlap).
    pub min_arm_clearance_m: Option<f64>,
    /// Smallest distance between an arm's moving capsules and an obstacle over the steps, m
    /// (0 when they touch or overlap).
    pub min_obstacle_clearance_m: Option<f64>,
    /// Ω-A*'s cost `g` of the paths, summed over the tracking robots (Ω-CBSA's sum of costs):
    /// the joint-space length plus, for a robot with an `initial` configuration, how far its
    /// tool centre point there is from the first pose.
    pub path_cost: f64,
}

/// The figures of `paths[i][t]` (robot i at step t) on `problem`, where `assignment[i]` is the
/// trajectory robot i tracks; speed and acceleration limits are each robot's model's. `paths`
/// must hold one path of the problem's horizon per robot.
pub fn path_quality<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    assignment: &[Option<usize>],
    paths: &[Vec<[f64; D]>],
) -> PathQuality {
    let dt = problem.dt;
    let mut q = PathQuality::default();
    for (i, path) in paths.iter().enumerate() {
        let robot = &problem.robots[i];
        let (velocity, accel) = (M::velocity(robot.model), M::acceleration(robot.model));
        let mut length = 0.0;
        for w in path.windows(2) {
            let step2: f64 = (0..D).map(|j| (w[1][j] - w[0][j]).powi(2)).sum();
            length += step2.sqrt();
            for j in 0..D {
                let speed = (w[1][j] - w[0][j]).abs() / dt / velocity[j];
                q.max_speed_frac = q.max_speed_frac.max(speed);
            }
        }
        for w in path.windows(3) {
            for j in 0..D {
                let a = (w[2][j] - 2.0 * w[1][j] + w[0][j]).abs() / (dt * dt) / accel[j];
                q.max_accel_frac = Some(q.max_accel_frac.map_or(a, |m: f64| m.max(a)));
            }
        }
        q.path_length_rad += length;
        let Some(trajectory) =
            (assignment.get(i).copied().flatten()).and_then(|j| problem.trajectories.get(j))
        else {
            continue;
        };
        q.path_cost += length;
        if let (Some(initial), Some(first)) = (robot.initial.as_ref(), trajectory.first()) {
            let tool = robot
                .base
                .compose(&M::fk(robot.model, initial))
                .compose(&robot.tcp);
            q.path_cost += (tool.pos - first.pos).norm();
        }
    }
    let horizon = paths.iter().map(Vec::len).min().unwrap_or(0);
    let min = |acc: &mut Option<f64>, d: f64| *acc = Some(acc.map_or(d, |m| m.min(d)));
    for t in 0..horizon {
        let arms: Vec<ArmPose> = (problem.robots.iter().zip(paths))
            .map(|(r, p)| ArmPose::new::<M, D>(r.model, &r.base, &r.tool, &p[t]))
            .collect();
        for (a, (arm, robot)) in arms.iter().zip(&problem.robots).enumerate() {
            for other in &arms[a + 1..] {
                for c in arm.capsules() {
                    for d in other.capsules() {
                        min(&mut q.min_arm_clearance_m, c.signed_distance(d));
                    }
                }
            }
            // Base capsules are mounted, and never checked against obstacles; tool capsules
            // (past the link capsules) move.
            let on_base = |k: usize| (M::capsules(robot.model).get(k)).is_some_and(|c| c.link == 0);
            let moving = (arm.capsules().iter().enumerate()).filter(|&(k, _)| !on_base(k));
            for (_, c) in moving {
                for o in problem.obstacles.iter() {
                    min(&mut q.min_obstacle_clearance_m, o.distance_to_capsule(c));
                }
            }
        }
    }
    q
}
