//! Detours through a via configuration: before one arm searches its way around the others
//! with RRT-Connect, two fixed detours of two straight legs are tried, each checked like any
//! motion: turn about the base first and then take the final shape, or take the shape first
//! and then turn (joint 0 turns the arm about its base; the others set its shape). Either
//! moves each joint once, as far as the straight bridge does, so the approach takes about as
//! long; where one is free it costs a few motion checks where a search checks a tree of them.
//! When both are blocked the search runs as before, so its completeness is unchanged.

use crate::model::Models;
use crate::problem::MAX_ROBOTS;

use super::composite::Composite;

/// Moves robot `r` from its configuration in `at` to `goal` through the first free detour,
/// the others standing. Writes the waypoints after `at` (the via, then `at` with `goal`) to
/// `out` and returns how many (2); `None` when both detours are blocked.
pub(super) fn detour<M: Models<D>, const D: usize>(
    composite: &Composite<'_, M, D>,
    at: &[[f64; D]],
    r: usize,
    goal: &[f64; D],
    out: &mut [[f64; D]],
) -> Option<usize> {
    let n = composite.n;
    if D == 0 || out.len() < 2 * n {
        return None;
    }
    let composite = &mut composite.standing(at, 1 << r);
    let (s, g) = (at[r], *goal);
    let turned = |q: &[f64; D], yaw: f64| {
        let mut v = *q;
        v[0] = yaw;
        v
    };
    for via in [turned(&s, g[0]), turned(&g, s[0])] {
        let mut legs = [[[0.0; D]; MAX_ROBOTS]; 3];
        for leg in &mut legs {
            leg[..n].copy_from_slice(at);
        }
        legs[1][r] = via;
        legs[2][r] = g;
        if composite.state_blocked(&legs[1][..n]).is_none()
            && (0..2).all(|k| {
                composite
                    .motion_blocked(&legs[k][..n], &legs[k + 1][..n])
                    .is_none()
            })
        {
            out[..n].copy_from_slice(&legs[1][..n]);
            out[n..2 * n].copy_from_slice(&legs[2][..n]);
            return Some(2);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::super::composite::tests::{draw, row};
    use super::*;
    use crate::model::KinovaGen3;
    use crate::rng::Rng;

    /// A detour found is two legs the composite finds free, through a via that differs from the
    /// start or the goal in joint 0 alone; and some are found where the bridge is blocked.
    #[test]
    fn a_detour_is_two_free_legs_through_a_turned_via() {
        let problem = row();
        let mut composite = Composite::<KinovaGen3, 7>::new(&problem, crate::motion::MOTION_STEP);
        let mut rng = Rng::new(11);
        let mut found = 0;
        for round in 0..400 {
            let at: [[f64; 7]; 3] = core::array::from_fn(|_| draw(&mut rng));
            let (r, goal) = (round % 3, draw(&mut rng));
            let mut end = at;
            end[r] = goal;
            if composite.state_blocked(&at).is_some()
                || composite.state_blocked(&end).is_some()
                || composite.motion_blocked(&at, &end).is_none()
            {
                continue;
            }
            let mut out = [[0.0; 7]; 6];
            let Some(k) = detour(&composite, &at, r, &goal, &mut out) else {
                continue;
            };
            found += 1;
            assert_eq!(k, 2);
            let (via, last) = (&out[..3], &out[3..6]);
            assert_eq!(last, &end[..]);
            let turned = |q: &[f64; 7]| (1..7).all(|j| via[r][j] == q[j]);
            assert!(turned(&at[r]) || turned(&goal), "round {round}");
            for k in (0..3).filter(|&k| k != r) {
                assert_eq!(via[k], at[k]);
            }
            assert!(composite.state_blocked(via).is_none());
            assert!(composite.motion_blocked(&at, via).is_none());
            assert!(composite.motion_blocked(via, last).is_none());
        }
        assert!(found >= 3, "{found} detours found");
    }
}
