//! Ω-A*_single and multi-goal Ω-A* (Shaoul, Li, Likhachev), with additions to the paper's:
//! joint velocity limits between consecutive states, swept-motion checks, point constraints
//! and assignment constraints from the high level, and bounded memory.
//!
//! States are `(q, t, j)`: a configuration whose tool centre point is at pose `t` of trajectory
//! `j`. OPEN starts with IK solutions from diverse seeds for the first pose of every allowed
//! trajectory. A state's successors realise pose `t + 1`: the IK projection `q'` of the parent,
//! then `q' ± ε n` for every null-space basis direction `n` at `q'`, each corrected by IK back
//! onto the pose. `f = g + w_h (H - 1 - t) + w_c c` with `g` the joint-space path length and `c`
//! the collisions with the other robots' given paths.

use core::cell::Cell;

use crate::collision::ArmPose;
use crate::geometry::Obstacle;
use crate::ik::ik;
use crate::kinematics::{axis_separation, null_space_basis, twist, SpeedMap};
use nalgebra::Vector6;

use crate::model::{Frame, Models};
use crate::problem::{Robot, Start, Trajectory};
use crate::rng::Rng;

use super::constraints::{OtherArm, OthersMode, PointConstraint};
use super::params::OmegaParams;
use super::validity::Validity;
use super::workspace::{Met, Node, StateKey, Workspace};
use super::{Deadline, OpenEntry};

/// What IK gave for one start seed, remembered across the searches of one planning run (see
/// [`Query::starts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum StartIk<const D: usize> {
    /// Not tried yet.
    #[default]
    Unknown,
    /// IK found no answer from this seed.
    Failed,
    /// IK's answer from this seed.
    Solved([f64; D]),
}

/// The start-seed IK answers of every robot of one planning run, in caller storage.
#[derive(Clone, Copy)]
pub struct StartCache<'a, const D: usize> {
    cells: &'a [Cell<StartIk<D>>],
    per_robot: usize,
}

impl<'a, const D: usize> StartCache<'a, D> {
    /// Forgets every answer in `buf` and lays it out for `robots` robots: as many of each
    /// trajectory's first seeds as fit, up to all those of the finest refinement level of `p`
    /// ([`super::refine`]). Later seeds are solved by IK in every search that reaches them.
    pub fn new(
        buf: &'a mut [StartIk<D>],
        robots: usize,
        trajectories: usize,
        p: &OmegaParams,
    ) -> Self {
        let finest = super::refine::level_params(p, super::refine::LEVELS - 1);
        let fit = buf.len() / (robots * trajectories).max(1);
        let per_robot = trajectories * fit.min(finest.start_attempts as usize + 1);
        let used = per_robot * robots;
        buf[..used].iter_mut().for_each(|e| *e = StartIk::Unknown);
        StartCache {
            cells: Cell::from_mut(&mut buf[..used]).as_slice_of_cells(),
            per_robot,
        }
    }

    /// Robot `i`'s entries, for [`Query::starts`].
    pub fn robot(&self, i: usize) -> &'a [Cell<StartIk<D>>] {
        self.cells
            .get(i * self.per_robot..(i + 1) * self.per_robot)
            .unwrap_or(&[])
    }
}

/// One low-level planning request.
#[derive(Clone, Copy)]
pub struct Query<'a, const D: usize> {
    /// The robot: its model, base, tool, start, fixed assignment and excluded starts.
    pub robot: Robot<D>,
    /// All trajectories of the problem (same length H).
    pub trajectories: &'a [Trajectory],
    /// Bit `j` set: the robot may take trajectory `j` (assignment constraints clear bits).
    pub allowed: u32,
    /// Whether holding `robot.initial` for the whole horizon is an answer (tried only when no
    /// allowed trajectory can be tracked).
    pub hold: bool,
    /// The fixed obstacles.
    pub obstacles: &'a [Obstacle],
    /// The other robots' paths (moving obstacles): fewer than
    /// [`MAX_ROBOTS`](crate::problem::MAX_ROBOTS), each of at least H configurations.
    pub others: &'a [OtherArm<'a, D>],
    /// Whether meeting the other robots is forbidden or counted.
    pub others_mode: OthersMode,
    /// Where the robot may not be (Ω-CBSA's constraints on it).
    pub points: &'a [PointConstraint],
    /// Time between steps, s.
    pub dt: f64,
    /// This robot's start-seed IK answers, kept across its searches in one planning run: a
    /// trajectory's seeds are the same in every search, so a replan (under one more
    /// constraint, or another priority order) skips the random-seed IK, the costliest part of
    /// a short search. The same number for every trajectory (the first seeds of each), all
    /// `Unknown` when the run starts; empty to remember nothing.
    pub starts: &'a [Cell<StartIk<D>>],
}

/// Counters of one search.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SearchStats {
    /// States expanded.
    pub expansions: u32,
    /// States generated (stored in the workspace).
    pub generated: u32,
}

/// A path was found and written to the caller's buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Found {
    /// The trajectory tracked, or `None` when the robot holds its initial configuration.
    pub trajectory: Option<u8>,
    /// Collisions with the other robots' paths (always 0 in `Avoid` mode).
    pub collisions: u32,
    /// Bit `k`: the path meets `others[k]` somewhere (a superset when not known exactly).
    pub met: Met,
}

/// Why no path was returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SearchError {
    /// Every reachable state was expanded: no path exists in the search space.
    NoSolution,
    /// The node pool or OPEN list is full.
    OutOfMemory,
    /// The deadline passed.
    Timeout,
    /// The query cannot be searched (empty trajectories, output buffer too short, ...).
    InvalidQuery(&'static str),
}

/// Expansions between two looks at the deadline.
const CHECK_EVERY: u32 = 32;

/// Most successors one state can have: the projection and `±ε` along up to three null-space
/// directions.
pub const MAX_MOVES: usize = 7;
// A node's moves are checked as one batch.
const _: () = assert!(MAX_MOVES <= crate::lanes::LANES);

/// The candidate successors of `q` on the manifold of `target` (before any validity check):
/// the IK projection `q'` of `q`, then `IK(target, q' ± ε n)` for each null-space basis
/// direction `n` at `q'`. Returns how many were written to `out`.
pub fn manifold_moves<M: Models<D>, const D: usize>(
    model: u8,
    target: &Frame,
    q: &[f64; D],
    p: &OmegaParams,
    out: &mut [[f64; D]; MAX_MOVES],
) -> usize {
    let Ok(proj) = ik::<M, D>(model, target, q, &p.ik) else {
        return 0;
    };
    out[0] = proj;
    let mut n = 1;
    let (_, jac) = M::jacobian(model, &proj);
    let basis = null_space_basis::<D>(&jac);
    for dir in basis.iter() {
        for sign in [1.0, -1.0] {
            if n == MAX_MOVES {
                return n;
            }
            let mut moved = proj;
            for i in 0..D {
                moved[i] += sign * p.epsilon * dir[i];
            }
            if let Ok(q2) = ik::<M, D>(model, target, &moved, &p.ik) {
                out[n] = q2;
                n += 1;
            }
        }
    }
    n
}

/// The cost a step to `q` adds besides its length: `q` nearing two collinear joint axes
/// ([`OmegaParams::w_a`]), the joints' speed headroom for the hand's `twist` there (base
/// frame; [`OmegaParams::w_v`]) and their reserve for any motion of the tool
/// ([`OmegaParams::w_r`]). 0 when every weight is.
pub fn step_cost<M: Models<D>, const D: usize>(
    model: u8,
    q: &[f64; D],
    twist: &Vector6<f64>,
    p: &OmegaParams,
) -> f64 {
    if p.w_a <= 0.0 && p.w_v <= 0.0 && p.w_r <= 0.0 {
        return 0.0;
    }
    let (tool, jac) = M::jacobian(model, q);
    let mut cost = 0.0;
    if p.w_a > 0.0 {
        cost += p.w_a * (p.axis_margin - axis_separation::<D>(&jac)).max(0.0);
    }
    if p.w_v <= 0.0 && p.w_r <= 0.0 {
        return cost;
    }
    // A step the joints cannot take at all is refused elsewhere; here it only costs most.
    let over = |ratio: f64| (ratio.min(2.0) - p.speed_margin).max(0.0);
    let Some(map) = SpeedMap::new(&jac, M::velocity(model)) else {
        return cost + over(f64::INFINITY) * (p.w_v + 6.0 * p.w_r);
    };
    if p.w_v > 0.0 {
        cost += p.w_v * over(map.ratio(twist));
    }
    if p.w_r > 0.0 {
        // Translating along, and turning about, each of the tool's axes.
        let (linear, angular) = p.reserve_speed;
        for axis in 0..3 {
            let a = tool.rot.column(axis);
            for (l, w) in [(linear, 0.0), (0.0, angular)] {
                let reference = Vector6::new(a.x * l, a.y * l, a.z * l, a.x * w, a.y * w, a.z * w);
                cost += p.w_r * over(map.ratio(&reference));
            }
        }
    }
    cost
}

/// Runs Ω-A* and writes the path (one configuration per step) to `out[..H]`.
///
/// Bad queries are [`SearchError::InvalidQuery`] with the reason (no or ragged trajectories,
/// more than 32 of them, `out` shorter than H, a start or hold at `initial` without one); a
/// full workspace [`SearchError::OutOfMemory`]; the deadline is looked at every 32
/// expansions. The [`crate::search`] module's documentation has a runnable example.
pub fn plan<M: Models<D>, const D: usize>(
    query: &Query<'_, D>,
    params: &OmegaParams,
    ws: &mut Workspace<'_, D>,
    deadline: &dyn Deadline,
    out: &mut [[f64; D]],
    stats: &mut SearchStats,
) -> Result<Found, SearchError> {
    let h = query.trajectories.first().map_or(0, |t| t.len());
    if h == 0 {
        return Err(SearchError::InvalidQuery(
            "no trajectory or empty trajectory",
        ));
    }
    if query.trajectories.iter().any(|t| t.len() != h) {
        return Err(SearchError::InvalidQuery("trajectories differ in length"));
    }
    if out.len() < h {
        return Err(SearchError::InvalidQuery(
            "output buffer shorter than the horizon",
        ));
    }
    if query.trajectories.len() > 32 {
        return Err(SearchError::InvalidQuery("more than 32 trajectories"));
    }
    // A robot's fixed part of the assignment narrows what the planner allows.
    let query = &Query {
        allowed: query.allowed & query.robot.assigned.mask(),
        hold: query.robot.assigned.may_hold(query.hold),
        ..*query
    };
    if query.robot.start == Start::AtInitial && query.robot.initial.is_none() {
        return Err(SearchError::InvalidQuery(
            "start at initial without an initial configuration",
        ));
    }
    if query.hold && query.robot.initial.is_none() {
        return Err(SearchError::InvalidQuery(
            "hold requested without an initial configuration",
        ));
    }
    let params = &params.at_step(query.dt);
    let ctx = Ctx::<M, D>::new(query, params, h);
    ws.reset();
    let mask = if query.trajectories.len() == 32 {
        u32::MAX
    } else {
        (1u32 << query.trajectories.len()) - 1
    };
    if query.allowed & mask != 0 {
        match ctx.search(ws, deadline, out, stats) {
            Err(SearchError::NoSolution) if query.hold => {}
            other => return other,
        }
    }
    if query.hold {
        if let Some(c) = ctx.hold_path(out) {
            // Holding is checked as a count: which robots it meets is not kept.
            return Ok(Found {
                trajectory: None,
                collisions: c,
                met: if c == 0 { 0 } else { Met::MAX },
            });
        }
    }
    Err(SearchError::NoSolution)
}

/// Two arms placed, each with the configuration it is placed at (`None`: not yet).
struct ArmCache<const D: usize>([(Option<[f64; D]>, ArmPose); 2]);

impl<const D: usize> ArmCache<D> {
    fn new() -> Self {
        ArmCache([(None, ArmPose::EMPTY), (None, ArmPose::EMPTY)])
    }
}

/// An initial state of the search (no parent, motion nothing to check).
fn start_node<const D: usize>(q: [f64; D], g: f64, met: Met, j: u8) -> Node<D> {
    Node {
        q,
        g,
        parent: u32::MAX,
        t: 0,
        c: met.count_ones() as u16,
        j,
        closed: false,
        checked: true,
        dead: false,
        met,
    }
}

struct Ctx<'q, 'a, M, const D: usize> {
    q: &'q Query<'a, D>,
    p: &'q OmegaParams,
    h: usize,
    base_inv: Frame,
    tcp_inv: Frame,
    valid: Validity<'q, M, D>,
}

impl<'q, 'a: 'q, M: Models<D>, const D: usize> Ctx<'q, 'a, M, D> {
    fn new(q: &'q Query<'a, D>, p: &'q OmegaParams, h: usize) -> Self {
        let valid = Validity::new(&q.robot, q.obstacles, q.dt, p.motion_step)
            .with_others(q.others, q.others_mode)
            .with_points(q.points);
        Ctx {
            q,
            p,
            h,
            base_inv: q.robot.base.inverse(),
            tcp_inv: q.robot.tcp.inverse(),
            valid,
        }
    }

    /// Pose `t` of trajectory `j` as a target for the model's tool frame in its base frame.
    fn target(&self, j: usize, t: usize) -> Frame {
        self.base_inv
            .compose(&self.q.trajectories[j][t])
            .compose(&self.tcp_inv)
    }

    fn f(&self, g: f64, t: usize, c: u16) -> f64 {
        g + self.p.w_h * (self.h - 1 - t) as f64 + self.p.w_c * c as f64
    }

    fn search(
        &self,
        ws: &mut Workspace<'_, D>,
        deadline: &dyn Deadline,
        out: &mut [[f64; D]],
        stats: &mut SearchStats,
    ) -> Result<Found, SearchError> {
        self.seed_open(ws, stats)?;
        // The arm at the last two configurations whose motion was checked: greedy search pops
        // the children of one parent in a row, and the child it expands next is most often
        // the one just checked.
        let mut arms = ArmCache::new();
        let mut since_check = 0;
        while let Some(entry) = ws.open.pop() {
            since_check += 1;
            if since_check == CHECK_EVERY {
                since_check = 0;
                if deadline.expired() {
                    return Err(SearchError::Timeout);
                }
            }
            let mut node = *ws.node(entry.node);
            // An entry is stale once its node was closed, replaced or re-queued.
            if node.closed || entry.f != self.f(node.g, node.t as usize, node.c) {
                continue;
            }
            if !node.checked {
                // Lazy edge evaluation: the motion from the parent is checked only for the
                // states popped, which with w_h = 10 are a small share of those generated.
                let Some(met) = self.motion_from_parent(ws, &node, &mut arms) else {
                    let dead = ws.node_mut(entry.node);
                    (dead.closed, dead.dead) = (true, true);
                    continue;
                };
                let c = met.count_ones() as u16;
                node.c = node.c.saturating_add(c);
                node.met |= met;
                node.checked = true;
                *ws.node_mut(entry.node) = node;
                if c > 0 {
                    self.queue(ws, entry.node, &node)?;
                    continue;
                }
            }
            if node.t as usize == self.h - 1 {
                return Ok(self.extract(ws, entry.node, out));
            }
            ws.node_mut(entry.node).closed = true;
            stats.expansions += 1;
            self.expand(ws, entry.node, &node, stats)?;
        }
        Err(SearchError::NoSolution)
    }

    /// Checks the motion from `node`'s parent to it: the other robots met on the way, or
    /// `None` when it is not allowed. `arms` keeps the arm at the parent and at
    /// the node.
    fn motion_from_parent(
        &self,
        ws: &Workspace<'_, D>,
        node: &Node<D>,
        arms: &mut ArmCache<D>,
    ) -> Option<Met> {
        let parent = ws.node(node.parent);
        let (model, base, tool) = (self.q.robot.model, &self.q.robot.base, &self.q.robot.tool);
        let p = match arms.0.iter().position(|(q, _)| *q == Some(parent.q)) {
            Some(p) => p,
            None => {
                arms.0[0].0 = Some(parent.q);
                arms.0[0].1.place::<M, D>(model, base, tool, &parent.q);
                0
            }
        };
        let [first, second] = &mut arms.0;
        let (from, to) = if p == 0 {
            (&*first, second)
        } else {
            (&*second, first)
        };
        to.0 = Some(node.q);
        to.1.place::<M, D>(model, base, tool, &node.q);
        self.valid
            .motion_met(&parent.q, &node.q, [&from.1, &to.1], parent.t as usize)
    }

    /// Puts IK solutions of the first pose of every allowed trajectory in OPEN: the one nearest
    /// `initial` (when given), then solutions from random seeds until `start_solutions`
    /// distinct valid states are in or `start_attempts` seeds were tried.
    ///
    /// A pose for which none of the first `start_solutions` seeds gives an IK answer is left
    /// there, as out of this robot's reach at this level (a finer level, wanting more start
    /// states, tries more seeds). Where several robots may take any hand, a robot's IK from
    /// random seeds reaches a hand's first pose from nearly every seed or from none (on the
    /// approach family of the suite: 662 of 1,203 robot-hand pairs from none of 97 seeds, the
    /// others from 73 or more), and a seed that fails iterates until it stalls, some 18 times
    /// as long as one that succeeds: the seeds that could not succeed took most of the
    /// planning time.
    fn seed_open(
        &self,
        ws: &mut Workspace<'_, D>,
        stats: &mut SearchStats,
    ) -> Result<(), SearchError> {
        for j in 0..self.q.trajectories.len() {
            if self.q.allowed & (1 << j) == 0 {
                continue;
            }
            if let (Start::AtInitial, Some(q)) = (self.q.robot.start, self.q.robot.initial) {
                // Online: the arm is where it is; its motion to the chunk starts at step 1.
                if let Some(met) = self.valid.state_met(&q, 0) {
                    self.add(ws, start_node(q, 0.0, met, j as u8), stats)?;
                }
                continue;
            }
            let target = self.target(j, 0);
            let g0 = self.start_cost(j);
            // The same seeds for a trajectory whatever else is asked, so a replan under one
            // more constraint explores the same start states.
            let mut rng = Rng::new(self.p.seed ^ (j as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let before = ws.used();
            let (lower, upper) = (M::lower(self.q.robot.model), M::upper(self.q.robot.model));
            let seeds = self
                .q
                .robot
                .initial
                .into_iter()
                .chain((0..self.p.start_attempts).map(|_| rng.configuration(lower, upper)));
            // The cache holds the first seeds of each trajectory (a finer refinement level
            // draws more, the first ones the same).
            let stride = self.q.starts.len() / self.q.trajectories.len();
            let mut answered = false;
            for (k, seed) in seeds.enumerate() {
                if ws.used() - before >= self.p.start_solutions
                    || (!answered && k >= self.p.start_solutions)
                {
                    break;
                }
                let solve = || ik::<M, D>(self.q.robot.model, &target, &seed, &self.p.ik).ok();
                let cached = (k < stride).then(|| self.q.starts.get(j * stride + k));
                let answer = match cached.flatten() {
                    None => solve(),
                    Some(cell) => match cell.get() {
                        StartIk::Solved(q) => Some(q),
                        StartIk::Failed => None,
                        StartIk::Unknown => {
                            let q = solve();
                            cell.set(q.map_or(StartIk::Failed, StartIk::Solved));
                            q
                        }
                    },
                };
                let Some(q) = answer else {
                    continue;
                };
                answered = true;
                let Some(met) = self.valid.state_met(&q, 0) else {
                    continue;
                };
                let g = g0 + self.approach_length(&q);
                self.add(ws, start_node(q, g, met, j as u8), stats)?;
            }
        }
        Ok(())
    }

    /// Joint-space distance from `initial` to a start state (0 without `initial`): the length
    /// of the straight approach to it, so that of two starts on one manifold the one nearer
    /// where the arm stands is tried first.
    fn approach_length(&self, q: &[f64; D]) -> f64 {
        self.q.robot.initial.map_or(0.0, |init| {
            let d2: f64 = init.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
            libm::sqrt(d2)
        })
    }

    /// The part of an initial state's `g` shared by every start of trajectory `j`: how far the
    /// tool centre point at `initial` is from the first pose (0 without `initial`), as in the
    /// paper; [`Ctx::approach_length`] adds the state's own distance from `initial`.
    fn start_cost(&self, j: usize) -> f64 {
        match &self.q.robot.initial {
            Some(init) => {
                let tool = self
                    .q
                    .robot
                    .base
                    .compose(&M::fk(self.q.robot.model, init))
                    .compose(&self.q.robot.tcp);
                (tool.pos - self.q.trajectories[j][0].pos).norm()
            }
            None => 0.0,
        }
    }

    fn expand(
        &self,
        ws: &mut Workspace<'_, D>,
        index: u32,
        node: &Node<D>,
        stats: &mut SearchStats,
    ) -> Result<(), SearchError> {
        let target = self.target(node.j as usize, node.t as usize + 1);
        let mut moves = [[0.0; D]; MAX_MOVES];
        let n = manifold_moves::<M, D>(self.q.robot.model, &target, &node.q, self.p, &mut moves);
        let t1 = node.t as usize + 1;
        let motion = self.twist_at(node.j as usize, t1);
        // The moves within the velocity limits, checked as one batch.
        let mut within = [[0.0; D]; MAX_MOVES];
        let mut m = 0;
        for q in moves[..n]
            .iter()
            .filter(|q| self.valid.step_within_limits(&node.q, q))
        {
            within[m] = *q;
            m += 1;
        }
        let states = self.valid.states_met(&within[..m], t1);
        for (q, state) in within[..m].iter().zip(states) {
            let Some(met) = state else {
                continue;
            };
            let dist2: f64 = (0..D)
                .map(|i| (q[i] - node.q[i]) * (q[i] - node.q[i]))
                .sum();
            let child = Node {
                q: *q,
                g: node.g + libm::sqrt(dist2) + self.step_cost(q, &motion),
                parent: index,
                t: t1 as u16,
                c: node.c.saturating_add(met.count_ones() as u16),
                j: node.j,
                closed: false,
                checked: false,
                dead: false,
                met: node.met | met,
            };
            self.add(ws, child, stats)?;
        }
        Ok(())
    }

    fn step_cost(&self, q: &[f64; D], motion: &Vector6<f64>) -> f64 {
        step_cost::<M, D>(self.q.robot.model, q, motion, self.p)
    }

    /// The hand's twist at step `t` of trajectory `j` (towards step `t + 1`; the last step's
    /// motion continues past the end), in the base frame. Zero unless the speed headroom is
    /// weighed.
    fn twist_at(&self, j: usize, t: usize) -> Vector6<f64> {
        let h = self.q.trajectories[j].len();
        if self.p.w_v <= 0.0 || h < 2 {
            return Vector6::zeros();
        }
        let t = t.min(h - 2);
        twist(&self.target(j, t), &self.target(j, t + 1), self.q.dt)
    }

    /// Inserts a generated state, or improves the stored one in its cell (or takes the cell
    /// of a state whose motion failed).
    fn add(
        &self,
        ws: &mut Workspace<'_, D>,
        node: Node<D>,
        stats: &mut SearchStats,
    ) -> Result<(), SearchError> {
        let key = StateKey::new(&node.q, node.t, node.j, self.p.resolution);
        let index = match ws.find(&key) {
            Ok(existing) => {
                let old = ws.node_mut(existing);
                let better = (node.g, node.c) < (old.g, old.c);
                if !old.dead && (old.closed || !better) {
                    return Ok(());
                }
                *old = node;
                existing
            }
            Err(slot) => ws.insert(slot, node).ok_or(SearchError::OutOfMemory)?,
        };
        stats.generated += 1;
        self.queue(ws, index, &node)
    }

    /// Puts node `index` in OPEN at its current `f`.
    fn queue(
        &self,
        ws: &mut Workspace<'_, D>,
        index: u32,
        node: &Node<D>,
    ) -> Result<(), SearchError> {
        let f = self.f(node.g, node.t as usize, node.c);
        if ws.open.push(OpenEntry {
            f,
            t: node.t as u32,
            node: index,
        }) {
            Ok(())
        } else {
            Err(SearchError::OutOfMemory)
        }
    }

    fn extract(&self, ws: &Workspace<'_, D>, mut i: u32, out: &mut [[f64; D]]) -> Found {
        let last = ws.node(i);
        let found = Found {
            trajectory: Some(last.j),
            collisions: last.c as u32,
            met: last.met,
        };
        loop {
            let n = ws.node(i);
            out[n.t as usize] = n.q;
            if n.parent == u32::MAX {
                break;
            }
            i = n.parent;
        }
        found
    }

    /// Holding `initial` for the whole horizon, if allowed by obstacles and constraints.
    fn hold_path(&self, out: &mut [[f64; D]]) -> Option<u32> {
        let init = self.q.robot.initial?;
        let c = self.valid.hold(&init, self.h)?;
        out[..self.h].iter_mut().for_each(|q| *q = init);
        Some(c)
    }
}
