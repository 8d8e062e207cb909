//! Distance from a segment to a solid box or a solid finite cylinder, both in their own frame.
//!
//! The squared distance from a point to a convex solid, `g(p) = |p - proj(p)|^2`, is convex
//! and continuously differentiable with gradient `2 (p - proj(p))`. Along a segment `p(t)` its
//! slope `h(t) = (p(t) - proj(p(t))) . (b - a)` is continuous and non-decreasing, so the
//! closest point is the root of `h` on `[0, 1]` (or an end). The root is bracketed and found by
//! regula falsi with the Illinois step; for a box `h` is piecewise linear, so the search is
//! exact as soon as the bracket lies within one piece, and for a cylinder it converges
//! superlinearly. Bisection steps guarantee that the bracket shrinks whatever the shape.

use nalgebra::Vector3;

use super::segment::Segment;

/// The search stops when the bracket is this narrow (in the segment parameter); the squared
/// distance is then off by at most `|b - a|^2 * TOL_T^2` plus rounding.
const TOL_T: f64 = 1e-13;
/// Hard cap on the iterations; the bracket at least halves every two, so `TOL_T` comes first.
const MAX_ITERS: u32 = 128;

/// Nearest point of the box `|x_i| <= half_extents_i` to `p`.
#[inline]
pub fn box_project(half_extents: &Vector3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    p.zip_map(half_extents, |x, h| x.clamp(-h, h))
}

#[inline]
pub fn box_contains(half_extents: &Vector3<f64>, p: &Vector3<f64>) -> bool {
    (0..3).all(|i| libm::fabs(p[i]) <= half_extents[i])
}

/// Nearest point of the solid cylinder `x^2 + y^2 <= radius^2, |z| <= half_length` to `p`.
#[inline]
pub fn cylinder_project(radius: f64, half_length: f64, p: &Vector3<f64>) -> Vector3<f64> {
    let rho2 = p.x * p.x + p.y * p.y;
    let z = p.z.clamp(-half_length, half_length);
    if rho2 <= radius * radius {
        Vector3::new(p.x, p.y, z)
    } else {
        let k = radius / libm::sqrt(rho2);
        Vector3::new(p.x * k, p.y * k, z)
    }
}

#[inline]
pub fn cylinder_contains(radius: f64, half_length: f64, p: &Vector3<f64>) -> bool {
    p.x * p.x + p.y * p.y <= radius * radius && libm::fabs(p.z) <= half_length
}

/// What a caller needs from [`segment_distance2`]: the exact value, or only whether it is
/// below a threshold (which allows stopping as soon as that is decided).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Want {
    Exact,
    /// Stop once the answer is known to be below, or at or above, this squared distance.
    Below(f64),
}

/// Squared distance from `seg` to the convex solid with nearest-point map `project`.
///
/// With `Want::Below(th)` the result may be any value on the same side of `th` as the true
/// minimum (an evaluated squared distance below `th`, or a lower bound at or above it).
pub fn segment_distance2(
    seg: &Segment,
    want: Want,
    project: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> f64 {
    let d = seg.b - seg.a;
    // (squared distance, slope) at parameter t.
    let eval = |t: f64| {
        let p = seg.at(t);
        let v = p - project(&p);
        (v.norm_squared(), v.dot(&d))
    };
    let below = match want {
        Want::Exact => 0.0,
        Want::Below(th) => th,
    };
    let (mut lo, (mut g_lo, mut h_lo)) = (0.0, eval(0.0));
    if h_lo >= 0.0 || g_lo < below {
        return g_lo;
    }
    let (mut hi, (mut g_hi, mut h_hi)) = (1.0, eval(1.0));
    if h_hi <= 0.0 || g_hi < below {
        return g_hi;
    }
    // Illinois: halve the weight of an end that has been kept twice in a row.
    let (mut w_lo, mut w_hi) = (1.0, 1.0);
    let mut side = 0i8;
    let mut bisect = false;
    for _ in 0..MAX_ITERS {
        let width = hi - lo;
        if width <= TOL_T {
            break;
        }
        if let Want::Below(th) = want {
            // The tangents at both ends (g' = 2h) bound the convex g from below; the lowest
            // point of that bound is where they cross.
            let (s_lo, s_hi) = (2.0 * h_lo, 2.0 * h_hi);
            let x = (g_hi - g_lo + s_lo * lo - s_hi * hi) / (s_lo - s_hi);
            let bound = g_lo + s_lo * (x - lo);
            if bound >= th {
                return bound;
            }
        }
        let t = if bisect {
            0.5 * (lo + hi)
        } else {
            let (a, b) = (w_lo * h_lo, w_hi * h_hi);
            (lo * b - hi * a) / (b - a)
        };
        let t = if t > lo && t < hi { t } else { 0.5 * (lo + hi) };
        let (g, h) = eval(t);
        if g < below || h == 0.0 {
            return g;
        }
        if h < 0.0 {
            (lo, g_lo, h_lo) = (t, g, h);
            w_lo = 1.0;
            w_hi = if side < 0 { 0.5 * w_hi } else { 1.0 };
            side = -1;
        } else {
            (hi, g_hi, h_hi) = (t, g, h);
            w_hi = 1.0;
            w_lo = if side > 0 { 0.5 * w_lo } else { 1.0 };
            side = 1;
        }
        // A false-position step that failed to halve the bracket is followed by a bisection.
        bisect = !bisect && hi - lo > 0.5 * width;
    }
    // The bracket is narrower than TOL_T: either end is as good as the minimum.
    g_lo.min(g_hi)
}
