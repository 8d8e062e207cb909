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

mod fleet;
mod orders;
mod rrt;
mod timing;
mod via;

pub use fleet::{Blocked, Touch};

use crate::model::Models;
use crate::pp::{identity, next_permutation};
use crate::problem::{Problem, MAX_ROBOTS};
use crate::search::Deadline;

use fleet::Fleet;
use orders::Bridges;
use rrt::Miss;

/// Tunables of the approach.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApproachParams {
    /// Share of each joint's velocity limit the approach may use (0 < speed <= 1).
    pub speed: f64,
    /// Share of each joint's acceleration limit ([`Model::ACCELERATION`](crate::model::Model::ACCELERATION)) the approach may
    /// use (0: no acceleration limit).
    pub acceleration: f64,
    /// See [`crate::search::OmegaParams::motion_step`].
    pub motion_step: f64,
    /// Whether the arms may take their straight bridges one at a time, in any order, when
    /// they cannot all move together.
    pub ordered: bool,
    /// Most priority orders tried one arm at a time with RRT-Connect per arm, before
    /// RRT-Connect on the composite space.
    pub rrt_orders: usize,
    /// RRT-Connect's longest edge, in seconds of motion at full speed. A motion check costs
    /// far less than in proportion to its length (the sweeps bisect, and a far-away motion is
    /// one check), so long edges reach as far with fewer nodes and checks.
    pub rrt_step: f64,
    /// RRT-Connect's samples in a first attempt ([`crate::embody`] doubles it on each retry).
    pub rrt_samples: u32,
    /// Seed of RRT-Connect's samples.
    pub seed: u64,
    /// Radius (joint space, rad) around a start whose approach failed in which
    /// [`crate::embody`] keeps the planner from choosing its next start.
    pub exclusion_radius: f64,
}

impl Default for ApproachParams {
    fn default() -> Self {
        ApproachParams {
            speed: 0.9,
            acceleration: 1.0,
            motion_step: crate::motion::MOTION_STEP,
            ordered: true,
            rrt_orders: 6,
            rrt_step: 0.5,
            rrt_samples: 400,
            seed: 0x0a99_7a0c,
            exclusion_radius: 0.5,
        }
    }
}

/// How the approach was found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// Nothing to do: every arm stands where its plan begins.
    #[default]
    None,
    /// All arms together along their straight bridges.
    Together,
    /// One arm at a time along its straight bridge.
    Ordered,
    /// One arm at a time, each along an RRT-Connect path around the others standing.
    OrderedRrt,
    /// RRT-Connect on the composite space, shortcut.
    Rrt,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::None => "none",
            Method::Together => "together",
            Method::Ordered => "ordered",
            Method::OrderedRrt => "ordered-rrt",
            Method::Rrt => "rrt-connect",
        }
    }
}

/// An approach written to the caller's buffer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Approach {
    /// Configurations per robot (`A`).
    pub len: usize,
    pub method: Method,
}

/// Why no approach was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ApproachError {
    /// A robot's `initial` is outside its limits or collides.
    Start(Blocked),
    /// The approach needs `needed` configurations per robot; the buffer holds `capacity`.
    TooLong { needed: usize, capacity: usize },
    /// No planner found an approach within its budget. The first motion the arms moving
    /// together failed on: robot `robot`'s, against robot `other` or obstacles / itself.
    Blocked { robot: usize, other: Option<usize> },
    /// The deadline passed.
    Timeout,
    /// A buffer of [`ApproachStorage`] is full; the message names it.
    OutOfMemory(&'static str),
    /// The problem or the buffers do not fit (robots, paths).
    Invalid(&'static str),
}

/// Caller storage of the approach planners.
pub struct ApproachStorage<'a, const D: usize> {
    /// RRT-Connect's two trees: `robots` configurations per node, half the nodes per tree.
    pub tree: &'a mut [[f64; D]],
    /// Each node's parent (at least as many as the nodes `tree` holds).
    pub parent: &'a mut [u32],
    /// The approach's waypoints, `robots` configurations each: at least `robots + 1` of them
    /// (the one-at-a-time orders), and as many as the longest RRT-Connect path kept.
    pub waypoints: &'a mut [[f64; D]],
}

/// The first robot whose `initial` is outside its limits or touches an obstacle, itself or
/// another robot's `initial`. Robots without `initial` are left out.
pub fn check_starts<M: Models<D>, const D: usize>(problem: &Problem<D>) -> Result<(), Blocked> {
    let mut fleet = Fleet::<M, D>::new(problem, crate::motion::MOTION_STEP)
        .restricted(|i| problem.robots[i].initial.is_some());
    let q: [[f64; D]; MAX_ROBOTS] = core::array::from_fn(|i| {
        problem
            .robots
            .get(i)
            .and_then(|r| r.initial)
            .unwrap_or([0.0; D])
    });
    match fleet.state_blocked(&q[..fleet.n]) {
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
    let mut fleet = Fleet::<M, D>::new(problem, crate::motion::MOTION_STEP);
    fleet.state_blocked(&q[..fleet.n.min(q.len())])
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

/// Plans the approach of every robot of `problem` from its `initial` (a robot without one
/// starts where its path does) to its path's first configuration, `paths[i * h]` for a horizon
/// `h`: straight together, one at a time, one at a time with RRT-Connect per arm, then
/// RRT-Connect on the composite space, with `samples` samples.
/// Writes robot `i`'s approach to `out[i * cap..i * cap + A]` with `cap = out.len() / robots`.
#[allow(clippy::too_many_arguments)]
pub fn plan_approach<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    paths: &[[f64; D]],
    h: usize,
    params: &ApproachParams,
    samples: u32,
    storage: &mut ApproachStorage<'_, D>,
    deadline: &dyn Deadline,
    out: &mut [[f64; D]],
) -> Result<Approach, ApproachError> {
    let ends = Ends::new(problem, paths, h)?;
    let mut fleet = Fleet::<M, D>::new(problem, params.motion_step);
    let n = fleet.n;
    let (starts, goals) = (&ends.starts[..n], &ends.goals[..n]);
    if let Some(b) = fleet.state_blocked(starts) {
        return Err(ApproachError::Start(b));
    }
    if storage.waypoints.len() < (n + 1) * n {
        return Err(ApproachError::OutOfMemory("approach waypoints"));
    }
    let models = fleet.models();
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
    let together = fleet.motion_blocked(starts, goals);
    if together.is_none() {
        storage.waypoints[..n].copy_from_slice(starts);
        storage.waypoints[n..2 * n].copy_from_slice(goals);
        return timed(2, Method::Together, storage, out);
    }
    let (robot, other) = together.unwrap_or((0, None));
    // One at a time: an order in which every straight bridge is free, found over all orders
    // from each bridge's checks against each other arm at either end (`orders.rs`).
    let mut bridges = Bridges::new(&fleet, starts, goals);
    let moving = bridges.moving();
    if let Some(order) = params.ordered.then(|| bridges.free_order(&fleet)).flatten() {
        let w = &mut *storage.waypoints;
        w[..n].copy_from_slice(starts);
        for (m, &r) in order[..moving].iter().enumerate() {
            let r = usize::from(r);
            w.copy_within(m * n..(m + 1) * n, (m + 1) * n);
            w[(m + 1) * n + r] = goals[r];
        }
        return timed(moving + 1, Method::Ordered, storage, out);
    }
    if deadline.expired() {
        return Err(ApproachError::Timeout);
    }
    // One arm at a time, each around the others standing (a detour or RRT-Connect in its own
    // space when its straight bridge is blocked): cheap where one composite search would be
    // slow. First the order with the fewest blocked bridges, then others in turn.
    let mut best = [0u8; MAX_ROBOTS];
    let mut order = identity(n);
    for attempt in 0..params.rrt_orders {
        let this = if attempt == 0 {
            best = bridges.fewest_blocked(&fleet);
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
        let m = one_at_a_time(
            &mut fleet,
            &mut bridges,
            starts,
            goals,
            this,
            params,
            samples,
            storage,
            deadline,
        )?;
        if let Some(m) = m {
            return timed(m, Method::OrderedRrt, storage, out);
        }
        if attempt > 0 && !next_permutation(&mut order[..n]) {
            break;
        }
    }
    match rrt::connect(
        &fleet,
        starts,
        goals,
        u32::MAX,
        params,
        samples,
        params.seed,
        storage,
        deadline,
    ) {
        Ok(m) => timed(m, Method::Rrt, storage, out),
        Err(Miss::Budget) => Err(ApproachError::Blocked { robot, other }),
        Err(Miss::Failed(e)) => Err(e),
    }
}

/// The robots whose approach fails even with the other arms out of the way (RRT-Connect with
/// `samples` samples for that arm alone), as a bit set. Ok(0): each arm alone can make it.
#[allow(clippy::too_many_arguments)]
pub fn blocked_alone<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    paths: &[[f64; D]],
    h: usize,
    params: &ApproachParams,
    samples: u32,
    storage: &mut ApproachStorage<'_, D>,
    deadline: &dyn Deadline,
) -> Result<u32, ApproachError> {
    let ends = Ends::new(problem, paths, h)?;
    let all = Fleet::<M, D>::new(problem, params.motion_step);
    let n = all.n;
    let (starts, goals) = (&ends.starts[..n], &ends.goals[..n]);
    let mut blocked = 0u32;
    for i in (0..n).filter(|&i| starts[i] != goals[i]) {
        let mut alone = all.restricted(|k| k == i);
        if alone.motion_blocked(starts, goals).is_none() {
            continue;
        }
        match rrt::connect(
            &alone,
            starts,
            goals,
            1 << i,
            params,
            samples,
            params.seed,
            storage,
            deadline,
        ) {
            Ok(_) => {}
            Err(Miss::Budget) => blocked |= 1 << i,
            Err(Miss::Failed(e)) => return Err(e),
        }
    }
    Ok(blocked)
}

/// Moves the arms to their goals one at a time in `order`, each along its straight bridge or,
/// when that is blocked, a detour through a via configuration or an RRT-Connect path of that
/// arm alone around the others standing.
/// Writes the waypoints and returns how many; `None` when some arm's path was not found.
#[allow(clippy::too_many_arguments)]
fn one_at_a_time<M: Models<D>, const D: usize>(
    fleet: &mut Fleet<'_, M, D>,
    bridges: &mut Bridges<'_, D>,
    starts: &[[f64; D]],
    goals: &[[f64; D]],
    order: &[u8],
    params: &ApproachParams,
    samples: u32,
    st: &mut ApproachStorage<'_, D>,
    deadline: &dyn Deadline,
) -> Result<Option<usize>, ApproachError> {
    let n = fleet.n;
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
        let blocked = bridges.blocked(fleet, r, done);
        done |= 1 << r;
        if !blocked {
            st.waypoints[from + n..from + 2 * n].copy_from_slice(&target[..n]);
            m += 1;
            continue;
        }
        if let Some(k) = via::detour(fleet, &at[..n], r, &goals[r], &mut st.waypoints[from + n..]) {
            m += k;
            continue;
        }
        let mut sub = ApproachStorage {
            tree: &mut *st.tree,
            parent: &mut *st.parent,
            waypoints: &mut st.waypoints[from..],
        };
        let seed = params.seed ^ (r as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let path = rrt::connect(
            fleet,
            &at[..n],
            &target[..n],
            1 << r,
            params,
            samples,
            seed,
            &mut sub,
            deadline,
        );
        match path {
            Ok(k) => m += k - 1,
            Err(Miss::Budget) => return Ok(None),
            Err(Miss::Failed(e)) => return Err(e),
        }
    }
    Ok(Some(m))
}
