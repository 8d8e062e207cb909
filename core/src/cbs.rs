//! Ω-CBSA: Conflict-Based Search over assignments and null spaces.
//!
//! A constraint tree (CT) whose nodes hold per-robot constraints, the paths multi-goal Ω-A*
//! found under them, and how many conflicts those paths have. The node with the fewest
//! conflicts is expanded first (the deepest among equals). Assignment conflicts (two robots on
//! one trajectory) are resolved first, by forbidding the trajectory to one robot or the other;
//! then the earliest geometric conflict, by forbidding one robot or the other to occupy a
//! witness point inside both at one step or one instant of a motion (disjunctive; see
//! docs/ARCHITECTURE.md, Completeness, for what is and is not kept). Each child replans only
//! the constrained robot. A tree that uses its budget of Ω-A* expansions without ending is
//! dropped for a new one from another root, with twice the budget
//! ([`CbsParams::restart_expansions`]); a tree that ends without a plan leaves the search to
//! the other refinement levels, which run interleaved with it ([`crate::search::refine`]).
//!
//! Memory: CT nodes, the OPEN list of the CT, the paths, the constraint scratch and the
//! start-seed IK answers all live in caller storage ([`CbsStorage`]); one path costs
//! `H * D * 8` bytes and one node `size_of::<CtNode>()` (about 240 bytes). A restart reuses
//! the pools from the start. A full pool ends planning with `Status::OutOfMemory` naming it.

use crate::collision::ArmPose;
use crate::model::Models;
use crate::motion::{motions_conflict_posed, motions_contact, ArmMotion};
use crate::planner::{
    Horizon, Planner, PlannerKind, Request, Solution, Stats, Status, Takes, Until,
};
use crate::problem::{Problem, Robot, Start, MAX_ROBOTS};
use crate::rng::Rng;
use crate::search::refine::{level_params, EXHAUSTED, FIRST_ROUND, LEVELS, LEVEL_CAP};
use crate::search::{
    plan, Deadline, OmegaParams, OpenEntry, OpenList, OtherArm, OthersMode, PointConstraint, Query,
    SearchError, SearchStats, StartCache, StartIk, Validity, Workspace,
};
use crate::tracking::{ranked_starts, track, Steps, RANKED_SEEDS};

/// Margin (m) of the witness of two arms that touch at a step without overlapping.
const TOUCH: f64 = 1e-6;

/// Assignment value of a robot that holds its initial configuration.
const HOLD: u8 = u8::MAX;

/// Tunables of Ω-CBSA.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CbsParams {
    /// The low level's (Ω-A*'s) settings at refinement level 0.
    pub low: OmegaParams,
    /// Time cap of each root's warm start by repeated IK tracking, seconds (0 turns it off).
    pub warm_start_seconds: f64,
    /// Random first-pose seeds per robot and trajectory in the warm start.
    pub warm_start_seeds: u32,
    /// Ω-A* expansions (after its root) a level's first constraint tree may take before the
    /// level restarts from a new root (robots placed in another order, other warm-start
    /// seeds); each of the level's trees gets twice the budget of the one before, so some tree
    /// always gets as long as it needs (completeness as docs/ARCHITECTURE.md states it). 0:
    /// one tree per level, no restarts.
    pub restart_expansions: u64,
    /// Refinement levels searched, from level 0 ([`LEVELS`] by default, the most there are).
    /// With fewer, exhausting the last one ends in `NoSolution` with the reason
    /// [`LEVEL_CAP`], which proves nothing: the suite generator uses it to find problems that
    /// the first level misses.
    pub levels: u8,
}

impl Default for CbsParams {
    fn default() -> Self {
        CbsParams {
            low: OmegaParams::default(),
            warm_start_seconds: 0.5,
            warm_start_seeds: 4,
            restart_expansions: 8000,
            levels: LEVELS,
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
enum Constraint {
    #[default]
    Root,
    /// The robot may not track this trajectory.
    Forbid(u8),
    Point(PointConstraint),
}

/// One constraint-tree node.
#[derive(Clone, Copy, Debug)]
pub struct CtNode {
    parent: u32,
    /// The robot `constraint` applies to.
    robot: u8,
    constraint: Constraint,
    /// Path slot of every robot.
    slots: [u32; MAX_ROBOTS],
    assignment: [u8; MAX_ROBOTS],
    /// Geometric conflicts (steps and motions) of each pair `i < k`.
    pairs: [[u16; MAX_ROBOTS]; MAX_ROBOTS],
    conflicts: u32,
    /// Constraints on the branch (0 at the root).
    depth: u32,
}

impl Default for CtNode {
    fn default() -> Self {
        CtNode {
            parent: u32::MAX,
            robot: 0,
            constraint: Constraint::Root,
            slots: [0; MAX_ROBOTS],
            assignment: [HOLD; MAX_ROBOTS],
            pairs: [[0; MAX_ROBOTS]; MAX_ROBOTS],
            conflicts: 0,
            depth: 0,
        }
    }
}

/// Caller storage of the high level. A pool that runs out ends the constraint tree it was
/// building (its refinement level is then not proven exhausted); when every level has ended so
/// the answer is [`Status::OutOfMemory`] naming the pool. Sizes and costs (`D = 7`): `nodes`
/// and `open` about 240 and 16 bytes a constraint-tree node, `paths` `H` configurations
/// (`H * D * 8` bytes) a pooled path (each node keeps one new path), `scratch` `H`
/// configurations, `points` 48 bytes a constraint (the longest branch's on one robot),
/// `starts` 64 bytes an entry, any length (more remembers more IK answers). Ω-A*'s
/// [`Workspace`] comes besides.
pub struct CbsStorage<'a, const D: usize> {
    /// The constraint-tree nodes.
    pub nodes: &'a mut [CtNode],
    /// The constraint tree's OPEN list (as many entries as `nodes`).
    pub open: &'a mut [OpenEntry],
    /// Path pool: slot `k` is `paths[k * H..(k + 1) * H]`.
    pub paths: &'a mut [[f64; D]],
    /// Where the low level writes a path before it is kept (at least H configurations).
    pub scratch: &'a mut [[f64; D]],
    /// The constraints of the robot being replanned.
    pub points: &'a mut [PointConstraint],
    /// Start-seed IK answers (see [`StartCache`]): the more entries, the more seeds are
    /// remembered.
    pub starts: &'a mut [StartIk<D>],
}

/// The Ω-CBSA planner: its settings, Ω-A*'s [`Workspace`] and the constraint tree's
/// [`CbsStorage`], all borrowed from the caller and reused request after request. Run it
/// through [`Planner::solve`].
///
/// Two Gen3s 2 m apart, each with a hand to follow in front of it; the first trajectory is
/// the second arm's. The pools are sized for this small problem (3 steps):
///
/// ```
/// use omcbsa_core::cbs::{CbsParams, CbsStorage, CtNode, OmegaCbsa};
/// use omcbsa_core::model::{Frame, KinovaGen3, Model};
/// use omcbsa_core::nalgebra::Vector3;
/// use omcbsa_core::planner::{NoClock, Planner, Request, Solution, Status, Until};
/// use omcbsa_core::problem::{Problem, Robot};
/// use omcbsa_core::search::{Node, OpenEntry, PointConstraint, Slot, StartIk, Workspace};
///
/// const H: usize = 3;
/// let left = Frame::IDENTITY;
/// let right = Frame { pos: Vector3::new(0.0, 2.0, 0.0), ..Frame::IDENTITY };
/// let mut problem = Problem::<7>::new(0.1);
/// problem.robots.push(Robot::at(0, left)).unwrap();
/// problem.robots.push(Robot::at(0, right)).unwrap();
/// // A hand in front of each arm, moving 1 cm a step along x.
/// let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
/// for base in [right, left] {
///     let pose = |t: usize| {
///         let mut x = base.compose(&hand);
///         x.pos.x += 0.01 * t as f64;
///         x
///     };
///     problem.trajectories.push((0..H).map(pose).collect()).unwrap();
/// }
///
/// // Ω-A*'s storage: nodes, OPEN entries, and a duplicate table (a power of two, at least
/// // the node count).
/// let mut nodes = [Node::<7>::default(); 256];
/// let mut open = [OpenEntry::default(); 512];
/// let mut table = [Slot::default(); 512];
/// let ws = Workspace::new(&mut nodes, &mut open, &mut table).unwrap();
/// // The constraint tree's: nodes and their OPEN list, a pool of paths of H steps, one path
/// // of scratch, point constraints, and start-seed IK answers.
/// let mut ct = [CtNode::default(); 16];
/// let mut ct_open = [OpenEntry::default(); 16];
/// let mut pool = [[0.0; 7]; 16 * H];
/// let mut scratch = [[0.0; 7]; H];
/// let none = PointConstraint { t: 0, segment: false, s: 0.0, p: [0.0; 3], margin: 0.0 };
/// let mut points = [none; 16];
/// let mut starts = [StartIk::default(); 64];
/// let st = CbsStorage {
///     nodes: &mut ct,
///     open: &mut ct_open,
///     paths: &mut pool,
///     scratch: &mut scratch,
///     points: &mut points,
///     starts: &mut starts,
/// };
/// let mut planner = OmegaCbsa::new(CbsParams::default(), ws, st);
///
/// // The answer: both robots' paths, robot after robot.
/// let mut paths = [[0.0; 7]; 2 * H];
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// assert_eq!(Planner::<KinovaGen3, 7>::solve(&mut planner, &mut req), Status::Solved);
/// assert_eq!(req.out.assignment[..2], [Some(1), Some(0)]);
/// for (i, robot) in problem.robots.iter().enumerate() {
///     let traj = &problem.trajectories[usize::from(req.out.assignment[i].unwrap())];
///     for (q, pose) in req.out.path(i, H).iter().zip(traj) {
///         let reached = robot.base.compose(&KinovaGen3::fk(q));
///         assert!((reached.pos - pose.pos).norm() <= problem.tolerance.position);
///     }
/// }
/// ```
pub struct OmegaCbsa<'a, const D: usize> {
    /// The settings; they may be changed between requests.
    pub params: CbsParams,
    ws: Workspace<'a, D>,
    st: CbsStorage<'a, D>,
}

impl<'a, const D: usize> OmegaCbsa<'a, D> {
    /// A planner over the caller's storage: `ws` for Ω-A*, `st` for the constraint tree.
    pub fn new(params: CbsParams, ws: Workspace<'a, D>, st: CbsStorage<'a, D>) -> Self {
        OmegaCbsa { params, ws, st }
    }
}

impl<M: Models<D>, const D: usize> Planner<M, D> for OmegaCbsa<'_, D> {
    const TAKES: Takes = Takes::Fixed;

    fn kind(&self) -> PlannerKind {
        PlannerKind::OmCbsa
    }

    fn plan(&mut self, req: &mut Request<'_, D>, h: Horizon) -> Status {
        let (problem, h) = (req.problem, h.get());
        if self.st.scratch.len() < h {
            return Status::OutOfMemory("CBS scratch path");
        }
        if self.st.paths.len() / h < problem.robots.len() {
            return Status::OutOfMemory("CBS path pool");
        }
        let st = &mut self.st;
        let mut run = Run::<M, D> {
            pr: problem,
            params: &self.params,
            low: self.params.low,
            incomplete: false,
            ws: &mut self.ws,
            nodes: &mut *st.nodes,
            used_nodes: 0,
            open: OpenList::new(&mut *st.open),
            paths: &mut *st.paths,
            used_slots: 0,
            scratch: &mut *st.scratch,
            points: &mut *st.points,
            starts: StartCache::new(
                &mut *st.starts,
                problem.robots.len(),
                problem.trajectories.len(),
                &self.params.low,
            ),
            h,
            n: problem.robots.len(),
            deadline: req.until,
            stats: &mut req.stats,
            _m: core::marker::PhantomData,
        };
        run.solve(&mut req.out)
    }
}

struct Run<'r, 's, M, const D: usize> {
    pr: &'r Problem<D>,
    params: &'r CbsParams,
    /// Ω-A*'s settings at the current refinement level.
    low: OmegaParams,
    /// A low-level search of this level ran out of memory: the level's exhaustion proves
    /// nothing.
    incomplete: bool,
    ws: &'r mut Workspace<'s, D>,
    nodes: &'r mut [CtNode],
    used_nodes: usize,
    open: OpenList<'r>,
    paths: &'r mut [[f64; D]],
    used_slots: usize,
    scratch: &'r mut [[f64; D]],
    points: &'r mut [PointConstraint],
    starts: StartCache<'r, D>,
    h: usize,
    n: usize,
    deadline: Until<'r>,
    stats: &'r mut Stats,
    _m: core::marker::PhantomData<M>,
}

/// The two branches of a conflict: (robot, constraint) each.
type Branches = [(usize, Constraint); 2];

impl<M: Models<D>, const D: usize> Run<'_, '_, M, D> {
    /// Constraint trees in turn, in rounds, until one ends with a plan, the deadline passes or
    /// every level is exhausted. Run times of tree search are heavy-tailed (most problems take
    /// a few milliseconds, a few take seconds from one root and milliseconds from another),
    /// which restarts cut. A tree that ends with its OPEN list empty has exhausted the search
    /// space at its refinement level ([`crate::search::refine`]), which is then left out.
    ///
    /// Level `l` builds its first tree in round [`FIRST_ROUND`]`[l]` = `f`, and in round `r`
    /// one with `restart_expansions * 2^(r - f)` Ω-A* expansions after its root: level 1 gets
    /// half of level 0's share, levels 2 and 3 a sixteenth and a sixty-fourth (see
    /// [`FIRST_ROUND`] for why). A level that is slow to exhaust does not keep the finer ones
    /// waiting until the deadline. The budgets count expansions, not time, so the answer is
    /// deterministic. A tree whose pools run out ends its level (not proven exhausted) and the
    /// other levels go on.
    fn solve(&mut self, out: &mut Solution<'_, D>) -> Status {
        let levels = usize::from(self.params.levels.clamp(1, LEVELS));
        let mut exhausted = [false; LEVELS as usize];
        // Whether the finest level's exhaustion proves nothing (a search ran out of memory).
        let mut unproven: Option<&'static str> = None;
        for round in 0u32.. {
            for (level, done) in exhausted.iter_mut().enumerate().take(levels) {
                let Some(shift) = round.checked_sub(FIRST_ROUND[level]) else {
                    continue;
                };
                if *done {
                    continue;
                }
                self.stats.level = level as u8;
                self.low = level_params(&self.params.low, level as u8);
                self.incomplete = false;
                let budget = match self.params.restart_expansions {
                    0 => u64::MAX,
                    b => b.saturating_mul(1u64 << shift.min(40)),
                };
                let ended = self.tree(out, shift, budget);
                self.used_nodes = 0;
                self.used_slots = 0;
                self.open.clear();
                match ended {
                    None => {}
                    Some(Status::NoSolution) => {
                        *done = true;
                        if level + 1 == levels && self.incomplete {
                            unproven = Some("Ω-A* workspace");
                        }
                    }
                    // The level's searches outgrow the pools: another level may still plan.
                    Some(Status::OutOfMemory(pool)) => {
                        *done = true;
                        if level + 1 == levels {
                            unproven = Some(pool);
                        }
                    }
                    Some(status) => return status,
                }
            }
            if exhausted[..levels].iter().all(|&e| e) {
                break;
            }
        }
        if let Some(pool) = unproven {
            return Status::OutOfMemory(pool);
        }
        self.stats.reason = Some(if levels < usize::from(LEVELS) {
            LEVEL_CAP
        } else {
            EXHAUSTED
        });
        Status::NoSolution
    }

    /// One constraint tree from the root of restart `restart` (the tree's number within its
    /// level: every level's first tree places the robots in index order, as level 0's does,
    /// and its later ones in the same shuffled orders); `None` when it used its budget
    /// (`budget` Ω-A* expansions after the root's) without ending. The root is not counted: a
    /// fine level's root alone can take more than a small budget, and a tree cut off at its
    /// root would be work thrown away.
    fn tree(&mut self, out: &mut Solution<'_, D>, restart: u32, budget: u64) -> Option<Status> {
        let root = match self.root(restart) {
            Ok(r) => r,
            Err(s) => return Some(s),
        };
        let limit = self.stats.expansions.saturating_add(budget);
        if let Err(s) = self.push(root) {
            return Some(s);
        }
        loop {
            if self.deadline.expired() {
                return Some(Status::Timeout);
            }
            if self.stats.expansions >= limit {
                return None;
            }
            let Some(entry) = self.open.pop() else {
                return Some(Status::NoSolution);
            };
            let node = self.nodes[entry.node as usize];
            let branches = match self.first_conflict(&node) {
                Some((b, exact)) => {
                    self.stats.inexact_branches += u32::from(!exact);
                    if let (_, Constraint::Point(p)) = b[0] {
                        self.stats.motion_conflicts += u32::from(p.segment);
                    }
                    b
                }
                None if node.conflicts == 0 => {
                    self.write_solution(&node, out);
                    return Some(Status::Solved);
                }
                // Counted conflicts but nowhere to branch: never reported as solved, and
                // counted, since completeness no longer covers its subtree.
                None => {
                    self.stats.unbranched_nodes += 1;
                    continue;
                }
            };
            self.stats.conflicts_resolved += 1;
            for (robot, constraint) in branches {
                match self.child(entry.node, &node, robot, constraint) {
                    Ok(Some(child)) => {
                        if let Err(s) = self.push(child) {
                            return Some(s);
                        }
                    }
                    Ok(None) => {}
                    Err(s) => return Some(s),
                }
            }
        }
    }

    /// Stores a node and puts it in OPEN.
    fn push(&mut self, node: CtNode) -> Result<(), Status> {
        if self.used_nodes == self.nodes.len() {
            return Err(Status::OutOfMemory("CBS node pool"));
        }
        let id = self.used_nodes as u32;
        self.nodes[self.used_nodes] = node;
        self.used_nodes += 1;
        self.stats.ct_nodes += 1;
        // Among nodes with as few conflicts, the deepest first: it is the closest to a
        // solution along its branch, and diving finds one sooner than widening.
        if self.open.push(OpenEntry {
            f: node.conflicts as f64,
            t: node.depth,
            node: id,
        }) {
            Ok(())
        } else {
            Err(Status::OutOfMemory("CBS open list"))
        }
    }

    fn slot(&self, k: u32) -> &[[f64; D]] {
        slot_of(self.paths, k, self.h)
    }

    /// Copies the scratch path into a new pool slot.
    fn keep_scratch(&mut self) -> Result<u32, Status> {
        if (self.used_slots + 1) * self.h > self.paths.len() {
            return Err(Status::OutOfMemory("CBS path pool"));
        }
        let k = self.used_slots;
        self.paths[k * self.h..(k + 1) * self.h].copy_from_slice(&self.scratch[..self.h]);
        self.used_slots += 1;
        Ok(k as u32)
    }

    fn can_hold(&self) -> bool {
        self.pr.trajectories.len() < self.n
    }

    fn all_trajectories(&self) -> u32 {
        if self.pr.trajectories.len() >= 32 {
            u32::MAX
        } else {
            (1u32 << self.pr.trajectories.len()) - 1
        }
    }

    /// The root: robots in turn (in index order, then in a shuffled order on each restart),
    /// each placed by repeated IK tracking (the warm start: a few seeds per trajectory no
    /// earlier robot took, nearest first, clear of the earlier robots, within
    /// `warm_start_seconds`) or,
    /// failing that, by Ω-A* with its collisions with the earlier robots counted. Only the root
    /// is built this way: every child replans by Ω-A* under its constraints, so the tree's
    /// completeness (docs/ARCHITECTURE.md) does not depend on the root.
    fn root(&mut self, restart: u32) -> Result<CtNode, Status> {
        // The cap counts from this root on: the tracking itself is a few milliseconds of
        // bounded work, so in practice the cap never cuts it and the root (hence the answer)
        // does not depend on how busy the machine is.
        let now = self.deadline.now();
        let warm = Until::new(
            self.deadline.clock,
            (now + self.params.warm_start_seconds).min(self.deadline.at),
        );
        let mut order: [usize; MAX_ROBOTS] = core::array::from_fn(|i| i);
        if restart > 0 {
            let mut rng = Rng::new(self.low.seed ^ u64::from(restart).rotate_left(40));
            for i in (1..self.n).rev() {
                order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
            }
        }
        let mut node = CtNode::default();
        let (mut taken, mut placed) = (0u32, 0u32);
        for &i in &order[..self.n] {
            let left = self.all_trajectories() & !taken & self.pr.robots[i].assigned.mask();
            let tracked = if self.params.warm_start_seconds > 0.0 && left != 0 {
                self.warm_track(i, &node, placed, left, restart, &warm)
            } else {
                None
            };
            node.assignment[i] = match tracked {
                Some(j) => j,
                // A trajectory left free first; if the robot can track none of them, any,
                // holding only if it can track none at all (the tree prunes on holders, so a
                // holder must be one that cannot track anything under its constraints).
                None => match self.low_level_in(i, &node, left, 0, placed, false) {
                    Err(Status::NoSolution) => {
                        self.low_level(i, &node, self.all_trajectories(), 0, placed)?
                            .0
                    }
                    r => r?.0,
                },
            };
            if node.assignment[i] != HOLD {
                taken |= 1 << node.assignment[i];
            }
            node.slots[i] = self.keep_scratch()?;
            placed |= 1 << i;
        }
        if self.too_many_holders(&node) {
            return Err(Status::NoSolution);
        }
        self.finish(&mut node);
        self.stats.warm_start_solved = node.conflicts == 0;
        Ok(node)
    }

    /// Fills in a node's conflicts from its paths.
    fn finish(&self, node: &mut CtNode) {
        self.pair_conflicts(node, u32::MAX, u32::MAX);
        node.conflicts = self.count(node);
    }

    /// Tries IK tracking of each trajectory in `left` from a few seeds, avoiding the robots in
    /// `placed`, writing the path to scratch. Returns the trajectory taken. The trajectories
    /// are tried by the distance from the robot's base to their first pose, nearest first (the
    /// paper's root takes each robot's cheapest goal; trying them in listed order instead
    /// gives arms the far hands and the tree many conflicts to undo: over the default suite it
    /// took 1.7 times the Ω-A* expansions, and 7.7 s where this takes 45 ms on one problem).
    fn warm_track(
        &mut self,
        i: usize,
        node: &CtNode,
        placed: u32,
        left: u32,
        restart: u32,
        warm: &Until<'_>,
    ) -> Option<u8> {
        let robot = self.pr.robots[i];
        let mut others: heapless::Vec<OtherArm<'_, D>, MAX_ROBOTS> = heapless::Vec::new();
        for k in (0..self.n).filter(|k| placed & (1 << k) != 0) {
            let _ = others.push(OtherArm {
                model: self.pr.robots[k].model,
                base: self.pr.robots[k].base,
                tool: self.pr.robots[k].tool,
                path: slot_of(self.paths, node.slots[k], self.h),
            });
        }
        let valid =
            Validity::<M, D>::new(&robot, &self.pr.obstacles, self.pr.dt, self.low.motion_step)
                .with_others(&others, OthersMode::Avoid);
        // With a step cost, the warm start weighs it as the search would.
        let steered = self.low.at_step(self.pr.dt);
        let steps = if steered.w_a > 0.0 || steered.w_v > 0.0 || steered.w_r > 0.0 {
            Steps::Steered(&steered)
        } else {
            Steps::Nearest(&self.low.ik)
        };
        let t = self.pr.trajectories.len();
        // Ties (and trajectories without poses, last) in listed order.
        let far = |j: usize| {
            self.pr.trajectories[j]
                .first()
                .map_or(f64::INFINITY, |p| (p.pos - robot.base.pos).norm())
        };
        let mut order: [usize; MAX_ROBOTS] = core::array::from_fn(|j| j);
        order[..t].sort_unstable_by(|&a, &b| far(a).total_cmp(&far(b)).then(a.cmp(&b)));
        for &j in &order[..t] {
            if left & (1 << j) == 0 {
                continue;
            }
            let key = (i as u64) << 32 | j as u64 | u64::from(restart) << 48;
            let mut rng = Rng::new(self.low.seed ^ key);
            let traj = &self.pr.trajectories[j];
            let mut seeds = [[0.0; D]; RANKED_SEEDS];
            let ranked = match steps {
                Steps::Steered(p)
                    if p.rank_starts && p.w_r > 0.0 && robot.start == Start::Sampled =>
                {
                    ranked_starts::<M, D>(&robot, traj, p, &mut rng, &mut seeds)
                }
                _ => 0,
            };
            for attempt in 0..self.params.warm_start_seeds {
                if warm.expired() {
                    return None;
                }
                let seed = match (attempt, robot.initial) {
                    (a, _) if (a as usize) < ranked => seeds[a as usize],
                    (0, Some(init)) if ranked == 0 => init,
                    _ => rng.configuration(M::lower(robot.model), M::upper(robot.model)),
                };
                if track::<M, D>(&robot, traj, &seed, &valid, steps, self.scratch).is_some() {
                    return Some(j as u8);
                }
            }
        }
        None
    }

    /// Runs multi-goal Ω-A* for robot `i` against the paths of `node` (collisions counted),
    /// with `npoints` point constraints in `self.points`, against the robots in the bit set
    /// `others` (the root plans robots in turn). Leaves the path in scratch; returns the
    /// trajectory and the robots (a bit set of robot indices) the path meets, as Ω-A* counted
    /// them.
    fn low_level(
        &mut self,
        i: usize,
        node: &CtNode,
        allowed: u32,
        npoints: usize,
        others: u32,
    ) -> Result<(u8, u32), Status> {
        self.low_level_in(i, node, allowed, npoints, others, self.can_hold())
    }

    /// [`Run::low_level`] with holding allowed (`hold`) or not.
    fn low_level_in(
        &mut self,
        i: usize,
        node: &CtNode,
        allowed: u32,
        npoints: usize,
        others_set: u32,
        hold: bool,
    ) -> Result<(u8, u32), Status> {
        let mut others: heapless::Vec<OtherArm<'_, D>, MAX_ROBOTS> = heapless::Vec::new();
        // Which robot each of `others` is.
        let mut robot_of = [0usize; MAX_ROBOTS];
        for k in (0..self.n).filter(|&k| k != i && others_set & (1 << k) != 0) {
            robot_of[others.len()] = k;
            let _ = others.push(OtherArm {
                model: self.pr.robots[k].model,
                base: self.pr.robots[k].base,
                tool: self.pr.robots[k].tool,
                path: slot_of(self.paths, node.slots[k], self.h),
            });
        }
        let query = Query {
            robot: self.pr.robots[i],
            trajectories: &self.pr.trajectories,
            allowed,
            hold,
            obstacles: &self.pr.obstacles,
            others: &others,
            others_mode: OthersMode::Count,
            points: &self.points[..npoints],
            dt: self.pr.dt,
            starts: self.starts.robot(i),
        };
        let mut s = SearchStats::default();
        self.stats.low_level_calls += 1;
        let r = plan::<M, D>(
            &query,
            &self.low,
            self.ws,
            &self.deadline,
            self.scratch,
            &mut s,
        );
        self.stats.expansions += s.expansions as u64;
        match r {
            Ok(found) => {
                let met = (0..others.len())
                    .filter(|&o| found.met & (1 << o) != 0)
                    .fold(0u32, |m, o| m | 1 << robot_of[o]);
                Ok((found.trajectory.unwrap_or(HOLD), met))
            }
            Err(e) => Err(stop_status(e)),
        }
    }

    /// The child of `parent` (stored at `id`) that adds `constraint` for `robot` and replans
    /// it; `None` when the robot has no path under its constraints.
    fn child(
        &mut self,
        id: u32,
        parent: &CtNode,
        robot: usize,
        constraint: Constraint,
    ) -> Result<Option<CtNode>, Status> {
        // Gather the robot's constraints along the branch.
        let mut allowed = self.all_trajectories();
        let mut npoints = 0;
        let mut c = Some((robot as u8, constraint));
        let mut at = id;
        while let Some((r, con)) = c {
            if r as usize == robot {
                match con {
                    Constraint::Root => {}
                    Constraint::Forbid(j) => allowed &= !(1u32 << j),
                    Constraint::Point(p) => {
                        if npoints == self.points.len() {
                            return Err(Status::OutOfMemory("CBS constraint scratch"));
                        }
                        self.points[npoints] = p;
                        npoints += 1;
                    }
                }
            }
            if at == u32::MAX {
                break;
            }
            let n = &self.nodes[at as usize];
            c = Some((n.robot, n.constraint));
            at = n.parent;
        }
        let (assigned, met) = match self.low_level(robot, parent, allowed, npoints, u32::MAX) {
            Ok(found) => found,
            Err(Status::NoSolution) => return Ok(None),
            // The finer levels' grids can outgrow the workspace: this child is lost, and the
            // level's exhaustion no longer proves anything.
            Err(Status::OutOfMemory(_)) => {
                self.incomplete = true;
                return Ok(None);
            }
            Err(s) => return Err(s),
        };
        let mut child = *parent;
        child.parent = id;
        child.depth = parent.depth + 1;
        child.robot = robot as u8;
        child.constraint = constraint;
        child.slots[robot] = self.keep_scratch()?;
        child.assignment[robot] = assigned;
        if self.too_many_holders(&child) {
            return Ok(None);
        }
        // Ω-A* checked the new path against every other robot, at every step and on every
        // motion, with the checks that count a pair's conflicts (whose motions are confirmed
        // by a finer sweep besides, so never more): only the robots it met can have any.
        self.pair_conflicts(&mut child, 1 << robot, met);
        #[cfg(debug_assertions)]
        {
            let mut every = child;
            self.pair_conflicts(&mut every, 1 << robot, u32::MAX);
            debug_assert_eq!(
                every.pairs, child.pairs,
                "a robot Ω-A* did not meet conflicts"
            );
        }
        child.conflicts = self.count(&child);
        Ok(Some(child))
    }

    /// Robots hold only when no trajectory is left to them in the subtree of `node`; if more
    /// hold than can, some trajectory is never tracked below it.
    fn too_many_holders(&self, node: &CtNode) -> bool {
        let holders = (0..self.n).filter(|&k| node.assignment[k] == HOLD).count();
        holders > self.n - self.pr.trajectories.len()
    }

    /// Assignment conflicts plus geometric ones.
    fn count(&self, node: &CtNode) -> u32 {
        let mut c = 0u32;
        for i in 0..self.n {
            for k in i + 1..self.n {
                let (a, b) = (node.assignment[i], node.assignment[k]);
                if a != HOLD && a == b {
                    c += 1;
                }
                c += node.pairs[i][k] as u32;
            }
        }
        c
    }

    /// Fills in `node.pairs` for every pair with a robot in the bit set `of`: steps where the
    /// two collide plus motions on which they meet, as Ω-A* counts them except that a
    /// motion's is confirmed by a finer sweep ([`motions_conflict_posed`]); checked only for
    /// pairs whose other robot is in `with` (the rest are known to be clear: 0). Each arm in a
    /// checked pair is placed once per step, whatever the number of pairs; the poses of two
    /// steps live on the stack (`2 * MAX_ROBOTS` [`ArmPose`]s, about 27 KB).
    fn pair_conflicts(&self, node: &mut CtNode, of: u32, with: u32) {
        let n = self.n;
        clear_pairs(node, n, of);
        let counted = |i: usize, k: usize| counted(of, with, i, k);
        // Only the arms of some counted pair are placed.
        let placed = of | with;
        let slots = node.slots;
        let path = |i: usize| slot_of(self.paths, slots[i], self.h);
        let place = |poses: &mut [ArmPose; MAX_ROBOTS], t: usize| {
            for (i, (pose, r)) in poses.iter_mut().zip(self.pr.robots.iter()).enumerate() {
                if placed & (1 << i) != 0 {
                    pose.place::<M, D>(r.model, &r.base, &r.tool, &path(i)[t]);
                }
            }
        };
        // The arms at steps t and t + 1: slots t % 2 and (t + 1) % 2.
        let mut poses = [[ArmPose::EMPTY; MAX_ROBOTS]; 2];
        place(&mut poses[0], 0);
        for t in 0..self.h {
            if t + 1 < self.h {
                place(&mut poses[(t + 1) % 2], t + 1);
            }
            let (now, next) = (&poses[t % 2], &poses[(t + 1) % 2]);
            for i in 0..n {
                for k in (i + 1..n).filter(|&k| counted(i, k)) {
                    let c = &mut node.pairs[i][k];
                    if now[i].arm_hit(&now[k], 0.0).is_some() {
                        *c = c.saturating_add(1);
                    }
                    if t + 1 < self.h {
                        let (ri, rk) = (&self.pr.robots[i], &self.pr.robots[k]);
                        let (ma, mb) = (step_motion(ri, path(i), t), step_motion(rk, path(k), t));
                        let (ea, eb) = ([&now[i], &next[i]], [&now[k], &next[k]]);
                        if motions_conflict_posed::<M, D>(&ma, ea, &mb, eb, self.low.motion_step) {
                            *c = c.saturating_add(1);
                        }
                    }
                }
            }
        }
    }

    /// The conflict to branch on: an assignment conflict if any, else the earliest geometric
    /// one, and whether its two branches are mutually disjunctive. `None` when the node is a
    /// solution (or, counted by the caller, when no conflict it counted could be located).
    fn first_conflict(&self, node: &CtNode) -> Option<(Branches, bool)> {
        for i in 0..self.n {
            for k in i + 1..self.n {
                let a = node.assignment[i];
                if a != HOLD && a == node.assignment[k] {
                    let branches = [(i, Constraint::Forbid(a)), (k, Constraint::Forbid(a))];
                    return Some((branches, true));
                }
            }
        }
        if node.conflicts == 0 {
            return None;
        }
        for t in 0..self.h {
            for i in 0..self.n {
                for k in i + 1..self.n {
                    if node.pairs[i][k] == 0 {
                        continue;
                    }
                    let (ri, rk) = (&self.pr.robots[i], &self.pr.robots[k]);
                    let (pi, pk) = (self.slot(node.slots[i]), self.slot(node.slots[k]));
                    let (a, b) = (
                        ArmPose::new::<M, D>(ri.model, &ri.base, &ri.tool, &pi[t]),
                        ArmPose::new::<M, D>(rk.model, &rk.base, &rk.tool, &pk[t]),
                    );
                    let hit = if a.arm_hit(&b, 0.0).is_some() {
                        // A point inside both arms at step t; arms that only touch have none,
                        // and a hair's margin stands in (not disjunctive, so counted).
                        let exact = a.witness(&b, 0.0).map(|p| (p, 0.0, true));
                        exact
                            .or_else(|| a.witness(&b, TOUCH).map(|p| (p, TOUCH, false)))
                            .map(|(p, margin, exact)| {
                                let pc = PointConstraint {
                                    t: t as u16,
                                    segment: false,
                                    s: 0.0,
                                    p: [p.x, p.y, p.z],
                                    margin,
                                };
                                (pc, exact)
                            })
                    } else if t + 1 < self.h {
                        let (ma, mb) = (step_motion(ri, pi, t), step_motion(rk, pk, t));
                        motions_contact::<M, D>(&ma, &mb, self.low.motion_step).map(|(c, exact)| {
                            let pc = PointConstraint {
                                t: t as u16,
                                segment: true,
                                s: c.s,
                                p: c.point,
                                margin: c.margin,
                            };
                            (pc, exact)
                        })
                    } else {
                        None
                    };
                    if let Some((pc, exact)) = hit {
                        let branches = [(i, Constraint::Point(pc)), (k, Constraint::Point(pc))];
                        return Some((branches, exact));
                    }
                }
            }
        }
        None
    }

    fn write_solution(&self, node: &CtNode, out: &mut Solution<'_, D>) {
        for i in 0..self.n {
            out.assignment[i] = (node.assignment[i] != HOLD).then_some(node.assignment[i]);
            out.paths[i * self.h..(i + 1) * self.h].copy_from_slice(self.slot(node.slots[i]));
        }
    }
}

/// Whether the pair `i`, `k` has one robot in the bit set `of` and the other in `with`.
fn counted(of: u32, with: u32, i: usize, k: usize) -> bool {
    (of >> i & with >> k | of >> k & with >> i) & 1 != 0
}

/// Sets the conflict counts of every pair with a robot in the bit set `of` to 0.
fn clear_pairs(node: &mut CtNode, n: usize, of: u32) {
    for i in 0..n {
        for k in (i + 1..n).filter(|&k| counted(of, u32::MAX, i, k)) {
            node.pairs[i][k] = 0;
        }
    }
}

/// A robot's motion from step `t` to `t + 1` of `path`.
fn step_motion<'a, const D: usize>(
    robot: &'a Robot<D>,
    path: &'a [[f64; D]],
    t: usize,
) -> ArmMotion<'a, D> {
    ArmMotion {
        model: robot.model,
        base: &robot.base,
        tool: &robot.tool,
        from: &path[t],
        to: &path[t + 1],
    }
}

fn slot_of<const D: usize>(paths: &[[f64; D]], k: u32, h: usize) -> &[[f64; D]] {
    let k = k as usize;
    &paths[k * h..(k + 1) * h]
}

fn stop_status(e: SearchError) -> Status {
    match e {
        SearchError::OutOfMemory => Status::OutOfMemory("Ω-A* workspace"),
        SearchError::Timeout => Status::Timeout,
        SearchError::NoSolution => Status::NoSolution,
        SearchError::InvalidQuery(m) => Status::InvalidProblem(m),
    }
}
