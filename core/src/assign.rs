//! Assignments for OM-PP-A*_single, cheapest first, from what each (robot, trajectory) pair
//! does alone: every pair is searched once without the other robots; a pair with no path
//! alone has none with them either, so every assignment using it is skipped, and the others
//! are enumerated in increasing order of their summed single-arm path lengths (the k-best
//! assignments, found again by a bounded depth-first search each time: at most 8! leaves, no
//! memory beyond the table).
//!
//! ```
//! use omcbsa_core::assign::{Pair, PairTable, HOLD};
//!
//! // Two robots, one trajectory: robot 0 tracks it for 1.0 rad of joint motion, robot 1 for
//! // 0.5; either may hold (cost 0).
//! let mut table = PairTable::new(2, 1);
//! table.set(0, 0, Pair::Feasible(1.0));
//! table.set(1, 0, Pair::Feasible(0.5));
//! table.set(0, HOLD, Pair::Feasible(0.0));
//! table.set(1, HOLD, Pair::Feasible(0.0));
//! let first = table.next(None).unwrap();
//! assert_eq!((first.robot_of[0], first.cost), (1, 0.5));
//! assert_eq!(first.trajectory_of(1, 1), Some(0));
//! assert_eq!(first.trajectory_of(0, 1), None); // robot 0 holds
//! let second = table.next(Some(&first)).unwrap();
//! assert_eq!(second.robot_of[0], 0);
//! assert!(table.next(Some(&second)).is_none());
//! ```

use crate::problem::MAX_ROBOTS;

/// What one robot does alone on one trajectory (or holding).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Pair {
    /// Not searched at this level.
    #[default]
    Unknown,
    /// No path alone at this level's resolution.
    Infeasible,
    /// A path alone of this joint-space length.
    Feasible(f64),
}

/// Column of [`PairTable`] for holding the initial configuration.
pub const HOLD: usize = MAX_ROBOTS;

/// Single-arm results of every (robot, trajectory) pair of a problem and of every robot
/// holding.
#[derive(Clone, Copy, Debug)]
pub struct PairTable {
    cells: [[Pair; MAX_ROBOTS + 1]; MAX_ROBOTS],
    n: usize,
    t: usize,
}

/// One assignment: trajectory `j < t` goes to robot `robot_of[j]`, every other robot holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    /// The summed single-arm path lengths of the pairs used (joint space, rad).
    pub cost: f64,
    /// The robot of each trajectory (entries past the problem's trajectories are unused).
    pub robot_of: [u8; MAX_ROBOTS],
}

impl Choice {
    /// The trajectory robot `r` tracks, `None` when it holds.
    pub fn trajectory_of(&self, r: usize, t: usize) -> Option<usize> {
        self.robot_of[..t].iter().position(|&x| usize::from(x) == r)
    }

    /// Order of enumeration: cheaper first, ties by the robots in trajectory order.
    fn before(&self, other: &Choice, t: usize) -> bool {
        self.cost < other.cost
            || (self.cost == other.cost && self.robot_of[..t] < other.robot_of[..t])
    }
}

impl PairTable {
    /// A table of `robots` robots (at most [`MAX_ROBOTS`]) and `trajectories` trajectories
    /// (at most `robots`), every cell [`Pair::Unknown`].
    pub fn new(robots: usize, trajectories: usize) -> Self {
        PairTable {
            cells: [[Pair::Unknown; MAX_ROBOTS + 1]; MAX_ROBOTS],
            n: robots,
            t: trajectories,
        }
    }

    /// Robot `r` on column `c` (a trajectory, or [`HOLD`]).
    pub fn get(&self, r: usize, c: usize) -> Pair {
        self.cells[r][c]
    }

    /// Records what robot `r` does alone on column `c` (a trajectory, or [`HOLD`]).
    pub fn set(&mut self, r: usize, c: usize, p: Pair) {
        self.cells[r][c] = p;
    }

    /// Forgets the failures, which a finer level may overturn; the paths found stay found.
    pub fn forget_failures(&mut self) {
        for p in self.cells.iter_mut().flatten() {
            if *p == Pair::Infeasible {
                *p = Pair::Unknown;
            }
        }
    }

    /// Bit `j` set: robot `r` has a path alone on trajectory `j`.
    pub fn feasible(&self, r: usize) -> u32 {
        (0..self.t)
            .filter(|&j| matches!(self.cells[r][j], Pair::Feasible(_)))
            .fold(0, |m, j| m | 1 << j)
    }

    /// A trajectory no robot has a path for alone, if any.
    pub fn orphan(&self) -> Option<usize> {
        (0..self.t).find(|&j| (0..self.n).all(|r| self.feasible(r) & (1 << j) == 0))
    }

    /// The first assignment after `after` (or the first of all) in order of cost, using only
    /// feasible pairs and holders; `None` after the last.
    pub fn next(&self, after: Option<&Choice>) -> Option<Choice> {
        let mut best = None;
        let mut cur = [0u8; MAX_ROBOTS];
        self.dfs(0, 0, 0.0, &mut cur, after, &mut best);
        best
    }

    fn dfs(
        &self,
        j: usize,
        used: u32,
        cost: f64,
        cur: &mut [u8; MAX_ROBOTS],
        after: Option<&Choice>,
        best: &mut Option<Choice>,
    ) {
        // Costs are lengths, never negative: a partial sum above the best cannot win.
        if best.as_ref().is_some_and(|b: &Choice| cost > b.cost) {
            return;
        }
        if j == self.t {
            let mut total = cost;
            for r in (0..self.n).filter(|r| used & (1 << r) == 0) {
                match self.cells[r][HOLD] {
                    Pair::Feasible(c) => total += c,
                    _ => return,
                }
            }
            let cand = Choice {
                cost: total,
                robot_of: *cur,
            };
            let later = after.is_none_or(|a| a.before(&cand, self.t));
            if later && best.as_ref().is_none_or(|b| cand.before(b, self.t)) {
                *best = Some(cand);
            }
            return;
        }
        for r in 0..self.n {
            if used & (1 << r) != 0 {
                continue;
            }
            if let Pair::Feasible(c) = self.cells[r][j] {
                cur[j] = r as u8;
                self.dfs(j + 1, used | 1 << r, cost + c, cur, after, best);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_come_cheapest_first_and_skip_infeasible_pairs() {
        // 3 robots, 2 trajectories; robot 2 cannot take trajectory 0; everyone may hold.
        let mut t = PairTable::new(3, 2);
        let costs = [[1.0, 5.0], [2.0, 1.0], [f64::NAN, 3.0]];
        for (r, row) in costs.iter().enumerate() {
            for (j, &c) in row.iter().enumerate() {
                let p = if c.is_nan() {
                    Pair::Infeasible
                } else {
                    Pair::Feasible(c)
                };
                t.set(r, j, p);
            }
            t.set(r, HOLD, Pair::Feasible(0.0));
        }
        let mut seen = [0.0f64; 8];
        let mut n = 0;
        let mut after = None;
        while let Some(c) = t.next(after.as_ref()) {
            assert_ne!(c.robot_of[0], 2, "an infeasible pair was used");
            seen[n] = c.cost;
            n += 1;
            after = Some(c);
        }
        // (0,1) 2, (0,2) 4, (1,0) 7, (1,2) 5: all four, in increasing cost.
        assert_eq!(&seen[..n], &[2.0, 4.0, 5.0, 7.0]);
        assert_eq!(t.orphan(), None);
        t.set(0, 0, Pair::Infeasible);
        t.set(1, 0, Pair::Infeasible);
        assert_eq!(t.orphan(), Some(0));
        assert_eq!(t.next(None), None);
    }
}
