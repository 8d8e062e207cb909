//! The joints' acceleration at the hands' own timing, and the time scaling a too fast step
//! needs: the rule every planner's path keeps, and what a planner says when it cannot.
//!
//! A path's acceleration is taken as `validate` takes it, by finite differences at the plan's
//! steps: `(q[t+1] - 2 q[t] + q[t-1]) / dt^2` at every step `t` with a step on either side.
//! The first and last steps are not taken at rest: the hands are already moving when a plan
//! begins and still moving when it ends, and bringing the arm to and from rest is the
//! approach's and the executor's part.
//!
//! Scaling time by `k` (steps `k dt` apart, the same poses) divides the joints' speeds by `k`
//! and their accelerations by `k^2`, so a step that needs `|dq| <= v dt` and
//! `|d2q| <= a dt^2` is feasible at `k >= max(|dq| / (v dt), sqrt(|d2q| / (a dt^2)))`.
//!
//! ```
//! use omcbsa_core::pace::step_scale;
//!
//! // Limits per step: 0.1 rad of motion, 0.02 rad of change in motion.
//! let (step, accel) = ([0.1], [0.02]);
//! // At rest, then 0.08 rad: within speed, four times the change allowed.
//! let (k, joint) = step_scale(&[0.0], &[0.0], &[0.08], &step, &accel);
//! assert_eq!(joint, 0);
//! assert!((k - 2.0).abs() < 1e-12); // twice as long a step quarters the change
//! ```

use crate::model::Models;
use crate::problem::MAX_ROBOTS;

/// Where the hands move faster than the joints can follow, and how much slower they would
/// have to move: a planner's answer when acceleration or speed cut its search (or its plan).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TooFast {
    /// The robot whose path was cut (its index in the problem).
    pub robot: u8,
    /// The trajectory (hand) it was following.
    pub trajectory: u8,
    /// The step at which the joint's acceleration (or speed into the next step) was over.
    pub step: u16,
    /// The joint over its limit.
    pub joint: u8,
    /// The factor on `dt` at which the step the search came furthest with is within every
    /// limit (at least 1).
    pub time_scale: f64,
}

impl TooFast {
    /// Of two reports, the one to keep: the step furthest along (the search got furthest
    /// there), then the smaller scaling, then the earlier robot and trajectory: a fixed
    /// order, so the answer is deterministic.
    pub fn keep(a: Option<TooFast>, b: Option<TooFast>) -> Option<TooFast> {
        match (a, b) {
            (Some(x), Some(y)) => {
                let key = |r: &TooFast| (u16::MAX - r.step, r.time_scale, r.robot, r.trajectory);
                let (kx, ky) = (key(&x), key(&y));
                Some(if ky.partial_cmp(&kx) == Some(core::cmp::Ordering::Less) {
                    y
                } else {
                    x
                })
            }
            (x, None) => x,
            (None, y) => y,
        }
    }

    /// Adds one search's report (robot `robot`'s; see [`crate::search::SearchStats`]) to a
    /// planner's, keeping the one [`TooFast::keep`] keeps.
    pub fn note(into: &mut Option<TooFast>, search: Option<TooFast>, robot: usize) {
        let search = search.map(|s| TooFast {
            robot: robot as u8,
            ..s
        });
        *into = TooFast::keep(*into, search);
    }
}

/// The least time scaling at which the steps `before -> at -> after` are within the per-step
/// limits `step_limit` (`v dt`) and `accel_limit` (`a dt^2`), and the joint that needs it
/// (the first of the largest). At least 1.
pub fn step_scale<const D: usize>(
    before: &[f64; D],
    at: &[f64; D],
    after: &[f64; D],
    step_limit: &[f64; D],
    accel_limit: &[f64; D],
) -> (f64, usize) {
    let mut worst = (1.0, 0);
    for j in 0..D {
        let speed = libm::fabs(after[j] - at[j]).max(libm::fabs(at[j] - before[j])) / step_limit[j];
        let accel = libm::sqrt(libm::fabs(after[j] - 2.0 * at[j] + before[j]) / accel_limit[j]);
        let k = speed.max(accel);
        if k > worst.0 {
            worst = (k, j);
        }
    }
    worst
}

/// The largest change a step may make in joint `j`'s motion, `a_j dt^2`, for model `model`.
pub fn accel_step<M: Models<D>, const D: usize>(model: u8, dt: f64) -> [f64; D] {
    let a = M::acceleration(model);
    core::array::from_fn(|j| a[j] * dt * dt)
}

/// The first place a solved plan breaks an acceleration limit (finite differences at the
/// plan's steps, as `validate` computes them), with the time scaling the whole plan needs;
/// `None` when it keeps every one. `paths` holds robot `i`'s path at `i * h..(i + 1) * h`,
/// `assignment[i]` its trajectory (a robot that holds cannot break one).
pub fn plan_too_fast<M: Models<D>, const D: usize>(
    models: &[u8],
    assignment: &[Option<u8>; MAX_ROBOTS],
    paths: &[[f64; D]],
    h: usize,
    dt: f64,
) -> Option<TooFast> {
    let mut found: Option<TooFast> = None;
    for (i, &model) in models.iter().enumerate() {
        let path = &paths[i * h..(i + 1) * h];
        let a = M::acceleration(model);
        let v = M::velocity(model);
        let step: [f64; D] = core::array::from_fn(|j| v[j] * dt);
        let accel = accel_step::<M, D>(model, dt);
        for (t, w) in path.windows(3).enumerate() {
            // The rule as validate states it: the finite difference over dt^2 against a.
            let over =
                (0..D).any(|j| libm::fabs(w[2][j] - 2.0 * w[1][j] + w[0][j]) / (dt * dt) > a[j]);
            if !over {
                continue;
            }
            let (k, joint) = step_scale(&w[0], &w[1], &w[2], &step, &accel);
            let here = TooFast {
                robot: i as u8,
                trajectory: assignment[i].unwrap_or(u8::MAX),
                step: (t + 1) as u16,
                joint: joint as u8,
                time_scale: k,
            };
            found = Some(match found {
                // The first place, with the scaling every place needs.
                Some(f) => TooFast {
                    time_scale: f.time_scale.max(k),
                    ..f
                },
                None => here,
            });
        }
    }
    found
}
