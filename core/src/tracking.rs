//! IK tracking: follow a trajectory by projecting each pose from the previous configuration,
//! `q_t = IK(x_t, q_{t-1})`, or steered along the null space by Ω-A*'s step cost
//! ([`Steps`]). Myopic but fast (one IK projection a step, three when steered);
//! Ω-CBSA warm-starts its root with it and the IK-tracking baseline is made of it.
//!
//! ```
//! use omcbsa_core::ik::IkParams;
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//! use omcbsa_core::motion::MOTION_STEP;
//! use omcbsa_core::nalgebra::Vector3;
//! use omcbsa_core::problem::{Robot, Trajectory};
//! use omcbsa_core::search::Validity;
//! use omcbsa_core::tracking::{track, Steps};
//!
//! let robot = Robot::at(0, Frame::IDENTITY);
//! let q0 = [0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0];
//! let hand = KinovaGen3::fk(&q0);
//! // Three poses 0.1 s apart, the hand sliding 1 cm a step along y.
//! let slide = |t: usize| Frame { pos: hand.pos + Vector3::y() * (0.01 * t as f64), ..hand };
//! let traj: Trajectory = (0..3).map(slide).collect();
//! // No obstacles, no other robots: only joint limits, speeds and self-collision count.
//! let valid = Validity::<KinovaGen3, 7>::new(&robot, &[], 0.1, MOTION_STEP);
//! let ik = IkParams::default();
//! let mut path = [[0.0; 7]; 3];
//! let collisions = track(&robot, &traj, &q0, &valid, Steps::Nearest(&ik), &mut path);
//! assert_eq!(collisions, Some(0));
//! for (q, pose) in path.iter().zip(&traj) {
//!     assert!((KinovaGen3::fk(q).pos - pose.pos).norm() <= ik.position_tolerance);
//! }
//! ```

use core::cell::Cell;

use crate::collision::ArmPose;
use crate::ik::{ik, IkParams};
use crate::kinematics::null_space_basis;
use crate::kinematics::twist;
use crate::model::{Frame, Models};
use crate::problem::{Robot, Start, Trajectory};
use crate::rng::Rng;
use crate::search::Validity;
use crate::search::{step_cost, OmegaParams};
use nalgebra::Vector6;

/// How [`track`] takes each step.
#[derive(Clone, Copy, Debug)]
pub enum Steps<'p> {
    /// The IK answer nearest the last configuration.
    Nearest(&'p IkParams),
    /// The IK projection moved along the null space (then back onto the pose by IK), at a
    /// rate of at most Ω-A*'s null-space step `epsilon` (these settings, already at the
    /// problem's step) that changes by at most `epsilon /` [`NULL_RATE_STEPS`] a step: each
    /// step keeps, slows or speeds up the rate, whichever gives the least joint motion plus
    /// [`step_cost`]. The search's costs without its backtracking, and without the jumps of
    /// its `± epsilon` moves, which a streamed path could not follow within the joints'
    /// accelerations.
    Steered(&'p OmegaParams),
}

/// Steps of [`Steps::Steered`] from rest to the full null-space rate.
pub const NULL_RATE_STEPS: f64 = 8.0;

/// Tracks `traj` starting from the IK solution of its first pose nearest `seed`, checking every
/// state and motion with `valid`, each step taken as `steps` says. Writes `out[..H]` and
/// returns the collision count with the other robots (always 0 when `valid` avoids them), or
/// `None` when tracking breaks down (IK fails, a step breaks a joint's speed limit, or a
/// state or motion is invalid). `out` must hold H configurations; a shorter one panics.
pub fn track<M: Models<D>, const D: usize>(
    robot: &Robot<D>,
    traj: &Trajectory,
    seed: &[f64; D],
    valid: &Validity<'_, M, D>,
    steps: Steps<'_>,
    out: &mut [[f64; D]],
) -> Option<u32> {
    let ik_params = match steps {
        Steps::Nearest(p) => p,
        Steps::Steered(p) => &p.ik,
    };
    // Steered: the null-space rate (rad a step) and direction of the last step.
    let rate = Cell::new(0.0);
    let last_dir = Cell::new([0.0; D]);
    // `motion`: the hand's twist at the step taken (see `step_cost`).
    let next = |target: &Frame, motion: &Vector6<f64>, q: &[f64; D]| {
        let proj = ik::<M, D>(robot.model, target, q, ik_params).ok()?;
        let Steps::Steered(p) = steps else {
            return Some(proj).filter(|next| valid.step_within_limits(q, next));
        };
        let (_, jac) = M::jacobian(robot.model, &proj);
        let mut dir = [0.0; D];
        if let Some(n) = null_space_basis::<D>(&jac).first() {
            dir.iter_mut().zip(n.iter()).for_each(|(d, x)| *d = *x);
        }
        // The basis fixes its sign by its first component: keep the last step's sense.
        let along: f64 = dir.iter().zip(&last_dir.get()).map(|(a, b)| a * b).sum();
        if along < 0.0 {
            dir.iter_mut().for_each(|d| *d = -*d);
        }
        last_dir.set(dir);
        let (a, d) = (rate.get(), p.epsilon / NULL_RATE_STEPS);
        let moved = |alpha: f64| {
            let mut s = proj;
            s.iter_mut().zip(&dir).for_each(|(x, n)| *x += alpha * n);
            ik::<M, D>(robot.model, target, &s, ik_params).ok()
        };
        let cost = |m: &[f64; D]| {
            let d2: f64 = m.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            libm::sqrt(d2) + step_cost::<M, D>(robot.model, m, motion, p)
        };
        let best = [a - d, a, a + d]
            .into_iter()
            .map(|alpha| alpha.clamp(-p.epsilon, p.epsilon))
            .filter_map(|alpha| Some((alpha, moved(alpha)?)))
            .filter(|(_, m)| valid.step_within_limits(q, m))
            .map(|(alpha, m)| (cost(&m), alpha, m))
            .min_by(|x, y| x.0.total_cmp(&y.0));
        // None within the limits: the projection, if it is, from rest.
        let (alpha, next) = match best {
            Some((_, alpha, m)) => (alpha, m),
            None => (0.0, Some(proj).filter(|m| valid.step_within_limits(q, m))?),
        };
        rate.set(alpha);
        Some(next)
    };
    let target = robot.ik_target();
    let mut q = match (robot.start, robot.initial) {
        // Online: the path begins where the arm is (pose 0 is not tracked).
        (Start::AtInitial, Some(q)) => q,
        (Start::AtInitial, None) => return None,
        (Start::Sampled, _) => ik::<M, D>(robot.model, &target(&traj[0]), seed, ik_params).ok()?,
    };
    // The arm at the last configuration and at the next: each step's motion check starts
    // from the poses its state checks placed.
    let mut poses = [ArmPose::EMPTY; 2];
    let mut c = valid.state_in(&q, 0, &mut poses[0])? as u32;
    out[0] = q;
    let (steered, dt) = (matches!(steps, Steps::Steered(p) if p.w_v > 0.0), valid.dt);
    for t in 1..traj.len() {
        let motion = match (steered, traj.get(t + 1)) {
            (false, _) => Vector6::zeros(),
            (true, Some(after)) => twist(&target(&traj[t]), &target(after), dt),
            // The last step's motion goes on past the end.
            (true, None) => twist(&target(&traj[t - 1]), &target(&traj[t]), dt),
        };
        let next = next(&target(&traj[t]), &motion, &q)?;
        let [here, there] = &mut poses;
        c += valid.state_in(&next, t, there)? as u32;
        c += valid.motion_posed(&q, &next, [here, there], t - 1)? as u32;
        poses.swap(0, 1);
        q = next;
        out[t] = q;
    }
    Some(c)
}

/// First-pose IK answers drawn when the warm start ranks its starts: seeds from
/// `initial` (when given) and random ones.
pub const RANKED_SEEDS: usize = 32;

/// Two ranked starts closer than this in every joint (rad) are one.
const DISTINCT_START: f64 = 0.1;

/// The warm start's first configurations for `traj` when starts are ranked
/// ([`OmegaParams::rank_starts`], with the joints' reserve weighed: [`OmegaParams::w_r`]): the first pose's IK answers from `initial` and random seeds,
/// best reserve first (its [`step_cost`] for a hand at rest; the seeds' order breaks ties),
/// distinct, written to `out`. Returns how many. A start fixes which of the arm's self-motion
/// families the chunks that follow can reach: the one nearest where the arm stands may leave
/// its joints no room for the hand's later motions, and no null-space motion leads out of it
/// in time once they come.
pub fn ranked_starts<M: Models<D>, const D: usize>(
    robot: &Robot<D>,
    traj: &Trajectory,
    p: &OmegaParams,
    rng: &mut Rng,
    out: &mut [[f64; D]; RANKED_SEEDS],
) -> usize {
    let Some(first) = traj.first() else {
        return 0;
    };
    let target = robot.ik_target()(first);
    let (lower, upper) = (M::lower(robot.model), M::upper(robot.model));
    let mut scored = [(f64::INFINITY, 0usize); RANKED_SEEDS];
    let mut n = 0;
    for k in 0..RANKED_SEEDS {
        let seed = match (k, robot.initial) {
            (0, Some(init)) => init,
            _ => rng.configuration(lower, upper),
        };
        let Ok(q) = ik::<M, D>(robot.model, &target, &seed, &p.ik) else {
            continue;
        };
        out[n] = q;
        scored[n] = (step_cost::<M, D>(robot.model, &q, &Vector6::zeros(), p), n);
        n += 1;
    }
    scored[..n].sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    // Distinct starts only: a second try from where the first failed would fail again.
    let answers = *out;
    let mut kept = 0;
    for (_, k) in &scored[..n] {
        let q = answers[*k];
        let near = |o: &[f64; D]| (0..D).all(|i| libm::fabs(o[i] - q[i]) < DISTINCT_START);
        if !out[..kept].iter().any(near) {
            out[kept] = q;
            kept += 1;
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::axis_separation;
    use crate::model::{KinovaGen3, Model};
    use crate::problem::{Assigned, StartExclusions};
    use crate::search::REFERENCE_DT;
    use crate::tool::Tool;

    /// A hand held still in front of a Gen3 whose shoulder stands nearly straight up (its
    /// first and third axes 0.1 rad apart): plain tracking stays where it is; steered by the
    /// axes' cost, the arm turns in its null space, the hand unmoved, until they part.
    #[test]
    fn steered_tracking_parts_the_axes_and_plain_tracking_stays() {
        let q0 = [0.3, -0.1, 1.1, -2.2, 0.6, 0.4, 2.5];
        let robot = Robot {
            model: 0,
            base: Frame::IDENTITY,
            tcp: Frame::IDENTITY,
            initial: Some(q0),
            tool: Tool::NONE,
            start: Start::AtInitial,
            assigned: Assigned::Track(0),
            excluded: StartExclusions::NONE,
        };
        let hand = <KinovaGen3 as Model<7>>::fk(&q0);
        let traj: Trajectory = (0..40).map(|_| hand).collect();
        let dt = 0.02;
        let valid = Validity::<KinovaGen3, 7>::new(&robot, &[], dt, crate::motion::MOTION_STEP);
        let separation = |q: &[f64; 7]| axis_separation(&<KinovaGen3 as Model<7>>::jacobian(q).1);
        let mut plain = [[0.0; 7]; 40];
        let ik_params = IkParams::default();
        track(
            &robot,
            &traj,
            &q0,
            &valid,
            Steps::Nearest(&ik_params),
            &mut plain,
        )
        .unwrap();
        let moved = |p: &[[f64; 7]]| (0..7).map(|d| (p[39][d] - q0[d]).abs()).fold(0.0, f64::max);
        assert!(moved(&plain) < 1e-6, "{}", moved(&plain));
        // Here a null-space step of ε parts the axes by only 0.13 ε: a weight above 8 pays
        // for the step's own length.
        let params = OmegaParams {
            w_a: 20.0,
            ..OmegaParams::default()
        }
        .at_step(dt);
        assert!(dt < REFERENCE_DT && params.epsilon < 0.2);
        let mut steered = [[0.0; 7]; 40];
        track(
            &robot,
            &traj,
            &q0,
            &valid,
            Steps::Steered(&params),
            &mut steered,
        )
        .unwrap();
        let (before, after) = (separation(&q0), separation(&steered[39]));
        assert!(after > before + 0.1, "{before} -> {after}");
        for q in &steered {
            let err = (<KinovaGen3 as Model<7>>::fk(q).pos - hand.pos).norm();
            assert!(err < 1e-3, "the hand moved {err} m");
        }
    }

    /// The ranked starts reach the first pose, are distinct, and come best reserve first;
    /// the same seed gives the same starts.
    #[test]
    fn ranked_starts_come_best_reserve_first_and_distinct() {
        let q0 = [0.0, 0.26, 3.0, -2.27, 0.0, 0.96, 1.57];
        let mut robot = Robot::at(0, Frame::IDENTITY);
        robot.initial = Some(q0);
        let hand = <KinovaGen3 as Model<7>>::fk(&[0.3, 0.6, -0.2, 1.6, 0.1, 0.9, 0.4]);
        let traj: Trajectory = (0..4).map(|_| hand).collect();
        let p = OmegaParams {
            w_r: 1.0,
            ..OmegaParams::default()
        };
        let rank = |out: &mut [[f64; 7]; RANKED_SEEDS]| {
            ranked_starts::<KinovaGen3, 7>(&robot, &traj, &p, &mut Rng::new(3), out)
        };
        let (mut a, mut b) = ([[0.0; 7]; RANKED_SEEDS], [[0.0; 7]; RANKED_SEEDS]);
        let n = rank(&mut a);
        assert!(n >= 2, "{n} starts");
        assert_eq!((n, a), (rank(&mut b), b));
        let cost = |q: &[f64; 7]| step_cost::<KinovaGen3, 7>(0, q, &Vector6::zeros(), &p);
        for w in a[..n].windows(2) {
            assert!(cost(&w[0]) <= cost(&w[1]));
        }
        for (k, q) in a[..n].iter().enumerate() {
            let err = crate::kinematics::pose_error(&<KinovaGen3 as Model<7>>::fk(q), &hand);
            assert!(err.norm() < 1e-3, "start {k}: {err:?}");
            for o in &a[..k] {
                assert!((0..7).any(|i| (o[i] - q[i]).abs() >= DISTINCT_START));
            }
        }
        // The answer nearest where the arm stood is not the best here: the ranking moved it.
        let nearest = ik::<KinovaGen3, 7>(0, &hand, &q0, &p.ik).unwrap();
        assert!(
            cost(&a[0]) < cost(&nearest),
            "{} {}",
            cost(&a[0]),
            cost(&nearest)
        );
    }
}
