//! Detours through via configurations: before one arm searches its way around the others
//! with RRT-Connect, a few fixed detours are tried, each leg checked like any motion:
//! 1. turn about the base first and then take the final shape;
//! 2. take the shape first and then turn (joint 0 turns the arm about its base; the others
//!    set its shape): either moves each joint once, as far as the straight bridge does, so the
//!    approach takes about as long;
//! 3. fold to the model's rest configuration ([`Model::REST`](crate::model::Model::REST), the
//!    vendor's retract or ready pose) facing where the arm stands, turn to face the goal, and
//!    unfold: longer, but a folded arm clears a post or a neighbour that both straight
//!    detours sweep through.
//!
//! Where one is free it costs a few motion checks where a search checks a tree of them. When
//! all are blocked the search runs as before, so its completeness is unchanged.

use crate::model::Models;
use crate::problem::MAX_ROBOTS;

use super::fleet::Fleet;

/// Most legs of a detour.
const MAX_LEGS: usize = 3;

/// Moves robot `r` from its configuration in `at` to `goal` through the first free detour,
/// the others standing. Writes the waypoints after `at` (the vias, then `at` with `goal`) to
/// `out` and returns how many (2 or 3); `None` when every detour is blocked.
pub(super) fn detour<M: Models<D>, const D: usize>(
    fleet: &Fleet<'_, M, D>,
    at: &[[f64; D]],
    r: usize,
    goal: &[f64; D],
    out: &mut [[f64; D]],
) -> Option<usize> {
    let n = fleet.n;
    if D == 0 || out.len() < MAX_LEGS * n {
        return None;
    }
    let fleet = &mut fleet.standing(at, 1 << r);
    let (s, g) = (at[r], *goal);
    let turned = |q: &[f64; D], yaw: f64| {
        let mut v = *q;
        v[0] = yaw;
        v
    };
    // Each detour's vias (a leg fewer than its waypoints).
    let (first, second) = ([turned(&s, g[0])], [turned(&g, s[0])]);
    let folded = M::rest(fleet.model(r)).map(|rest| [turned(&rest, s[0]), turned(&rest, g[0])]);
    let detours = [
        Some(&first[..]),
        Some(&second[..]),
        folded.as_ref().map(|f| &f[..]),
    ];
    for vias in detours.into_iter().flatten() {
        let legs = vias.len() + 1;
        let mut way = [[[0.0; D]; MAX_ROBOTS]; MAX_LEGS + 1];
        for (k, w) in way.iter_mut().enumerate().take(legs + 1) {
            w[..n].copy_from_slice(at);
            w[r] = match k {
                0 => s,
                k if k == legs => g,
                k => vias[k - 1],
            };
        }
        // The vias first: a blocked configuration is cheaper to find than a blocked motion.
        if (1..legs).all(|k| fleet.state_blocked(&way[k][..n]).is_none())
            && (0..legs).all(|k| {
                fleet
                    .motion_blocked(&way[k][..n], &way[k + 1][..n])
                    .is_none()
            })
        {
            for k in 0..legs {
                out[k * n..(k + 1) * n].copy_from_slice(&way[k + 1][..n]);
            }
            return Some(legs);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::super::fleet::tests::{draw, row};
    use super::*;
    use crate::model::{KinovaGen3, Model};
    use crate::rng::Rng;

    /// A detour found is two or three legs the fleet finds free, through vias that differ from
    /// the start or the goal in joint 0 alone, or are the model's rest configuration turned;
    /// and some of each are found where the bridge is blocked.
    #[test]
    fn a_detour_is_free_legs_through_turned_or_folded_vias() {
        let problem = row();
        let mut fleet = Fleet::<KinovaGen3, 7>::new(&problem, crate::motion::MOTION_STEP);
        let rest = KinovaGen3::REST.unwrap_or_default();
        let mut rng = Rng::new(11);
        let mut found = [0; 2];
        for round in 0..600 {
            let at: [[f64; 7]; 3] = core::array::from_fn(|_| draw(&mut rng));
            let (r, goal) = (round % 3, draw(&mut rng));
            let mut end = at;
            end[r] = goal;
            if fleet.state_blocked(&at).is_some()
                || fleet.state_blocked(&end).is_some()
                || fleet.motion_blocked(&at, &end).is_none()
            {
                continue;
            }
            let mut out = [[0.0; 7]; 9];
            let Some(k) = detour(&fleet, &at, r, &goal, &mut out) else {
                continue;
            };
            assert!(k == 2 || k == 3, "round {round}");
            found[k - 2] += 1;
            let way: heapless::Vec<&[[f64; 7]], 4> = core::iter::once(&at[..])
                .chain((0..k).map(|i| &out[i * 3..(i + 1) * 3]))
                .collect();
            assert_eq!(way[k], &end[..]);
            let same_but_yaw = |a: &[f64; 7], b: &[f64; 7]| (1..7).all(|j| a[j] == b[j]);
            for (i, via) in way[1..k].iter().enumerate() {
                let v = &via[r];
                if k == 2 {
                    assert!(
                        same_but_yaw(v, &at[r]) || same_but_yaw(v, &goal),
                        "round {round}"
                    );
                } else {
                    assert!(same_but_yaw(v, &rest), "round {round}");
                    assert_eq!(v[0], if i == 0 { at[r][0] } else { goal[0] });
                }
                for o in (0..3).filter(|&o| o != r) {
                    assert_eq!(via[o], at[o]);
                }
                assert!(fleet.state_blocked(via).is_none());
            }
            for leg in way.windows(2) {
                assert!(
                    fleet.motion_blocked(leg[0], leg[1]).is_none(),
                    "round {round}"
                );
            }
        }
        assert!(found[0] >= 3 && found[1] >= 3, "{found:?} detours found");
    }
}
