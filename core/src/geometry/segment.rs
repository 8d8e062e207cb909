//! Line segments: closest points to a point and between two segments.

use nalgebra::Vector3;

/// Below this, `|d1 x d2|^2 / (|d1|^2 |d2|^2)` (the squared sine of the angle between two
/// segments) counts as parallel. Solving the 2x2 system there would amplify rounding; on the
/// other side the solve loses at most `1e-32 / 1e-14` of the squared distance.
pub(super) const PARALLEL_SIN2: f64 = 1e-14;

/// The segment from `a` to `b` (a point when `a == b`), parametrised as `a + t (b - a)`,
/// `t` in `[0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// The start (`t = 0`).
    pub a: Vector3<f64>,
    /// The end (`t = 1`).
    pub b: Vector3<f64>,
}

impl Segment {
    /// The segment from `a` to `b`.
    pub const fn new(a: Vector3<f64>, b: Vector3<f64>) -> Segment {
        Segment { a, b }
    }

    /// The point `a + t (b - a)` (any `t`; the segment is `0..=1`).
    #[inline]
    pub fn at(&self, t: f64) -> Vector3<f64> {
        self.a + (self.b - self.a) * t
    }

    /// Parameter of the point of the segment closest to `p`.
    #[inline]
    pub fn closest_param(&self, p: &Vector3<f64>) -> f64 {
        param_toward(&(self.b - self.a), &(p - self.a))
    }

    /// Squared distance from `p` to the segment.
    #[inline]
    pub fn distance2_to_point(&self, p: &Vector3<f64>) -> f64 {
        (self.at(self.closest_param(p)) - p).norm_squared()
    }

    /// Parameters `(s, t)` of a pair of closest points, `s` on `self` and `t` on `other`.
    ///
    /// The squared distance between `self.at(s)` and `other.at(t)` is a convex quadratic on
    /// the unit square. Its free minimum is used when it lies inside; otherwise the minimum is
    /// on an edge, found by fixing the parameter that left the square and projecting in turn.
    /// Parallel and point-like segments have a whole family of minima; one is returned.
    pub fn closest_params(&self, other: &Segment) -> (f64, f64) {
        let d1 = self.b - self.a;
        let d2 = other.b - other.a;
        let r = self.a - other.a;
        let l1 = d1.norm_squared();
        let l2 = d2.norm_squared();
        if l1 == 0.0 {
            return (0.0, param_toward(&d2, &r));
        }
        if l2 == 0.0 {
            return (param_toward(&d1, &-r), 0.0);
        }
        let c = d1.dot(&d2);
        let e1 = d1.dot(&r);
        let e2 = d2.dot(&r);
        let det = l1 * l2 - c * c;
        // Free minimum of s, or s = 0 for (nearly) parallel segments: any s is then on the
        // valley floor, and the projection steps below find the right end of the overlap.
        let s = if det > PARALLEL_SIN2 * l1 * l2 {
            clamp01((c * e2 - l2 * e1) / det)
        } else {
            0.0
        };
        // Best t for that s; if it leaves [0, 1], clamp it and re-optimise s for that end.
        let t = (c * s + e2) / l2;
        if t < 0.0 {
            (clamp01(-e1 / l1), 0.0)
        } else if t > 1.0 {
            (clamp01((c - e1) / l1), 1.0)
        } else {
            (s, t)
        }
    }

    /// Squared distance between two segments: the same, to the last bit, whichever of the
    /// two asks (the pair is put in one order first), so that a planner asking "does arm A
    /// meet arm B" and one asking "does B meet A" agree.
    #[inline]
    pub fn distance2_to_segment(&self, other: &Segment) -> f64 {
        let key = |g: &Segment| [g.a.x, g.a.y, g.a.z, g.b.x, g.b.y, g.b.z];
        let (first, second) = if key(other) < key(self) {
            (other, self)
        } else {
            (self, other)
        };
        let (s, t) = first.closest_params(second);
        (first.at(s) - second.at(t)).norm_squared()
    }
}

/// `clamp(d.v / d.d, 0, 1)`, 0 for `d == 0`: where the projection of `v` falls along `d`.
#[inline]
fn param_toward(d: &Vector3<f64>, v: &Vector3<f64>) -> f64 {
    let l = d.norm_squared();
    if l == 0.0 {
        0.0
    } else {
        clamp01(d.dot(v) / l)
    }
}

#[inline]
fn clamp01(x: f64) -> f64 {
    x.clamp(0.0, 1.0)
}
