//! IK tracking: follow a trajectory by projecting each pose from the previous configuration,
//! `q_t = IK(x_t, q_{t-1})`. Myopic but fast; Ω-CBSA warm-starts its root with it and the
//! IK-tracking baseline is made of it.

use crate::ik::{ik, IkParams};
use crate::model::{Frame, Models};
use crate::problem::{Robot, Start, Trajectory};
use crate::search::Validity;

/// Tracks `traj` starting from the IK solution of its first pose nearest `seed`, checking every
/// state and motion with `valid`. Writes `out[..H]` and returns the collision count with the
/// other robots (always 0 when `valid` avoids them), or `None` when tracking breaks down.
pub fn track<M: Models<D>, const D: usize>(
    robot: &Robot<D>,
    traj: &Trajectory,
    seed: &[f64; D],
    valid: &Validity<'_, M, D>,
    ik_params: &IkParams,
    out: &mut [[f64; D]],
) -> Option<u32> {
    let base_inv = robot.base.inverse();
    let tcp_inv = robot.tcp.inverse();
    let target = |x: &Frame| base_inv.compose(x).compose(&tcp_inv);
    let mut q = match (robot.start, robot.initial) {
        // Online: the path begins where the arm is (pose 0 is not tracked).
        (Start::AtInitial, Some(q)) => q,
        (Start::AtInitial, None) => return None,
        (Start::Sampled, _) => ik::<M, D>(robot.model, &target(&traj[0]), seed, ik_params).ok()?,
    };
    let mut c = valid.state(&q, 0)? as u32;
    out[0] = q;
    for t in 1..traj.len() {
        let next = ik::<M, D>(robot.model, &target(&traj[t]), &q, ik_params).ok()?;
        if !valid.step_within_limits(&q, &next) {
            return None;
        }
        c += valid.state(&next, t)? as u32;
        c += valid.motion(&q, &next, t - 1)? as u32;
        q = next;
        out[t] = q;
    }
    Some(c)
}
