//! The approach: from where the arms stand (`initial`) to where their plan begins.
//!
//! Planners choose each robot's first configuration on its first pose's manifold, generally
//! away from where the arm stands. The approach joins them: robot `i`'s timeline is `initial`,
//! `approach[i][0..A]`, then its path, at `dt` spacing, the same `A` for every robot. All arms
//! move at once; an arm may wait while another passes. Four planners are tried, cheapest
//! first, and the first that finds a collision-free approach wins ([`Method`]):
//! 1. all arms together along their straight joint-space bridges;
//! 2. one arm at a time along its bridge, in any order in which every bridge is free (found
//!    over all orders from a few checks of one arm against one other: `orders.rs`);
//! 3. one arm at a time again, first in the order with the fewest blocked bridges, each arm
//!    whose straight bridge is blocked through a via configuration (turn about the base first,
//!    or take the shape first: `via.rs`) or else along an RRT-Connect path in its own space
//!    around the others standing, in up to
//!    [`ApproachParams::rrt_orders`] orders;
//! 4. RRT-Connect on the arms' composite configuration space with shortcutting (`rrt.rs`):
//!    probabilistically complete, so with a growing sample budget it finds any approach that
//!    has some clearance ([`crate::embody`] grows the budget until the deadline).
//!
//! Every motion is checked like a planned one (obstacles, the arm itself, the other arms; the
//! conservative sweeps of [`crate::motion`]). The waypoints found are then timed (`timing.rs`):
//! straight segments with a cosine profile from rest to rest, slow enough for the velocity
//! and acceleration limits. Deterministic for a given [`ApproachParams::seed`].
//!
//! Memory: [`ApproachStorage`] is the caller's. A tree node costs `robots * D * 8 + 4` bytes;
//! a full tree ends that search as a spent sample budget does (the budget is the lesser of the
//! two).
//!
//! [`plan_approach`] has a runnable example; [`crate::embody`] runs the approach after a
//! planner, trying other starts until one can be reached.

mod composite;
mod orders;
mod query;
mod rrt;
mod timing;
mod via;

pub use composite::{Blocked, Touch};
pub use query::{Approach, ApproachError, ApproachParams, ApproachQuery, ApproachStorage, Method};

use crate::model::Models;
use crate::pp::{identity, next_permutation};
use crate::problem::{Problem, MAX_ROBOTS};

use composite::Composite;
use orders::Bridges;
use rrt::{Connect, Miss};

/// The first robot whose `initial` is outside its limits or touches an obstacle, itself or
/// another robot's `initial`. Robots without `initial` are left out.
pub fn check_starts<M: Models<D>, const D: usize>(problem: &Problem<D>) -> Result<(), Blocked> {
    let mut composite = Composite::<M, D>::new(problem, crate::motion::MOTION_STEP)
        .restricted(|i| problem.robots[i].initial.is_some());
    let q: [[f64; D]; MAX_ROBOTS] = core::array::from_fn(|i| {
        problem
            .robots
            .get(i)
            .and_then(|r| r.initial)
            .unwrap_or([0.0; D])
    });
    match composite.state_blocked(&q[..composite.n]) {
        Some(b) => Err(b),
        None => Ok(()),
    }
}

/// The first robot whose configuration `q[i]` is outside its limits or touches an obstacle,
/// itself or another robot's `q` (every robot of `problem`, one configuration each).
pub fn configurations_blocked<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    q: &[[f64; D]],
) -> Option<Blocked> {
    let mut composite = Composite::<M, D>::new(problem, crate::motion::MOTION_STEP);
    composite.state_blocked(&q[..composite.n.min(q.len())])
}

/// Where each robot stands and where its path begins: `paths[i * h]` (a robot without
/// `initial` starts there too).
struct Ends<const D: usize> {
    starts: [[f64; D]; MAX_ROBOTS],
    goals: [[f64; D]; MAX_ROBOTS],
}

impl<const D: usize> Ends<D> {
    fn new(problem: &Problem<D>, paths: &[[f64; D]], h: usize) -> Result<Self, ApproachError> {
        let n = problem.robots.len();
        if n == 0 || h == 0 || paths.len() < n * h {
            return Err(ApproachError::Invalid(
                "paths shorter than robots * horizon",
            ));
        }
        let goals: [[f64; D]; MAX_ROBOTS] =
            core::array::from_fn(|i| paths[(i * h).min(paths.len() - 1)]);
        let starts = core::array::from_fn(|i| {
            problem
                .robots
                .get(i)
                .and_then(|r| r.initial)
                .unwrap_or(goals[i])
        });
        Ok(Ends { starts, goals })
    }
}

/// Plans the approach of every robot of the query's problem from its `initial` to its path's
/// first configuration: straight together, one at a time, one at a time with RRT-Connect per
/// arm, then RRT-Connect on the composite space, with `q.params.rrt_samples` samples. Writes
/// robot `i`'s approach to `out[i * cap..i * cap + A]` with `cap = out.len() / robots`.
///
/// A buffer too short for the approach is [`ApproachError::TooLong`] (nothing truncated), a
/// full [`ApproachStorage`] [`ApproachError::OutOfMemory`], a start that collides
/// [`ApproachError::Start`]. A Gen3 standing upright, whose plan begins bent forward:
///
/// ```
/// use omcbsa_core::approach::{plan_approach, ApproachError, ApproachParams, ApproachQuery};
/// use omcbsa_core::approach::{ApproachStorage, Method};
/// use omcbsa_core::model::{Frame, KinovaGen3, Model};
/// use omcbsa_core::problem::{Problem, Robot};
/// use omcbsa_core::search::NoDeadline;
///
/// let mut problem = Problem::<7>::new(0.1);
/// let mut gen3 = Robot::at(0, Frame::IDENTITY);
/// gen3.initial = Some([0.0; 7]);
/// problem.robots.push(gen3).unwrap();
/// // The plan (2 steps) the approach leads to.
/// let bent = [0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0];
/// let plan = [bent, bent];
/// let query = ApproachQuery {
///     problem: &problem,
///     plan: &plan,
///     horizon: 2,
///     params: ApproachParams::default(),
///     deadline: &NoDeadline,
/// };
/// // RRT-Connect's trees (robots configurations a node), their parents, and waypoints
/// // (robots configurations each, at least robots + 1 of them).
/// let mut tree = [[0.0; 7]; 64];
/// let mut parent = [0u32; 64];
/// let mut waypoints = [[0.0; 7]; 16];
/// let mut storage = ApproachStorage {
///     tree: &mut tree,
///     parent: &mut parent,
///     waypoints: &mut waypoints,
/// };
///
/// let mut out = [[0.0; 7]; 64];
/// let approach = plan_approach::<KinovaGen3, 7>(&query, &mut storage, &mut out).unwrap();
/// assert_eq!(approach.method, Method::Together);
/// // From `initial` through the approach to the plan, within 90 % of every joint's speed
/// // limit (`ApproachParams::speed`).
/// let a = approach.len;
/// let mut last = [0.0; 7];
/// for q in out[..a].iter().chain([&bent]) {
///     for j in 0..7 {
///         assert!((q[j] - last[j]).abs() <= 0.9 * KinovaGen3::VELOCITY[j] * problem.dt + 1e-12);
///     }
///     last = *q;
/// }
///
/// // Too short a buffer is refused, not truncated.
/// let mut short = [[0.0; 7]; 4];
/// match plan_approach::<KinovaGen3, 7>(&query, &mut storage, &mut short) {
///     Err(ApproachError::TooLong { needed, capacity: 4 }) => assert_eq!(needed, a),
///     other => panic!("{other:?}"),
/// }
/// ```
pub fn plan_approach<M: Models<D>, const D: usize>(
    q: &ApproachQuery<'_, D>,
    storage: &mut ApproachStorage<'_, D>,
    out: &mut [[f64; D]],
) -> Result<Approach, ApproachError> {
    let (problem, params) = (q.problem, &q.params);
    let ends = Ends::new(problem, q.plan, q.horizon)?;
    let mut composite = Composite::<M, D>::new(problem, params.motion_step);
    let n = composite.n;
    let (starts, goals) = (&ends.starts[..n], &ends.goals[..n]);
    if let Some(b) = composite.state_blocked(starts) {
        return Err(ApproachError::Start(b));
    }
    if storage.waypoints.len() < (n + 1) * n {
        return Err(ApproachError::OutOfMemory("approach waypoints"));
    }
    let models = composite.models();
    let timed = |m: usize, method: Method, st: &ApproachStorage<'_, D>, out: &mut [[f64; D]]| {
        let len =
            timing::write::<M, D>(&models, &st.waypoints[..m * n], n, problem.dt, params, out)?;
        let method = if len == 0 && starts == goals {
            Method::None
        } else {
            method
        };
        Ok(Approach { len, method })
    };
    // All together.
    let together = composite.motion_blocked(starts, goals);
    if together.is_none() {
        storage.waypoints[..n].copy_from_slice(starts);
        storage.waypoints[n..2 * n].copy_from_slice(goals);
        return timed(2, Method::Together, storage, out);
    }
    let (robot, other) = together.unwrap_or((0, None));
    // One at a time: an order in which every straight bridge is free, found over all orders
    // from each bridge's checks against each other arm at either end (`orders.rs`).
    let mut bridges = Bridges::new(&composite, starts, goals);
    let moving = bridges.moving();
    if let Some(order) = params
        .ordered
        .then(|| bridges.free_order(&composite))
        .flatten()
    {
        let w = &mut *storage.waypoints;
        w[..n].copy_from_slice(starts);
        for (m, &r) in order[..moving].iter().enumerate() {
            let r = usize::from(r);
            w.copy_within(m * n..(m + 1) * n, (m + 1) * n);
            w[(m + 1) * n + r] = goals[r];
        }
        return timed(moving + 1, Method::Ordered, storage, out);
    }
    if q.deadline.expired() {
        return Err(ApproachError::Timeout);
    }
    // One arm at a time, each around the others standing (a detour or RRT-Connect in its own
    // space when its straight bridge is blocked): cheap where one composite search would be
    // slow. First the order with the fewest blocked bridges, then others in turn.
    let mut best = [0u8; MAX_ROBOTS];
    let mut order = identity(n);
    let all_arms = Connect {
        start: starts,
        goal: goals,
        free: u32::MAX,
        seed: params.seed,
    };
    for attempt in 0..params.rrt_orders {
        let this = if attempt == 0 {
            best = bridges.fewest_blocked(&composite);
            &best[..moving]
        } else {
            let moves = |r: &&u8| starts[usize::from(**r)] != goals[usize::from(**r)];
            if order[..n].iter().filter(moves).eq(&best[..moving]) {
                // Tried first.
                if !next_permutation(&mut order[..n]) {
                    break;
                }
                continue;
            }
            &order[..n]
        };
        if let Some(m) = one_at_a_time(&mut composite, &mut bridges, &all_arms, this, q, storage)? {
            return timed(m, Method::OrderedRrt, storage, out);
        }
        if attempt > 0 && !next_permutation(&mut order[..n]) {
            break;
        }
    }
    match rrt::connect(&composite, &all_arms, params, storage, q.deadline) {
        Ok(m) => timed(m, Method::Rrt, storage, out),
        Err(Miss::Budget) => Err(ApproachError::Blocked { robot, other }),
        Err(Miss::Failed(e)) => Err(e),
    }
}

/// The robots whose approach fails even with the other arms out of the way (RRT-Connect with
/// `q.params.rrt_samples` samples for that arm alone), as a bit set. Ok(0): each arm alone
/// can make it.
pub fn blocked_alone<M: Models<D>, const D: usize>(
    q: &ApproachQuery<'_, D>,
    storage: &mut ApproachStorage<'_, D>,
) -> Result<u32, ApproachError> {
    let ends = Ends::new(q.problem, q.plan, q.horizon)?;
    let all = Composite::<M, D>::new(q.problem, q.params.motion_step);
    let n = all.n;
    let (starts, goals) = (&ends.starts[..n], &ends.goals[..n]);
    let mut blocked = 0u32;
    for i in (0..n).filter(|&i| starts[i] != goals[i]) {
        let mut alone = all.restricted(|k| k == i);
        if alone.motion_blocked(starts, goals).is_none() {
            continue;
        }
        let ask = Connect {
            start: starts,
            goal: goals,
            free: 1 << i,
            seed: q.params.seed,
        };
        match rrt::connect(&alone, &ask, &q.params, storage, q.deadline) {
            Ok(_) => {}
            Err(Miss::Budget) => blocked |= 1 << i,
            Err(Miss::Failed(e)) => return Err(e),
        }
    }
    Ok(blocked)
}

/// Moves the arms to their goals (`ends.goal`, from `ends.start`) one at a time in `order`,
/// each along its straight bridge or, when that is blocked, a detour through a via
/// configuration or an RRT-Connect path of that arm alone around the others standing.
/// Writes the waypoints and returns how many; `None` when some arm's path was not found.
fn one_at_a_time<M: Models<D>, const D: usize>(
    composite: &mut Composite<'_, M, D>,
    bridges: &mut Bridges<'_, D>,
    ends: &Connect<'_, D>,
    order: &[u8],
    q: &ApproachQuery<'_, D>,
    st: &mut ApproachStorage<'_, D>,
) -> Result<Option<usize>, ApproachError> {
    let (starts, goals, params) = (ends.start, ends.goal, &q.params);
    let n = composite.n;
    st.waypoints[..n].copy_from_slice(starts);
    let (mut m, mut done) = (1, 0u32);
    for &r in order {
        let r = usize::from(r);
        if starts[r] == goals[r] {
            continue;
        }
        let from = (m - 1) * n;
        if st.waypoints.len() < from + 2 * n {
            return Err(ApproachError::OutOfMemory("approach waypoints"));
        }
        let mut at = [[0.0; D]; MAX_ROBOTS];
        at[..n].copy_from_slice(&st.waypoints[from..from + n]);
        let mut target = at;
        target[r] = goals[r];
        let blocked = bridges.blocked(composite, r, done);
        done |= 1 << r;
        if !blocked {
            st.waypoints[from + n..from + 2 * n].copy_from_slice(&target[..n]);
            m += 1;
            continue;
        }
        if let Some(k) = via::detour(
            composite,
            &at[..n],
            r,
            &goals[r],
            &mut st.waypoints[from + n..],
        ) {
            m += k;
            continue;
        }
        let mut sub = ApproachStorage {
            tree: &mut *st.tree,
            parent: &mut *st.parent,
            waypoints: &mut st.waypoints[from..],
        };
        let ask = Connect {
            start: &at[..n],
            goal: &target[..n],
            free: 1 << r,
            seed: params.seed ^ (r as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15),
        };
        let path = rrt::connect(composite, &ask, params, &mut sub, q.deadline);
        match path {
            Ok(k) => m += k - 1,
            Err(Miss::Budget) => return Ok(None),
            Err(Miss::Failed(e)) => return Err(e),
        }
    }
    Ok(Some(m))
}
