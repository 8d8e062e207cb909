//! Which arm takes which hand, when the caller knows: a fixed assignment (a hand holding an
//! object cannot change arms) or a preferred one (tried first; the planner chooses freely
//! when it has no plan).

use omcbsa_core::model::Models;
use omcbsa_core::planner::{PlannerKind, Status};
use omcbsa_core::problem::{Assigned, Problem};
use omcbsa_core::reach::tcp_reach;

use crate::error::{Errors, InputError};
use crate::planners::{Outcome, Storage, DOF};

/// `list[i]`: the hand robot `i` takes, `None` for a robot that holds still.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum AssignmentRule {
    /// The planner chooses.
    #[default]
    Free,
    /// Kept as given: no plan under it is `no_solution`.
    Fixed(Vec<Option<usize>>),
    /// Tried first; when it has no plan, the planner chooses in the time left.
    Preferred(Vec<Option<usize>>),
}

impl AssignmentRule {
    /// The list of a fixed or preferred rule.
    pub fn list(&self) -> Option<&[Option<usize>]> {
        match self {
            AssignmentRule::Free => None,
            AssignmentRule::Fixed(l) | AssignmentRule::Preferred(l) => Some(l),
        }
    }

    /// Checks the list against `robots` robots and `hands` hands: one entry per robot, hand
    /// indices in range, no hand taken twice, every hand taken. Errors are at `field[i]`.
    pub fn check(&self, field: &str, robots: usize, hands: usize) -> Result<(), InputError> {
        let Some(list) = self.list() else {
            return Ok(());
        };
        let mut errors = Errors::default();
        if list.len() != robots {
            errors.push(
                field,
                format!("{} entries for {robots} robots: one per robot", list.len()),
            );
        }
        let mut taken = vec![None; hands];
        for (i, h) in list.iter().enumerate() {
            let Some(h) = *h else { continue };
            match taken.get_mut(h) {
                None => errors.push(
                    format!("{field}[{i}]"),
                    format!("hand {h} does not exist: there are {hands} hands"),
                ),
                Some(Some(other)) => errors.push(
                    format!("{field}[{i}]"),
                    format!("hand {h} is already taken by robot {other}"),
                ),
                Some(slot) => *slot = Some(i),
            }
        }
        if let Some(h) = taken.iter().position(Option::is_none) {
            errors.push(
                field,
                format!("no robot takes hand {h}: every hand needs one"),
            );
        }
        errors.finish()
    }

    /// Sets every robot of `problem` to the list (a checked rule); `Free` frees them all.
    pub fn apply<const D: usize>(list: Option<&[Option<usize>]>, problem: &mut Problem<D>) {
        for (i, r) in problem.robots.iter_mut().enumerate() {
            r.assigned = match list.map(|l| l[i]) {
                None => Assigned::Free,
                Some(None) => Assigned::Hold,
                Some(Some(h)) => Assigned::Track(h as u8),
            };
        }
    }
}

/// Share of the time a preferred assignment is tried for, before the planner chooses freely in
/// the rest: a preference with no plan in sight must not use up the deadline.
const PREFERRED_SHARE: f64 = 0.5;

/// Plans `problem` with planner `kind` under `rule` (checked) within `timeout_s` in all. The
/// robots' assignment is set in place for the call and restored after it (a problem is
/// hundreds of kilobytes: no copy on the stack).
pub fn solve(
    storage: &mut Storage,
    kind: PlannerKind,
    problem: &mut Problem<DOF>,
    rule: &AssignmentRule,
    timeout_s: f64,
) -> Result<Outcome, String> {
    let kept: Vec<Assigned> = problem.robots.iter().map(|r| r.assigned).collect();
    let outcome = solve_under(storage, kind, problem, rule, timeout_s);
    for (r, a) in problem.robots.iter_mut().zip(kept) {
        r.assigned = a;
    }
    outcome
}

fn solve_under(
    storage: &mut Storage,
    kind: PlannerKind,
    p: &mut Problem<DOF>,
    rule: &AssignmentRule,
    timeout_s: f64,
) -> Result<Outcome, String> {
    AssignmentRule::apply(rule.list(), p);
    let AssignmentRule::Preferred(_) = rule else {
        return storage.solve(kind, p, timeout_s);
    };
    let first = storage.solve(kind, p, PREFERRED_SHARE * timeout_s)?;
    let left = timeout_s - first.planning_time_s;
    if first.status == Status::Solved || left <= 0.0 {
        return Ok(first);
    }
    AssignmentRule::apply(None, p);
    let mut free = storage.solve(kind, p, left)?;
    free.planning_time_s += first.planning_time_s;
    Ok(free)
}

/// The assignment whose arms have the hands' poses nearest their bases, relative to how far
/// each reaches (the sum over hands of the largest `|pose - base| / reach` over the poses);
/// `None` when no assignment keeps every pose within reach. When only the start of a task is
/// known (an online policy's first chunk), an arm that has its hand deep in its workspace is
/// the one most likely to follow it on: an arm at the edge of its reach soon cannot.
pub fn nearest<M: Models<D>, const D: usize>(problem: &Problem<D>) -> Option<Vec<Option<usize>>> {
    let (n, m) = (problem.robots.len(), problem.trajectories.len());
    if m > n {
        return None;
    }
    let score: Vec<Vec<f64>> = (problem.robots.iter())
        .map(|r| {
            let reach = tcp_reach::<M, D>(r);
            (problem.trajectories.iter())
                .map(|t| {
                    let far = t.iter().map(|f| (f.pos - r.base.pos).norm());
                    let ratio = far.fold(0.0, f64::max) / reach;
                    if ratio <= 1.0 {
                        ratio
                    } else {
                        f64::INFINITY
                    }
                })
                .collect()
        })
        .collect();
    // Every injective map of hands to robots (at most 6 * 5 * ... : 720 for six).
    let mut best: Option<(f64, Vec<usize>)> = None;
    let mut pick = Vec::with_capacity(m);
    fn walk(
        score: &[Vec<f64>],
        pick: &mut Vec<usize>,
        sum: f64,
        best: &mut Option<(f64, Vec<usize>)>,
    ) {
        let j = pick.len();
        if j == score.first().map_or(0, Vec::len) {
            if best.as_ref().is_none_or(|(b, _)| sum < *b) {
                *best = Some((sum, pick.clone()));
            }
            return;
        }
        for (i, row) in score.iter().enumerate() {
            if pick.contains(&i) || !row[j].is_finite() {
                continue;
            }
            pick.push(i);
            walk(score, pick, sum + row[j], best);
            pick.pop();
        }
    }
    walk(&score, &mut pick, 0.0, &mut best);
    let (_, robots) = best?;
    let mut list = vec![None; n];
    for (j, &i) in robots.iter().enumerate() {
        list[i] = Some(j);
    }
    Some(list)
}
