//! The cubic Hermite spline every joint follows between waypoints: one segment per pair of
//! waypoints, tangents from the neighbouring slopes (Fritsch–Butland), so that the spline is C1
//! and monotone between waypoints (it never leaves their range). Pure arithmetic on `f64`.
//!
//! The executor (`omcbsa-hw`'s stream) moves the arms along it and [`crate::retime`] times it:
//! one spline, so that the time law is computed on the path the arms follow.

/// One cubic Hermite segment on u ∈ [0, 1]; tangents are per segment (rad per segment).
///
/// ```
/// use omcbsa_core::spline::{fritsch_butland, Segment};
///
/// // From 0 to 1 rad, at rest at the start, the next segment rising more steeply.
/// let s = Segment { p0: 0.0, p1: 1.0, m0: 0.0, m1: fritsch_butland(1.0, 3.0) };
/// assert_eq!((s.position(0.0), s.position(1.0)), (0.0, 1.0));
/// assert_eq!(s.m1, 1.5); // the harmonic mean of the slopes
/// assert!(s.max_slope() >= 1.0); // at least the chord's slope somewhere
/// // Where the path turns, the tangent is zero: no overshoot past the waypoint.
/// assert_eq!(fritsch_butland(1.0, -0.5), 0.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Position at u = 0, rad.
    pub p0: f64,
    /// Position at u = 1, rad.
    pub p1: f64,
    /// Tangent at u = 0, rad per segment.
    pub m0: f64,
    /// Tangent at u = 1, rad per segment.
    pub m1: f64,
}

impl Segment {
    /// The position at `u` (0 to 1), rad.
    pub fn position(&self, u: f64) -> f64 {
        let (u2, u3) = (u * u, u * u * u);
        (2.0 * u3 - 3.0 * u2 + 1.0) * self.p0
            + (u3 - 2.0 * u2 + u) * self.m0
            + (-2.0 * u3 + 3.0 * u2) * self.p1
            + (u3 - u2) * self.m1
    }

    /// dp/du at `u`, rad per segment.
    pub fn velocity(&self, u: f64) -> f64 {
        let d = self.p1 - self.p0;
        (6.0 * u - 6.0 * u * u) * d
            + (3.0 * u * u - 4.0 * u + 1.0) * self.m0
            + (3.0 * u * u - 2.0 * u) * self.m1
    }

    /// d²p/du² at `u`, rad per segment².
    pub fn acceleration(&self, u: f64) -> f64 {
        let d = self.p1 - self.p0;
        (6.0 - 12.0 * u) * d + (6.0 * u - 4.0) * self.m0 + (6.0 * u - 2.0) * self.m1
    }

    /// Largest |dp/du| on the segment: the derivative is a quadratic, so the maximum is at an
    /// end or at the vertex.
    pub fn max_slope(&self) -> f64 {
        let d = self.p1 - self.p0;
        let a = -6.0 * d + 3.0 * self.m0 + 3.0 * self.m1;
        let b = 6.0 * d - 4.0 * self.m0 - 2.0 * self.m1;
        let slope = |u: f64| a * u * u + b * u + self.m0;
        let mut m = slope(0.0).abs().max(slope(1.0).abs());
        if a != 0.0 {
            let v = -b / (2.0 * a);
            if (0.0..=1.0).contains(&v) {
                m = m.max(slope(v).abs());
            }
        }
        m
    }

    /// Largest |d²p/du²|: the second derivative is linear, so it is at an end.
    pub fn max_curvature(&self) -> f64 {
        let d = self.p1 - self.p0;
        let at0 = 6.0 * d - 4.0 * self.m0 - 2.0 * self.m1;
        let at1 = -6.0 * d + 2.0 * self.m0 + 4.0 * self.m1;
        at0.abs().max(at1.abs())
    }
}

/// The tangent at a waypoint between slopes `a` (from the previous waypoint) and `b` (to the
/// next): their harmonic mean, or zero where the path turns (Fritsch–Butland).
pub fn fritsch_butland(a: f64, b: f64) -> f64 {
    if a * b <= 0.0 {
        0.0
    } else {
        2.0 * a * b / (a + b)
    }
}

/// Segment `i` (waypoint `i` to `i + 1`) of joint `j` of `path`, at rest at both ends.
pub fn segment<const N: usize>(path: &[[f64; N]], j: usize, i: usize) -> Segment {
    segment_of(path.len(), |k| path[k][j], i)
}

/// Segment `i` of the spline through `n` waypoints whose positions `p(k)` gives, at rest at
/// both ends: the one definition of the path every caller shares.
pub fn segment_of(n: usize, p: impl Fn(usize) -> f64, i: usize) -> Segment {
    Segment {
        p0: p(i),
        p1: p(i + 1),
        m0: tangent_at(n, &p, i),
        m1: tangent_at(n, &p, i + 1),
    }
}

/// The tangent at waypoint `k` of `n`: zero at the ends, Fritsch–Butland between.
pub fn tangent_at(n: usize, p: impl Fn(usize) -> f64, k: usize) -> f64 {
    if k == 0 || k + 1 >= n {
        0.0
    } else {
        fritsch_butland(p(k) - p(k - 1), p(k + 1) - p(k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hermite_passes_through_waypoints_with_continuous_slope() {
        let path = [0.0, 1.0, 1.5, 0.5].map(|v| [v; 7]);
        let segs = [0, 1, 2].map(|i| segment(&path, 0, i));
        for w in segs.windows(2) {
            assert_eq!(w[0].position(1.0), w[1].position(0.0));
            assert_eq!(w[0].m1, w[1].m0);
        }
        assert_eq!(segs[0].m0, 0.0);
        assert_eq!(segs[2].m1, 0.0);
        // turning point at waypoint 2: zero tangent, no overshoot past 1.5
        assert_eq!(segs[1].m1, 0.0);
        let top = (0..=100)
            .map(|i| segs[1].position(i as f64 / 100.0))
            .fold(f64::MIN, f64::max);
        assert!(top <= 1.5);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let s = Segment {
            p0: 0.2,
            p1: -0.4,
            m0: 0.3,
            m1: -0.9,
        };
        let h = 1e-6;
        for u in [0.0, 0.3, 0.7, 1.0] {
            let v = (s.position(u + h) - s.position(u - h)) / (2.0 * h);
            let a = (s.velocity(u + h) - s.velocity(u - h)) / (2.0 * h);
            assert!((v - s.velocity(u)).abs() < 1e-6, "{u}");
            assert!((a - s.acceleration(u)).abs() < 1e-6, "{u}");
        }
        assert_eq!((s.velocity(0.0), s.velocity(1.0)), (0.3, -0.9));
    }
}
