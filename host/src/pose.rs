//! Poses at the file boundary: `{"position", "quat_xyzw"}` to and from the core's [`Frame`].

use omcbsa_core::model::Frame;
use omcbsa_core::nalgebra::{Quaternion, Rotation3, UnitQuaternion, Vector3};

use crate::error::FieldError;
use crate::format::Pose;

/// How far a quaternion's norm may be from 1 (the spec's rule; nothing is normalised beyond
/// this).
pub const QUAT_NORM_TOLERANCE: f64 = 1e-6;

/// Checks a pose (finite numbers, unit quaternion) and converts it. Error paths are relative
/// to the pose (`quat_xyzw`, `position[2]`).
///
/// ```
/// use omcbsa::format::Pose;
/// use omcbsa::pose::{from_frame, to_frame};
///
/// // Half a turn about x: the tool's z axis points down.
/// let down = Pose { position: [0.5, 0.0, 0.4], quat_xyzw: [1.0, 0.0, 0.0, 0.0] };
/// let frame = to_frame(&down).unwrap();
/// assert!((frame.rot[(2, 2)] + 1.0).abs() < 1e-12);
/// assert_eq!(from_frame(&frame), down);
///
/// // A quaternion that is not a unit one is refused, not normalised.
/// let err = to_frame(&Pose { quat_xyzw: [1.0, 0.0, 0.0, 0.1], ..down }).unwrap_err();
/// assert_eq!(err.path, "quat_xyzw");
/// let err = to_frame(&Pose { position: [0.5, f64::NAN, 0.4], ..down }).unwrap_err();
/// assert_eq!(err.path, "position[1]");
/// ```
pub fn to_frame(pose: &Pose) -> Result<Frame, FieldError> {
    finite(&pose.position).map_err(|e| e.within("position"))?;
    finite(&pose.quat_xyzw).map_err(|e| e.within("quat_xyzw"))?;
    let [x, y, z, w] = pose.quat_xyzw;
    let norm = (x * x + y * y + z * z + w * w).sqrt();
    if (norm - 1.0).abs() > QUAT_NORM_TOLERANCE {
        return Err(FieldError::new(
            "quat_xyzw",
            format!("norm {} is more than 1e-6 away from 1", short(norm)),
        ));
    }
    // Within the tolerance, normalising only removes rounding so the matrix is orthonormal.
    let q = UnitQuaternion::new_normalize(Quaternion::new(w, x, y, z));
    Ok(Frame {
        rot: q.to_rotation_matrix().into_inner(),
        pos: Vector3::from(pose.position),
    })
}

/// The pose of a frame, with `w >= 0` so that a rotation always prints as one quaternion.
pub fn from_frame(frame: &Frame) -> Pose {
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(frame.rot));
    let q = if q.w < 0.0 {
        -q.into_inner()
    } else {
        q.into_inner()
    };
    Pose {
        position: frame.pos.into(),
        quat_xyzw: [q.i, q.j, q.k, q.w],
    }
}

/// Fails on the first NaN or infinite value, naming its index (`[2]`).
pub fn finite(values: &[f64]) -> Result<(), FieldError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(FieldError::new(
            format!("[{i}]"),
            format!("{} is not a finite number", values[i]),
        )),
    }
}

/// A number for a message: at most 9 decimals, without trailing zeros.
pub fn short(x: f64) -> String {
    // Beyond a million, nine decimals say nothing: the exponent form (1e308) is short.
    if x.abs() >= 1e6 {
        return format!("{x:e}");
    }
    let s = format!("{x:.9}");
    let s = s.trim_end_matches('0');
    s.strip_suffix('.').unwrap_or(s).to_string()
}
