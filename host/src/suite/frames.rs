//! Small constructors for world frames used by the layouts and motion families.

use omcbsa_core::model::Frame;
use omcbsa_core::nalgebra::{Matrix3, Rotation3, Unit, Vector3};

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

/// Rotation by `angle` about the unit vector `axis`.
pub fn rot(axis: V3, angle: f64) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle).into_inner()
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
    v3(a.cos(), a.sin(), 0.0)
}

/// `0 -> 0`, `1 -> 1`, with zero speed at both ends: how a policy starts and stops a motion.
pub fn ease(s: f64) -> f64 {
    0.5 - 0.5 * (std::f64::consts::PI * s).cos()
}
