//! The approach: from where the arms are (`initial`) to where their plan begins.
//!
//! Planners choose each robot's first configuration on its first pose's manifold, generally
//! away from where the arm stands. The approach joins them: robot `i`'s timeline is `initial`,
//! `approach[i][0..A]`, then its path, at `dt` spacing, the same `A` for every robot. All arms
//! move together along straight joint-space segments with a smooth (cosine) time profile that
//! starts and ends at rest, slow enough for the velocity and acceleration limits. When that
//! collides, the arms move one at a time, in priority orders tried one after another. Every
//! motion is checked like a planned one (obstacles, the arm itself, the other arms).

use core::f64::consts::PI;

use crate::collision::ArmPose;
use crate::model::{Frame, Model};
use crate::motion::{motion_is_free, motions_collide, ArmMotion};
use crate::pp::{identity, next_permutation};
use crate::problem::{Problem, MAX_ROBOTS};

/// Tunables of the approach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApproachParams {
    /// Share of each joint's velocity limit the approach may use (0 < speed <= 1).
    pub speed: f64,
    /// Acceleration limit of every joint, rad/s^2 (0: none).
    pub acceleration: f64,
    /// See [`crate::search::OmegaParams::motion_step`].
    pub motion_step: f64,
    /// Most priority orders tried when the arms cannot all move together.
    pub max_orders: usize,
}

impl Default for ApproachParams {
    fn default() -> Self {
        ApproachParams {
            speed: 0.9,
            // Kinova Gen3's slowest joints (1-4) per Kinova's joint_limits.yaml.
            acceleration: 1.0,
            motion_step: crate::motion::MOTION_STEP,
            max_orders: 24,
        }
    }
}

/// Why no approach was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ApproachError {
    /// Robot `robot` collides where it stands (with an obstacle, itself, or robot `other`).
    StartCollides { robot: usize, other: Option<usize> },
    /// The approach needs `needed` configurations per robot; the buffer holds `capacity`.
    TooLong { needed: usize, capacity: usize },
    /// Neither moving together nor any order tried is free: the first failing motion of the
    /// last order tried was robot `robot`'s (against robot `other`, or obstacles / itself).
    Blocked { robot: usize, other: Option<usize> },
    /// The problem or the buffers do not fit (robots, paths).
    Invalid(&'static str),
}

/// Plans the approach of every robot of `problem` from its `initial` (a robot without one
/// starts where its path does) to its path's first configuration, `paths[i * h]` for a horizon
/// `h`. Writes robot `i`'s approach to `out[i * cap..i * cap + A]` with `cap = out.len() /
/// robots` and returns `A`.
pub fn plan_approach<M: Model<D>, const D: usize>(
    problem: &Problem<D>,
    paths: &[[f64; D]],
    h: usize,
    params: &ApproachParams,
    out: &mut [[f64; D]],
) -> Result<usize, ApproachError> {
    let n = problem.robots.len();
    if n == 0 || h == 0 || paths.len() < n * h {
        return Err(ApproachError::Invalid(
            "paths shorter than robots * horizon",
        ));
    }
    let cap = out.len() / n;
    let goals: [[f64; D]; MAX_ROBOTS] =
        core::array::from_fn(|i| paths[(i * h).min(paths.len() - 1)]);
    let starts: [[f64; D]; MAX_ROBOTS] = core::array::from_fn(|i| {
        problem
            .robots
            .get(i)
            .and_then(|r| r.initial)
            .unwrap_or(goals[i])
    });
    let bases: [Frame; MAX_ROBOTS] =
        core::array::from_fn(|i| problem.robots.get(i).map_or(Frame::IDENTITY, |r| r.base));
    let plan = Plan::<M, D> {
        problem,
        params,
        n,
        bases,
        starts,
        goals,
        _m: core::marker::PhantomData,
    };
    plan.check_starts()?;
    // All together first.
    let all = [true; MAX_ROBOTS];
    let together = plan.segments(&all);
    let mut last_failure = match plan.phase_free(&all, together, &starts) {
        Ok(()) => return plan.write(&[all], &[together], out, cap),
        Err(e) => e,
    };
    // Then one at a time, in priority orders.
    let mut order = identity(n);
    for _ in 0..params.max_orders {
        let mut moving = [[false; MAX_ROBOTS]; MAX_ROBOTS];
        let mut counts = [0usize; MAX_ROBOTS];
        let mut at = starts;
        let mut failed = None;
        for (p, &r) in order[..n].iter().enumerate() {
            moving[p][r as usize] = true;
            counts[p] = plan.segments(&moving[p]);
            if let Err(e) = plan.phase_free(&moving[p], counts[p], &at) {
                failed = Some(e);
                break;
            }
            at[r as usize] = goals[r as usize];
        }
        match failed {
            None => return plan.write(&moving[..n], &counts[..n], out, cap),
            Some(e) => last_failure = e,
        }
        if !next_permutation(&mut order[..n]) {
            break;
        }
    }
    Err(last_failure)
}

struct Plan<'p, M, const D: usize> {
    problem: &'p Problem<D>,
    params: &'p ApproachParams,
    n: usize,
    bases: [Frame; MAX_ROBOTS],
    starts: [[f64; D]; MAX_ROBOTS],
    goals: [[f64; D]; MAX_ROBOTS],
    _m: core::marker::PhantomData<M>,
}

impl<M: Model<D>, const D: usize> Plan<'_, M, D> {
    /// Every robot's start is free of obstacles, itself and the others.
    fn check_starts(&self) -> Result<(), ApproachError> {
        let arms: [ArmPose; MAX_ROBOTS] = core::array::from_fn(|i| {
            ArmPose::new::<M, D>(&self.bases[i], &self.starts[i.min(self.n - 1)])
        });
        for i in 0..self.n {
            if arms[i].obstacle_hit(&self.problem.obstacles, 0.0).is_some()
                || arms[i].self_hit(0.0).is_some()
            {
                return Err(ApproachError::StartCollides {
                    robot: i,
                    other: None,
                });
            }
            if let Some(k) = (i + 1..self.n).find(|&k| arms[i].arm_hit(&arms[k], 0.0).is_some()) {
                return Err(ApproachError::StartCollides {
                    robot: i,
                    other: Some(k),
                });
            }
        }
        Ok(())
    }

    /// Segments the robots in `moving` need to go from start to goal together: enough for the
    /// velocity and acceleration limits under the cosine profile (0 when none moves).
    fn segments(&self, moving: &[bool; MAX_ROBOTS]) -> usize {
        let dt = self.problem.dt;
        let mut need = 0.0f64;
        for i in (0..self.n).filter(|&i| moving[i]) {
            for j in 0..D {
                let d = libm::fabs(self.goals[i][j] - self.starts[i][j]);
                // The profile's largest step is at most (pi / 2N) of the distance.
                need = need.max(PI * d / (2.0 * self.params.speed * M::VELOCITY[j] * dt));
                if self.params.acceleration > 0.0 {
                    // Its largest second difference is (pi / N)^2 / 2 of it.
                    need = need.max(PI * libm::sqrt(d / (2.0 * self.params.acceleration)) / dt);
                }
            }
        }
        libm::ceil(need) as usize
    }

    /// Robot `i` at segment boundary `k` of a phase of `count` segments in which `moving`
    /// move, the others staying at `at`.
    fn config(
        &self,
        i: usize,
        moving: &[bool; MAX_ROBOTS],
        k: usize,
        count: usize,
        at: &[[f64; D]; MAX_ROBOTS],
    ) -> [f64; D] {
        if !moving[i] {
            return at[i];
        }
        let s = 0.5 * (1.0 - libm::cos(PI * k as f64 / count as f64));
        let (a, b) = (&self.starts[i], &self.goals[i]);
        core::array::from_fn(|j| {
            if k == count {
                b[j]
            } else {
                a[j] + s * (b[j] - a[j])
            }
        })
    }

    /// Checks every motion of a phase (the arms in `moving` from start to goal in `count`
    /// segments, the others still at `at`).
    fn phase_free(
        &self,
        moving: &[bool; MAX_ROBOTS],
        count: usize,
        at: &[[f64; D]; MAX_ROBOTS],
    ) -> Result<(), ApproachError> {
        let obstacles = &self.problem.obstacles;
        let step = self.params.motion_step;
        for k in 0..count {
            let from: [[f64; D]; MAX_ROBOTS] =
                core::array::from_fn(|i| self.config(i, moving, k, count, at));
            let to: [[f64; D]; MAX_ROBOTS] =
                core::array::from_fn(|i| self.config(i, moving, k + 1, count, at));
            let motion = |i: usize| ArmMotion {
                base: &self.bases[i],
                from: &from[i],
                to: &to[i],
            };
            for i in (0..self.n).filter(|&i| moving[i]) {
                if !motion_is_free::<M, D>(&motion(i), obstacles, step) {
                    return Err(ApproachError::Blocked {
                        robot: i,
                        other: None,
                    });
                }
                for o in (0..self.n).filter(|&o| o != i && (o > i || !moving[o])) {
                    if motions_collide::<M, D>(&motion(i), &motion(o), step) {
                        return Err(ApproachError::Blocked {
                            robot: i,
                            other: Some(o),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Writes the phases' configurations, goals excluded (the path's first configuration
    /// follows). Returns `A`.
    fn write(
        &self,
        phases: &[[bool; MAX_ROBOTS]],
        counts: &[usize],
        out: &mut [[f64; D]],
        cap: usize,
    ) -> Result<usize, ApproachError> {
        let total: usize = counts.iter().sum();
        let a = total.saturating_sub(1);
        if a > cap {
            return Err(ApproachError::TooLong {
                needed: a,
                capacity: cap,
            });
        }
        let mut at = self.starts;
        let mut written = 0;
        for (moving, &count) in phases.iter().zip(counts) {
            for k in 1..=count {
                if written == a {
                    break;
                }
                for i in 0..self.n {
                    out[i * cap + written] = self.config(i, moving, k, count, &at);
                }
                written += 1;
            }
            for i in (0..self.n).filter(|&i| moving[i]) {
                at[i] = self.goals[i];
            }
        }
        Ok(a)
    }
}
