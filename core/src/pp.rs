//! On-manifold prioritised planning: OM-PP-A* (multi-goal Ω-A* per robot) and
//! OM-PP-A*_single (single-goal Ω-A* under an explicit assignment).
//!
//! Robots plan one after another; each treats the paths of the robots before it as moving
//! obstacles it must avoid. Prioritised planning is incomplete, so both planners try priority
//! orders (and, for the single-goal variant, assignments) in lexicographic order until one
//! works, the orders run out (`NoSolution`) or time does (`Timeout`).

use crate::model::Model;
use crate::planner::{check_problem, Clock, Planner, Solution, Stats, Status, Until};
use crate::problem::{Problem, MAX_ROBOTS};
use crate::search::{
    plan, Deadline, OmegaParams, OtherArm, OthersMode, Query, SearchError, SearchStats, StartCache,
    StartIk, Workspace,
};

/// Which Ω-A* the robots use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// OM-PP-A*: each robot picks among the trajectories not yet taken.
    MultiGoal,
    /// OM-PP-A*_single: the assignment is enumerated; each robot tracks the one it is given.
    SingleGoal,
}

/// A prioritised planner.
pub struct Prioritized<'a, const D: usize> {
    pub variant: Variant,
    pub params: OmegaParams,
    ws: Workspace<'a, D>,
    scratch: &'a mut [[f64; D]],
    starts: &'a mut [StartIk<D>],
}

impl<'a, const D: usize> Prioritized<'a, D> {
    /// `scratch` must hold at least H configurations; `starts` remembers start-seed IK
    /// answers across priority orders (see [`StartCache`]; too short, it remembers none).
    pub fn new(
        variant: Variant,
        params: OmegaParams,
        ws: Workspace<'a, D>,
        scratch: &'a mut [[f64; D]],
        starts: &'a mut [StartIk<D>],
    ) -> Self {
        Prioritized {
            variant,
            params,
            ws,
            scratch,
            starts,
        }
    }
}

impl<M: Model<D>, const D: usize> Planner<M, D> for Prioritized<'_, D> {
    fn name(&self) -> &'static str {
        match self.variant {
            Variant::MultiGoal => "pp",
            Variant::SingleGoal => "pp-single",
        }
    }

    fn solve(
        &mut self,
        problem: &Problem<D>,
        clock: &dyn Clock,
        timeout: f64,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Status {
        let h = match check_problem(problem, out) {
            Ok(h) => h,
            Err(s) => return s,
        };
        if self.scratch.len() < h {
            return Status::OutOfMemory("prioritised planning scratch path");
        }
        let n = problem.robots.len();
        let deadline = Until { clock, at: timeout };
        // Taken out for the run, so the cache and the search workspace can be borrowed apart.
        let buf = core::mem::take(&mut self.starts);
        let starts = StartCache::new(&mut *buf, n, problem.trajectories.len(), &self.params);
        let status = self.orders::<M>(problem, h, &starts, &deadline, out, stats);
        self.starts = buf;
        status
    }
}

impl<const D: usize> Prioritized<'_, D> {
    /// Tries assignments and priority orders until one works or time or orders run out.
    fn orders<M: Model<D>>(
        &mut self,
        problem: &Problem<D>,
        h: usize,
        starts: &StartCache<'_, D>,
        deadline: &Until<'_>,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Status {
        let mut orders = Orders::new(
            problem.robots.len(),
            problem.trajectories.len(),
            self.variant == Variant::SingleGoal,
        );
        loop {
            // Attempts that fail at once never reach Ω-A*'s own deadline checks.
            if deadline.expired() {
                return Status::Timeout;
            }
            match self.attempt::<M>(problem, h, &orders, starts, deadline, out, stats) {
                Ok(true) => return Status::Solved,
                Ok(false) => {}
                Err(s) => return s,
            }
            if !orders.advance() {
                return Status::NoSolution;
            }
        }
    }

    /// Plans the robots in `order`; `Ok(false)` when one of them finds no path.
    #[allow(clippy::too_many_arguments)]
    fn attempt<M: Model<D>>(
        &mut self,
        problem: &Problem<D>,
        h: usize,
        orders: &Orders,
        starts: &StartCache<'_, D>,
        deadline: &Until<'_>,
        out: &mut Solution<'_, D>,
        stats: &mut Stats,
    ) -> Result<bool, Status> {
        let n = problem.robots.len();
        let ntraj = problem.trajectories.len();
        let all = if ntraj >= 32 {
            u32::MAX
        } else {
            (1u32 << ntraj) - 1
        };
        let mut taken = 0u32;
        for (rank, &r) in orders.order[..n].iter().enumerate() {
            let r = r as usize;
            let (allowed, hold) = match self.variant {
                Variant::MultiGoal => {
                    let left = all & !taken;
                    // Hold only if the robots still to plan can cover what is left without it.
                    (left, (n - rank) as u32 > left.count_ones())
                }
                Variant::SingleGoal => match orders.trajectory_of(r) {
                    Some(j) => (1u32 << j, false),
                    None => (0, true),
                },
            };
            let mut others: heapless::Vec<OtherArm<'_, D>, MAX_ROBOTS> = heapless::Vec::new();
            for &k in &orders.order[..rank] {
                let k = k as usize;
                let _ = others.push(OtherArm {
                    base: problem.robots[k].base,
                    tool: problem.robots[k].tool,
                    path: &out.paths[k * h..(k + 1) * h],
                });
            }
            let query = Query {
                robot: problem.robots[r],
                trajectories: &problem.trajectories,
                allowed,
                hold,
                obstacles: &problem.obstacles,
                others: &others,
                others_mode: OthersMode::Avoid,
                points: &[],
                dt: problem.dt,
                starts: starts.robot(r),
            };
            let mut s = SearchStats::default();
            stats.low_level_calls += 1;
            let res = plan::<M, D>(
                &query,
                &self.params,
                &mut self.ws,
                deadline,
                self.scratch,
                &mut s,
            );
            drop(others);
            stats.expansions += s.expansions as u64;
            match res {
                Ok(found) => {
                    out.paths[r * h..(r + 1) * h].copy_from_slice(&self.scratch[..h]);
                    out.assignment[r] = found.trajectory;
                    if let Some(j) = found.trajectory {
                        taken |= 1 << j;
                    }
                }
                Err(SearchError::NoSolution) => return Ok(false),
                Err(SearchError::Timeout) => return Err(Status::Timeout),
                Err(SearchError::OutOfMemory) => return Err(Status::OutOfMemory("Ω-A* workspace")),
                Err(SearchError::InvalidQuery(m)) => return Err(Status::InvalidProblem(m)),
            }
        }
        Ok(taken == all)
    }
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
}
