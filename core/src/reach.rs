//! Proofs that a problem has no plan at any search resolution, found before searching: a
//! trajectory whose poses no single robot can all reach. Every planner runs this check
//! before it searches ([`crate::planner::open`]); it costs two link-frame evaluations per
//! robot and one distance per pose and robot.
//!
//! ```
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//! use omcbsa_core::problem::{Problem, Robot, Trajectory};
//! use omcbsa_core::reach::{tcp_reach, unreachable_trajectory};
//!
//! let gen3 = Robot::at(0, Frame::IDENTITY);
//! let reach = tcp_reach::<KinovaGen3, 7>(&gen3);
//! // The sum of the Gen3's link lengths: a little more than its 1.19 m fully stretched.
//! assert!(reach > 1.18 && reach < 1.3);
//!
//! let mut problem = Problem::<7>::new(0.1);
//! problem.robots.push(gen3).unwrap();
//! let near = KinovaGen3::fk(&[0.0; 7]);
//! let far = Frame { pos: near.pos * 2.0, ..near };
//! problem.trajectories.push(Trajectory::from_slice(&[near, near]).unwrap()).unwrap();
//! assert_eq!(unreachable_trajectory::<KinovaGen3, 7>(&problem), None);
//! problem.trajectories[0][1] = far;
//! assert_eq!(unreachable_trajectory::<KinovaGen3, 7>(&problem), Some(0));
//! ```

use crate::collision::MAX_LINK_FRAMES;
use crate::model::{Frame, Models};
use crate::problem::{Problem, Robot};

/// An upper bound on the distance from the robot's base origin to its tool centre point over
/// all configurations: the lengths of the chain's links (the distances between consecutive
/// link frame origins) plus the tool offset. A revolute joint turns its child frame about the
/// child's origin, so those lengths do not depend on `q`; a model where they do (a prismatic
/// joint) gets no bound (infinity).
pub fn tcp_reach<M: Models<D>, const D: usize>(robot: &Robot<D>) -> f64 {
    let links = M::link_names(robot.model).len();
    let lengths = |q: &[f64; D]| {
        let mut f = [Frame::IDENTITY; MAX_LINK_FRAMES];
        let tool = M::link_frames(robot.model, q, &mut f[..links]);
        let mut sum = (tool.pos - f[links - 1].pos).norm();
        for k in 1..links {
            sum += (f[k].pos - f[k - 1].pos).norm();
        }
        sum
    };
    let mid: [f64; D] = core::array::from_fn(|j| {
        let (lo, hi) = (M::lower(robot.model)[j], M::upper(robot.model)[j]);
        if lo.is_finite() && hi.is_finite() {
            0.5 * (lo + hi) + 0.25 * (hi - lo)
        } else {
            1.0
        }
    });
    let (a, b) = (lengths(&[0.0; D]), lengths(&mid));
    if libm::fabs(a - b) > 1e-9 * (1.0 + a) {
        return f64::INFINITY;
    }
    a + robot.tcp.pos.norm()
}

/// The first trajectory that no robot can follow because for every robot some pose of it lies
/// farther from the robot's base than the robot reaches (plus the position tolerance).
pub fn unreachable_trajectory<M: Models<D>, const D: usize>(problem: &Problem<D>) -> Option<usize> {
    let mut reach = [0.0; crate::problem::MAX_ROBOTS];
    for (r, robot) in reach.iter_mut().zip(&problem.robots) {
        *r = tcp_reach::<M, D>(robot) + problem.tolerance.position;
    }
    problem.trajectories.iter().position(|traj| {
        !problem.robots.iter().zip(&reach).any(|(robot, r)| {
            traj.iter()
                .all(|pose| (pose.pos - robot.base.pos).norm() <= *r)
        })
    })
}

/// The reason planners report for [`unreachable_trajectory`].
pub const UNREACHABLE: &str = "a trajectory has a pose out of every robot's reach";
