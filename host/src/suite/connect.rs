//! The witness's approach: from where the arms stand (`initial`) to the first configurations
//! of the witness's paths, by a plain RRT-Connect (Kuffner and LaValle, 2000) in the joint
//! space of the arms that move, every motion checked with the validator's own checks
//! ([`placing_is_clear`], [`motion_is_clear`]). It shares nothing else with the planners'
//! approach (`omcbsa_core::approach`): whether a problem counts as known solvable does not
//! depend on the code under test.
//!
//! A motion is cut into steps that move no joint more than [`STEP_FRACTION`] of its velocity
//! limit times `dt` (rule 3, with room to spare), and checked step by step: the steps the
//! trees are built of are the approach's, checked as its validation checks them. The straight
//! motion of all arms together is tried first. Deterministic: the sample's generator, fixed
//! budgets, no clock.

use omcbsa_core::model::Models;
use omcbsa_core::problem::Problem;
use omcbsa_core::rng::Rng;

use super::witness::{Arms, Q, STEP_FRACTION};
use crate::load::joint_range;
use crate::models::DOF;
use crate::validate::{motion_is_clear, placing_is_clear};

/// Longest edge of a tree, in steps.
const EDGE_STEPS: f64 = 3.0;
/// Random samples each tree grows toward before the search gives up.
const ITERATIONS: usize = 300;
/// Random shortcuts tried on a path found.
const SHORTCUTS: usize = 30;

/// How an approach was found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Every arm straight to its start, all together.
    Straight,
    /// RRT-Connect.
    RrtConnect,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Straight => "straight",
            Method::RrtConnect => "rrt-connect",
        }
    }
}

/// An approach: every robot's configuration at each step strictly between `from` and `to`
/// (the arms all move at once, so every step holds one configuration per robot).
pub struct Approach {
    pub method: Method,
    pub steps: Vec<Vec<Q>>,
}

/// The arms of a problem moving from one placing of them all to another.
struct Space<'a> {
    problem: &'a Problem<DOF>,
    /// Per robot and joint, the most a step may move it.
    step: Vec<Q>,
    /// The robots that move (the others stand at their place in `from` all along).
    moving: Vec<usize>,
}

impl<'a> Space<'a> {
    /// The robots of `problem` moving from `from` to `to`.
    fn new(problem: &'a Problem<DOF>, from: &[Q], to: &[Q]) -> Space<'a> {
        let step = (problem.robots.iter())
            .map(|r| {
                let v = Arms::velocity(r.model);
                std::array::from_fn(|j| STEP_FRACTION * v[j] * problem.dt)
            })
            .collect();
        let moving = (0..from.len()).filter(|&r| from[r] != to[r]).collect();
        Space {
            problem,
            step,
            moving,
        }
    }

    /// Steps from `a` to `b`: how many the joint that moves farthest for its limit needs.
    fn distance(&self, a: &[Q], b: &[Q]) -> f64 {
        (self.moving.iter())
            .flat_map(|&r| (0..DOF).map(move |j| (r, j)))
            .map(|(r, j)| (b[r][j] - a[r][j]).abs() / self.step[r][j])
            .fold(0.0, f64::max)
    }

    /// The placings after `a` on the straight motion to `b`, `b` last, evenly spaced and
    /// as few as the step limit allows.
    fn steps(&self, a: &[Q], b: &[Q]) -> Vec<Vec<Q>> {
        let k = self.distance(a, b).ceil().max(1.0) as usize;
        let mut out: Vec<Vec<Q>> = (1..k)
            .map(|i| {
                let s = i as f64 / k as f64;
                (a.iter().zip(b))
                    .map(|(qa, qb)| std::array::from_fn(|j| qa[j] + (qb[j] - qa[j]) * s))
                    .collect()
            })
            .collect();
        out.push(b.to_vec());
        out
    }

    /// Whether the straight motion from `a` (clear) to `b` passes the validator, step by step.
    fn clear(&self, a: &[Q], b: &[Q]) -> bool {
        let mut previous = a.to_vec();
        self.steps(a, b).into_iter().all(|next| {
            let ok = placing_is_clear::<Arms, DOF>(self.problem, &next)
                && motion_is_clear::<Arms, DOF>(self.problem, &previous, &next);
            previous = next;
            ok
        })
    }

    /// A placing with every moving arm somewhere random within its joint range.
    fn sample(&self, around: &[Q], rng: &mut Rng) -> Vec<Q> {
        let mut q = around.to_vec();
        for &r in &self.moving {
            let model = self.problem.robots[r].model;
            let range = |j| joint_range::<Arms, DOF>(model, j);
            q[r] = std::array::from_fn(|j| {
                let (lo, hi) = range(j);
                rng.uniform(lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI))
            });
        }
        q
    }
}

/// One tree of RRT-Connect: placings and each one's parent.
struct Tree {
    nodes: Vec<Vec<Q>>,
    parent: Vec<usize>,
}

/// What one extension of a tree did.
enum Extend {
    /// It reached the target (the new node's index).
    Reached(usize),
    /// It grew one edge toward it.
    Advanced(usize),
    Trapped,
}

impl Tree {
    fn new(root: &[Q]) -> Tree {
        Tree {
            nodes: vec![root.to_vec()],
            parent: vec![0],
        }
    }

    /// One edge from the node nearest `target` toward it, at most [`EDGE_STEPS`] long.
    fn extend(&mut self, space: &Space, target: &[Q]) -> Extend {
        let (near, d) = (self.nodes.iter().enumerate())
            .map(|(i, n)| (i, space.distance(n, target)))
            .fold(
                (0, f64::INFINITY),
                |best, c| if c.1 < best.1 { c } else { best },
            );
        let reached = d <= EDGE_STEPS;
        let new: Vec<Q> = if reached {
            target.to_vec()
        } else {
            let s = EDGE_STEPS / d;
            (self.nodes[near].iter().zip(target))
                .map(|(a, b)| std::array::from_fn(|j| a[j] + (b[j] - a[j]) * s))
                .collect()
        };
        if !space.clear(&self.nodes[near], &new) {
            return Extend::Trapped;
        }
        self.nodes.push(new);
        self.parent.push(near);
        let i = self.nodes.len() - 1;
        if reached {
            Extend::Reached(i)
        } else {
            Extend::Advanced(i)
        }
    }

    /// Extends toward `target` until it is reached (the node reaching it) or blocked.
    fn connect(&mut self, space: &Space, target: &[Q]) -> Option<usize> {
        loop {
            match self.extend(space, target) {
                Extend::Reached(i) => return Some(i),
                Extend::Advanced(_) => {}
                Extend::Trapped => return None,
            }
        }
    }

    /// The placings from the root to node `i`.
    fn path_to(&self, mut i: usize) -> Vec<Vec<Q>> {
        let mut path = vec![self.nodes[i].clone()];
        while i != 0 {
            i = self.parent[i];
            path.push(self.nodes[i].clone());
        }
        path.reverse();
        path
    }
}

/// An approach of `problem`'s robots from `from` to `to` (one configuration per robot, both
/// placings clear), or `None` when neither the straight motion nor RRT-Connect within its
/// budget finds one.
pub fn approach(problem: &Problem<DOF>, from: &[Q], to: &[Q], rng: &mut Rng) -> Option<Approach> {
    let space = Space::new(problem, from, to);
    let steps = |waypoints: &[Vec<Q>]| -> Vec<Vec<Q>> {
        let mut steps: Vec<Vec<Q>> = (waypoints.windows(2))
            .flat_map(|w| space.steps(&w[0], &w[1]))
            .collect();
        // The last is `to`: the witness's first configurations, not the approach's.
        steps.pop();
        steps
    };
    if space.clear(from, to) {
        return Some(Approach {
            method: Method::Straight,
            steps: steps(&[from.to_vec(), to.to_vec()]),
        });
    }
    let mut waypoints = rrt_connect(&space, from, to, rng)?;
    shortcut(&space, &mut waypoints, rng);
    Some(Approach {
        method: Method::RrtConnect,
        steps: steps(&waypoints),
    })
}

/// Whether the straight motion of all arms together from `from` to `to` collides, by the
/// validator's checks (step by step, as an approach).
pub fn straight_collides(problem: &Problem<DOF>, from: &[Q], to: &[Q]) -> bool {
    !Space::new(problem, from, to).clear(from, to)
}

/// The waypoints of a path from `from` to `to`: trees from both ends, each in turn growing
/// an edge toward a random placing and the other connecting to the new node.
fn rrt_connect(space: &Space, from: &[Q], to: &[Q], rng: &mut Rng) -> Option<Vec<Vec<Q>>> {
    let mut trees = [Tree::new(from), Tree::new(to)];
    for k in 0..2 * ITERATIONS {
        let (a, b) = if k % 2 == 0 { (0, 1) } else { (1, 0) };
        let target = space.sample(from, rng);
        let new = match trees[a].extend(space, &target) {
            Extend::Reached(i) | Extend::Advanced(i) => i,
            Extend::Trapped => continue,
        };
        let node = trees[a].nodes[new].clone();
        if let Some(meet) = trees[b].connect(space, &node) {
            let (mut head, mut tail) = (trees[a].path_to(new), trees[b].path_to(meet));
            if a == 1 {
                std::mem::swap(&mut head, &mut tail);
            }
            // Both end at the node where the trees met.
            tail.pop();
            tail.reverse();
            head.extend(tail);
            return Some(head);
        }
    }
    None
}

/// Random shortcuts: two waypoints joined straight where that motion is clear.
fn shortcut(space: &Space, waypoints: &mut Vec<Vec<Q>>, rng: &mut Rng) {
    for _ in 0..SHORTCUTS {
        let n = waypoints.len();
        if n < 3 {
            return;
        }
        let i = (rng.next_u64() % (n as u64 - 2)) as usize;
        let j = i + 2 + (rng.next_u64() % (n - i - 2) as u64) as usize;
        if space.clear(&waypoints[i], &waypoints[j]) {
            waypoints.drain(i + 1..j);
        }
    }
}
