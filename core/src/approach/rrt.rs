//! RRT-Connect (Kuffner and LaValle, 2000) on the composite configuration space of the arms,
//! then greedy shortcutting.
//!
//! Two trees grow from the start (where the arms stand) and from the goal (the plan's first
//! configurations) in caller storage: each node is one composite configuration. Each round
//! draws a sample, extends one tree one step towards it and then pulls the other tree towards
//! the new node until it is reached or blocked; the trees swap roles every round.
//!
//! - Distance is the time the move takes at full speed, `max |dq_j| / v_j` over every arm and
//!   joint, so one step of [`ApproachParams::rrt_step`] seconds is a motion all arms make in
//!   that time.
//! - A sample draws each arm, with even odds, uniformly within its limits (a continuous joint
//!   within half a turn past its start and goal) or on its own straight bridge. The uniform
//!   draw of every arm at once has positive density everywhere, so the planner keeps
//!   RRT-Connect's probabilistic completeness: if an approach with some clearance exists, the
//!   chance of missing it goes to 0 as the sample budget grows.
//! - When only some arms are sampled (one arm finding its way around the others), the others
//!   are placed once ([`Composite::standing`]) and distance counts the sampled arms only.
//! - Shortcutting: first the waypoints inside straight runs (a tree extending again and again
//!   towards one node) are dropped, unchecked, for the motion past them is the motions
//!   checked; then from the start each waypoint kept is joined to the farthest one it sees,
//!   found by bisection over those after it (a few long checks where trying random pairs and
//!   then every single waypoint took many).
//! - Deterministic: the samples come from [`Rng`] with the caller's seed, and the deadline is
//!   the only thing that depends on the clock (it ends the search, never changes it).

use core::f64::consts::PI;

use crate::model::Models;
use crate::problem::MAX_ROBOTS;
use crate::rng::Rng;
use crate::search::Deadline;

use super::composite::Composite;
use super::query::{ApproachError, ApproachParams, ApproachStorage};

/// How an RRT-Connect search ended without a path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Miss {
    /// Every sample of the budget was drawn.
    Budget,
    Failed(ApproachError),
}

enum Extend {
    Trapped,
    Advanced(usize),
    Reached(usize),
}

/// The two trees: tree `t`'s node `k` is node `t * cap + k` of the storage, its
/// configurations `q[(t * cap + k) * n..][..n]`.
struct Trees<'s, 'a, const D: usize> {
    st: &'s mut ApproachStorage<'a, D>,
    n: usize,
    cap: usize,
    len: [usize; 2],
}

impl<const D: usize> Trees<'_, '_, D> {
    fn config(&self, t: usize, k: usize) -> &[[f64; D]] {
        let at = (t * self.cap + k) * self.n;
        &self.st.tree[at..at + self.n]
    }

    /// Adds a node to tree `t`. A full tree ends the search as a spent budget does: the
    /// budget is the lesser of the samples and the room in the trees.
    fn push(&mut self, t: usize, q: &[[f64; D]], parent: u32) -> Result<usize, Miss> {
        let k = self.len[t];
        if k == self.cap {
            return Err(Miss::Budget);
        }
        let at = (t * self.cap + k) * self.n;
        self.st.tree[at..at + self.n].copy_from_slice(q);
        self.st.parent[t * self.cap + k] = parent;
        self.len[t] += 1;
        Ok(k)
    }

    /// Copies tree `t`'s node `k` to waypoint `at`.
    fn copy_to_waypoint(&mut self, at: usize, t: usize, k: usize) {
        let from = (t * self.cap + k) * self.n;
        let (n, st) = (self.n, &mut *self.st);
        st.waypoints[at * n..(at + 1) * n].copy_from_slice(&st.tree[from..from + n]);
    }

    fn parent(&self, t: usize, k: usize) -> Option<usize> {
        let p = self.st.parent[t * self.cap + k];
        (p != u32::MAX).then_some(p as usize)
    }
}

/// Seconds at full speed from `a` to `b` (the arms moving together), over the robots in the
/// bit set `free` (the others are where they stand in both).
fn distance<M: Models<D>, const D: usize>(
    composite: &Composite<'_, M, D>,
    a: &[[f64; D]],
    b: &[[f64; D]],
    free: u32,
) -> f64 {
    let mut d = 0.0f64;
    let arms = a
        .iter()
        .zip(b)
        .enumerate()
        .filter(|(i, _)| free & (1 << i) != 0);
    for (i, (qa, qb)) in arms {
        let velocity = M::velocity(composite.model(i));
        for j in 0..D {
            d = d.max(libm::fabs(qb[j] - qa[j]) / velocity[j]);
        }
    }
    d
}

/// One RRT-Connect search: its ends (composite, `composite.n` robots each), the robots it moves
/// (a bit set) and its samples' seed.
pub(super) struct Connect<'a, const D: usize> {
    pub start: &'a [[f64; D]],
    pub goal: &'a [[f64; D]],
    /// Only these robots are sampled; the others keep their start (they are still checked,
    /// as obstacles when `start` and `goal` agree on them).
    pub free: u32,
    pub seed: u64,
}

/// Plans from `ask.start` to `ask.goal` with `params.rrt_samples` samples and writes the
/// shortcut path's waypoints, start and goal included, to `st.waypoints`. Returns how many.
pub(super) fn connect<M: Models<D>, const D: usize>(
    composite: &Composite<'_, M, D>,
    ask: &Connect<'_, D>,
    params: &ApproachParams,
    st: &mut ApproachStorage<'_, D>,
    deadline: &dyn Deadline,
) -> Result<usize, Miss> {
    let (start, goal, free) = (ask.start, ask.goal, ask.free);
    let n = composite.n;
    // The arms not sampled stand where they start in every node: placed once.
    let composite = &mut composite.standing(start, free);
    let cap = (st.tree.len() / n).min(st.parent.len()) / 2;
    if cap < 2 || st.waypoints.len() / n < 2 {
        return Err(Miss::Failed(ApproachError::OutOfMemory("approach tree")));
    }
    let mut trees = Trees {
        st,
        n,
        cap,
        len: [0, 0],
    };
    let fail = Miss::Failed;
    trees.push(0, start, u32::MAX)?;
    trees.push(1, goal, u32::MAX)?;
    let mut rng = Rng::new(ask.seed);
    let mut sample = [[0.0; D]; MAX_ROBOTS];
    let mut grow = 0;
    for _ in 0..params.rrt_samples {
        if deadline.expired() {
            return Err(fail(ApproachError::Timeout));
        }
        draw::<M, D>(composite, start, goal, free, &mut rng, &mut sample[..n]);
        if let Extend::Advanced(k) | Extend::Reached(k) =
            extend(composite, &mut trees, grow, &sample[..n], free, params)?
        {
            let target: [[f64; D]; MAX_ROBOTS] = core::array::from_fn(|i| {
                if i < n {
                    trees.config(grow, k)[i]
                } else {
                    [0.0; D]
                }
            });
            let other = 1 - grow;
            loop {
                match extend(composite, &mut trees, other, &target[..n], free, params)? {
                    Extend::Advanced(_) => continue,
                    Extend::Trapped => break,
                    Extend::Reached(r) => {
                        let (from_start, from_goal) = if grow == 0 { (k, r) } else { (r, k) };
                        let m = trace(&mut trees, from_start, from_goal).map_err(fail)?;
                        let m = straighten(&mut trees.st.waypoints[..m * n], n);
                        let m = shortcut(composite, trees.st, n, m, deadline);
                        return Ok(m);
                    }
                }
            }
        }
        grow = 1 - grow;
    }
    Err(Miss::Budget)
}

/// A sample: each active arm in `free` uniform within its bounds or on its own bridge, even
/// odds; the others at their start.
fn draw<M: Models<D>, const D: usize>(
    composite: &Composite<'_, M, D>,
    start: &[[f64; D]],
    goal: &[[f64; D]],
    free: u32,
    rng: &mut Rng,
    out: &mut [[f64; D]],
) {
    for (i, q) in out.iter_mut().enumerate() {
        let (s, g) = (&start[i], &goal[i]);
        if !composite.is_active(i) || free & (1 << i) == 0 {
            *q = *s;
        } else if rng.next_f64() < 0.5 {
            let f = rng.next_f64();
            *q = core::array::from_fn(|j| s[j] + f * (g[j] - s[j]));
        } else {
            let (lower, upper) = (M::lower(composite.model(i)), M::upper(composite.model(i)));
            *q = core::array::from_fn(|j| {
                let lo = if lower[j].is_finite() {
                    lower[j]
                } else {
                    s[j].min(g[j]) - PI
                };
                let hi = if upper[j].is_finite() {
                    upper[j]
                } else {
                    s[j].max(g[j]) + PI
                };
                rng.uniform(lo, hi)
            });
        }
    }
}

/// One step of tree `t` from its node nearest `target` towards it.
fn extend<M: Models<D>, const D: usize>(
    composite: &mut Composite<'_, M, D>,
    trees: &mut Trees<'_, '_, D>,
    t: usize,
    target: &[[f64; D]],
    free: u32,
    params: &ApproachParams,
) -> Result<Extend, Miss> {
    let n = trees.n;
    let (mut near, mut best) = (0, f64::INFINITY);
    for k in 0..trees.len[t] {
        let d = distance::<M, D>(composite, trees.config(t, k), target, free);
        if d < best {
            (near, best) = (k, d);
        }
    }
    let from = trees.config(t, near);
    let reach = best <= params.rrt_step;
    let f = if reach { 1.0 } else { params.rrt_step / best };
    let new: [[f64; D]; MAX_ROBOTS] = core::array::from_fn(|i| {
        if i >= n {
            [0.0; D]
        } else if reach {
            target[i]
        } else {
            core::array::from_fn(|j| from[i][j] + f * (target[i][j] - from[i][j]))
        }
    });
    if composite.step_blocked(from, &new[..n]) {
        return Ok(Extend::Trapped);
    }
    let k = trees.push(t, &new[..n], near as u32)?;
    Ok(if reach {
        Extend::Reached(k)
    } else {
        Extend::Advanced(k)
    })
}

/// Writes the path start -> `from_start` (tree 0), `from_goal` -> goal (tree 1) to the
/// waypoints (the two meeting nodes are the same configuration: it is written once).
fn trace<const D: usize>(
    trees: &mut Trees<'_, '_, D>,
    from_start: usize,
    from_goal: usize,
) -> Result<usize, ApproachError> {
    let n = trees.n;
    let cap = trees.st.waypoints.len() / n;
    let depth = |t: usize, mut k: usize| {
        let mut d = 1;
        while let Some(p) = trees.parent(t, k) {
            (k, d) = (p, d + 1);
        }
        d
    };
    let (ds, dg) = (depth(0, from_start), depth(1, from_goal));
    let m = ds + dg - 1;
    if m > cap {
        return Err(ApproachError::OutOfMemory("approach waypoints"));
    }
    // The start side backwards from the meeting node, then the goal side forwards from the
    // node after it.
    let (mut at, mut k) = (ds, Some(from_start));
    while let Some(node) = k {
        at -= 1;
        trees.copy_to_waypoint(at, 0, node);
        k = trees.parent(0, node);
    }
    let (mut at, mut k) = (ds, trees.parent(1, from_goal));
    while let Some(node) = k {
        trees.copy_to_waypoint(at, 1, node);
        at += 1;
        k = trees.parent(1, node);
    }
    Ok(m)
}

/// Drops each of the `m = w.len() / n` waypoints that lies on the straight composite motion
/// between its neighbours, going on in the same direction (a tree's connect phase makes such
/// runs, extending again and again towards one node): the motion from the one before to the
/// one after is the two motions checked, so nothing is checked. Returns the waypoints left.
fn straighten<const D: usize>(w: &mut [[f64; D]], n: usize) -> usize {
    let m = w.len() / n;
    if m < 3 {
        return m;
    }
    // Whether `b` lies on the way from `a` to `c`: `b - a` is `f (c - a)` for one `f` in (0, 1).
    let between = |a: &[[f64; D]], b: &[[f64; D]], c: &[[f64; D]]| {
        let (mut f, mut span) = (0.0, 0.0f64);
        for ((qa, qb), qc) in a.iter().zip(b).zip(c) {
            for j in 0..D {
                let d = libm::fabs(qc[j] - qa[j]);
                if d > span {
                    (span, f) = (d, (qb[j] - qa[j]) / (qc[j] - qa[j]));
                }
            }
        }
        span > 0.0
            && f > 0.0
            && f < 1.0
            && a.iter().zip(b).zip(c).all(|((qa, qb), qc)| {
                (0..D).all(|j| libm::fabs(qa[j] + f * (qc[j] - qa[j]) - qb[j]) <= 1e-9 * span)
            })
    };
    let mut kept = 1;
    for k in 1..m {
        let (last, next) = ((kept - 1) * n, (k + 1) * n);
        if k + 1 < m && between(&w[last..last + n], &w[k * n..next], &w[next..next + n]) {
            continue;
        }
        w.copy_within(k * n..(k + 1) * n, kept * n);
        kept += 1;
    }
    kept
}

/// Greedy shortcutting: from the start, each waypoint kept is joined to the farthest one it
/// sees (the straight composite motion between them free), found by bisection over the
/// waypoints after it, and the ones between are dropped. Each motion kept was checked, or is an
/// edge of the path. Returns the waypoints left.
fn shortcut<M: Models<D>, const D: usize>(
    composite: &mut Composite<'_, M, D>,
    st: &mut ApproachStorage<'_, D>,
    n: usize,
    m: usize,
    deadline: &dyn Deadline,
) -> usize {
    let w = &mut *st.waypoints;
    // `a`: the last waypoint kept, at `kept - 1` of the compacted path; waypoints from `a + 1`
    // on are still where the tree put them.
    let (mut a, mut kept) = (0, 1);
    while a + 1 < m {
        let at = (kept - 1) * n;
        let sees = |composite: &mut Composite<'_, M, D>, w: &[[f64; D]], b: usize| {
            !deadline.expired()
                && composite
                    .motion_blocked(&w[at..at + n], &w[b * n..(b + 1) * n])
                    .is_none()
        };
        // From the start the end is not seen: every caller searches because that motion is
        // blocked.
        let b = if a > 0 && a + 2 < m && sees(composite, w, m - 1) {
            m - 1
        } else {
            // `lo` is seen (the path's own edge), `hi` is not.
            let (mut lo, mut hi) = (a + 1, m - 1);
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if sees(composite, w, mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lo
        };
        w.copy_within(b * n..(b + 1) * n, kept * n);
        (a, kept) = (b, kept + 1);
    }
    kept
}
