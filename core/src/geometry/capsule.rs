//! Capsules in world coordinates: the collision volumes of links.

use nalgebra::Vector3;

use super::aabb::{self, Aabb};
use super::segment::Segment;
use super::Contact;

/// All points within `radius` of the segment `a`-`b` (a sphere when `a == b`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    /// The axis.
    pub segment: Segment,
    /// Radius, metres.
    pub radius: f64,
}

impl Capsule {
    /// The capsule of radius `radius` around the segment `a`-`b`.
    pub const fn new(a: Vector3<f64>, b: Vector3<f64>, radius: f64) -> Capsule {
        Capsule {
            segment: Segment::new(a, b),
            radius,
        }
    }

    /// The smallest axis-aligned box around the capsule.
    #[inline]
    pub fn aabb(&self) -> Aabb {
        let s = &self.segment;
        let r = Vector3::repeat(self.radius);
        Aabb {
            min: aabb::min3(&s.a, &s.b) - r,
            max: aabb::max3(&s.a, &s.b) + r,
        }
    }

    /// Signed distance between the surfaces: negative when the capsules overlap (then minus
    /// the depth of the overlap, which is exact for capsules).
    #[inline]
    pub fn signed_distance(&self, other: &Capsule) -> f64 {
        // One sum of radii, so that the answer is the same whichever capsule asks.
        libm::sqrt(self.segment.distance2_to_segment(&other.segment)) - (self.radius + other.radius)
    }

    /// Whether the capsules come closer than `margin` or meet.
    #[inline]
    pub fn hits(&self, other: &Capsule, margin: f64) -> bool {
        self.contact(other, margin) != Contact::Clear
    }

    /// How close the capsules come against `margin`, for the cost of [`Capsule::hits`].
    #[inline]
    pub fn contact(&self, other: &Capsule, margin: f64) -> Contact {
        let d2 = self.segment.distance2_to_segment(&other.segment);
        super::contact(d2, self.radius + other.radius, margin)
    }

    /// Whether `p` lies in the capsule, boundary included.
    #[inline]
    pub fn contains_point(&self, p: &Vector3<f64>) -> bool {
        self.segment.distance2_to_point(p) <= self.radius * self.radius
    }

    /// A point inside both capsules, if they overlap: on the shortest segment between the two
    /// axes, split in the ratio of the radii so that it is within each radius.
    pub fn witness(&self, other: &Capsule) -> Option<Vector3<f64>> {
        let (s, t) = self.segment.closest_params(&other.segment);
        let (p, q) = (self.segment.at(s), other.segment.at(t));
        let reach = self.radius + other.radius;
        if (q - p).norm_squared() >= reach * reach {
            return None;
        }
        Some(p + (q - p) * (self.radius / reach))
    }
}
