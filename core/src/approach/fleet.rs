//! The arms of a problem as one composite system: what the approach planners check. A
//! composite configuration is one configuration per robot (`&[[f64; D]]`, robot order), and a
//! composite motion moves every arm along its straight joint-space segment at the same pace,
//! so a piece of it is again a composite motion (what the time parametrisation relies on).

use crate::collision::ArmPose;
use crate::model::{Frame, Models};
use crate::motion::{motion_is_free_posed, motions_collide_posed, ArmMotion};
use crate::problem::{Problem, MAX_ROBOTS};
use crate::tool::Tool;

/// What a robot's configuration touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Touch {
    /// Joint `joint` is outside the model's limits (or not a number).
    JointLimit { joint: usize },
    /// Obstacle `index` of the problem.
    Obstacle { index: usize },
    /// Two of its own capsules (indices into the arm's capsules: the model's
    /// `Model::CAPSULES`, then its tool's).
    Itself {
        capsule: usize,
        other_capsule: usize,
    },
    /// Robot `robot`.
    Robot { robot: usize },
}

/// A robot whose configuration is not free.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Blocked {
    pub robot: usize,
    pub touch: Touch,
}

/// The robots of `problem`, checked together. Robots not `active` are left out of every
/// check (used to ask whether one arm alone can make its approach).
pub(crate) struct Fleet<'p, M, const D: usize> {
    problem: &'p Problem<D>,
    pub n: usize,
    active: [bool; MAX_ROBOTS],
    motion_step: f64,
    _m: core::marker::PhantomData<M>,
}

impl<'p, M: Models<D>, const D: usize> Fleet<'p, M, D> {
    pub fn new(problem: &'p Problem<D>, motion_step: f64) -> Self {
        let n = problem.robots.len();
        Fleet {
            problem,
            n,
            active: core::array::from_fn(|i| i < n),
            motion_step,
            _m: core::marker::PhantomData,
        }
    }

    /// The same fleet with only the robots `keep` accepts in it.
    pub fn restricted(&self, keep: impl Fn(usize) -> bool) -> Self {
        Fleet {
            active: core::array::from_fn(|i| self.active[i] && keep(i)),
            ..*self
        }
    }

    pub fn is_active(&self, i: usize) -> bool {
        self.active[i]
    }

    /// Robot `i`'s model, an index into `M`.
    pub fn model(&self, i: usize) -> u8 {
        self.problem.robots[i].model
    }

    /// Every robot's model (0 past the last robot).
    pub fn models(&self) -> [u8; MAX_ROBOTS] {
        core::array::from_fn(|i| self.problem.robots.get(i).map_or(0, |r| r.model))
    }

    fn base(&self, i: usize) -> &'p Frame {
        &self.problem.robots[i].base
    }

    fn tool(&self, i: usize) -> &'p Tool {
        &self.problem.robots[i].tool
    }

    fn pose(&self, i: usize, q: &[f64; D]) -> ArmPose {
        ArmPose::new::<M, D>(self.model(i), self.base(i), self.tool(i), q)
    }

    /// The first robot (in index order) whose configuration in `q` is outside its limits or
    /// touches an obstacle, itself, or a robot of higher index.
    pub fn state_blocked(&self, q: &[[f64; D]]) -> Option<Blocked> {
        let mut poses = [ArmPose::EMPTY; MAX_ROBOTS];
        for i in (0..self.n).filter(|&i| self.active[i]) {
            // Written so that NaN is refused too.
            let (lower, upper) = (M::lower(self.model(i)), M::upper(self.model(i)));
            let out = (0..D).find(|&j| !(q[i][j] >= lower[j] && q[i][j] <= upper[j]));
            if let Some(joint) = out {
                return Some(Blocked {
                    robot: i,
                    touch: Touch::JointLimit { joint },
                });
            }
            poses[i] = self.pose(i, &q[i]);
        }
        for i in (0..self.n).filter(|&i| self.active[i]) {
            let pose = &poses[i];
            let touch = if let Some(index) = pose.obstacle_hit(&self.problem.obstacles, 0.0) {
                Some(Touch::Obstacle { index })
            } else if let Some((capsule, other_capsule)) = pose.self_hit(0.0) {
                Some(Touch::Itself {
                    capsule,
                    other_capsule,
                })
            } else {
                (i + 1..self.n)
                    .find(|&k| self.active[k] && pose.arm_hit(&poses[k], 0.0).is_some())
                    .map(|robot| Touch::Robot { robot })
            };
            if let Some(touch) = touch {
                return Some(Blocked { robot: i, touch });
            }
        }
        None
    }

    /// Checks the composite motion `a -> b` (every arm along its straight segment, at the same
    /// pace): each moving arm against the obstacles and itself, each pair with a moving arm
    /// against each other. The first failure found, as (robot, other robot).
    pub fn motion_blocked(&self, a: &[[f64; D]], b: &[[f64; D]]) -> Option<(usize, Option<usize>)> {
        let moving: [bool; MAX_ROBOTS] =
            core::array::from_fn(|i| i < self.n && self.active[i] && a[i] != b[i]);
        let mut ends = [[ArmPose::EMPTY; 2]; MAX_ROBOTS];
        for i in (0..self.n).filter(|&i| self.active[i]) {
            ends[i][0] = self.pose(i, &a[i]);
            ends[i][1] = if moving[i] {
                self.pose(i, &b[i])
            } else {
                ends[i][0]
            };
        }
        let motion = |i: usize| ArmMotion {
            model: self.model(i),
            base: self.base(i),
            tool: self.tool(i),
            from: &a[i],
            to: &b[i],
        };
        let obstacles = &self.problem.obstacles;
        for i in (0..self.n).filter(|&i| moving[i]) {
            let [e0, e1] = &ends[i];
            if !motion_is_free_posed::<M, D>(&motion(i), [e0, e1], obstacles, self.motion_step) {
                return Some((i, None));
            }
        }
        for i in (0..self.n).filter(|&i| self.active[i]) {
            for k in (i + 1..self.n).filter(|&k| self.active[k] && (moving[i] || moving[k])) {
                let ([a0, a1], [b0, b1]) = (&ends[i], &ends[k]);
                if motions_collide_posed::<M, D>(
                    &motion(i),
                    [a0, a1],
                    &motion(k),
                    [b0, b1],
                    self.motion_step,
                ) {
                    return Some((i, Some(k)));
                }
            }
        }
        None
    }
}
