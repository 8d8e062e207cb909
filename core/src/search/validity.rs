//! The state validity checker shared by Ω-A*, IK tracking and the baselines: what a robot may
//! occupy at a step and how it may move to the next.

use core::cell::RefCell;

use crate::collision::{ArmLanes, ArmPose, Obstacles};
use crate::geometry::Obstacle;
use crate::lanes::{lanes_of, F64s, Mask, LANES, WIDE};
use crate::model::{Frame, Models};
use crate::motion::{motion_is_free_posed, motions_collide_posed, near_point, ArmMotion};
use crate::problem::{Robot, StartExclusions, MAX_ROBOTS};
use crate::tool::Tool;

use super::constraints::{OtherArm, OthersMode, PointConstraint};
use super::workspace::Met;

/// Everything that constrains one robot's states and motions. It keeps the arm's last
/// placing and the other robots' placings at the last two steps asked for (a few tens of KB:
/// keep it off a very small stack); a check places at most the arm and those robots, and
/// allocates nothing.
///
/// ```
/// use omcbsa_core::model::{Frame, KinovaGen3};
/// use omcbsa_core::motion::MOTION_STEP;
/// use omcbsa_core::nalgebra::Vector3;
/// use omcbsa_core::problem::Robot;
/// use omcbsa_core::search::{OtherArm, OthersMode, PointConstraint, Validity};
/// use omcbsa_core::tool::Tool;
///
/// let robot = Robot::at(0, Frame::IDENTITY);
/// let (up, forward) = ([0.0; 7], [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
/// // Alone, 0.1 s steps: a Gen3 joint may move 0.14 rad a step.
/// let alone = Validity::<KinovaGen3, 7>::new(&robot, &[], 0.1, MOTION_STEP);
/// assert_eq!(alone.state(&forward, 0), Some(0));
/// assert!(!alone.step_within_limits(&up, &forward));
/// // Out of joint 2's limits (±2.24 rad): refused.
/// assert_eq!(alone.state(&[0.0, 2.5, 0.0, 0.0, 0.0, 0.0, 0.0], 0), None);
///
/// // Another Gen3 standing upright 0.6 m ahead, over two steps.
/// let path = [up, up];
/// let other_base = Frame { pos: Vector3::new(0.6, 0.0, 0.0), ..Frame::IDENTITY };
/// let others = [OtherArm { model: 0, base: other_base, tool: Tool::NONE, path: &path }];
/// let counting = Validity::<KinovaGen3, 7>::new(&robot, &[], 0.1, MOTION_STEP)
///     .with_others(&others, OthersMode::Count);
/// assert_eq!(counting.state(&forward, 1), Some(1)); // one collision, counted
/// let avoiding = Validity::<KinovaGen3, 7>::new(&robot, &[], 0.1, MOTION_STEP)
///     .with_others(&others, OthersMode::Avoid);
/// assert_eq!(avoiding.state(&forward, 1), None);
/// assert_eq!(avoiding.state(&up, 1), Some(0));
///
/// // A point constraint: not within 1 cm of a point on the upright arm's axis at step 0.
/// let p = [0.0, 0.0, 0.6];
/// let keep_off = [PointConstraint { t: 0, segment: false, s: 0.0, p, margin: 0.01 }];
/// let constrained = Validity::<KinovaGen3, 7>::new(&robot, &[], 0.1, MOTION_STEP)
///     .with_points(&keep_off);
/// assert_eq!(constrained.state(&up, 0), None);
/// assert_eq!(constrained.state(&up, 1), Some(0));
/// ```
pub struct Validity<'q, M, const D: usize> {
    /// The robot's model, an index into `M`.
    pub model: u8,
    /// The robot's base frame in the world.
    pub base: Frame,
    /// What the robot carries.
    pub tool: Tool,
    /// The fixed obstacles.
    obstacles: &'q [Obstacle],
    /// The same with their boxes for motion checks (`None` past [`crate::problem::MAX_OBSTACLES`]: every
    /// motion is then refused).
    scene: Option<Obstacles<'q>>,
    /// The other robots' paths (fewer than [`MAX_ROBOTS`], each covering every step asked
    /// about: a shorter one panics).
    pub others: &'q [OtherArm<'q, D>],
    /// Whether meeting the other robots is forbidden or counted.
    pub others_mode: OthersMode,
    /// Where the robot may not be, at a step or an instant of a motion.
    pub points: &'q [PointConstraint],
    /// Time between consecutive steps, s.
    pub dt: f64,
    /// Largest joint change between consecutive steps (velocity limit times dt).
    pub step_limit: [f64; D],
    /// See [`super::OmegaParams::motion_step`].
    pub motion_step: f64,
    /// Configurations refused at step 0 (the robot's [`Robot::excluded`]).
    pub excluded: StartExclusions<D>,
    /// The other robots' link capsules at the two steps asked for last (`usize::MAX`: none
    /// yet): every successor of one expansion is checked at the same steps, so this saves all
    /// but the first placing.
    others_at: RefCell<[(usize, [ArmPose; MAX_ROBOTS]); 2]>,
    /// Where [`Validity::state`] places the robot.
    mine: RefCell<ArmPose>,
    /// Where [`Validity::states_met`] places the robot.
    batch: RefCell<ArmLanes>,
    _model: core::marker::PhantomData<M>,
}

impl<'q, M: Models<D>, const D: usize> Validity<'q, M, D> {
    /// The checker of `robot` (its model, base, tool and excluded starts) among `obstacles`,
    /// its steps `dt` apart and its motions checked every `motion_step`
    /// ([`super::OmegaParams::motion_step`]); no other robots and no point constraints until
    /// [`Validity::with_others`] and [`Validity::with_points`] add them.
    pub fn new(robot: &Robot<D>, obstacles: &'q [Obstacle], dt: f64, motion_step: f64) -> Self {
        let mut step_limit = [0.0; D];
        for (s, v) in step_limit.iter_mut().zip(M::velocity(robot.model).iter()) {
            *s = v * dt;
        }
        Validity {
            model: robot.model,
            base: robot.base,
            tool: robot.tool,
            obstacles,
            scene: Obstacles::new(obstacles),
            others: &[],
            others_mode: OthersMode::Avoid,
            points: &[],
            dt,
            step_limit,
            motion_step,
            excluded: robot.excluded,
            others_at: RefCell::new([(usize::MAX, [ArmPose::EMPTY; MAX_ROBOTS]); 2]),
            mine: RefCell::new(ArmPose::EMPTY),
            batch: RefCell::new(ArmLanes::EMPTY),
            _model: core::marker::PhantomData,
        }
    }

    /// The fixed obstacles.
    pub fn obstacles(&self) -> &'q [Obstacle] {
        self.obstacles
    }

    /// The same checker with the other robots' paths, avoided or counted (`mode`).
    pub fn with_others(self, others: &'q [OtherArm<'q, D>], mode: OthersMode) -> Self {
        Validity {
            others,
            others_mode: mode,
            ..self
        }
    }

    /// The same checker with point constraints.
    pub fn with_points(self, points: &'q [PointConstraint]) -> Self {
        Validity { points, ..self }
    }

    /// Places the other robots at step `t` in the cache (slot `t % 2`) unless already there.
    fn place_others(&self, t: usize) {
        let mut cache = self.others_at.borrow_mut();
        let (at, poses) = &mut cache[t % 2];
        if *at != t {
            for (p, other) in poses.iter_mut().zip(self.others) {
                p.place::<M, D>(other.model, &other.base, &other.tool, &other.path[t]);
            }
            *at = t;
        }
    }

    /// Runs `f` on the other robots' poses at step `t`.
    fn with_others_at<R>(&self, t: usize, f: impl FnOnce(&[ArmPose]) -> R) -> R {
        self.place_others(t);
        let cache = self.others_at.borrow();
        f(&cache[t % 2].1[..self.others.len()])
    }

    /// Whether every joint of `q` is within its limits (NaN is not).
    fn within_limits(&self, q: &[f64; D]) -> bool {
        let within = |(v, (lo, hi)): (&f64, (&f64, &f64))| *v >= *lo && *v <= *hi;
        (q.iter())
            .zip(M::lower(self.model).iter().zip(M::upper(self.model)))
            .all(within)
    }

    /// Whether no joint moves faster than its velocity limit from `a` to `b`.
    pub fn step_within_limits(&self, a: &[f64; D], b: &[f64; D]) -> bool {
        (0..D).all(|i| libm::fabs(b[i] - a[i]) <= self.step_limit[i])
    }

    /// Checks a configuration at step `t`: joint limits, obstacles, self-collision, point
    /// constraints, and the other robots (forbidden or counted). Returns the collision count.
    pub fn state(&self, q: &[f64; D], t: usize) -> Option<u16> {
        self.state_met(q, t).map(|m| m.count_ones() as u16)
    }

    /// [`Validity::state`] telling which other robots (bit `k`: `others[k]`) it meets.
    pub fn state_met(&self, q: &[f64; D], t: usize) -> Option<Met> {
        self.state_met_in(q, t, &mut self.mine.borrow_mut())
    }

    /// [`Validity::state`], placing the robot in `pose` (which then holds it at `q` when the
    /// check got that far: always when it passes), for a caller that checks a motion from or
    /// to `q` next ([`Validity::motion_posed`]).
    pub fn state_in(&self, q: &[f64; D], t: usize, pose: &mut ArmPose) -> Option<u16> {
        self.state_met_in(q, t, pose).map(|m| m.count_ones() as u16)
    }

    fn state_met_in(&self, q: &[f64; D], t: usize, pose: &mut ArmPose) -> Option<Met> {
        if !self.within_limits(q) {
            return None;
        }
        if t == 0 && self.excluded.excludes(q) {
            return None;
        }
        pose.place::<M, D>(self.model, &self.base, &self.tool, q);
        if pose.obstacle_hit(self.obstacles, 0.0).is_some() || pose.self_hit(0.0).is_some() {
            return None;
        }
        for pc in self.points {
            if !pc.segment && pc.t as usize == t && near_point(pose, &pc.p, pc.margin) {
                return None;
            }
        }
        self.with_others_at(t, |theirs| {
            let mut met: Met = 0;
            for (k, other) in theirs.iter().enumerate() {
                if pose.arm_hit(other, 0.0).is_some() {
                    if self.others_mode == OthersMode::Avoid {
                        return None;
                    }
                    met |= 1 << k;
                }
            }
            Some(met)
        })
    }

    /// [`Validity::state_met`] of each of `qs` (at most [`LANES`]), placed and checked
    /// together where the build's SIMD makes a batch pay ([`WIDE`]), else one at a time: the
    /// same answers.
    pub fn states_met(&self, qs: &[[f64; D]], t: usize) -> [Option<Met>; LANES] {
        let mut out = [None; LANES];
        let qs = &qs[..qs.len().min(LANES)];
        if !WIDE {
            for (o, q) in out.iter_mut().zip(qs) {
                *o = self.state_met(q, t);
            }
            return out;
        }
        self.states_met_batched(qs, t)
    }

    /// [`Validity::states_met`] as one batch whatever the build (what it does on a [`WIDE`]
    /// one).
    pub fn states_met_batched(&self, qs: &[[f64; D]], t: usize) -> [Option<Met>; LANES] {
        let mut out = [None; LANES];
        let qs = &qs[..qs.len().min(LANES)];
        let Some(last) = qs.len().checked_sub(1) else {
            return out;
        };
        let live = (qs.iter().enumerate())
            .filter(|(_, q)| self.within_limits(q) && !(t == 0 && self.excluded.excludes(q)))
            .fold(0, |m: Mask, (k, _)| m | 1 << k);
        if live == 0 {
            return out;
        }
        let mut guard = self.batch.borrow_mut();
        let batch = &mut *guard;
        let q = core::array::from_fn(|j| F64s::new(core::array::from_fn(|k| qs[k.min(last)][j])));
        batch.place_lanes::<M, D>(self.model, &self.base, &self.tool, &q, live, u32::MAX);
        batch.keep(!batch.obstacle_hits(self.obstacles, 0.0));
        batch.keep(!batch.self_hits(0.0));
        for pc in self.points {
            if !pc.segment && pc.t as usize == t {
                for k in lanes_of(batch.lanes()) {
                    if near_point(&batch.pose(k), &pc.p, pc.margin) {
                        batch.keep(!(1 << k));
                    }
                }
            }
        }
        let mut met = [0; LANES];
        self.with_others_at(t, |theirs| {
            for (o, other) in theirs.iter().enumerate() {
                let hit = batch.arm_hits_pose(other, 0.0);
                if self.others_mode == OthersMode::Avoid {
                    batch.keep(!hit);
                } else {
                    lanes_of(hit).for_each(|k| met[k] |= 1 << o);
                }
            }
        });
        for k in lanes_of(batch.lanes()) {
            out[k] = Some(met[k]);
        }
        out
    }

    /// Checks the straight joint-space motion `a -> b` from step `t` to `t + 1` (see
    /// [`crate::motion`]). Returns the number of other robots met on the way.
    pub fn motion(&self, a: &[f64; D], b: &[f64; D], t: usize) -> Option<u16> {
        let ends = [
            ArmPose::new::<M, D>(self.model, &self.base, &self.tool, a),
            ArmPose::new::<M, D>(self.model, &self.base, &self.tool, b),
        ];
        self.motion_posed(a, b, [&ends[0], &ends[1]], t)
    }

    /// [`Validity::motion`] for a caller that already placed the arm at `a` and `b`.
    pub fn motion_posed(
        &self,
        a: &[f64; D],
        b: &[f64; D],
        ends: [&ArmPose; 2],
        t: usize,
    ) -> Option<u16> {
        self.motion_met(a, b, ends, t)
            .map(|m| m.count_ones() as u16)
    }

    /// [`Validity::motion_posed`] telling which other robots (bit `k`: `others[k]`) it meets.
    pub fn motion_met(
        &self,
        a: &[f64; D],
        b: &[f64; D],
        ends: [&ArmPose; 2],
        t: usize,
    ) -> Option<Met> {
        let me = ArmMotion {
            model: self.model,
            base: &self.base,
            tool: &self.tool,
            from: a,
            to: b,
        };
        let scene = self.scene.as_ref()?;
        if !motion_is_free_posed::<M, D>(&me, ends, scene, self.motion_step) {
            return None;
        }
        for pc in self.points {
            if pc.segment && pc.t as usize == t {
                let q: [f64; D] = core::array::from_fn(|i| a[i] + pc.s * (b[i] - a[i]));
                if near_point(
                    &ArmPose::new::<M, D>(self.model, &self.base, &self.tool, &q),
                    &pc.p,
                    pc.margin,
                ) {
                    return None;
                }
            }
        }
        self.place_others(t);
        self.place_others(t + 1);
        let cache = self.others_at.borrow();
        let mut met: Met = 0;
        for (o, other) in self.others.iter().enumerate() {
            let theirs = ArmMotion {
                model: other.model,
                base: &other.base,
                tool: &other.tool,
                from: &other.path[t],
                to: &other.path[t + 1],
            };
            let their_ends = [&cache[t % 2].1[o], &cache[(t + 1) % 2].1[o]];
            if motions_collide_posed::<M, D>(&me, ends, &theirs, their_ends, self.motion_step) {
                if self.others_mode == OthersMode::Avoid {
                    return None;
                }
                met |= 1 << o;
            }
        }
        Some(met)
    }

    /// Holding `q` for `h` steps: the collision count with the others, or `None` when not
    /// allowed.
    pub fn hold(&self, q: &[f64; D], h: usize) -> Option<u32> {
        let mut c = 0u32;
        for t in 0..h {
            c += self.state(q, t)? as u32;
            if t + 1 < h {
                c += self.motion(q, q, t)? as u32;
            }
        }
        Some(c)
    }
}
