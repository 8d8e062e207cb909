//! Time-optimal retiming of a joint path under per-joint velocity and acceleration limits:
//! TOPP-RA (Pham & Pham, "A new approach to time-optimal path parameterization based on
//! reachability analysis", IEEE T-RO 2018).
//!
//! The path is the one the executor follows: every coordinate on the cubic Hermite spline of
//! [`crate::spline`] through the waypoints, parametrised by the waypoint index `s`. Several
//! arms are one path (their joints side by side in one row per waypoint): they share one time
//! law, so the arms stay where the joint plan put them relative to each other, which is what
//! its collision checks were made on.
//!
//! With `x = ṡ²` and `u = s̈`, a joint's velocity is `q'(s)·ṡ` and its acceleration
//! `q'(s)·u + q''(s)·x`: every limit is linear in `(u, x)`. Over a grid of `s` (each segment
//! cut into [`Options::per_segment`] intervals, waypoints on the grid), `u` is constant on an
//! interval, so `x` is linear on it and the limits are checked at its start, middle and end.
//! A backward pass computes, at every grid point, the largest `x` from which the rest of the
//! path can still be followed to rest at its end (the controllable set, an interval that
//! always contains 0); a forward pass from the start state then takes the largest `u` that
//! stays in it. Where every coordinate's tangent is zero (the path's ends, a hold), any `ṡ` is
//! rest: a law from rest there starts, and every law ends, at the largest `ṡ` the acceleration
//! limits allow, as a time-optimal joint motion starts and stops at full acceleration. The largest `x` of a grid point is found by bisection on `x` (at a fixed `x`
//! the feasible `u` form an interval, and the feasible `x` an interval from 0): a fixed number
//! of halvings, so the result is deterministic and always on the feasible side.
//!
//! Cost: the caller hands in one [`GridPoint`] (32 bytes) per grid point; [`grid_len`] says
//! how many. Time: about `45 · 9 · dof` multiply-adds per grid point (up to 45 halvings of the
//! backward pass, to 1e-12 relative, over 9 constraints per coordinate), no allocation.
//!
//! ```
//! use omcbsa_core::retime::{grid_len, retime, GridPoint, JointPath, Limits, Options};
//!
//! // One joint, 1 rad in 4 equal steps of a straight line: 1 rad/s, 2 rad/s².
//! let points = [0.0, 0.25, 0.5, 0.75, 1.0];
//! let path = JointPath::new(&points, 1)?;
//! let limits = Limits { velocity: &[1.0], acceleration: &[2.0] };
//! let options = Options::from_rest(20, f64::INFINITY);
//! let mut grid = [GridPoint::default(); 128];
//! assert!(grid_len(&path, &options) <= grid.len());
//! let law = retime(&path, &limits, &options, &mut grid)?;
//! // A monotone joint can follow the time-optimal trapezoid: 0.5 s up, 0.5 s at 1 rad/s,
//! // 0.5 s down; the grid's law is within 2 % of its 1.5 s.
//! assert!((law.duration() - 1.5).abs() < 0.03, "{}", law.duration());
//! # Ok::<(), omcbsa_core::retime::RetimeError>(())
//! ```

use crate::spline::{fritsch_butland, Segment};

/// A joint path: `waypoints` rows of `dof` coordinates (several arms side by side in a row),
/// each coordinate on the Hermite spline through its waypoints, at rest at both ends unless
/// the first tangents are frozen (see [`JointPath::with_frozen_tangents`]).
#[derive(Clone, Copy, Debug)]
pub struct JointPath<'a> {
    points: &'a [f64],
    dof: usize,
    /// Tangents at waypoints 0 and 1 fixed before (an executor already moving on segment 0).
    frozen: Option<(&'a [f64], &'a [f64])>,
}

/// Per-coordinate limits, in the units of the path per second: `velocity[c]`, rad/s, and
/// `acceleration[c]`, rad/s², for coordinate `c`.
#[derive(Clone, Copy, Debug)]
pub struct Limits<'a> {
    /// rad/s, positive.
    pub velocity: &'a [f64],
    /// rad/s², positive.
    pub acceleration: &'a [f64],
}

/// How to retime.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Grid intervals per segment (waypoint to waypoint), at least 1: more is closer to the
    /// continuous optimum and to the limits between grid points, at a linear cost.
    pub per_segment: usize,
    /// The largest path speed ṡ, waypoints per second (`1 / dt` keeps a plan from running
    /// faster than its own timing; `f64::INFINITY` for none).
    pub max_speed: f64,
    /// Where the law starts, in waypoints (0 = the first).
    pub start: f64,
    /// The path speed there, waypoints per second; 0 at a point where no coordinate moves
    /// (the path's start) is rest, and the law leaves it as fast as the limits allow.
    pub start_speed: f64,
}

impl Options {
    /// From rest at the first waypoint.
    pub fn from_rest(per_segment: usize, max_speed: f64) -> Self {
        Self {
            per_segment,
            max_speed,
            start: 0.0,
            start_speed: 0.0,
        }
    }
}

/// One point of the grid: what the caller's buffer holds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridPoint {
    /// Path parameter, waypoints.
    pub s: f64,
    /// The largest ṡ² from which the rest of the path can be followed to rest.
    pub reach: f64,
    /// ṡ² of the law.
    pub x: f64,
    /// Time of the law at `s`, from the start, s.
    pub t: f64,
}

/// What was wrong with a retiming's input, or why the start state cannot be followed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RetimeError {
    /// Fewer than two waypoints, or no coordinates.
    TooFewWaypoints {
        /// Waypoints given.
        waypoints: usize,
    },
    /// The points are not whole rows of `dof`, or a limit or frozen tangent table is not
    /// `dof` long.
    Shape {
        /// Coordinates per waypoint.
        dof: usize,
        /// The length found.
        got: usize,
    },
    /// A waypoint coordinate or frozen tangent is NaN or infinite.
    NotFinite {
        /// The waypoint.
        waypoint: usize,
        /// The coordinate, from 0.
        coordinate: usize,
    },
    /// A velocity or acceleration limit is not a positive finite number.
    BadLimit {
        /// The coordinate, from 0.
        coordinate: usize,
        /// The limit's value.
        value: f64,
    },
    /// `per_segment` is 0, `max_speed` not positive, the start outside the path or its speed
    /// negative or not finite.
    BadOptions,
    /// The grid buffer holds fewer points than [`grid_len`].
    BufferTooSmall {
        /// Points needed.
        needed: usize,
        /// Points given.
        got: usize,
    },
    /// The start speed is above what the path allows there, or too fast to stop by its end.
    TooFast {
        /// ṡ at the start, waypoints/s.
        speed: f64,
        /// The largest ṡ from which the path can be followed to rest, waypoints/s.
        reach: f64,
    },
}

impl core::fmt::Display for RetimeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::TooFewWaypoints { waypoints } => {
                write!(f, "a path needs at least 2 waypoints, got {waypoints}")
            }
            Self::Shape { dof, got } => write!(f, "expected rows of {dof} coordinates, got {got}"),
            Self::NotFinite {
                waypoint,
                coordinate,
            } => write!(
                f,
                "waypoint {waypoint} coordinate {coordinate}: not a finite number"
            ),
            Self::BadLimit { coordinate, value } => write!(
                f,
                "coordinate {coordinate}: limit {value} is not a positive number"
            ),
            Self::BadOptions => write!(
                f,
                "per_segment must be at least 1, max_speed positive, the start on the path with \
                 a finite, non-negative speed"
            ),
            Self::BufferTooSmall { needed, got } => {
                write!(f, "the grid needs {needed} points, the buffer holds {got}")
            }
            Self::TooFast { speed, reach } => write!(
                f,
                "path speed {speed} waypoints/s at the start, above the {reach} from which the \
                 path can be followed to rest within the limits"
            ),
        }
    }
}

impl<'a> JointPath<'a> {
    /// `points`: waypoint `k`'s coordinate `c` at `points[k * dof + c]`.
    pub fn new(points: &'a [f64], dof: usize) -> Result<Self, RetimeError> {
        if dof == 0 || !points.len().is_multiple_of(dof) {
            return Err(RetimeError::Shape {
                dof,
                got: points.len(),
            });
        }
        if points.len() / dof < 2 {
            return Err(RetimeError::TooFewWaypoints {
                waypoints: points.len() / dof,
            });
        }
        if let Some(i) = points.iter().position(|v| !v.is_finite()) {
            return Err(RetimeError::NotFinite {
                waypoint: i / dof,
                coordinate: i % dof,
            });
        }
        Ok(Self {
            points,
            dof,
            frozen: None,
        })
    }

    /// The same path with the tangents at waypoints 0 and 1 (rad per segment) fixed earlier,
    /// as an executor freezes them when it enters segment 0.
    pub fn with_frozen_tangents(self, at0: &'a [f64], at1: &'a [f64]) -> Result<Self, RetimeError> {
        for (w, t) in [at0, at1].into_iter().enumerate() {
            if t.len() != self.dof {
                return Err(RetimeError::Shape {
                    dof: self.dof,
                    got: t.len(),
                });
            }
            if let Some(c) = t.iter().position(|v| !v.is_finite()) {
                return Err(RetimeError::NotFinite {
                    waypoint: w,
                    coordinate: c,
                });
            }
        }
        Ok(Self {
            frozen: Some((at0, at1)),
            ..self
        })
    }

    /// Waypoints.
    pub fn waypoints(&self) -> usize {
        self.points.len() / self.dof
    }

    /// Coordinates per waypoint.
    pub fn dof(&self) -> usize {
        self.dof
    }

    fn at(&self, k: usize, c: usize) -> f64 {
        self.points[k * self.dof + c]
    }

    fn tangent(&self, k: usize, c: usize) -> f64 {
        match self.frozen {
            Some((t0, _)) if k == 0 => t0[c],
            Some((_, t1)) if k == 1 => t1[c],
            _ if k == 0 || k + 1 >= self.waypoints() => 0.0,
            _ => fritsch_butland(
                self.at(k, c) - self.at(k - 1, c),
                self.at(k + 1, c) - self.at(k, c),
            ),
        }
    }

    /// Coordinate `c`'s segment from waypoint `k` to `k + 1`.
    pub fn segment(&self, k: usize, c: usize) -> Segment {
        Segment {
            p0: self.at(k, c),
            p1: self.at(k + 1, c),
            m0: self.tangent(k, c),
            m1: self.tangent(k + 1, c),
        }
    }

    /// The segment holding `s` and where in it `s` is (0 to 1).
    pub fn locate(&self, s: f64) -> (usize, f64) {
        let last = self.waypoints() - 2;
        let k = (libm::floor(s.max(0.0)) as usize).min(last);
        (k, s - k as f64)
    }

    /// Coordinate `c` at `s`, rad.
    pub fn position(&self, s: f64, c: usize) -> f64 {
        let (k, u) = self.locate(s);
        self.segment(k, c).position(u)
    }
}

/// Grid points [`retime`] needs for `path` with `options` (0 if the options are invalid).
pub fn grid_len(path: &JointPath, options: &Options) -> usize {
    let mut n = 1;
    let ok = each_interval(path, options, |_, _| {
        n += 1;
        true
    });
    if ok {
        n
    } else {
        0
    }
}

/// Calls `f(start, end)` for every grid interval in order; stops early (false) if `f` does or
/// the options are invalid.
fn each_interval(path: &JointPath, o: &Options, mut f: impl FnMut(f64, f64) -> bool) -> bool {
    let end = (path.waypoints() - 1) as f64;
    if o.per_segment == 0 || !(0.0..end).contains(&o.start) {
        return false;
    }
    let mut k = libm::floor(o.start) as usize;
    while (k as f64) < end {
        let lo = o.start.max(k as f64);
        let len = (k + 1) as f64 - lo;
        let m = (libm::ceil(len * o.per_segment as f64) as usize).max(1);
        for i in 0..m {
            let a = lo + len * i as f64 / m as f64;
            let b = if i + 1 == m {
                (k + 1) as f64
            } else {
                lo + len * (i + 1) as f64 / m as f64
            };
            if !f(a, b) {
                return false;
            }
        }
        k += 1;
    }
    true
}

/// The limits on `(u, x)` of one grid interval: `u` between `lo(x)` and `hi(x)`, `x` below
/// `x_max`, where the bounds are the extremes of lines in `x`.
struct Interval<'p, 'l> {
    path: &'p JointPath<'p>,
    limits: &'l Limits<'l>,
    k: usize,
    a: f64,
    b: f64,
    /// Upper bound of x from the velocity limits at the interval's start and the speed cap.
    x_max: f64,
}

impl Interval<'_, '_> {
    fn new<'p, 'l>(
        path: &'p JointPath<'p>,
        limits: &'l Limits<'l>,
        cap: f64,
        a: f64,
        b: f64,
    ) -> Interval<'p, 'l> {
        let k = path.locate(0.5 * (a + b)).0;
        // A cap for a hold (no coordinate moves) without a speed cap: 10⁶ waypoints/s.
        let mut x_max = (cap * cap).min(1e12);
        for c in 0..path.dof {
            let d1 = path.segment(k, c).velocity(a - k as f64);
            let v = limits.velocity[c];
            if d1 * d1 * x_max > v * v {
                x_max = v * v / (d1 * d1);
            }
        }
        Interval {
            path,
            limits,
            k,
            a,
            b,
            x_max,
        }
    }

    /// The interval of `u` feasible at `x` (empty if `lo > hi`): each coordinate's
    /// acceleration at the start, middle and end, and its velocity at the middle.
    fn u_range(&self, x: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        let h = self.b - self.a;
        let k = self.k as f64;
        for c in 0..self.path.dof {
            let seg = self.path.segment(self.k, c);
            let (acc, vel) = (self.limits.acceleration[c], self.limits.velocity[c]);
            // At offset `w` into the interval, x there is x + 2·w·u.
            for w in [0.0, 0.5 * h, h] {
                let p = self.a + w - k;
                let (d1, d2) = (seg.velocity(p), seg.acceleration(p));
                // |alpha·u + d2·x| ≤ acc
                let alpha = d1 + 2.0 * w * d2;
                bound(alpha, acc - d2 * x, &mut lo, &mut hi);
                bound(-alpha, acc + d2 * x, &mut lo, &mut hi);
                if w == 0.5 * h {
                    // d1²·(x + h·u) ≤ vel²
                    bound(d1 * d1 * h, vel * vel - d1 * d1 * x, &mut lo, &mut hi);
                }
            }
        }
        (lo, hi)
    }

    /// The `u` range at `x` that also lands in `[0, reach]` at the interval's end.
    fn u_range_to(&self, x: f64, reach: f64) -> (f64, f64) {
        let (lo, hi) = self.u_range(x);
        let h2 = 2.0 * (self.b - self.a);
        (lo.max(-x / h2), hi.min((reach - x) / h2))
    }

    /// The largest x from which the interval can be crossed into `[0, reach]`.
    fn reach(&self, reach: f64) -> f64 {
        let ok = |x: f64| {
            let (lo, hi) = self.u_range_to(x, reach);
            lo <= hi
        };
        if ok(self.x_max) {
            return self.x_max;
        }
        let (mut good, mut bad) = (0.0, self.x_max);
        while bad - good > 1e-12 * bad {
            let mid = 0.5 * (good + bad);
            if ok(mid) {
                good = mid;
            } else {
                bad = mid;
            }
        }
        good
    }
}

/// Where no coordinate moves along the path (every tangent zero, as at its ends), any path
/// speed is rest: the largest `x` the acceleration limits allow there (on the segment holding
/// `inside`), or `None` where the path moves.
fn rest_reach(path: &JointPath, limits: &Limits, cap: f64, s: f64, inside: f64) -> Option<f64> {
    let k = path.locate(inside).0;
    let mut x = (cap * cap).min(1e12);
    for c in 0..path.dof {
        let seg = path.segment(k, c);
        let u = s - k as f64;
        if seg.velocity(u) != 0.0 {
            return None;
        }
        let d2 = seg.acceleration(u).abs();
        if d2 * x > limits.acceleration[c] {
            x = limits.acceleration[c] / d2;
        }
    }
    Some(x)
}

/// Narrows `[lo, hi]` by `alpha·u ≤ beta`; a constraint without `u` that fails empties it.
fn bound(alpha: f64, beta: f64, lo: &mut f64, hi: &mut f64) {
    if alpha > 0.0 {
        *hi = hi.min(beta / alpha);
    } else if alpha < 0.0 {
        *lo = lo.max(beta / alpha);
    } else if beta < 0.0 {
        (*lo, *hi) = (f64::INFINITY, f64::NEG_INFINITY);
    }
}

fn check(path: &JointPath, limits: &Limits, o: &Options) -> Result<(), RetimeError> {
    for table in [limits.velocity, limits.acceleration] {
        if table.len() != path.dof {
            return Err(RetimeError::Shape {
                dof: path.dof,
                got: table.len(),
            });
        }
        if let Some(c) = table.iter().position(|v| !v.is_finite() || *v <= 0.0) {
            return Err(RetimeError::BadLimit {
                coordinate: c,
                value: table[c],
            });
        }
    }
    let speed_ok = o.start_speed.is_finite() && o.start_speed >= 0.0;
    if o.max_speed.is_nan() || o.max_speed <= 0.0 || !speed_ok || o.per_segment == 0 {
        return Err(RetimeError::BadOptions);
    }
    Ok(())
}

/// The time-optimal law along `path` from `options.start` at `options.start_speed` to rest at
/// the path's end, within `limits` and `options.max_speed`, computed in `grid` (at least
/// [`grid_len`] points; the law uses the first [`grid_len`]).
pub fn retime<'g>(
    path: &JointPath,
    limits: &Limits,
    options: &Options,
    grid: &'g mut [GridPoint],
) -> Result<TimeLaw<'g>, RetimeError> {
    check(path, limits, options)?;
    let n = grid_len(path, options);
    if n == 0 {
        return Err(RetimeError::BadOptions);
    }
    if grid.len() < n {
        return Err(RetimeError::BufferTooSmall {
            needed: n,
            got: grid.len(),
        });
    }
    let grid = &mut grid[..n];
    let mut i = 0;
    each_interval(path, options, |a, b| {
        grid[i].s = a;
        grid[i + 1].s = b;
        i += 1;
        true
    });
    let cap = options.max_speed;
    // Backward: the controllable sets [0, reach], at rest at the end.
    let end = grid[n - 1].s;
    grid[n - 1].reach = rest_reach(path, limits, cap, end, end - 1.0).unwrap_or(0.0);
    for i in (0..n - 1).rev() {
        let iv = Interval::new(path, limits, cap, grid[i].s, grid[i + 1].s);
        grid[i].reach = iv.reach(grid[i + 1].reach);
    }
    let mut x0 = options.start_speed * options.start_speed;
    if x0 == 0.0 {
        let s0 = grid[0].s;
        x0 = rest_reach(path, limits, cap, s0, s0).map_or(0.0, |_| grid[0].reach);
    }
    if x0 > grid[0].reach * (1.0 + 1e-9) {
        return Err(RetimeError::TooFast {
            speed: options.start_speed,
            reach: libm::sqrt(grid[0].reach),
        });
    }
    // Forward: the largest acceleration that stays controllable.
    (grid[0].x, grid[0].t) = (x0.min(grid[0].reach), 0.0);
    for i in 0..n - 1 {
        let iv = Interval::new(path, limits, cap, grid[i].s, grid[i + 1].s);
        let x = grid[i].x;
        let (lo, hi) = iv.u_range_to(x, grid[i + 1].reach);
        // Rounding can leave the range empty by a hair: keep the slower side then.
        let u = if lo <= hi { hi } else { lo.min(0.0) };
        let h = grid[i + 1].s - grid[i].s;
        let next = (x + 2.0 * h * u).clamp(0.0, grid[i + 1].reach);
        let speeds = libm::sqrt(x) + libm::sqrt(next);
        grid[i + 1].x = next;
        grid[i + 1].t = grid[i].t + if speeds > 0.0 { 2.0 * h / speeds } else { 0.0 };
    }
    Ok(TimeLaw { points: grid })
}

/// Where the law is at a time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Path parameter, waypoints.
    pub s: f64,
    /// ṡ, waypoints/s.
    pub speed: f64,
    /// s̈, waypoints/s².
    pub accel: f64,
}

/// A time law on the grid: `s̈` constant on every interval.
#[derive(Clone, Copy, Debug)]
pub struct TimeLaw<'g> {
    points: &'g [GridPoint],
}

impl<'g> TimeLaw<'g> {
    /// A law over grid points computed before by [`retime`] (e.g. kept by the caller).
    pub fn from_points(points: &'g [GridPoint]) -> Self {
        Self { points }
    }

    /// The grid.
    pub fn points(&self) -> &'g [GridPoint] {
        self.points
    }

    /// Seconds from the start to rest at the end.
    pub fn duration(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.t)
    }

    /// The state at `t` seconds from the start (at rest at the end after the duration).
    pub fn sample(&self, t: f64) -> State {
        let p = self.points;
        let last = p[p.len() - 1];
        if t >= last.t {
            return State {
                s: last.s,
                speed: 0.0,
                accel: 0.0,
            };
        }
        // The last interval starting at or before t.
        let i = p.partition_point(|g| g.t <= t).saturating_sub(1);
        let (a, b) = (p[i], p[i + 1]);
        let accel = (b.x - a.x) / (2.0 * (b.s - a.s));
        let tau = (t - a.t).max(0.0);
        let v0 = libm::sqrt(a.x);
        State {
            s: (a.s + v0 * tau + 0.5 * accel * tau * tau).min(b.s),
            speed: (v0 + accel * tau).max(0.0),
            accel,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    const DOF: usize = 14;

    /// Two 7-joint arms side by side, `n` waypoints of a random walk.
    fn walk(seed: u64, n: usize, points: &mut [f64]) {
        let mut rng = Rng::new(seed);
        for p in &mut points[..DOF] {
            *p = rng.uniform(-1.0, 1.0);
        }
        for k in 1..n {
            for c in 0..DOF {
                points[k * DOF + c] = points[(k - 1) * DOF + c] + rng.uniform(-0.3, 0.3);
            }
        }
    }

    const VEL: [f64; DOF] = [
        1.4, 1.4, 1.4, 1.4, 1.2, 1.2, 1.2, 2.2, 2.2, 2.2, 2.2, 2.6, 2.6, 2.6,
    ];
    const ACC: [f64; DOF] = [
        5.2, 5.2, 5.2, 5.2, 10., 10., 10., 15., 7.5, 10., 12.5, 15., 20., 20.,
    ];

    fn limits() -> Limits<'static> {
        Limits {
            velocity: &VEL,
            acceleration: &ACC,
        }
    }

    /// The largest ratio of a joint's speed or acceleration to its limit, sampled 50 times per
    /// grid interval (where `x` is exactly linear in `s`).
    fn worst_ratio(path: &JointPath, law: &TimeLaw) -> f64 {
        let mut worst: f64 = 0.0;
        for w in law.points().windows(2) {
            let (a, b) = (w[0], w[1]);
            let u = (b.x - a.x) / (2.0 * (b.s - a.s));
            let k = path.locate(0.5 * (a.s + b.s)).0;
            for i in 0..=50 {
                let s = a.s + (b.s - a.s) * i as f64 / 50.0;
                let x = (a.x + 2.0 * u * (s - a.s)).max(0.0);
                for c in 0..path.dof() {
                    let seg = path.segment(k, c);
                    let p = s - k as f64;
                    let v = seg.velocity(p).abs() * libm::sqrt(x) / VEL[c];
                    let acc = (seg.velocity(p) * u + seg.acceleration(p) * x).abs() / ACC[c];
                    worst = worst.max(v).max(acc);
                }
            }
        }
        worst
    }

    #[test]
    fn random_two_arm_paths_stay_within_the_limits_between_grid_points() {
        let mut points = [0.0; 30 * DOF];
        let mut grid = [GridPoint::default(); 30 * 10 + 1];
        for seed in 0..20 {
            walk(seed, 30, &mut points);
            let path = JointPath::new(&points, DOF).unwrap();
            let law = retime(&path, &limits(), &Options::from_rest(10, 50.0), &mut grid).unwrap();
            let worst = worst_ratio(&path, &law);
            // The limits hold exactly at 3 points per interval; between them within 1 % at
            // 10 intervals per segment (the error falls with the grid's spacing).
            assert!(worst <= 1.01, "seed {seed}: {worst}");
            // and the law is time-optimal enough to touch a limit somewhere
            assert!(worst > 0.95, "seed {seed}: {worst}");
            assert!(law.points().iter().all(|p| libm::sqrt(p.x) <= 50.0 + 1e-9));
            // at rest at both ends: no coordinate moves there
            let (first, last) = (law.points()[0], law.points()[290]);
            assert_eq!((first.s, last.s), (0.0, 29.0));
        }
    }

    #[test]
    fn a_single_joint_takes_the_bang_bang_time() {
        // 1 rad in 10 steps: the spline is monotone, so the joint can follow the
        // time-optimal trapezoid exactly: 1 rad at 1 rad/s with 2 rad/s² takes 1.5 s.
        let points: [f64; 11] = core::array::from_fn(|k| k as f64 / 10.0);
        let path = JointPath::new(&points, 1).unwrap();
        let l = Limits {
            velocity: &[1.0],
            acceleration: &[2.0],
        };
        let mut grid = [GridPoint::default(); 10 * 80 + 1];
        let law = retime(&path, &l, &Options::from_rest(80, f64::INFINITY), &mut grid).unwrap();
        // within 1 %: the limits are held at 3 points per interval, a little conservative
        assert!(
            (law.duration() - 1.5).abs() < 0.01 * 1.5,
            "{}",
            law.duration()
        );
        // too short to reach full speed: 0.1 rad with 2 rad/s² takes 2·√(0.05) s
        let short: [f64; 11] = core::array::from_fn(|k| k as f64 / 100.0);
        let path = JointPath::new(&short, 1).unwrap();
        let law = retime(&path, &l, &Options::from_rest(80, f64::INFINITY), &mut grid).unwrap();
        let t = 2.0 * libm::sqrt(0.05);
        assert!((law.duration() - t).abs() < 0.01 * t, "{}", law.duration());
    }

    #[test]
    fn the_speed_cap_keeps_the_plan_timing_where_limits_allow() {
        // Tiny moves: the limits never bind, the cap (10 waypoints/s) does; the law takes the
        // plan's 2.9 s plus what starting and stopping cost.
        let mut points = [0.0; 30 * DOF];
        walk(3, 30, &mut points);
        for v in points.iter_mut() {
            *v *= 1e-3;
        }
        let path = JointPath::new(&points, DOF).unwrap();
        let mut grid = [GridPoint::default(); 301];
        let law = retime(&path, &limits(), &Options::from_rest(10, 10.0), &mut grid).unwrap();
        assert!(
            law.duration() >= 2.9 && law.duration() < 3.1,
            "{}",
            law.duration()
        );
        let mid = law.sample(1.5);
        assert!((mid.speed - 10.0).abs() < 1e-9, "{mid:?}");
    }

    #[test]
    fn a_start_in_motion_is_followed_or_refused_when_it_cannot_stop() {
        let points: [f64; 11] = core::array::from_fn(|k| k as f64 / 10.0);
        let path = JointPath::new(&points, 1).unwrap();
        let l = Limits {
            velocity: &[1.0],
            acceleration: &[2.0],
        };
        let mut grid = [GridPoint::default(); 401];
        // At 5.5 (0.55 rad) at 1 rad/s (10 waypoints/s): 0.25 rad to stop, 0.45 left.
        let o = Options {
            start: 5.5,
            start_speed: 10.0,
            ..Options::from_rest(40, f64::INFINITY)
        };
        let law = retime(&path, &l, &o, &mut grid).unwrap();
        assert_eq!(law.points()[0].s, 5.5);
        assert!((law.sample(0.0).speed - 10.0).abs() < 1e-9);
        // ...but at 8.5 only 0.15 rad are left: refused, saying how fast it could be.
        let o = Options { start: 8.5, ..o };
        match retime(&path, &l, &o, &mut grid) {
            Err(RetimeError::TooFast { speed, reach }) => {
                assert_eq!(speed, 10.0);
                // √(2·2·0.15) = 0.775 rad/s, 7.75 waypoints/s, less the grid's error
                assert!(reach <= 7.75 && reach > 7.5, "{reach}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn the_same_input_gives_the_same_law() {
        let mut points = [0.0; 20 * DOF];
        walk(7, 20, &mut points);
        let path = JointPath::new(&points, DOF).unwrap();
        let (mut a, mut b) = ([GridPoint::default(); 191], [GridPoint::default(); 191]);
        let o = Options::from_rest(10, 20.0);
        let la = retime(&path, &limits(), &o, &mut a).unwrap().duration();
        let lb = retime(&path, &limits(), &o, &mut b).unwrap().duration();
        assert_eq!(la.to_bits(), lb.to_bits());
        assert_eq!(a, b);
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let mut grid = [GridPoint::default(); 8];
        let one = [0.0; 7];
        assert_eq!(
            JointPath::new(&one, 7).unwrap_err(),
            RetimeError::TooFewWaypoints { waypoints: 1 }
        );
        assert_eq!(
            JointPath::new(&[0.0; 13], 7).unwrap_err(),
            RetimeError::Shape { dof: 7, got: 13 }
        );
        let mut nan = [0.0; 14];
        nan[9] = f64::NAN;
        assert_eq!(
            JointPath::new(&nan, 7).unwrap_err(),
            RetimeError::NotFinite {
                waypoint: 1,
                coordinate: 2
            }
        );
        let two = [0.0, 1.0];
        let path = JointPath::new(&two, 1).unwrap();
        let o = Options::from_rest(4, 1.0);
        for (v, a) in [
            (0.0, 1.0),
            (1.0, -1.0),
            (f64::NAN, 1.0),
            (1.0, f64::INFINITY),
        ] {
            let l = Limits {
                velocity: &[v],
                acceleration: &[a],
            };
            let e = retime(&path, &l, &o, &mut grid).unwrap_err();
            assert!(
                matches!(e, RetimeError::BadLimit { coordinate: 0, .. }),
                "{e:?}"
            );
        }
        let l = Limits {
            velocity: &[1.0],
            acceleration: &[1.0],
        };
        let e = retime(&path, &l, &o, &mut grid[..4]).unwrap_err();
        assert_eq!(e, RetimeError::BufferTooSmall { needed: 5, got: 4 });
        for bad in [
            Options::from_rest(0, 1.0),
            Options::from_rest(4, 0.0),
            Options::from_rest(4, f64::NAN),
            Options { start: 1.0, ..o },
            Options {
                start: f64::NAN,
                ..o
            },
            Options {
                start_speed: -1.0,
                ..o
            },
        ] {
            assert_eq!(
                retime(&path, &l, &bad, &mut grid).unwrap_err(),
                RetimeError::BadOptions,
                "{bad:?}"
            );
        }
        let t = [f64::INFINITY];
        assert!(path.with_frozen_tangents(&t, &[0.0]).is_err());
        assert!(path.with_frozen_tangents(&[0.0, 1.0], &[0.0]).is_err());
    }
}
