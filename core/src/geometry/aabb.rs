//! Axis-aligned bounding boxes: the cheap first test before an exact query.

use nalgebra::Vector3;

/// The box `min..=max` in world axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The least corner, metres.
    pub min: Vector3<f64>,
    /// The greatest corner, metres.
    pub max: Vector3<f64>,
}

impl Aabb {
    /// Contains nothing; the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vector3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY),
        max: Vector3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY),
    };

    /// The box of all points within `r` of `c` along each axis.
    #[inline]
    pub fn around(c: &Vector3<f64>, r: &Vector3<f64>) -> Aabb {
        Aabb {
            min: c - r,
            max: c + r,
        }
    }

    /// The smallest box around both.
    #[inline]
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb {
            min: min3(&self.min, &other.min),
            max: max3(&self.max, &other.max),
        }
    }

    /// Whether the boxes come closer than `margin` along every axis (a necessary condition
    /// for any two shapes inside them to come closer than `margin`).
    #[inline]
    pub fn near(&self, other: &Aabb, margin: f64) -> bool {
        (0..3).all(|i| self.min[i] < other.max[i] + margin && other.min[i] < self.max[i] + margin)
    }

    /// Distance between the boxes (0 when they overlap): a lower bound on the distance
    /// between any two shapes inside them.
    #[inline]
    pub fn distance(&self, other: &Aabb) -> f64 {
        libm::sqrt(self.distance2(other))
    }

    /// [`Aabb::distance`] squared.
    #[inline]
    pub fn distance2(&self, other: &Aabb) -> f64 {
        let gap = |i: usize| {
            (other.min[i] - self.max[i])
                .max(self.min[i] - other.max[i])
                .max(0.0)
        };
        let (x, y, z) = (gap(0), gap(1), gap(2));
        x * x + y * y + z * z
    }

    /// Whether the distances between `a[0]` and `b[0]` and between `a[1]` and `b[1]` add up
    /// to more than `limit`: as that sum, computed with two roots only where the sum is at
    /// least the root of the squares' sum does not already tell (most boxes far apart).
    #[inline]
    pub fn apart_over(a: [&Aabb; 2], b: [&Aabb; 2], limit: f64) -> bool {
        let (d0, d1) = (a[0].distance2(b[0]), a[1].distance2(b[1]));
        d0 + d1 > limit * limit || libm::sqrt(d0) + libm::sqrt(d1) > limit
    }

    /// Whether `p` lies in the box, boundary included.
    #[inline]
    pub fn contains_point(&self, p: &Vector3<f64>) -> bool {
        (0..3).all(|i| self.min[i] <= p[i] && p[i] <= self.max[i])
    }
}

// Component-wise, written out: nalgebra's generic `inf`/`sup` cost several times more here,
// and plain comparisons (one instruction each) less than `f64::min`'s NaN handling. A NaN
// input gives a NaN box, which is near nothing and contains nothing; every query on a
// configuration with a NaN was refused long before.
#[inline]
pub(super) fn min3(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let m = |x: f64, y: f64| if x < y { x } else { y };
    Vector3::new(m(a.x, b.x), m(a.y, b.y), m(a.z, b.z))
}

#[inline]
pub(super) fn max3(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let m = |x: f64, y: f64| if x > y { x } else { y };
    Vector3::new(m(a.x, b.x), m(a.y, b.y), m(a.z, b.z))
}
