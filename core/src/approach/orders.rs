//! The orders in which the arms take their straight bridges one at a time.
//!
//! While one arm moves along its bridge (from where it stands to where its path begins), every
//! other arm stands at its own start or its own goal. So whether that move is free depends only
//! on the moving arm and, for each other arm, on which of its two ends it stands at: at most
//! `n` checks of an arm against the obstacles and itself, and `2 n (n - 1)` checks of a
//! moving arm against one standing arm, decide every move of every one of the `n!` orders.
//! [`Bridges`] makes those checks when first asked and keeps their answers (a few bits), so
//! searching over all orders costs no more motion checks than trying one order per arm pair,
//! where trying orders one after the other checked the same moves again and again.

use crate::model::Models;
use crate::problem::MAX_ROBOTS;

use super::composite::Composite;

/// Sets of robots (bit `i`: robot `i`) in `0..1 << MAX_ROBOTS`.
const SETS: usize = 1 << MAX_ROBOTS;

/// The straight bridges of a composite's robots from `starts` to `goals`, checked when first
/// asked about.
pub(super) struct Bridges<'s, const D: usize> {
    starts: &'s [[f64; D]],
    goals: &'s [[f64; D]],
    /// Robots that move (start and goal differ).
    moving: u32,
    /// Bit `r`: robot `r`'s own check (obstacles, itself) is known / blocked.
    own_known: u32,
    own_blocked: u32,
    /// `[r][side]`, bit `k`: robot `r`'s bridge against robot `k` standing at its start
    /// (side 0) or its goal (side 1) is known / blocked.
    pair_known: [[u32; 2]; MAX_ROBOTS],
    pair_blocked: [[u32; 2]; MAX_ROBOTS],
}

impl<'s, const D: usize> Bridges<'s, D> {
    pub fn new<M: Models<D>>(
        composite: &Composite<'_, M, D>,
        starts: &'s [[f64; D]],
        goals: &'s [[f64; D]],
    ) -> Self {
        let moving = (0..composite.n)
            .filter(|&i| composite.is_active(i) && starts[i] != goals[i])
            .fold(0u32, |m, i| m | 1 << i);
        Bridges {
            starts,
            goals,
            moving,
            own_known: 0,
            own_blocked: 0,
            pair_known: [[0; 2]; MAX_ROBOTS],
            pair_blocked: [[0; 2]; MAX_ROBOTS],
        }
    }

    /// How many robots move (the length of an order).
    pub fn moving(&self) -> usize {
        self.moving.count_ones() as usize
    }

    /// Whether robot `r`'s bridge touches an obstacle or the arm itself (no order helps).
    pub fn own_blocked<M: Models<D>>(&mut self, composite: &Composite<'_, M, D>, r: usize) -> bool {
        if self.own_known & (1 << r) == 0 {
            self.own_known |= 1 << r;
            if composite.own_motion_blocked(r, &self.starts[r], &self.goals[r]) {
                self.own_blocked |= 1 << r;
            }
        }
        self.own_blocked & (1 << r) != 0
    }

    /// Whether robot `r`'s bridge is blocked while the robots in `done` stand at their goals
    /// and the others at their starts: exactly [`Composite::motion_blocked`] of that move.
    pub fn blocked<M: Models<D>>(
        &mut self,
        composite: &Composite<'_, M, D>,
        r: usize,
        done: u32,
    ) -> bool {
        if self.own_blocked(composite, r) {
            return true;
        }
        for k in (0..composite.n).filter(|&k| k != r && composite.is_active(k)) {
            // A robot that does not move stands at its start, which is its goal.
            let side = usize::from(done & self.moving & (1 << k) != 0);
            if self.pair_known[r][side] & (1 << k) == 0 {
                self.pair_known[r][side] |= 1 << k;
                let at = if side == 1 {
                    &self.goals[k]
                } else {
                    &self.starts[k]
                };
                if composite.pair_motion_blocked(r, &self.starts[r], &self.goals[r], k, at) {
                    self.pair_blocked[r][side] |= 1 << k;
                }
            }
            if self.pair_blocked[r][side] & (1 << k) != 0 {
                return true;
            }
        }
        false
    }

    /// An order of the moving robots in which each bridge is free when its turn comes, if
    /// there is one: depth first over the sets of robots already at their goals, lowest index
    /// first, each set found to lead nowhere tried once. Complete over all orders.
    pub fn free_order<M: Models<D>>(
        &mut self,
        composite: &Composite<'_, M, D>,
    ) -> Option<[u8; MAX_ROBOTS]> {
        // Every robot blocked by an obstacle or itself stays blocked in every order.
        if (0..composite.n).any(|r| self.moving & (1 << r) != 0 && self.own_blocked(composite, r)) {
            return None;
        }
        let mut dead = [false; SETS];
        let mut order = [0u8; MAX_ROBOTS];
        self.extend_free(composite, 0, &mut dead, &mut order, 0)
            .then_some(order)
    }

    fn extend_free<M: Models<D>>(
        &mut self,
        composite: &Composite<'_, M, D>,
        done: u32,
        dead: &mut [bool; SETS],
        order: &mut [u8; MAX_ROBOTS],
        len: usize,
    ) -> bool {
        if done == self.moving {
            return true;
        }
        if dead[done as usize] {
            return false;
        }
        let left = self.moving & !done;
        for r in (0..composite.n).filter(|&r| left & (1 << r) != 0) {
            if !self.blocked(composite, r, done) {
                order[len] = r as u8;
                if self.extend_free(composite, done | 1 << r, dead, order, len + 1) {
                    return true;
                }
            }
        }
        dead[done as usize] = true;
        false
    }

    /// The order of the moving robots with the fewest blocked bridges (each of which needs a
    /// detour or a search around the others). A* over the sets of robots already moved, from
    /// none to all: a move costs 1 when its bridge is blocked, and the robots blocked by an
    /// obstacle or themselves still to move are a lower bound of what is left (each costs 1 in
    /// every order), so the first time all are moved the order is a fewest-blocked one. Only
    /// the moves out of the sets it expands are asked about, where filling the table of every
    /// set asked about every bridge against every other robot at either end. Ties go to the
    /// set with more robots moved, then the lower set: deterministic.
    pub fn fewest_blocked<M: Models<D>>(
        &mut self,
        composite: &Composite<'_, M, D>,
    ) -> [u8; MAX_ROBOTS] {
        let all = self.moving;
        let own = (0..composite.n)
            .filter(|&r| all & (1 << r) != 0 && self.own_blocked(composite, r))
            .fold(0u32, |m, r| m | 1 << r);
        // g[done]: the fewest blocked moves found to reach `done`; came[done]: the robot that
        // moved last on that way.
        let mut g = [u8::MAX; SETS];
        let mut came = [0u8; SETS];
        let mut closed = [false; SETS];
        g[0] = 0;
        loop {
            let key = |done: u32| {
                let f = u32::from(g[done as usize]) + (own & !done).count_ones();
                (f, MAX_ROBOTS as u32 - done.count_ones(), done)
            };
            // The subsets of `all`, from all down to none.
            let subsets = core::iter::successors(Some(all), |&d| (d != 0).then(|| (d - 1) & all));
            let open = subsets.filter(|&d| g[d as usize] != u8::MAX && !closed[d as usize]);
            let Some(done) = open.min_by_key(|&d| key(d)) else {
                // Unreachable: every set of `all` is reached from the empty one.
                break;
            };
            if done == all {
                break;
            }
            closed[done as usize] = true;
            for r in (0..composite.n).filter(|&r| all & !done & (1 << r) != 0) {
                let next = (done | 1 << r) as usize;
                let c = g[done as usize].saturating_add(u8::from(self.blocked(composite, r, done)));
                if c < g[next] {
                    (g[next], came[next]) = (c, r as u8);
                }
            }
        }
        // Back from all to none.
        let mut order = [0u8; MAX_ROBOTS];
        let (mut len, mut done) = (all.count_ones() as usize, all);
        while len > 0 {
            len -= 1;
            order[len] = came[done as usize];
            done &= !(1 << came[done as usize]);
        }
        order
    }
}

#[cfg(test)]
mod tests {
    use super::super::composite::tests::{draw, row};
    use super::*;
    use crate::model::KinovaGen3;
    use crate::pp::{identity, next_permutation};
    use crate::rng::Rng;

    /// Blocked bridges along `order`, checked by the composite's motion check alone.
    fn blocked_along(
        composite: &mut Composite<'_, KinovaGen3, 7>,
        starts: &[[f64; 7]; 3],
        goals: &[[f64; 7]; 3],
        order: &[u8],
    ) -> usize {
        let mut at = *starts;
        let mut blocked = 0;
        for &r in order {
            let r = usize::from(r);
            let mut to = at;
            to[r] = goals[r];
            blocked += usize::from(composite.motion_blocked(&at, &to).is_some());
            at = to;
        }
        blocked
    }

    /// Against every order of three arms checked move by move with the composite check: each
    /// bridge's answer is the composite check's, a free order is found exactly when one exists
    /// (and is free), and the fewest-blocked order has the fewest.
    #[test]
    fn orders_agree_with_checking_every_order() {
        let problem = row();
        let mut composite = Composite::<KinovaGen3, 7>::new(&problem, crate::motion::MOTION_STEP);
        let mut rng = Rng::new(5);
        let (mut with_free, mut without) = (0, 0);
        for round in 0..150 {
            let starts: [[f64; 7]; 3] = core::array::from_fn(|_| draw(&mut rng));
            let mut goals: [[f64; 7]; 3] = core::array::from_fn(|_| draw(&mut rng));
            if round % 4 == 0 {
                // An arm that does not move.
                goals[round % 3] = starts[round % 3];
            }
            if composite.state_blocked(&starts).is_some()
                || composite.state_blocked(&goals).is_some()
            {
                continue;
            }
            let moves: heapless::Vec<u8, 3> = (0..3u8)
                .filter(|&r| starts[usize::from(r)] != goals[usize::from(r)])
                .collect();
            let mut bridges = Bridges::new(&composite, &starts, &goals);
            assert_eq!(bridges.moving(), moves.len());
            let mut fewest = usize::MAX;
            let mut order = identity(moves.len());
            loop {
                let o: heapless::Vec<u8, 3> = order[..moves.len()]
                    .iter()
                    .map(|&i| moves[usize::from(i)])
                    .collect();
                fewest = fewest.min(blocked_along(&mut composite, &starts, &goals, &o));
                if !next_permutation(&mut order[..moves.len()]) {
                    break;
                }
            }
            let mut at = starts;
            for r in 0..3 {
                let mut to = at;
                to[r] = goals[r];
                let done = (0..3)
                    .filter(|&k| at[k] == goals[k])
                    .fold(0, |m, k| m | 1 << k);
                let expect = composite.motion_blocked(&at, &to).is_some() && starts[r] != goals[r];
                assert_eq!(
                    bridges.blocked(&composite, r, done) && starts[r] != goals[r],
                    expect,
                    "round {round}"
                );
                at = to;
            }
            match bridges.free_order(&composite) {
                Some(o) => {
                    with_free += 1;
                    assert_eq!(fewest, 0, "round {round}");
                    assert_eq!(
                        blocked_along(&mut composite, &starts, &goals, &o[..moves.len()]),
                        0
                    );
                }
                None => {
                    without += 1;
                    assert!(fewest > 0, "round {round}");
                }
            }
            let best = bridges.fewest_blocked(&composite);
            let mut sorted = best;
            sorted[..moves.len()].sort_unstable();
            assert_eq!(&sorted[..moves.len()], &moves[..]);
            assert_eq!(
                blocked_along(&mut composite, &starts, &goals, &best[..moves.len()]),
                fewest,
                "round {round}"
            );
        }
        assert!(
            with_free > 10 && without > 10,
            "{with_free} with a free order, {without} without"
        );
    }
}
