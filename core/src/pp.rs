//! On-manifold prioritised planning: OM-PP-A* (multi-goal Ω-A* per robot) and
//! OM-PP-A*_single (single-goal Ω-A* under an explicit assignment).
//!
//! Robots plan one after another; each treats the paths of the robots before it as moving
//! obstacles it must avoid. Prioritised planning is incomplete, so both planners try priority
//! orders until one works. OM-PP-A*_single first searches every (robot, trajectory) pair alone
//! ([`crate::assign`]) and tries only assignments of pairs that work alone, cheapest first, in
//! rounds: round `r` visits the `2^r` cheapest assignments with `2^r` times
//! [`ASSIGNMENT_BUDGET`] Ω-A* expansions each for their priority orders, so no assignment can
//! take the whole time and the cheap ones get the most. OM-PP-A* keeps trajectories a robot
//! cannot track alone out of its goals. When every order (and assignment) fails at one
//! resolution, both go on at a finer one ([`crate::search::refine`]); `NoSolution` only when the
//! finest is exhausted too, or a trajectory is out of every robot's reach.

use crate::assign::{Choice, Pair, PairTable, HOLD};
use crate::model::Models;
use crate::planner::{
    Horizon, Planner, PlannerKind, Request, Solution, Stats, Status, Takes, Until,
};
use crate::problem::{Problem, MAX_ROBOTS};
use crate::search::refine::{level_params, EXHAUSTED, LEVELS};
use crate::search::{
    plan, Deadline, OmegaParams, OtherArm, OthersMode, Query, SearchError, SearchStats, StartCache,
    StartIk, Workspace,
};

/// Ω-A* expansions the priority orders of one assignment get in the first round (doubled each
/// round): a few attempts of a 6-arm problem.
pub const ASSIGNMENT_BUDGET: u64 = 4000;

/// Which Ω-A* the robots use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// OM-PP-A*: each robot picks among the trajectories not yet taken.
    MultiGoal,
    /// OM-PP-A*_single: the assignment is enumerated; each robot tracks the one it is given.
    SingleGoal,
}

/// A prioritised planner, over the caller's storage: Ω-A*'s [`Workspace`] and a
/// [`PpStorage`] (one path of scratch, the start-seed IK answers). A full workspace ends the
/// search that filled it (its level is then not proven exhausted); the answer is
/// [`Status::OutOfMemory`] only when nothing else is left to try. Run it through
/// [`Planner::solve`].
///
/// Two Gen3s side by side 2 m apart, each with a hand in front of it, planned one after the
/// other (OM-PP-A*_single: the assignment enumerated, cheapest first):
///
/// ```
/// use omcbsa_core::model::{Frame, KinovaGen3, Model};
/// use omcbsa_core::nalgebra::Vector3;
/// use omcbsa_core::planner::{NoClock, Planner, Request, Solution, Status, Until};
/// use omcbsa_core::pp::{PpStorage, Prioritized, Variant};
/// use omcbsa_core::problem::{Problem, Robot};
/// use omcbsa_core::search::{Node, OmegaParams, OpenEntry, Slot, StartIk, Workspace};
///
/// const H: usize = 3;
/// let hand = KinovaGen3::fk(&[0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0]);
/// let mut problem = Problem::<7>::new(0.1);
/// for y in [0.0, 2.0] {
///     let base = Frame { pos: Vector3::new(0.0, y, 0.0), ..Frame::IDENTITY };
///     problem.robots.push(Robot::at(0, base)).unwrap();
///     let pose = |t: usize| {
///         let mut x = base.compose(&hand);
///         x.pos.z += 0.01 * t as f64;
///         x
///     };
///     problem.trajectories.push((0..H).map(pose).collect()).unwrap();
/// }
///
/// let mut nodes = [Node::<7>::default(); 256];
/// let mut open = [OpenEntry::default(); 512];
/// let mut table = [Slot::default(); 512];
/// let ws = Workspace::new(&mut nodes, &mut open, &mut table).unwrap();
/// let (mut scratch, mut starts) = ([[0.0; 7]; H], [StartIk::default(); 64]);
/// let st = PpStorage { scratch: &mut scratch, starts: &mut starts };
/// let mut pp = Prioritized::new(Variant::SingleGoal, OmegaParams::default(), ws, st);
///
/// let mut paths = [[0.0; 7]; 2 * H];
/// let mut req = Request::new(&problem, Until::never(&NoClock), Solution::new(&mut paths));
/// assert_eq!(Planner::<KinovaGen3, 7>::solve(&mut pp, &mut req), Status::Solved);
/// assert_eq!(req.out.assignment[..2], [Some(0), Some(1)]);
/// // Joint speeds hold between steps: no joint moves more than its limit times dt.
/// for i in 0..2 {
///     let path = req.out.path(i, H);
///     for (a, b) in path.iter().zip(&path[1..]) {
///         for j in 0..7 {
///             assert!((b[j] - a[j]).abs() <= KinovaGen3::VELOCITY[j] * problem.dt);
///         }
///     }
/// }
/// ```
pub struct Prioritized<'a, const D: usize> {
    /// Which Ω-A* the robots use.
    pub variant: Variant,
    /// Ω-A*'s settings at refinement level 0.
    pub params: OmegaParams,
    ws: Workspace<'a, D>,
    st: PpStorage<'a, D>,
}

/// Caller storage of the prioritised planners besides Ω-A*'s [`Workspace`] (about 112 bytes
/// a search node): `scratch` at least `H` configurations (`H * D * 8` bytes; shorter ends
/// planning with [`Status::OutOfMemory`]), `starts` 64 bytes an entry for `D = 7`, any length
/// (see [`StartCache`]; the more entries, the more start-seed IK answers are remembered
/// across priority orders; too short, none).
pub struct PpStorage<'a, const D: usize> {
    /// Where Ω-A* writes a robot's path.
    pub scratch: &'a mut [[f64; D]],
    /// Start-seed IK answers.
    pub starts: &'a mut [StartIk<D>],
}

impl<'a, const D: usize> Prioritized<'a, D> {
    /// A planner over the caller's storage: `ws` for Ω-A*, `st` for the rest.
    pub fn new(
        variant: Variant,
        params: OmegaParams,
        ws: Workspace<'a, D>,
        st: PpStorage<'a, D>,
    ) -> Self {
        Prioritized {
            variant,
            params,
            ws,
            st,
        }
    }
}

impl<M: Models<D>, const D: usize> Planner<M, D> for Prioritized<'_, D> {
    const TAKES: Takes = Takes::Fixed;

    fn kind(&self) -> PlannerKind {
        match self.variant {
            Variant::MultiGoal => PlannerKind::Pp,
            Variant::SingleGoal => PlannerKind::PpSingle,
        }
    }

    fn plan(&mut self, req: &mut Request<'_, D>, h: Horizon) -> Status {
        let (problem, h) = (req.problem, h.get());
        if self.st.scratch.len() < h {
            return Status::OutOfMemory("prioritised planning scratch path");
        }
        let n = problem.robots.len();
        // Taken out for the run, so the cache and the search workspace can be borrowed apart.
        let buf = core::mem::take(&mut self.st.starts);
        let mut run = Run::<M, D> {
            pr: problem,
            h,
            starts: StartCache::new(&mut *buf, n, problem.trajectories.len(), &self.params),
            deadline: req.until,
            ws: &mut self.ws,
            scratch: &mut *self.st.scratch,
            params: self.params,
            pairs: PairTable::new(n, problem.trajectories.len()),
            incomplete: false,
            _m: core::marker::PhantomData,
        };
        let status = run.levels(self.variant, &self.params, &mut req.out, &mut req.stats);
        self.st.starts = buf;
        status
    }
}

/// One planning run.
struct Run<'r, 's, M, const D: usize> {
    pr: &'r Problem<D>,
    h: usize,
    starts: StartCache<'r, D>,
    deadline: Until<'r>,
    ws: &'r mut Workspace<'s, D>,
    scratch: &'r mut [[f64; D]],
    /// This level's Ω-A* settings.
    params: OmegaParams,
    pairs: PairTable,
    /// A search at this level ran out of memory: its exhaustion proves nothing.
    incomplete: bool,
    _m: core::marker::PhantomData<M>,
}

/// How the priority orders of one assignment ended.
enum Tried {
    Solved,
    /// Every order failed.
    Exhausted,
    /// The budget ran out first.
    OverBudget,
}

impl<M: Models<D>, const D: usize> Run<'_, '_, M, D> {
    /// Refinement levels in turn until one plans, the deadline passes or the finest is
    /// exhausted.
    fn levels(
        &mut self,
        variant: Variant,
        base: &OmegaParams,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Status {
        for level in 0..LEVELS {
            stats.level = level;
            self.params = level_params(base, level);
            self.incomplete = false;
            self.pairs.forget_failures();
            let status = match variant {
                Variant::SingleGoal => self.assignments(out, stats),
                Variant::MultiGoal => self.orders(None, u64::MAX, out, stats).map(|t| match t {
                    Tried::Solved => Status::Solved,
                    _ => Status::NoSolution,
                }),
            };
            match status {
                Ok(Status::NoSolution) => {}
                Ok(s) | Err(s) => return s,
            }
        }
        if self.incomplete {
            return Status::OutOfMemory("Ω-A* workspace");
        }
        stats.reason = Some(EXHAUSTED);
        Status::NoSolution
    }

    /// Searches every pair not yet known at this level alone (and every robot holding, when
    /// some must).
    fn fill_pairs(&mut self, stats: &mut Stats) -> Result<(), Status> {
        let (n, t) = (self.pr.robots.len(), self.pr.trajectories.len());
        for r in 0..n {
            let columns = (0..t).chain((t < n).then_some(HOLD));
            for c in columns {
                if self.pairs.get(r, c) != Pair::Unknown {
                    continue;
                }
                let (allowed, hold) = if c == HOLD {
                    (0, true)
                } else {
                    (1u32 << c, false)
                };
                let found = self.search(r, allowed, hold, &[], stats)?;
                let pair = match found {
                    Some(_) => Pair::Feasible(path_length(&self.scratch[..self.h])),
                    None => Pair::Infeasible,
                };
                self.pairs.set(r, c, pair);
            }
        }
        Ok(())
    }

    /// OM-PP-A*_single at this level: assignments cheapest first, in rounds of doubling width
    /// and budget, until one plans or a round leaves none cut short (this level exhausted).
    fn assignments(
        &mut self,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Result<Status, Status> {
        self.fill_pairs(stats)?;
        if self.pairs.orphan().is_some() {
            return Ok(Status::NoSolution);
        }
        for round in 0u32.. {
            let budget = ASSIGNMENT_BUDGET.saturating_mul(1 << round.min(40));
            let width = 1u64 << round.min(40);
            let (mut after, mut visited, mut cut) = (None, 0u64, false);
            while visited < width {
                let Some(choice) = self.pairs.next(after.as_ref()) else {
                    break;
                };
                match self.orders(Some(&choice), budget, out, stats)? {
                    Tried::Solved => return Ok(Status::Solved),
                    Tried::Exhausted => {}
                    Tried::OverBudget => cut = true,
                }
                visited += 1;
                after = Some(choice);
            }
            let more = self.pairs.next(after.as_ref()).is_some();
            if !more && !cut {
                return Ok(Status::NoSolution);
            }
        }
        Ok(Status::NoSolution)
    }

    /// Priority orders for one assignment (`None`: multi-goal) until one plans, all fail, or
    /// `budget` expansions are spent. Robots that hold come first (they cannot give way), then
    /// the others by decreasing single-arm cost (the hardest first), then every other order.
    fn orders(
        &mut self,
        choice: Option<&Choice>,
        budget: u64,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Result<Tried, Status> {
        let n = self.pr.robots.len();
        let t = self.pr.trajectories.len();
        let mut base = identity(n);
        if let Some(c) = choice {
            let key = |r: u8| match c.trajectory_of(usize::from(r), t) {
                None => f64::INFINITY,
                Some(j) => match self.pairs.get(usize::from(r), j) {
                    Pair::Feasible(x) => x,
                    _ => 0.0,
                },
            };
            // Stable insertion sort, decreasing key.
            for i in 1..n {
                let mut k = i;
                while k > 0 && key(base[k - 1]) < key(base[k]) {
                    base.swap(k - 1, k);
                    k -= 1;
                }
            }
        }
        let start = stats.expansions;
        let mut perm = identity(n);
        // Robots at the first `kept` ranks of `perm` were planned by the last attempt with the
        // same robots before them, so their paths in `out` stand: the search is deterministic,
        // and a robot's query depends only on the robots before it (and, for multi-goal, on
        // the pair table, which is why a change to it keeps nothing).
        let mut kept = 0;
        loop {
            if self.deadline.expired() {
                return Err(Status::Timeout);
            }
            let order: [u8; MAX_ROBOTS] =
                core::array::from_fn(|i| if i < n { base[usize::from(perm[i])] } else { 0 });
            let known = self.pairs_known();
            let failed = match self.attempt(&order[..n], kept, choice, out, stats)? {
                None => return Ok(Tried::Solved),
                Some(rank) => rank,
            };
            if choice.is_none() {
                // Multi-goal learns what each robot can track alone only once it needs to.
                self.fill_pairs(stats)?;
                if self.pairs.orphan().is_some() {
                    return Ok(Tried::Exhausted);
                }
            }
            let Some(same) = skip_failed(&mut perm[..n], failed) else {
                return Ok(Tried::Exhausted);
            };
            let stable = known && self.pairs_known();
            kept = if stable || choice.is_some() { same } else { 0 };
            if stats.expansions - start >= budget {
                return Ok(Tried::OverBudget);
            }
        }
    }

    /// Whether every robot's feasible trajectories are known (multi-goal's masks no longer
    /// change within this level) and no search ran out of memory.
    fn pairs_known(&self) -> bool {
        let t = self.pr.trajectories.len();
        !self.incomplete
            && (0..self.pr.robots.len())
                .all(|r| (0..t).all(|j| self.pairs.get(r, j) != Pair::Unknown))
    }

    /// Plans the robots in `order` from rank `kept` on (those before it are in `out` from the
    /// last attempt); `None` when all are planned and every trajectory is taken, else the rank
    /// of the robot that found no path (the last rank when trajectories are left untaken: no
    /// other order with the same robots first differs).
    fn attempt(
        &mut self,
        order: &[u8],
        kept: usize,
        choice: Option<&Choice>,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Result<Option<usize>, Status> {
        let (n, h) = (self.pr.robots.len(), self.h);
        let ntraj = self.pr.trajectories.len();
        let all = if ntraj >= 32 {
            u32::MAX
        } else {
            (1u32 << ntraj) - 1
        };
        let mut taken = 0u32;
        for &r in &order[..kept] {
            if let Some(j) = out.assignment[usize::from(r)] {
                taken |= 1 << j;
            }
        }
        for (rank, &r) in order.iter().enumerate().skip(kept) {
            let r = usize::from(r);
            let (allowed, hold) = match choice {
                None => {
                    let left = all & !taken;
                    // Hold only if the robots still to plan can cover what is left without it;
                    // a trajectory the robot cannot track alone is no goal for it, except at
                    // a level whose pairs are not all known.
                    let mask = if self.incomplete {
                        all
                    } else {
                        self.feasible_or_all(r)
                    };
                    (left & mask, (n - rank) as u32 > left.count_ones())
                }
                Some(c) => match c.trajectory_of(r, ntraj) {
                    Some(j) => (1u32 << j, false),
                    None => (0, true),
                },
            };
            let mut others: heapless::Vec<OtherArm<'_, D>, MAX_ROBOTS> = heapless::Vec::new();
            for &k in &order[..rank] {
                let k = usize::from(k);
                let _ = others.push(OtherArm {
                    model: self.pr.robots[k].model,
                    base: self.pr.robots[k].base,
                    tool: self.pr.robots[k].tool,
                    path: &out.paths[k * h..(k + 1) * h],
                });
            }
            let found = self.search(r, allowed, hold, &others, stats)?;
            drop(others);
            let Some(trajectory) = found else {
                return Ok(Some(rank));
            };
            out.paths[r * h..(r + 1) * h].copy_from_slice(&self.scratch[..h]);
            out.assignment[r] = trajectory;
            if let Some(j) = trajectory {
                taken |= 1 << j;
            }
        }
        Ok((taken != all).then_some(n - 1))
    }

    /// The trajectories robot `r` can track alone, once known (multi-goal fills the table
    /// only when its first attempt fails); all of them before.
    fn feasible_or_all(&self, r: usize) -> u32 {
        let known = (0..self.pr.trajectories.len()).all(|j| self.pairs.get(r, j) != Pair::Unknown);
        if known {
            self.pairs.feasible(r)
        } else {
            u32::MAX
        }
    }

    /// One Ω-A* search for robot `r` avoiding `others`, the path left in scratch: the
    /// trajectory taken (`None` holding), `Ok(None)` when there is no path. Running out of
    /// memory counts as no path but marks the level incomplete.
    fn search(
        &mut self,
        r: usize,
        allowed: u32,
        hold: bool,
        others: &[OtherArm<'_, D>],
        stats: &mut Stats,
    ) -> Result<Option<Option<u8>>, Status> {
        let query = Query {
            robot: self.pr.robots[r],
            trajectories: &self.pr.trajectories,
            allowed,
            hold,
            obstacles: &self.pr.obstacles,
            others,
            others_mode: OthersMode::Avoid,
            points: &[],
            dt: self.pr.dt,
            starts: self.starts.robot(r),
        };
        let mut s = SearchStats::default();
        stats.low_level_calls += 1;
        let res = plan::<M, D>(
            &query,
            &self.params,
            self.ws,
            &self.deadline,
            self.scratch,
            &mut s,
        );
        stats.expansions += u64::from(s.expansions);
        match res {
            Ok(found) => Ok(Some(found.trajectory)),
            Err(SearchError::NoSolution) => Ok(None),
            Err(SearchError::OutOfMemory) => {
                self.incomplete = true;
                Ok(None)
            }
            Err(SearchError::Timeout) => Err(Status::Timeout),
            Err(SearchError::InvalidQuery(m)) => Err(Status::InvalidProblem(m)),
        }
    }
}

/// Joint-space length of a path.
fn path_length<const D: usize>(path: &[[f64; D]]) -> f64 {
    path.windows(2)
        .map(|w| {
            libm::sqrt(
                (0..D)
                    .map(|i| (w[1][i] - w[0][i]) * (w[1][i] - w[0][i]))
                    .sum(),
            )
        })
        .sum()
}

/// Assignments (outer loop, only when `assignments`) and priority orders (inner loop), both in
/// lexicographic order: trajectory `j` goes to robot `assign[j]`, robots `assign[T..]` hold.
pub(crate) struct Orders {
    pub order: [u8; MAX_ROBOTS],
    pub assign: [u8; MAX_ROBOTS],
    n: usize,
    t: usize,
    assignments: bool,
}

impl Orders {
    pub fn new(n: usize, t: usize, assignments: bool) -> Self {
        Orders {
            order: identity(n),
            assign: identity(n),
            n,
            t,
            assignments,
        }
    }

    /// The trajectory robot `r` tracks under the current assignment, `None` when it holds.
    pub fn trajectory_of(&self, r: usize) -> Option<usize> {
        self.assign[..self.t].iter().position(|&x| x as usize == r)
    }

    /// Steps to the next assignment, keeping the order; `false` after the last.
    pub fn next_assignment(&mut self) -> bool {
        next_assignment(&mut self.assign[..self.n], self.t)
    }

    /// Steps to the next (assignment, order); `false` when all were tried.
    pub fn advance(&mut self) -> bool {
        if next_permutation(&mut self.order[..self.n]) {
            return true;
        }
        self.order = identity(self.n);
        self.assignments && self.next_assignment()
    }
}

pub(crate) fn identity(n: usize) -> [u8; MAX_ROBOTS] {
    let mut a = [0u8; MAX_ROBOTS];
    for (i, x) in a.iter_mut().enumerate().take(n) {
        *x = i as u8;
    }
    a
}

/// Steps `a` to the next permutation in lexicographic order; `false` after the last.
pub(crate) fn next_permutation(a: &mut [u8]) -> bool {
    if a.len() < 2 {
        return false;
    }
    let Some(i) = (0..a.len() - 1).rev().find(|&i| a[i] < a[i + 1]) else {
        return false;
    };
    let j = (i + 1..a.len())
        .rev()
        .find(|&j| a[j] > a[i])
        .unwrap_or(i + 1);
    a.swap(i, j);
    a[i + 1..].reverse();
    true
}

/// Steps `perm` past every order that keeps the robots at ranks `..=failed` where they are
/// (each of them fails at `failed` again, in the same way: the robots before it plan as they
/// did) to the next order in lexicographic order; `None` after the last. Returns how many
/// leading ranks the new order shares with the old one and were planned (at most `failed`).
pub(crate) fn skip_failed(perm: &mut [u8], failed: usize) -> Option<usize> {
    let before: heapless::Vec<u8, MAX_ROBOTS> = perm.iter().copied().collect();
    if failed + 1 < perm.len() {
        perm[failed + 1..].sort_unstable_by(|a, b| b.cmp(a));
    }
    if !next_permutation(perm) {
        return None;
    }
    let same = perm.iter().zip(&before).take_while(|(a, b)| a == b).count();
    Some(same.min(failed))
}

/// Next assignment: permutations whose holding robots (`a[t..]`) are in increasing order, so
/// each distinct assignment comes once.
pub(crate) fn next_assignment(a: &mut [u8], t: usize) -> bool {
    while next_permutation(a) {
        if a[t.min(a.len())..].windows(2).all(|w| w[0] < w[1]) {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutations_and_assignments_are_enumerated_once() {
        let mut a = [0u8, 1, 2, 3];
        let mut n = 1;
        while next_permutation(&mut a) {
            n += 1;
        }
        assert_eq!(n, 24);
        // 4 robots, 2 trajectories: 4 * 3 ordered choices of trackers.
        let mut a = [0u8, 1, 2, 3];
        let mut n = 1;
        while next_assignment(&mut a, 2) {
            n += 1;
        }
        assert_eq!(n, 12);
    }

    #[test]
    fn a_failed_prefix_is_never_tried_again_and_the_rest_are_all_tried() {
        // An order fails at the first rank whose robots so far meet a rule (the last rank if
        // none): as in the planner, where the robots up to a rank decide whether it fails.
        let fail_at = |p: &[u8]| {
            (0..p.len())
                .find(|&i| {
                    p[..=i].iter().map(|&r| usize::from(r)).sum::<usize>() * (i + 1) % 4 == 1
                })
                .unwrap_or(p.len() - 1)
        };
        let n = 5;
        let mut all = identity(n);
        let mut expected = 0;
        let mut seen_prefixes: heapless::Vec<([u8; MAX_ROBOTS], usize), 200> = heapless::Vec::new();
        loop {
            let k = fail_at(&all[..n]);
            let mut prefix = [u8::MAX; MAX_ROBOTS];
            prefix[..=k].copy_from_slice(&all[..=k]);
            if !seen_prefixes.iter().any(|(p, _)| *p == prefix) {
                seen_prefixes.push((prefix, k)).unwrap();
                expected += 1;
            }
            if !next_permutation(&mut all[..n]) {
                break;
            }
        }
        let mut perm = identity(n);
        let (mut tried, mut last) = (0, identity(n));
        loop {
            tried += 1;
            let k = fail_at(&perm[..n]);
            last.copy_from_slice(&perm);
            match skip_failed(&mut perm[..n], k) {
                None => break,
                Some(kept) => {
                    assert!(kept <= k);
                    assert_eq!(perm[..kept], last[..kept]);
                    // Something at or before the failed rank moved.
                    assert_ne!(perm[..=k], last[..=k]);
                }
            }
        }
        assert_eq!(tried, expected);
    }
}
