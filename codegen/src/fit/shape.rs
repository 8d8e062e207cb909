//! The shape the fit makes: a capsule, with the measures the fit compares (volume, distance
//! to its axis). A leaf: fitting and scoring both use it.

use std::f64::consts::PI;

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Points within `radius` of the segment `a`-`b` (a sphere when `a == b`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    pub a: V3,
    pub b: V3,
    pub radius: f64,
}

impl Capsule {
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }

    pub fn volume(&self) -> f64 {
        PI * self.radius * self.radius * (self.length() + 4.0 / 3.0 * self.radius)
    }

    /// Distance from `p` to the segment `a`-`b`.
    pub fn axis_distance(&self, p: &V3) -> f64 {
        let ab = self.b - self.a;
        let len2 = ab.norm_squared();
        let t = if len2 > 0.0 {
            ((p - self.a).dot(&ab) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (p - (self.a + ab * t)).norm()
    }

    pub fn contains(&self, p: &V3) -> bool {
        self.axis_distance(p) <= self.radius
    }
}

pub fn total_volume(capsules: &[Capsule]) -> f64 {
    capsules.iter().map(Capsule::volume).sum()
}
