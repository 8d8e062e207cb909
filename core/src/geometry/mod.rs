//! Shapes and closed-form geometric queries (no heap, no iteration over meshes).
//!
//! Every query is a small function over shape types, in the spirit of parry: the caller
//! composes them. Shapes are given in world coordinates by a [`Frame`] pose.
//!
//! Intersection tests take a `margin` (>= 0): they report a hit when the shapes come closer
//! than `margin` or meet, so that a swept motion can be checked conservatively at a few
//! configurations.
//!
//! Every query is closed-form: a fixed number of flops, no iteration to convergence, no
//! memory. Lengths are in metres. The queries expect finite coordinates: the loaders and
//! planners refuse NaN and infinite input before any query runs.
//!
//! ```
//! use omcbsa_core::geometry::{Capsule, Obstacle, Segment, Shape};
//! use omcbsa_core::model::Frame;
//! use omcbsa_core::nalgebra::Vector3;
//!
//! // Two capsules of radius 0.1 whose axes cross 0.15 m apart: they overlap by 5 cm.
//! let a = Capsule::new(Vector3::new(-1.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0), 0.1);
//! let b = Capsule::new(Vector3::new(0.0, -1.0, 0.15), Vector3::new(0.0, 1.0, 0.15), 0.1);
//! assert!((a.signed_distance(&b) + 0.05).abs() < 1e-12);
//! assert!(a.hits(&b, 0.0));
//! let inside = a.witness(&b).unwrap();
//! assert!(a.contains_point(&inside) && b.contains_point(&inside));
//!
//! // The closest points of the two axes.
//! let (s, t) = a.segment.closest_params(&b.segment);
//! assert!((s - 0.5).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
//! let gap = Segment::new(a.segment.at(s), b.segment.at(t));
//! assert!(((gap.b - gap.a).norm() - 0.15).abs() < 1e-12);
//!
//! // A 20 cm cube on the floor, 0.3 m from the first capsule's axis.
//! let cube = Obstacle {
//!     shape: Shape::Box { half_extents: [0.1, 0.1, 0.1] },
//!     pose: Frame { pos: Vector3::new(0.0, 0.0, -0.4), ..Frame::IDENTITY },
//! };
//! assert!((cube.distance_to_capsule(&a) - 0.2).abs() < 1e-12);
//! assert!(!cube.hits_capsule(&a, 0.15) && cube.hits_capsule(&a, 0.25));
//! assert!(cube.aabb().contains_point(&Vector3::new(0.05, 0.0, -0.35)));
//! ```

mod aabb;
mod capsule;
pub mod lanes;
mod segment;
mod solid;

pub use aabb::Aabb;
pub use capsule::Capsule;
pub use segment::Segment;

/// How close two shapes come, against a margin: what a motion check needs to know at one
/// configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Contact {
    /// Farther apart than the margin.
    Clear,
    /// Within the margin, and not known to meet.
    Near,
    /// They meet: found at an actual pair of their points.
    Touch,
}

use nalgebra::Vector3;

use crate::model::Frame;
use solid::Want;

/// An obstacle shape, in its own frame (capsule and cylinder axes along local z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A box centred on the frame's origin, aligned with its axes.
    Box {
        /// Half of the box's size along x, y and z, metres.
        half_extents: [f64; 3],
    },
    /// A ball centred on the frame's origin.
    Sphere {
        /// Radius, metres.
        radius: f64,
    },
    /// The points within `radius` of the local z axis from `-half_length` to `half_length`.
    Capsule {
        /// Radius, metres.
        radius: f64,
        /// Half the axis' length, metres.
        half_length: f64,
    },
    /// A solid cylinder about the local z axis, flat ends at `z = ±half_length`.
    Cylinder {
        /// Radius, metres.
        radius: f64,
        /// Half the length, metres.
        half_length: f64,
    },
}

/// A shape placed in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obstacle {
    /// The shape, in its own frame.
    pub shape: Shape,
    /// Where the shape's frame is in the world.
    pub pose: Frame,
}

impl Obstacle {
    /// The smallest axis-aligned box around the obstacle.
    pub fn aabb(&self) -> Aabb {
        let rot = &self.pose.rot;
        let c = &self.pose.pos;
        match self.shape {
            Shape::Box { half_extents } => {
                Aabb::around(c, &(rot.abs() * Vector3::from(half_extents)))
            }
            Shape::Sphere { radius } => Aabb::around(c, &Vector3::repeat(radius)),
            Shape::Capsule {
                radius,
                half_length,
            } => Capsule {
                segment: self.axis(half_length),
                radius,
            }
            .aabb(),
            Shape::Cylinder {
                radius,
                half_length,
            } => {
                // A disc of radius r with unit normal n spans r * sqrt(1 - n_i^2) along axis i.
                let n = rot.column(2);
                let disc = n.map(|n_i| radius * libm::sqrt((1.0 - n_i * n_i).max(0.0)));
                Aabb::around(c, &(n.abs() * half_length + disc))
            }
        }
    }

    /// Whether `p` (world frame) lies in the obstacle, boundary included.
    pub fn contains_point(&self, p: &Vector3<f64>) -> bool {
        let local = self.local_point(p);
        match self.shape {
            Shape::Box { half_extents } => solid::box_contains(&half_extents.into(), &local),
            Shape::Sphere { radius } => local.norm_squared() <= radius * radius,
            Shape::Capsule {
                radius,
                half_length,
            } => self.axis(half_length).distance2_to_point(p) <= radius * radius,
            Shape::Cylinder {
                radius,
                half_length,
            } => solid::cylinder_contains(radius, half_length, &local),
        }
    }

    /// Distance between the obstacle and `capsule` (0 when they touch or overlap).
    pub fn distance_to_capsule(&self, capsule: &Capsule) -> f64 {
        let (d2, inflate) = self.distance2_to_segment(&capsule.segment, Want::Exact);
        (libm::sqrt(d2) - inflate - capsule.radius).max(0.0)
    }

    /// Whether the obstacle and `capsule` come closer than `margin` or meet.
    pub fn hits_capsule(&self, capsule: &Capsule, margin: f64) -> bool {
        self.capsule_contact(capsule, margin) != Contact::Clear
    }

    /// How close the obstacle and `capsule` come against `margin`, for the cost of
    /// [`Obstacle::hits_capsule`]: a distance below the threshold is always one evaluated at
    /// a point of the capsule's axis, so it tells a touch too.
    pub fn capsule_contact(&self, capsule: &Capsule, margin: f64) -> Contact {
        let reach = capsule.radius + margin;
        let want = match self.shape {
            // Solids: decide against the threshold without finding the exact distance.
            Shape::Box { .. } | Shape::Cylinder { .. } => Want::Below(reach * reach),
            Shape::Sphere { .. } | Shape::Capsule { .. } => Want::Exact,
        };
        let (d2, inflate) = self.distance2_to_segment(&capsule.segment, want);
        contact(d2, capsule.radius + inflate, margin)
    }

    /// Squared distance from `seg` to the obstacle's core (its axis for a capsule, its centre
    /// for a sphere, the solid itself otherwise), and the radius the core is inflated by.
    fn distance2_to_segment(&self, seg: &Segment, want: Want) -> (f64, f64) {
        match self.shape {
            Shape::Sphere { radius } => (seg.distance2_to_point(&self.pose.pos), radius),
            Shape::Capsule {
                radius,
                half_length,
            } => (seg.distance2_to_segment(&self.axis(half_length)), radius),
            Shape::Box { half_extents } => {
                let h = Vector3::from(half_extents);
                let local = self.local_segment(seg);
                (
                    solid::segment_distance2(&local, want, |p| solid::box_project(&h, p)),
                    0.0,
                )
            }
            Shape::Cylinder {
                radius,
                half_length,
            } => {
                let local = self.local_segment(seg);
                let project = |p: &Vector3<f64>| solid::cylinder_project(radius, half_length, p);
                (solid::segment_distance2(&local, want, project), 0.0)
            }
        }
    }

    /// The local z axis from `-half_length` to `half_length`, in the world.
    fn axis(&self, half_length: f64) -> Segment {
        let z = self.pose.rot.column(2) * half_length;
        Segment::new(self.pose.pos - z, self.pose.pos + z)
    }

    fn local_point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.pose.rot.tr_mul(&(p - self.pose.pos))
    }

    fn local_segment(&self, seg: &Segment) -> Segment {
        Segment::new(self.local_point(&seg.a), self.local_point(&seg.b))
    }
}

/// Whether cores at squared distance `d2`, inflated by `reach` in all, come closer than that
/// or meet (a bare segment meeting a solid is a hit).
#[inline]
fn within(d2: f64, reach: f64) -> bool {
    d2 < reach * reach || d2 == 0.0
}

/// [`Contact`] of cores at squared distance `d2` inflated by `reach` in all, against `margin`.
#[inline]
fn contact(d2: f64, reach: f64, margin: f64) -> Contact {
    if !within(d2, reach + margin) {
        Contact::Clear
    } else if within(d2, reach) {
        Contact::Touch
    } else {
        Contact::Near
    }
}
