//! Small constructors for world frames used by the layouts and motion families. Sines and
//! cosines come from `libm` (see [`sin`]), so that the suite is the same on every platform.

use omcbsa_core::model::Frame;
use omcbsa_core::nalgebra::{Matrix3, Vector3};

pub type V3 = Vector3<f64>;

pub fn v3(x: f64, y: f64, z: f64) -> V3 {
    Vector3::new(x, y, z)
}

pub fn at(pos: V3) -> Frame {
    Frame {
        rot: Matrix3::identity(),
        pos,
    }
}

/// The sine, the same bits on every platform: `libm`'s, not the C library's behind `f64::sin`
/// (nor nalgebra's, which is either, by the features a build enables).
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

/// The cosine, as [`sin`].
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}

/// The angle of `(x, y)` from the x axis, as [`sin`].
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// Rotation by `angle` about `axis` (any length but 0): Rodrigues' formula.
pub fn rot(axis: V3, angle: f64) -> Matrix3<f64> {
    let k = axis.normalize();
    let (s, c) = (sin(angle), cos(angle));
    let cross = Matrix3::new(0.0, -k.z, k.y, k.z, 0.0, -k.x, -k.y, k.x, 0.0);
    Matrix3::identity() * c + cross * s + k * k.transpose() * (1.0 - c)
}

/// Rotation about world z.
pub fn yaw(angle: f64) -> Matrix3<f64> {
    rot(Vector3::z(), angle)
}

/// The frame at `pos` whose z axis is `z` and whose x axis is `x_hint` made orthogonal to it
/// (`x_hint` must not be parallel to `z`).
pub fn aligned(pos: V3, z: V3, x_hint: V3) -> Frame {
    let z = z.normalize();
    let x = (x_hint - z * x_hint.dot(&z)).normalize();
    let y = z.cross(&x);
    Frame {
        rot: Matrix3::from_columns(&[x, y, z]),
        pos,
    }
}

/// A horizontal unit vector at angle `a` from world x.
pub fn heading(a: f64) -> V3 {
    v3(cos(a), sin(a), 0.0)
}

/// `0 -> 0`, `1 -> 1`, with zero speed at both ends: how a policy starts and stops a motion.
pub fn ease(s: f64) -> f64 {
    0.5 - 0.5 * cos(std::f64::consts::PI * s)
}
