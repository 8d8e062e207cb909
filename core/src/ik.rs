//! Numerical inverse kinematics: the projection `IK(x, q_seed)` of the paper.
//!
//! A Levenberg-Marquardt iteration on the pose error, with the damping of Sugihara (2011):
//! `lambda = damping + |e|^2 / 2`, large far from the target (short, safe steps) and vanishing
//! at it (fast final convergence). A step that does not lower the error is rejected and retried
//! with more damping. Each step solves the 6x6 system `(J J^T + lambda I) y = e` and moves by
//! `dq = J^T y`, the same step as the DxD normal equations but cheaper for D > 6. Joints are
//! clamped into their limits after every step, and a joint pressed against a limit is taken
//! out of the next solve so the others make up for it.
//!
//! Every `Ok` answer is a configuration within the joint limits whose forward kinematics was
//! checked against the target with the requested tolerances; anything else is an [`IkError`].
//! Bad input (a target with a NaN, a matrix that is no rotation, a NaN seed, parameters that
//! are not positive) is an error too, never a panic.
//!
//! Cost: at most [`IkParams::max_iterations`] Jacobian evaluations and 6 x 6 Cholesky
//! solves per call (a few microseconds in a release build when the seed is near); no memory
//! beyond the stack.

use core::f64::consts::PI;

use nalgebra::{Cholesky, SMatrix, Vector6};

use crate::kinematics::pose_error;
use crate::model::{Frame, Models};
use crate::rng::Rng;

/// Settings of one IK projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IkParams {
    /// Most iterations (Jacobian evaluations) before giving up.
    pub max_iterations: u32,
    /// Largest accepted position error, metres.
    pub position_tolerance: f64,
    /// Largest accepted rotation angle between reached and target orientation, radians.
    pub orientation_tolerance: f64,
    /// Damping floor added to `J J^T`; keeps steps bounded at singularities.
    pub damping: f64,
    /// Largest change of one joint in one step (rad or m); longer steps are scaled down.
    pub max_step: f64,
    /// Give up after this many steps in a row that each lower the squared error by less than
    /// 1 % (a local minimum, a joint limit or an unreachable target).
    pub max_stalled: u32,
}

impl Default for IkParams {
    fn default() -> Self {
        IkParams {
            max_iterations: 300,
            position_tolerance: 1e-5,
            orientation_tolerance: 1e-4,
            damping: 1e-6,
            max_step: 0.5,
            max_stalled: 30,
        }
    }
}

/// Why IK gave no answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IkError {
    /// The target pose has a NaN or infinite component.
    NonFiniteTarget,
    /// The target's rotation matrix is not orthonormal with determinant 1 (to 1e-6).
    NotARotation,
    /// The seed configuration has a NaN or infinite component.
    NonFiniteSeed,
    /// The parameters cannot work (a tolerance, damping or step that is not positive).
    InvalidParams,
    /// The iteration stopped (iteration budget or stall) short of the target with joint
    /// `joint` at a position limit; `position` and `orientation` are the smallest errors seen.
    BlockedByLimit {
        /// The first joint (0-based) at a limit.
        joint: usize,
        /// Position error, metres.
        position: f64,
        /// Orientation error (rotation angle), radians.
        orientation: f64,
    },
    /// The iteration stopped short of the target: a local minimum, a singularity or an
    /// unreachable pose. `position` and `orientation` are the smallest errors seen.
    NoConvergence {
        /// Position error, metres.
        position: f64,
        /// Orientation error (rotation angle), radians.
        orientation: f64,
    },
}

impl core::fmt::Display for IkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            IkError::NonFiniteTarget => write!(f, "target pose has a NaN or infinite component"),
            IkError::NotARotation => write!(f, "target rotation is not a rotation matrix"),
            IkError::NonFiniteSeed => write!(f, "seed configuration has a NaN or infinite value"),
            IkError::InvalidParams => write!(f, "IK parameters must be positive"),
            IkError::BlockedByLimit {
                joint,
                position,
                orientation,
            } => write!(
                f,
                "no IK solution found: joint {} at its limit, error {position:.3e} m, \
                 {orientation:.3e} rad",
                joint + 1
            ),
            IkError::NoConvergence {
                position,
                orientation,
            } => write!(
                f,
                "no IK solution found: error {position:.3e} m, {orientation:.3e} rad"
            ),
        }
    }
}

/// Projects `seed` onto the configurations of model `model` of `M` whose tool frame is at
/// `target` (in the model's base frame). The answer is usually the solution nearest the seed,
/// which is what trajectory tracking wants.
///
/// For a robot placed in the world, the target is `base^-1 * pose * tcp^-1` (see
/// [`crate::problem::Robot`]).
///
/// ```
/// use omcbsa_core::ik::{ik, IkError, IkParams};
/// use omcbsa_core::kinematics::orientation_angle;
/// use omcbsa_core::model::{KinovaGen3, Model};
///
/// let params = IkParams::default();
/// let q = [0.1, 0.5, -0.2, 1.2, 0.0, 0.8, 0.3];
/// let target = KinovaGen3::fk(&q);
/// // From a seed a little off, IK lands on the target within the tolerances.
/// let seed = [0.2, 0.4, -0.1, 1.1, 0.1, 0.9, 0.2];
/// let found = ik::<KinovaGen3, 7>(0, &target, &seed, &params).unwrap();
/// let reached = KinovaGen3::fk(&found);
/// assert!((reached.pos - target.pos).norm() <= params.position_tolerance);
/// assert!(orientation_angle(&reached.rot, &target.rot) <= params.orientation_tolerance);
///
/// // Out of reach (3 m up): an error that says how close it came.
/// let mut far = target;
/// far.pos.z += 3.0;
/// match ik::<KinovaGen3, 7>(0, &far, &seed, &params) {
///     Err(IkError::NoConvergence { position, .. } | IkError::BlockedByLimit { position, .. }) => {
///         assert!(position > 1.0)
///     }
///     other => panic!("{other:?}"),
/// }
/// // A NaN seed is refused.
/// let nan = [f64::NAN; 7];
/// assert_eq!(ik::<KinovaGen3, 7>(0, &target, &nan, &params), Err(IkError::NonFiniteSeed));
/// ```
pub fn ik<M: Models<D>, const D: usize>(
    model: u8,
    target: &Frame,
    seed: &[f64; D],
    params: &IkParams,
) -> Result<[f64; D], IkError> {
    check_target(target)?;
    check_params(params)?;
    if seed.iter().any(|x| !x.is_finite()) {
        return Err(IkError::NonFiniteSeed);
    }
    solve::<M, D>(model, target, seed, params)
}

/// The iteration itself, for inputs already checked.
fn solve<M: Models<D>, const D: usize>(
    model: u8,
    target: &Frame,
    seed: &[f64; D],
    params: &IkParams,
) -> Result<[f64; D], IkError> {
    let mut q = clamp::<M, D>(model, seed);
    let (frame, mut jac) = M::jacobian(model, &q);
    let mut err = pose_error(&frame, target);
    let mut cost = err.norm_squared();
    // Multiplies the damping; grows on rejected steps, shrinks on accepted ones.
    let mut boost = 1.0;
    let mut stalled = 0;
    for _ in 0..params.max_iterations {
        if within(&err, params) {
            return Ok(q);
        }
        let lambda = boost * (params.damping + 0.5 * cost);
        let dq = step::<M, D>(model, &q, &jac, &err, lambda, params.max_step);
        let next = clamp::<M, D>(model, &core::array::from_fn(|i| q[i] + dq[i]));
        let (next_frame, next_jac) = M::jacobian(model, &next);
        let next_err = pose_error(&next_frame, target);
        let next_cost = next_err.norm_squared();
        // A NaN cost (from overflow on absurd targets) is rejected here too.
        if next_cost < cost {
            stalled = if next_cost > 0.99 * cost {
                stalled + 1
            } else {
                0
            };
            (q, jac, err, cost) = (next, next_jac, next_err, next_cost);
            boost = (boost * 0.25).max(1.0);
        } else {
            stalled += 1;
            boost *= 8.0;
        }
        if stalled >= params.max_stalled {
            break;
        }
    }
    if within(&err, params) {
        return Ok(q);
    }
    let position = err.fixed_rows::<3>(0).norm();
    let orientation = err.fixed_rows::<3>(3).norm();
    match (0..D).find(|&i| at_limit::<M, D>(model, &q, i)) {
        Some(joint) => Err(IkError::BlockedByLimit {
            joint,
            position,
            orientation,
        }),
        None => Err(IkError::NoConvergence {
            position,
            orientation,
        }),
    }
}

/// The damped least-squares step `J^T (J J^T + lambda I)^-1 e`, with the columns of joints
/// that sit at a limit and would be pushed past it removed, scaled so no joint moves by more
/// than `max_step`.
fn step<M: Models<D>, const D: usize>(
    model: u8,
    q: &[f64; D],
    jac: &SMatrix<f64, 6, D>,
    err: &Vector6<f64>,
    lambda: f64,
    max_step: f64,
) -> [f64; D] {
    let mut j = *jac;
    let mut dq = dls(&j, err, lambda);
    let mut blocked = false;
    for i in 0..D {
        let pushed_out = (dq[i] < 0.0 && q[i] <= M::lower(model)[i])
            || (dq[i] > 0.0 && q[i] >= M::upper(model)[i]);
        if pushed_out {
            j.column_mut(i).fill(0.0);
            blocked = true;
        }
    }
    if blocked {
        dq = dls(&j, err, lambda);
    }
    let largest = dq.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let scale = if largest > max_step {
        max_step / largest
    } else {
        1.0
    };
    core::array::from_fn(|i| dq[i] * scale)
}

/// `J^T (J J^T + lambda I)^-1 e`; zero if the system is not positive definite (only possible
/// with non-finite values, which the caller's error check then rejects).
fn dls<const D: usize>(
    j: &SMatrix<f64, 6, D>,
    err: &Vector6<f64>,
    lambda: f64,
) -> SMatrix<f64, D, 1> {
    let mut a = j * j.transpose();
    for k in 0..6 {
        a[(k, k)] += lambda;
    }
    match Cholesky::new(a) {
        Some(chol) => j.tr_mul(&chol.solve(err)),
        None => SMatrix::zeros(),
    }
}

fn within(err: &Vector6<f64>, params: &IkParams) -> bool {
    let p = err.fixed_rows::<3>(0).norm_squared();
    let r = err.fixed_rows::<3>(3).norm_squared();
    p <= params.position_tolerance * params.position_tolerance
        && r <= params.orientation_tolerance * params.orientation_tolerance
}

fn clamp<M: Models<D>, const D: usize>(model: u8, q: &[f64; D]) -> [f64; D] {
    core::array::from_fn(|i| q[i].clamp(M::lower(model)[i], M::upper(model)[i]))
}

fn at_limit<M: Models<D>, const D: usize>(model: u8, q: &[f64; D], i: usize) -> bool {
    q[i] <= M::lower(model)[i] || q[i] >= M::upper(model)[i]
}

fn check_target(target: &Frame) -> Result<(), IkError> {
    if target
        .rot
        .iter()
        .chain(target.pos.iter())
        .any(|x| !x.is_finite())
    {
        return Err(IkError::NonFiniteTarget);
    }
    let off_orthonormal = (target.rot.tr_mul(&target.rot) - nalgebra::Matrix3::identity()).amax();
    if off_orthonormal > 1e-6 || target.rot.determinant() < 0.0 {
        return Err(IkError::NotARotation);
    }
    Ok(())
}

fn check_params(p: &IkParams) -> Result<(), IkError> {
    let positive = |x: f64| x > 0.0 && x.is_finite();
    if positive(p.position_tolerance)
        && positive(p.orientation_tolerance)
        && positive(p.damping)
        && positive(p.max_step)
        && p.max_iterations > 0
        && p.max_stalled > 0
    {
        Ok(())
    } else {
        Err(IkError::InvalidParams)
    }
}

/// How to look for several IK solutions of one pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiStart {
    /// Random seeds tried at most.
    pub attempts: u32,
    /// Two solutions are distinct when some joint differs by more than this (rad or m);
    /// continuous joints are compared modulo a full turn.
    pub min_separation: f64,
}

impl Default for MultiStart {
    fn default() -> Self {
        MultiStart {
            attempts: 64,
            min_separation: 0.1,
        }
    }
}

/// Runs IK on `target` from random seeds drawn from `rng` within the joint limits and stores
/// distinct solutions in `out`, stopping when `out` is full or after `multi.attempts` seeds.
/// Returns how many were stored: pass a one-element `out` for the first solution found. If no
/// seed succeeds, returns the error of the last attempt. Cost: up to `multi.attempts` IK
/// projections; `out` is the caller's storage, and an empty `out` stores nothing (`Err`).
///
/// ```
/// use omcbsa_core::ik::{ik_multi_start, IkParams, MultiStart};
/// use omcbsa_core::model::{KinovaGen3, Model};
/// use omcbsa_core::rng::Rng;
///
/// let target = KinovaGen3::fk(&[0.1, 0.5, -0.2, 1.2, 0.0, 0.8, 0.3]);
/// let multi = MultiStart { attempts: 16, min_separation: 0.1 };
/// let mut out = [[0.0; 7]; 2];
/// let (params, mut rng) = (IkParams::default(), Rng::new(7));
/// let n = ik_multi_start::<KinovaGen3, 7>(0, &target, &params, &multi, &mut rng, &mut out);
/// let n = n.unwrap();
/// // The Gen3 is redundant: two distinct answers are found from 16 seeds.
/// assert_eq!(n, 2);
/// for q in &out {
///     assert!((KinovaGen3::fk(q).pos - target.pos).norm() < 1e-5);
/// }
/// // Distinct: some joint differs by more than `min_separation`.
/// assert!((0..7).any(|j| (out[0][j] - out[1][j]).abs() > 0.1));
/// ```
pub fn ik_multi_start<M: Models<D>, const D: usize>(
    model: u8,
    target: &Frame,
    params: &IkParams,
    multi: &MultiStart,
    rng: &mut Rng,
    out: &mut [[f64; D]],
) -> Result<usize, IkError> {
    check_target(target)?;
    check_params(params)?;
    let mut found = 0;
    let mut last = IkError::NoConvergence {
        position: f64::INFINITY,
        orientation: f64::INFINITY,
    };
    for _ in 0..multi.attempts {
        if found == out.len() {
            break;
        }
        let seed = rng.configuration(M::lower(model), M::upper(model));
        match solve::<M, D>(model, target, &seed, params) {
            Ok(q) => {
                if out[..found]
                    .iter()
                    .all(|s| separation::<M, D>(model, s, &q) > multi.min_separation)
                {
                    out[found] = q;
                    found += 1;
                }
            }
            Err(e) => last = e,
        }
    }
    if found == 0 {
        Err(last)
    } else {
        Ok(found)
    }
}

/// Largest joint difference, continuous joints (no limits) taken modulo a full turn.
fn separation<M: Models<D>, const D: usize>(model: u8, a: &[f64; D], b: &[f64; D]) -> f64 {
    (0..D)
        .map(|i| {
            let d = (a[i] - b[i]).abs();
            if M::lower(model)[i].is_finite() || M::upper(model)[i].is_finite() {
                d
            } else {
                let d = d % (2.0 * PI);
                d.min(2.0 * PI - d)
            }
        })
        .fold(0.0, f64::max)
}
