//! Pose errors (the rotation log map), the null space of a model's Jacobian, and how fast the
//! joints must turn for the tool to move with a given twist.
//!
//! Both work in the model's base frame, with the Jacobian's row order: position first,
//! rotation second. Neither allocates; the null-space basis costs one 6 x D elimination.
//!
//! A 7-joint arm away from singularities has a one-dimensional null space: moving along it
//! turns the joints without moving the hand (to first order), which is what Ω-A* explores.
//!
//! ```
//! use omcbsa_core::kinematics::{null_space_basis, pose_error};
//! use omcbsa_core::model::{KinovaGen3, Model};
//!
//! let q = [0.1, 0.5, -0.2, 1.2, 0.0, 0.8, 0.3];
//! let (hand, jacobian) = KinovaGen3::jacobian(&q);
//! let basis = null_space_basis(&jacobian);
//! assert_eq!(basis.len(), 1);
//! let n = basis[0];
//! assert!((n.norm() - 1.0).abs() < 1e-12);
//! assert!((jacobian * n).norm() < 1e-9);
//!
//! // A small step along it leaves the hand where it was, to second order.
//! let moved: [f64; 7] = core::array::from_fn(|i| q[i] + 1e-3 * n[i]);
//! let err = pose_error(&KinovaGen3::fk(&moved), &hand);
//! assert!(err.norm() < 1e-5);
//! ```

use heapless::Vec;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3, Vector6};

use crate::model::Frame;

/// The twist that takes `current` to `target`, in the base frame: rows 0-2 the position
/// difference `target - current`, rows 3-5 the rotation vector `log(target.rot *
/// current.rot^T)` (axis times angle, angle in `[0, pi]`). A Jacobian step `J dq = e` moves
/// `current` towards `target`.
///
/// ```
/// use omcbsa_core::kinematics::pose_error;
/// use omcbsa_core::model::Frame;
/// use omcbsa_core::nalgebra::{Rotation3, Vector3};
///
/// let target = Frame {
///     rot: Rotation3::from_axis_angle(&Vector3::z_axis(), 0.5).into_inner(),
///     pos: Vector3::new(0.1, 0.0, 0.0),
/// };
/// let e = pose_error(&Frame::IDENTITY, &target);
/// assert!((e[0] - 0.1).abs() < 1e-15);
/// // Rows 3-5: the rotation vector, 0.5 rad about z.
/// assert!((e[5] - 0.5).abs() < 1e-15 && e[3].abs() < 1e-15 && e[4].abs() < 1e-15);
/// ```
pub fn pose_error(current: &Frame, target: &Frame) -> Vector6<f64> {
    let dp = target.pos - current.pos;
    let w = log_rotation(&(target.rot * current.rot.transpose()));
    Vector6::new(dp.x, dp.y, dp.z, w.x, w.y, w.z)
}

/// The angle of the rotation taking `a` to `b`, in `[0, pi]`.
pub fn orientation_angle(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    angle_parts(&(b * a.transpose())).0
}

/// `(angle, v)` of a rotation `r`, where `v = vee(r - r^T) / 2 = sin(angle) * axis`. The
/// angle comes from `atan2`, accurate over the whole range (unlike `acos` of the trace).
fn angle_parts(r: &Matrix3<f64>) -> (f64, Vector3<f64>) {
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    ) * 0.5;
    let cos = (r.trace() - 1.0) * 0.5;
    (libm::atan2(v.norm(), cos), v)
}

/// The rotation vector of `r`. Near angle 0, `v * angle / sin(angle)`; beyond pi/2, where
/// `sin` loses the axis, the axis comes from the symmetric part `(r + r^T)/2 = cos I + (1 -
/// cos) a a^T` and only its sign from `v`.
fn log_rotation(r: &Matrix3<f64>) -> Vector3<f64> {
    let (angle, v) = angle_parts(r);
    let sin = v.norm();
    let cos = (r.trace() - 1.0) * 0.5;
    if cos > 0.0 {
        return if sin > 0.0 { v * (angle / sin) } else { v };
    }
    // cos <= 0, so 1 - cos >= 1: a a^T is well defined.
    let aat = ((r + r.transpose()) * 0.5 - Matrix3::identity() * cos) / (1.0 - cos);
    let i = (0..3).fold(0, |best, k| {
        if aat[(k, k)] > aat[(best, best)] {
            k
        } else {
            best
        }
    });
    let mut axis = aat.column(i) / libm::sqrt(aat[(i, i)].max(0.0));
    axis /= axis.norm();
    if axis.dot(&v) < 0.0 {
        axis = -axis;
    }
    axis * angle
}

/// Pivots smaller than this times the largest entry of the Jacobian count as zero.
pub const RANK_TOLERANCE: f64 = 1e-9;

/// An orthonormal basis of the null space of a `6 x D` Jacobian: `D - 6` unit vectors when
/// `J` has full row rank (one for the 7-joint Gen3), none when `D <= 6`, and none when `J`
/// is rank-deficient (a singular configuration, judged by [`RANK_TOLERANCE`]) or not finite.
///
/// Gaussian elimination with complete pivoting, back substitution for each free variable,
/// Gram-Schmidt across the results: exact up to rounding, no SVD, no heap. Each vector's
/// sign is fixed (its first component of magnitude above `1e-12` is positive) so that
/// callers iterate over the same directions whatever the pivoting did.
pub fn null_space_basis<const D: usize>(jacobian: &SMatrix<f64, 6, D>) -> Vec<SVector<f64, D>, D> {
    let mut basis = Vec::new();
    if D <= 6 || jacobian.iter().any(|x| !x.is_finite()) {
        return basis;
    }
    let mut a: [[f64; D]; 6] = core::array::from_fn(|i| core::array::from_fn(|j| jacobian[(i, j)]));
    // perm[j]: the Jacobian column now in column j
    let mut perm: [usize; D] = core::array::from_fn(|j| j);
    let scale = jacobian.amax();
    for k in 0..6 {
        let (mut pi, mut pj) = (k, k);
        for (i, row) in a.iter().enumerate().skip(k) {
            for (j, x) in row.iter().enumerate().skip(k) {
                if x.abs() > a[pi][pj].abs() {
                    (pi, pj) = (i, j);
                }
            }
        }
        if a[pi][pj].abs() <= RANK_TOLERANCE * scale {
            return basis;
        }
        a.swap(k, pi);
        for row in a.iter_mut() {
            row.swap(k, pj);
        }
        perm.swap(k, pj);
        let pivot_row = a[k];
        for row in a.iter_mut().skip(k + 1) {
            let f = row[k] / pivot_row[k];
            for (x, p) in row.iter_mut().zip(pivot_row.iter()).skip(k) {
                *x -= f * p;
            }
        }
    }
    for free in 6..D {
        // x[free] = 1, the other free variables 0, pivot variables by back substitution
        let mut x = [0.0; D];
        x[free] = 1.0;
        for k in (0..6).rev() {
            let s: f64 = (k + 1..D).map(|j| a[k][j] * x[j]).sum();
            x[k] = -s / a[k][k];
        }
        let mut n = SVector::<f64, D>::zeros();
        for (j, &col) in perm.iter().enumerate() {
            n[col] = x[j];
        }
        for b in basis.iter() {
            n -= b * b.dot(&n);
        }
        n /= n.norm();
        if n.iter().find(|x| x.abs() > 1e-12).is_some_and(|&x| x < 0.0) {
            n = -n;
        }
        // at most D - 6 < D vectors
        let _ = basis.push(n);
    }
    basis
}

/// How far the arm is from two of its joint axes lying on one line: the least distance,
/// up to sign, between two columns of the Jacobian (metres for the linear rows, radians for
/// the angular ones). Two collinear axes give equal columns: the two joints then only turn
/// against each other, and the hand moving past such a configuration needs one of them to
/// spin (for a redundant arm this is where following the hand within the joints' speeds
/// becomes impossible although the Jacobian keeps full rank). `f64::INFINITY` for fewer
/// than two joints.
pub fn axis_separation<const D: usize>(jacobian: &SMatrix<f64, 6, D>) -> f64 {
    let mut least = f64::INFINITY;
    for a in 0..D {
        for b in a + 1..D {
            let (ca, cb) = (jacobian.column(a), jacobian.column(b));
            least = least.min((ca - cb).norm()).min((ca + cb).norm());
        }
    }
    least
}

/// The tool's twist moving from `a` to `b` in `dt` seconds, as [`pose_error`] over `dt`:
/// rows 0-2 metres per second, rows 3-5 radians per second, in the frame both poses are in.
pub fn twist(a: &Frame, b: &Frame, dt: f64) -> Vector6<f64> {
    pose_error(a, b) / dt
}

/// How close to their speed limits the joints must turn for the tool to move with `twist`
/// (as [`twist`] gives it, in the base frame) at the configuration whose Jacobian is `jac`:
/// the fastest joint's share of its limit `vmax[j]`, with the arm's motion along its null
/// space chosen to make that share least (exactly, for one null-space direction: 7 joints for
/// 6 task dimensions; with more, only the first direction is used). Above 1, no joint motion
/// follows the twist within the limits; `f64::INFINITY` at a singular Jacobian. About 1 µs;
/// [`SpeedMap`] answers several twists at one configuration for less.
pub fn speed_ratio<const D: usize>(
    jac: &SMatrix<f64, 6, D>,
    twist: &Vector6<f64>,
    vmax: &[f64; D],
) -> f64 {
    SpeedMap::new(jac, vmax).map_or(f64::INFINITY, |m| m.ratio(twist))
}

/// One configuration's map from tool twists to joint speeds ([`speed_ratio`] for several
/// twists): the least-norm solution's matrix and the null-space direction, made once (a 6x6
/// Cholesky factorisation and the null space), then about 200 flops a twist.
pub struct SpeedMap<const D: usize> {
    /// `J^T (J J^T)^-1`, each row over its joint's limit.
    pinv: SMatrix<f64, D, 6>,
    /// The null-space direction, over the limits (zero without one).
    n: SVector<f64, D>,
}

impl<const D: usize> SpeedMap<D> {
    /// The map at the configuration whose Jacobian is `jac`, for joint speed limits `vmax`;
    /// `None` at a singular Jacobian.
    pub fn new(jac: &SMatrix<f64, 6, D>, vmax: &[f64; D]) -> Option<Self> {
        let chol = (jac * jac.transpose()).cholesky()?;
        let mut pinv = jac.transpose() * chol.inverse();
        let mut n = null_space_basis::<D>(jac)
            .first()
            .copied()
            .unwrap_or_else(SVector::zeros);
        for (j, v) in vmax.iter().enumerate() {
            pinv.row_mut(j).scale_mut(1.0 / v);
            n[j] /= v;
        }
        Some(SpeedMap { pinv, n })
    }

    /// [`speed_ratio`] of `twist` here.
    pub fn ratio(&self, twist: &Vector6<f64>) -> f64 {
        // The least-norm joint velocity as shares of the limits; the null space adds `n z`.
        let p: SVector<f64, D> = self.pinv * twist;
        let n = &self.n;
        // min over z of max_j |p_j + n_j z|: each term is `|n_j| |z - z_j|`, so the least
        // value is where the intervals `{z : |p_j + n_j z| <= r}` first all meet, and on a
        // line intervals meet when every two do (Helly): the largest over pairs of the two's
        // own least value, `|p_k n_i - p_i n_k| / (|n_i| + |n_k|)`, and `|p_j|` where
        // `n_j = 0`.
        let mut best = 0.0f64;
        for i in 0..D {
            if n[i] == 0.0 {
                best = best.max(libm::fabs(p[i]));
            }
            for k in i + 1..D {
                let w = libm::fabs(n[i]) + libm::fabs(n[k]);
                if w > 0.0 {
                    best = best.max(libm::fabs(p[k] * n[i] - p[i] * n[k]) / w);
                }
            }
        }
        if best.is_finite() {
            best
        } else {
            f64::INFINITY
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn frame(axis: Vector3<f64>, angle: f64) -> Frame {
        let rot = Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle).into_inner();
        Frame {
            rot,
            pos: Vector3::new(0.1, -0.2, 0.3),
        }
    }

    #[test]
    fn log_map_recovers_axis_angle_across_the_range() {
        let axis = Vector3::new(0.3, -0.5, 0.8).normalize();
        for angle in [
            0.0,
            1e-12,
            1e-6,
            0.5,
            1.5,
            2.5,
            core::f64::consts::PI - 1e-5,
            core::f64::consts::PI - 1e-10,
        ] {
            let e = pose_error(&Frame::IDENTITY, &frame(axis, angle));
            let w = Vector3::new(e[3], e[4], e[5]);
            assert!((w - axis * angle).norm() < 1e-12, "angle {angle}: {w:?}");
            assert!((Vector3::new(e[0], e[1], e[2]) - Vector3::new(0.1, -0.2, 0.3)).norm() < 1e-15);
        }
    }

    #[test]
    fn log_map_at_pi_gives_a_rotation_by_pi_about_the_axis() {
        let axis = Vector3::new(1.0, 2.0, -2.0) / 3.0;
        let e = pose_error(&Frame::IDENTITY, &frame(axis, core::f64::consts::PI));
        let w = Vector3::new(e[3], e[4], e[5]);
        assert!((w.norm() - core::f64::consts::PI).abs() < 1e-12);
        assert!(w.normalize().cross(&axis).norm() < 1e-12);
    }

    #[test]
    fn error_is_relative_and_in_the_base_frame() {
        let current = frame(Vector3::new(0.0, 0.0, 1.0), 0.7);
        let delta = Rotation3::from_axis_angle(&Vector3::x_axis(), 0.2).into_inner();
        let target = Frame {
            rot: delta * current.rot,
            pos: current.pos,
        };
        let e = pose_error(&current, &target);
        assert!((Vector6::new(0.0, 0.0, 0.0, 0.2, 0.0, 0.0) - e).norm() < 1e-14);
        assert!((orientation_angle(&current.rot, &target.rot) - 0.2).abs() < 1e-14);
    }

    #[test]
    fn null_space_of_a_known_matrix() {
        // Columns 0..5 the identity, column 6 = (1, 2, 0, 0, 0, 0): null vector (1, 2, 0..0, -1).
        let mut j = SMatrix::<f64, 6, 7>::zeros();
        for i in 0..6 {
            j[(i, i)] = 1.0;
        }
        j[(0, 6)] = 1.0;
        j[(1, 6)] = 2.0;
        let basis = null_space_basis(&j);
        assert_eq!(basis.len(), 1);
        let expected = SVector::<f64, 7>::from([1.0, 2.0, 0.0, 0.0, 0.0, 0.0, -1.0]) / 6f64.sqrt();
        assert!((basis[0] - expected).norm() < 1e-15);
    }

    /// A dense matrix of full rank.
    fn dense<const D: usize>() -> SMatrix<f64, 6, D> {
        SMatrix::from_fn(|i, k| libm::sin(((i + 1) * (k + 3)) as f64 * 0.7 + (i * i) as f64))
    }

    #[test]
    fn null_space_of_a_wide_matrix_is_orthonormal() {
        let j = dense::<9>();
        let basis = null_space_basis(&j);
        assert_eq!(basis.len(), 3);
        for (a, x) in basis.iter().enumerate() {
            assert!((j * x).norm() < 1e-12);
            for (b, y) in basis.iter().enumerate() {
                let expected = if a == b { 1.0 } else { 0.0 };
                assert!((x.dot(y) - expected).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn rank_deficient_or_square_jacobians_have_no_basis() {
        let mut j = dense::<7>();
        assert_eq!(null_space_basis(&j).len(), 1);
        let row = j.row(0).into_owned();
        j.set_row(5, &(row * 2.0));
        assert!(null_space_basis(&j).is_empty());
        assert!(null_space_basis(&SMatrix::<f64, 6, 6>::identity()).is_empty());
        j[(0, 0)] = f64::NAN;
        assert!(null_space_basis(&j).is_empty());
    }

    #[test]
    fn collinear_axes_have_no_separation() {
        use crate::model::{KinovaGen3, Model};
        // The Gen3's shoulder straight up: joints 1 and 3 turn about vertical lines 12 mm
        // apart (the links' offsets).
        let mut q = [0.3, 0.0, 1.1, -2.2, 0.6, 0.4, 2.5];
        let (_, jac) = KinovaGen3::jacobian(&q);
        assert!(axis_separation(&jac) < 0.02, "{}", axis_separation(&jac));
        // Tilted, the two columns part; more tilt, more separation (until another pair is
        // the nearest).
        let mut last = 0.0;
        for tilt in [0.1, 0.2, 0.3] {
            q[1] = -tilt;
            let (_, jac) = KinovaGen3::jacobian(&q);
            let s = axis_separation(&jac);
            assert!(s > last, "tilt {tilt}: {s} after {last}");
            last = s;
        }
        assert_eq!(
            axis_separation(&SMatrix::<f64, 6, 1>::zeros()),
            f64::INFINITY
        );
    }
}
