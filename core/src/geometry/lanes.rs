//! [`Segment::distance2_to_segment`] and [`Capsule::hits`] for [`crate::lanes::LANES`] pairs at once, a
//! pair per lane: every branch of the scalar code computed in every lane and the lane's own
//! taken by selection, each with the scalar code's operations in its order (nalgebra's dot
//! products and norms left to right), so that each lane is, bit for bit, the scalar answer
//! (`core/tests/batch.rs`).
//!
//! [`Segment::distance2_to_segment`]: super::Segment::distance2_to_segment
//! [`Capsule::hits`]: super::Capsule::hits

use crate::lanes::{F64s, Mask};

use super::{Obstacle, Shape};

use super::segment::PARALLEL_SIN2;

/// Three coordinates, a lane each.
pub type Point = [F64s; 3];

/// A segment per lane, from `a` to `b`.
#[derive(Clone, Copy, Debug)]
pub struct Segments {
    /// The first end.
    pub a: Point,
    /// The second end.
    pub b: Point,
}

#[inline(always)]
fn sub(u: &Point, v: &Point) -> Point {
    [u[0] - v[0], u[1] - v[1], u[2] - v[2]]
}

/// nalgebra's `dot` of three: `x + y + z` of the products, left to right.
#[inline(always)]
fn dot(u: &Point, v: &Point) -> F64s {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

#[inline(always)]
fn splat(v: f64) -> F64s {
    F64s::splat(v)
}

/// `f64::clamp(x, 0.0, 1.0)` (NaN stays NaN).
#[inline(always)]
fn clamp01(x: F64s) -> F64s {
    let x = x.simd_lt(splat(0.0)).select(splat(0.0), x);
    x.simd_gt(splat(1.0)).select(splat(1.0), x)
}

/// `param_toward(d, v)` of `segment.rs`: `clamp01(d.v / d.d)`, 0 for `d == 0`.
#[inline(always)]
fn param_toward(d: &Point, v: &Point) -> F64s {
    let l = dot(d, d);
    l.simd_eq(splat(0.0))
        .select(splat(0.0), clamp01(dot(d, v) / l))
}

/// `select(m, x, y)` of points.
#[inline(always)]
fn select(m: F64s, x: &Point, y: &Point) -> Point {
    [
        m.select(x[0], y[0]),
        m.select(x[1], y[1]),
        m.select(x[2], y[2]),
    ]
}

impl Segments {
    /// `Segment::at`.
    #[inline(always)]
    fn at(&self, t: F64s) -> Point {
        let d = sub(&self.b, &self.a);
        [
            self.a[0] + d[0] * t,
            self.a[1] + d[1] * t,
            self.a[2] + d[2] * t,
        ]
    }

    /// `Segment::closest_params`.
    #[inline(always)]
    fn closest_params(&self, other: &Segments) -> (F64s, F64s) {
        let zero = splat(0.0);
        let d1 = sub(&self.b, &self.a);
        let d2 = sub(&other.b, &other.a);
        let r = sub(&self.a, &other.a);
        let l1 = dot(&d1, &d1);
        let l2 = dot(&d2, &d2);
        let c = dot(&d1, &d2);
        let e1 = dot(&d1, &r);
        let e2 = dot(&d2, &r);
        let det = l1 * l2 - c * c;
        let free = det.simd_gt(splat(PARALLEL_SIN2) * l1 * l2);
        let s = free.select(clamp01((c * e2 - l2 * e1) / det), zero);
        let t = (c * s + e2) / l2;
        let (below, above) = (t.simd_lt(zero), t.simd_gt(splat(1.0)));
        let s = below.select(clamp01(-e1 / l1), above.select(clamp01((c - e1) / l1), s));
        let t = below.select(zero, above.select(splat(1.0), t));
        // A point-like segment first, as the scalar code returns early for it.
        let minus_r = [-r[0], -r[1], -r[2]];
        let point2 = l2.simd_eq(zero);
        let (s, t) = (
            point2.select(param_toward(&d1, &minus_r), s),
            point2.select(zero, t),
        );
        let point1 = l1.simd_eq(zero);
        (
            point1.select(zero, s),
            point1.select(param_toward(&d2, &r), t),
        )
    }

    /// `Segment::distance2_to_segment` per lane: the pair in one order first (the same order
    /// as the scalar code's, by the same lexicographic key).
    #[inline(always)]
    pub fn distance2(&self, other: &Segments) -> F64s {
        // `key(other) < key(self)` over [a.x, a.y, a.z, b.x, b.y, b.z]: the first pair of
        // coordinates that are not equal (NaN is not) decides, by `<`.
        let keys = |s: &Segments| [s.a[0], s.a[1], s.a[2], s.b[0], s.b[1], s.b[2]];
        let (k_other, k_self) = (keys(other), keys(self));
        let mut less = splat(0.0).simd_ne(splat(0.0));
        let mut decided = less;
        for i in 0..6 {
            let differ = k_other[i].simd_ne(k_self[i]);
            less |= !decided & differ & k_other[i].simd_lt(k_self[i]);
            decided |= differ;
        }
        let first = Segments {
            a: select(less, &other.a, &self.a),
            b: select(less, &other.b, &self.b),
        };
        let second = Segments {
            a: select(less, &self.a, &other.a),
            b: select(less, &self.b, &other.b),
        };
        let (s, t) = first.closest_params(&second);
        let d = sub(&first.at(s), &second.at(t));
        // nalgebra's `norm_squared`: 0 plus the dot product.
        splat(0.0) + dot(&d, &d)
    }

    /// The lanes where capsules on these segments, of radii adding up to `reach`, come
    /// closer than `margin` or meet: [`super::Capsule::hits`] per lane.
    #[inline(always)]
    pub fn hits(&self, other: &Segments, reach: f64, margin: f64) -> Mask {
        let d2 = self.distance2(other);
        // `within(d2, reach + margin)` of `geometry`.
        let r = splat(reach + margin);
        let within = d2.simd_lt(r * r) | d2.simd_eq(splat(0.0));
        within.to_bitmask() as Mask
    }
}

/// Relative and absolute slack (metres) of [`Segments::apart_from`] over the rounding of the
/// exact query it stands in front of: far more than that query's error, far less than a
/// distance that matters.
const APART_REL: f64 = 1e-9;
const APART_ABS: f64 = 1e-9;

/// `rot^T (p - c)` of `o`'s pose, as `Obstacle::local_point` computes it: the point in the
/// obstacle's frame.
#[inline(always)]
fn local(o: &Obstacle, p: &Point) -> Point {
    let (r, c) = (&o.pose.rot, &o.pose.pos);
    let d = [p[0] - splat(c[0]), p[1] - splat(c[1]), p[2] - splat(c[2])];
    core::array::from_fn(|j| {
        d[0] * splat(r[(0, j)]) + d[1] * splat(r[(1, j)]) + d[2] * splat(r[(2, j)])
    })
}

/// `within(d2, reach)` of `geometry`: cores `d2` apart squared, inflated by `reach` in all,
/// come closer than that or meet.
#[inline(always)]
fn within(d2: F64s, reach: f64) -> Mask {
    let r = splat(reach);
    (d2.simd_lt(r * r) | d2.simd_eq(splat(0.0))).to_bitmask() as Mask
}

impl Segments {
    /// The lanes where capsules on these segments, of radius and margin adding up to `reach`,
    /// certainly keep farther than that from the solid obstacle `o` (a box or a cylinder;
    /// none for another shape): in the obstacle's frame, both ends lie beyond one face of the
    /// box around the solid by more than `reach`, with room to spare for rounding. A cheap
    /// test ahead of [`Obstacle::hits_capsule`], whose exact query is an iteration: no lane
    /// it clears is a hit there (NaN is never apart).
    #[inline(always)]
    pub fn apart_from(&self, o: &Obstacle, reach: f64) -> Mask {
        let half = match o.shape {
            Shape::Box { half_extents } => half_extents,
            Shape::Cylinder {
                radius,
                half_length,
            } => [radius, radius, half_length],
            Shape::Sphere { .. } | Shape::Capsule { .. } => return 0,
        };
        let (a, b) = (local(o, &self.a), local(o, &self.b));
        let room = reach * (1.0 + APART_REL) + APART_ABS;
        let mut apart = splat(0.0).simd_ne(splat(0.0));
        for j in 0..3 {
            let beyond = splat(half[j] + room);
            let (lo, hi) = (
                a[j].simd_lt(b[j]).select(a[j], b[j]),
                a[j].simd_gt(b[j]).select(a[j], b[j]),
            );
            apart |= lo.simd_gt(beyond) | hi.simd_lt(-beyond);
        }
        apart.to_bitmask() as Mask
    }

    /// What [`Obstacle::hits_capsule`] answers for capsules of radius `radius` on these
    /// segments against `margin`, where it needs no iteration: the lanes it decides as hits
    /// and as clear; the others are left to it. A sphere or a capsule is decided in every
    /// lane. A box is decided where its exact query stops at the segment's ends (its first
    /// two evaluations: the closest point is an end, or an end comes within reach), a
    /// cylinder nowhere. Each lane takes the scalar code's operations in its order, so it is
    /// bit for bit the scalar answer.
    #[inline(always)]
    pub fn obstacle_decided(&self, o: &Obstacle, radius: f64, margin: f64) -> (Mask, Mask) {
        let decided = |hit: Mask, done: Mask| (hit & done, !hit & done);
        match o.shape {
            Shape::Sphere { radius: inflate } => {
                // `Segment::distance2_to_point` of the centre.
                let p = [0, 1, 2].map(|i| splat(o.pose.pos[i]));
                let t = param_toward(&sub(&self.b, &self.a), &sub(&p, &self.a));
                let d = sub(&self.at(t), &p);
                decided(
                    within(splat(0.0) + dot(&d, &d), radius + inflate + margin),
                    !0,
                )
            }
            Shape::Capsule {
                radius: inflate,
                half_length,
            } => {
                let z = o.pose.rot.column(2) * half_length;
                let (a, b) = (o.pose.pos - z, o.pose.pos + z);
                let axis = Segments {
                    a: [0, 1, 2].map(|i| splat(a[i])),
                    b: [0, 1, 2].map(|i| splat(b[i])),
                };
                decided(within(self.distance2(&axis), radius + inflate + margin), !0)
            }
            Shape::Box { half_extents } => {
                // `solid::segment_distance2` with `Want::Below(reach^2)` up to its loop, in
                // the box's frame.
                let local = Segments {
                    a: local(o, &self.a),
                    b: local(o, &self.b),
                };
                let d = sub(&local.b, &local.a);
                let eval = |t: f64| {
                    let p = local.at(splat(t));
                    let v: Point = core::array::from_fn(|i| {
                        let h = splat(half_extents[i]);
                        // `f64::clamp(p, -h, h)`.
                        let x = p[i].simd_lt(-h).select(-h, p[i]);
                        p[i] - x.simd_gt(h).select(h, x)
                    });
                    (splat(0.0) + dot(&v, &v), dot(&v, &d))
                };
                let reach = splat(radius + margin);
                let below = reach * reach;
                let ((g_lo, h_lo), (g_hi, h_hi)) = (eval(0.0), eval(1.0));
                let at_lo = h_lo.simd_ge(splat(0.0)) | g_lo.simd_lt(below);
                let at_hi = !at_lo & (h_hi.simd_le(splat(0.0)) | g_hi.simd_lt(below));
                let g = at_lo.select(g_lo, g_hi);
                let done = (at_lo | at_hi).to_bitmask() as Mask;
                // `contact` adds the radius's inflation, 0 for a solid: the same square.
                decided(within(g, radius + margin), done)
            }
            Shape::Cylinder { .. } => (0, 0),
        }
    }
}
