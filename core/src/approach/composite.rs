//! The arms of a problem as one composite system: what the approach planners check. A
//! composite configuration is one configuration per robot (`&[[f64; D]]`, robot order), and a
//! composite motion moves every arm along its straight joint-space segment at the same pace,
//! so a piece of it is again a composite motion (what the time parametrisation relies on).

use crate::collision::{ArmPose, Obstacles};
use crate::model::{Frame, Models};
use crate::motion::{motion_is_free_posed, motions_collide_posed, ArmMotion};
use crate::problem::{Problem, MAX_ROBOTS};
use crate::tool::Tool;

/// What a robot's configuration touches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Touch {
    /// Joint `joint` is outside the model's limits (or not a number).
    JointLimit {
        /// The joint (0-based).
        joint: usize,
    },
    /// Obstacle `index` of the problem.
    Obstacle {
        /// Index into the problem's obstacles.
        index: usize,
    },
    /// Two of its own capsules (indices into the arm's capsules: the model's
    /// `Model::CAPSULES`, then its tool's).
    Itself {
        /// One capsule.
        capsule: usize,
        /// The other.
        other_capsule: usize,
    },
    /// Robot `robot`.
    Robot {
        /// Index into the problem's robots.
        robot: usize,
    },
}

/// A robot whose configuration is not free.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Blocked {
    /// The robot (index into the problem's robots).
    pub robot: usize,
    /// What it touches.
    pub touch: Touch,
}

/// The robots of `problem`, checked together. Robots not `active` are left out of every
/// check (used to ask whether one arm alone can make its approach).
///
/// A composite made by [`Composite::standing`] knows some robots stand still in every query (the
/// others' arms, while one arm plans its way around them): their poses are placed once, and
/// what they touch among themselves or with the obstacles is checked once, so a query places
/// and checks only the arms that move. A query where a standing robot is elsewhere is checked
/// in full, as by a composite without them.
pub(crate) struct Composite<'p, M, const D: usize> {
    arms: Arms<'p, M, D>,
    /// The queries' scratch, kept: a buffer this size made anew is filled at every query, at
    /// more cost than a one-arm step's checks.
    placed: Placed,
    pub n: usize,
}

/// What a [`Composite`] checks, without its scratch.
struct Arms<'p, M, const D: usize> {
    problem: &'p Problem<D>,
    /// The problem's obstacles with their boxes, for the motion checks.
    obstacles: Obstacles<'p>,
    n: usize,
    active: [bool; MAX_ROBOTS],
    motion_step: f64,
    /// The standing robots (bit set), where they stand, their poses there, and the first of
    /// them blocked there (by limits, obstacles, itself or another standing robot).
    still: u32,
    still_q: [[f64; D]; MAX_ROBOTS],
    still_poses: [ArmPose; MAX_ROBOTS],
    still_blocked: Option<Blocked>,
    _m: core::marker::PhantomData<M>,
}

/// No pose placed here: the robot's standing pose ([`Composite::standing`]).
const STILL: u8 = u8::MAX;

/// The arms of a composite motion's two ends placed in the world, by the query: pose `at[i][e]`
/// of `poses` is robot `i` at end `e` (0: from, 1: to), [`STILL`] for a standing robot.
struct Placed {
    poses: heapless::Vec<ArmPose, { 2 * MAX_ROBOTS }>,
    at: [[u8; 2]; MAX_ROBOTS],
}

impl<'p, M: Models<D>, const D: usize> Composite<'p, M, D> {
    pub fn new(problem: &'p Problem<D>, motion_step: f64) -> Self {
        Self::of(Arms::new(problem, motion_step))
    }

    fn of(arms: Arms<'p, M, D>) -> Self {
        Composite {
            n: arms.n,
            arms,
            placed: Placed {
                poses: heapless::Vec::new(),
                at: [[STILL; 2]; MAX_ROBOTS],
            },
        }
    }

    /// The same composite with only the robots `keep` accepts in it (none standing).
    pub fn restricted(&self, keep: impl Fn(usize) -> bool) -> Self {
        Self::of(self.arms.restricted(keep))
    }

    /// The same composite where the active robots not in the bit set `moving` stand at `q`.
    pub fn standing(&self, q: &[[f64; D]], moving: u32) -> Self {
        Self::of(self.arms.standing(q, moving, &mut Placed::new()))
    }

    pub fn is_active(&self, i: usize) -> bool {
        self.arms.active[i]
    }

    /// Robot `i`'s model, an index into `M`.
    pub fn model(&self, i: usize) -> u8 {
        self.arms.model(i)
    }

    /// Every robot's model (0 past the last robot).
    pub fn models(&self) -> [u8; MAX_ROBOTS] {
        self.arms.models()
    }

    /// The first robot (in index order) whose configuration in `q` is outside its limits or
    /// touches an obstacle, itself, or a robot of higher index.
    pub fn state_blocked(&mut self, q: &[[f64; D]]) -> Option<Blocked> {
        self.arms.state_blocked(q, &mut self.placed)
    }

    /// Whether the composite state `b` is blocked ([`Composite::state_blocked`]) or the motion
    /// `a -> b` is ([`Composite::motion_blocked`]): one step of a tree, the arms at `b` placed
    /// once for both checks.
    pub fn step_blocked(&mut self, a: &[[f64; D]], b: &[[f64; D]]) -> bool {
        self.arms.step_blocked(a, b, &mut self.placed)
    }

    /// Whether robot `r` moving `from -> to` touches an obstacle or itself: the part of
    /// [`Composite::motion_blocked`] that no other arm changes.
    pub fn own_motion_blocked(&self, r: usize, from: &[f64; D], to: &[f64; D]) -> bool {
        self.arms.own_motion_blocked(r, from, to)
    }

    /// Whether robot `r` moving `from -> to` comes too close to robot `k` standing at `at`:
    /// [`Composite::motion_blocked`] of that one pair, so a one-arm motion is blocked exactly when
    /// its own check or the check against some other active robot is.
    pub fn pair_motion_blocked(
        &self,
        r: usize,
        from: &[f64; D],
        to: &[f64; D],
        k: usize,
        at: &[f64; D],
    ) -> bool {
        self.arms.pair_motion_blocked(r, from, to, k, at)
    }

    /// Checks the composite motion `a -> b` (every arm along its straight segment, at the same
    /// pace): each moving arm against the obstacles and itself, each pair with a moving arm
    /// against each other. The first failure found, as (robot, other robot).
    pub fn motion_blocked(
        &mut self,
        a: &[[f64; D]],
        b: &[[f64; D]],
    ) -> Option<(usize, Option<usize>)> {
        self.arms.motion_blocked(a, b, &mut self.placed)
    }
}

impl Placed {
    fn new() -> Self {
        Placed {
            poses: heapless::Vec::new(),
            at: [[STILL; 2]; MAX_ROBOTS],
        }
    }
}

impl<'p, M: Models<D>, const D: usize> Arms<'p, M, D> {
    fn new(problem: &'p Problem<D>, motion_step: f64) -> Self {
        let n = problem.robots.len();
        Arms {
            problem,
            obstacles: Obstacles::from(&problem.obstacles),
            n,
            active: core::array::from_fn(|i| i < n),
            motion_step,
            still: 0,
            still_q: [[0.0; D]; MAX_ROBOTS],
            still_poses: [ArmPose::EMPTY; MAX_ROBOTS],
            still_blocked: None,
            _m: core::marker::PhantomData,
        }
    }

    fn restricted(&self, keep: impl Fn(usize) -> bool) -> Self {
        Arms {
            active: core::array::from_fn(|i| self.active[i] && keep(i)),
            still: 0,
            still_blocked: None,
            ..*self
        }
    }

    fn standing(&self, q: &[[f64; D]], moving: u32, placed: &mut Placed) -> Self {
        let still = (0..self.n)
            .filter(|&i| self.active[i] && moving & (1 << i) == 0)
            .fold(0u32, |m, i| m | 1 << i);
        let mut composite = Arms { ..*self };
        composite.still_blocked = self
            .restricted(|i| still & (1 << i) != 0)
            .state_blocked(q, placed);
        for i in (0..self.n).filter(|&i| still & (1 << i) != 0) {
            composite.still_q[i] = q[i];
            composite.still_poses[i] = self.pose(i, &q[i]);
        }
        composite.still = still;
        composite
    }

    fn model(&self, i: usize) -> u8 {
        self.problem.robots[i].model
    }

    fn models(&self) -> [u8; MAX_ROBOTS] {
        core::array::from_fn(|i| self.problem.robots.get(i).map_or(0, |r| r.model))
    }

    fn base(&self, i: usize) -> &'p Frame {
        &self.problem.robots[i].base
    }

    fn tool(&self, i: usize) -> &'p Tool {
        &self.problem.robots[i].tool
    }

    fn pose(&self, i: usize, q: &[f64; D]) -> ArmPose {
        ArmPose::new::<M, D>(self.model(i), self.base(i), self.tool(i), q)
    }

    /// The standing robots when each stands where it does in every one of `qs`, else none.
    fn still_in(&self, qs: [&[[f64; D]]; 2]) -> u32 {
        let here = (0..self.n)
            .filter(|&i| self.still & (1 << i) != 0)
            .all(|i| qs.iter().all(|q| q[i] == self.still_q[i]));
        if here {
            self.still
        } else {
            0
        }
    }

    /// The robots placed: active, not among `still`.
    fn placed(&self, still: u32) -> impl Iterator<Item = usize> + '_ {
        (0..self.n).filter(move |&i| self.active[i] && still & (1 << i) == 0)
    }

    /// Robot `i` at end `end` of `placed`.
    fn at<'a>(&'a self, placed: &'a Placed, i: usize, end: usize) -> &'a ArmPose {
        match placed.at[i][end] {
            STILL => &self.still_poses[i],
            k => &placed.poses[usize::from(k)],
        }
    }

    /// The first robot not in `still` whose configuration in `q` is outside its limits (or
    /// not a number).
    fn limits_blocked(&self, q: &[[f64; D]], still: u32) -> Option<Blocked> {
        self.placed(still).find_map(|i| {
            // Written so that NaN is refused too.
            let (lower, upper) = (M::lower(self.model(i)), M::upper(self.model(i)));
            let out = (0..D).find(|&j| !(q[i][j] >= lower[j] && q[i][j] <= upper[j]));
            out.map(|joint| Blocked {
                robot: i,
                touch: Touch::JointLimit { joint },
            })
        })
    }

    /// Places end `end` of a query at `q`: the robots not in `still`. An arm at the same
    /// configuration in `other_end` (placed already) shares its pose.
    fn place(
        &self,
        q: &[[f64; D]],
        end: usize,
        still: u32,
        placed: &mut Placed,
        other_end: Option<&[[f64; D]]>,
    ) {
        for i in self.placed(still) {
            if other_end.is_some_and(|o| o[i] == q[i]) {
                placed.at[i][end] = placed.at[i][1 - end];
            } else {
                placed.at[i][end] = placed.poses.len() as u8;
                // Room for both ends of every robot.
                let _ = placed.poses.push(self.pose(i, &q[i]));
            }
        }
    }

    /// The first robot not in `still`, in index order, that touches an obstacle, itself, or
    /// a robot of higher index or a standing one, at end `end` of `placed` (standing robots
    /// among themselves are the caller's).
    fn placed_blocked(&self, placed: &Placed, end: usize, still: u32) -> Option<Blocked> {
        let active = |k: usize| self.active[k];
        for i in (0..self.n).filter(|&i| active(i)) {
            let pose = self.at(placed, i, end);
            let standing = still & (1 << i) != 0;
            let touch = if standing {
                None
            } else if let Some(index) = pose.obstacle_hit(&self.problem.obstacles, 0.0) {
                Some(Touch::Obstacle { index })
            } else if let Some((capsule, other_capsule)) = pose.self_hit(0.0) {
                Some(Touch::Itself {
                    capsule,
                    other_capsule,
                })
            } else {
                None
            };
            // A standing robot against the moving ones after it; a moving one against all.
            let touch = touch.or_else(|| {
                (i + 1..self.n)
                    .filter(|&k| active(k) && !(standing && still & (1 << k) != 0))
                    .find(|&k| pose.arm_hit(self.at(placed, k, end), 0.0).is_some())
                    .map(|robot| Touch::Robot { robot })
            });
            if let Some(touch) = touch {
                return Some(Blocked { robot: i, touch });
            }
        }
        None
    }

    fn state_blocked(&self, q: &[[f64; D]], placed: &mut Placed) -> Option<Blocked> {
        let still = self.still_in([q, q]);
        if still != 0 && self.still_blocked.is_some() {
            return self.still_blocked;
        }
        if let Some(b) = self.limits_blocked(q, still) {
            return Some(b);
        }
        placed.poses.clear();
        self.place(q, 1, still, placed, None);
        self.placed_blocked(placed, 1, still)
    }

    fn step_blocked(&self, a: &[[f64; D]], b: &[[f64; D]], placed: &mut Placed) -> bool {
        let still = self.still_in([a, b]);
        if still != 0 && self.still_blocked.is_some() {
            return true;
        }
        if self.limits_blocked(b, still).is_some() {
            return true;
        }
        placed.poses.clear();
        self.place(b, 1, still, placed, None);
        if self.placed_blocked(placed, 1, still).is_some() {
            return true;
        }
        self.place(a, 0, still, placed, Some(b));
        self.placed_motion_blocked(a, b, placed).is_some()
    }

    fn motion_blocked(
        &self,
        a: &[[f64; D]],
        b: &[[f64; D]],
        placed: &mut Placed,
    ) -> Option<(usize, Option<usize>)> {
        let still = self.still_in([a, b]);
        placed.poses.clear();
        self.place(a, 0, still, placed, None);
        self.place(b, 1, still, placed, Some(a));
        self.placed_motion_blocked(a, b, placed)
    }

    fn motion<'a>(&'a self, i: usize, from: &'a [f64; D], to: &'a [f64; D]) -> ArmMotion<'a, D> {
        ArmMotion {
            model: self.model(i),
            base: self.base(i),
            tool: self.tool(i),
            from,
            to,
        }
    }

    fn own_motion_blocked(&self, r: usize, from: &[f64; D], to: &[f64; D]) -> bool {
        let ends = [self.pose(r, from), self.pose(r, to)];
        !motion_is_free_posed::<M, D>(
            &self.motion(r, from, to),
            [&ends[0], &ends[1]],
            &self.obstacles,
            self.motion_step,
        )
    }

    fn pair_motion_blocked(
        &self,
        r: usize,
        from: &[f64; D],
        to: &[f64; D],
        k: usize,
        at: &[f64; D],
    ) -> bool {
        let moving = (
            self.motion(r, from, to),
            [self.pose(r, from), self.pose(r, to)],
        );
        let still = self.pose(k, at);
        let standing = (self.motion(k, at, at), [still, still]);
        // In index order, as the composite check pairs them.
        let ((a, a_ends), (b, b_ends)) = if r < k {
            (&moving, &standing)
        } else {
            (&standing, &moving)
        };
        motions_collide_posed::<M, D>(
            a,
            [&a_ends[0], &a_ends[1]],
            b,
            [&b_ends[0], &b_ends[1]],
            self.motion_step,
        )
    }

    /// [`Composite::motion_blocked`] with both ends placed.
    fn placed_motion_blocked(
        &self,
        a: &[[f64; D]],
        b: &[[f64; D]],
        placed: &Placed,
    ) -> Option<(usize, Option<usize>)> {
        let moving: [bool; MAX_ROBOTS] =
            core::array::from_fn(|i| i < self.n && self.active[i] && a[i] != b[i]);
        let ends = |i: usize| [self.at(placed, i, 0), self.at(placed, i, 1)];
        let motion = |i: usize| self.motion(i, &a[i], &b[i]);
        let obstacles = &self.obstacles;
        for i in (0..self.n).filter(|&i| moving[i]) {
            if !motion_is_free_posed::<M, D>(&motion(i), ends(i), obstacles, self.motion_step) {
                return Some((i, None));
            }
        }
        for i in (0..self.n).filter(|&i| self.active[i]) {
            for k in (i + 1..self.n).filter(|&k| self.active[k] && (moving[i] || moving[k])) {
                if motions_collide_posed::<M, D>(
                    &motion(i),
                    ends(i),
                    &motion(k),
                    ends(k),
                    self.motion_step,
                ) {
                    return Some((i, Some(k)));
                }
            }
        }
        None
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::geometry::{Obstacle, Shape};
    use crate::model::KinovaGen3;
    use crate::problem::{Assigned, Robot, Start, StartExclusions, Tolerance};
    use crate::rng::Rng;
    use nalgebra::{Matrix3, Vector3};

    /// Three arms 0.5 m apart in a row, a box in front of the middle one.
    pub(crate) fn row() -> Problem<7> {
        let frame = |x: f64, y: f64, z: f64| Frame {
            rot: Matrix3::identity(),
            pos: Vector3::new(x, y, z),
        };
        let mut p = Problem {
            dt: 0.1,
            robots: heapless::Vec::new(),
            trajectories: heapless::Vec::new(),
            obstacles: heapless::Vec::new(),
            tolerance: Tolerance::default(),
        };
        for i in 0..3 {
            let robot = Robot {
                model: 0,
                base: frame(0.5 * i as f64, 0.0, 0.0),
                tcp: Frame::IDENTITY,
                initial: None,
                tool: Tool::NONE,
                start: Start::default(),
                assigned: Assigned::default(),
                excluded: StartExclusions::NONE,
            };
            assert!(p.robots.push(robot).is_ok());
        }
        let post = Obstacle {
            shape: Shape::Box {
                half_extents: [0.05, 0.05, 0.4],
            },
            pose: frame(0.5, 0.45, 0.4),
        };
        assert!(p.obstacles.push(post).is_ok());
        p
    }

    pub(crate) fn draw(rng: &mut Rng) -> [f64; 7] {
        core::array::from_fn(|j| {
            let (lo, hi) = (KinovaGen3::lower(0)[j], KinovaGen3::upper(0)[j]);
            let (lo, hi) = (lo.max(-3.0), hi.min(3.0));
            rng.uniform(lo, hi)
        })
    }

    /// A composite with arms standing answers every query as the plain composite does: queries that
    /// move one arm from where they stand, and queries with a standing arm elsewhere.
    #[test]
    fn standing_arms_change_no_answer() {
        let problem = row();
        let mut plain = Composite::<KinovaGen3, 7>::new(&problem, crate::motion::MOTION_STEP);
        let mut rng = Rng::new(7);
        let (mut blocked, mut free) = (0, 0);
        for round in 0..300 {
            let stand: [[f64; 7]; 3] = core::array::from_fn(|_| draw(&mut rng));
            let r = round % 3;
            let mut standing = plain.standing(&stand, 1 << r);
            let mut a = stand;
            let mut b = stand;
            a[r] = draw(&mut rng);
            b[r] = draw(&mut rng);
            if round % 5 == 0 {
                // A standing arm elsewhere: checked in full.
                let k = (r + 1) % 3;
                b[k] = draw(&mut rng);
            }
            let s = standing.state_blocked(&b).is_some();
            assert_eq!(s, plain.state_blocked(&b).is_some(), "state, round {round}");
            let m = standing.motion_blocked(&a, &b);
            assert_eq!(m, plain.motion_blocked(&a, &b), "motion, round {round}");
            let step = standing.step_blocked(&a, &b);
            assert_eq!(step, s || m.is_some(), "step, round {round}");
            if step {
                blocked += 1;
            } else {
                free += 1;
            }
        }
        // Both answers were asked about.
        assert!(blocked > 20 && free > 20, "{blocked} blocked, {free} free");
    }
}
