//! Arm-level collision checks on link capsules and the capsules of the arm's tool
//! ([`Tool`]): against obstacles, other arms and the arm's own links, at one configuration
//! ([`ArmPose`]) or along a straight joint-space motion ([`Sweep`]).
//!
//! Every check tests bounding boxes first (the whole arm's, then each capsule's) and runs the
//! exact capsule query only on what is left. Checks return the first thing hit (an obstacle
//! or capsule index), so a validator can say where; planners use `.is_some()`.
//!
//! Memory: an [`ArmPose`] is a fixed-size value (about 2 KB: [`MAX_POSE_CAPSULES`] capsules
//! and their boxes); a model with more capsules or link frames than that does not compile
//! (see [`crate::model::MAX_ARM_CAPSULES`]). Nothing allocates.
//!
//! Two Gen3s, the second 0.6 m in front of the first: upright they are clear; the first
//! reaching forward runs into the second.
//!
//! ```
//! use omcbsa_core::collision::ArmPose;
//! use omcbsa_core::geometry::{Obstacle, Shape};
//! use omcbsa_core::model::{Frame, KinovaGen3};
//! use omcbsa_core::nalgebra::Vector3;
//! use omcbsa_core::tool::Tool;
//!
//! let (upright, forward) = ([0.0; 7], [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! let base_b = Frame { pos: Vector3::new(0.6, 0.0, 0.0), ..Frame::IDENTITY };
//! let a = ArmPose::new::<KinovaGen3, 7>(0, &Frame::IDENTITY, &Tool::NONE, &upright);
//! let b = ArmPose::new::<KinovaGen3, 7>(0, &base_b, &Tool::NONE, &upright);
//! assert_eq!(a.arm_hit(&b, 0.0), None);
//! // Their volumes are 0.6 m apart less the links' radii.
//! assert!(a.clearance(&b) > 0.4 && a.clearance(&b) < 0.6);
//!
//! let reaching = ArmPose::new::<KinovaGen3, 7>(0, &Frame::IDENTITY, &Tool::NONE, &forward);
//! let (i, j) = reaching.arm_hit(&b, 0.0).expect("the arms overlap");
//! assert!(reaching.capsules()[i].hits(&b.capsules()[j], 0.0));
//! // A point inside both arms: what Ω-CBSA branches on.
//! let p = reaching.witness(&b, 0.0).unwrap();
//! assert!(reaching.contains_point(&p) && b.contains_point(&p));
//!
//! // Against obstacles: the index of the first one hit; the arm's own links.
//! let ball = Obstacle {
//!     shape: Shape::Sphere { radius: 0.1 },
//!     pose: Frame { pos: Vector3::new(0.0, 0.0, 0.8), ..Frame::IDENTITY },
//! };
//! let far = Obstacle { pose: Frame { pos: Vector3::new(2.0, 0.0, 0.8), ..ball.pose }, ..ball };
//! assert_eq!(a.obstacle_hit(&[far, ball], 0.0), Some(1));
//! assert_eq!(a.obstacle_hit(&[far], 0.0), None);
//! assert_eq!(a.self_hit(0.0), None);
//! ```

use core::marker::PhantomData;

mod batch;
mod cull;
mod groups;
mod pose;
mod rake;

pub use batch::{ArmLanes, Boxes, Scene};
pub use cull::Obstacles;
use pose::{bits, bits64};
pub use pose::{ArmPose, MAX_POSE_CAPSULES};
pub use rake::Placing;
use rake::Rake;

use crate::geometry::{Aabb, Contact, Obstacle};
use crate::lanes::F64s;
use crate::model::{Frame, Models};
use crate::problem::MAX_OBSTACLES;
use crate::tool::Tool;

pub use crate::model::{MAX_ARM_CAPSULES, MAX_LINK_FRAMES};
/// Most configurations a [`Sweep`] checks; beyond that its margin grows instead.
pub const MAX_SWEEP_CHECKS: usize = 1 << 16;
/// Longest motion (m, its [`Sweep::length`]) that [`Sweep::arm_collides`] checks as a whole
/// before it splits it: a longer one it splits at once, at its middle.
pub const WHOLE_CHECK_LENGTH: f64 = 0.5;

/// A straight joint-space motion of model `M` from `q0` to `q1`, split into `count` equal
/// pieces. Moving joint `j` by `dq` moves no link point by more than `REACH[j] * |dq|`, so
/// along the whole motion no point moves more than `length = sum_j REACH[j] |q1_j - q0_j|`
/// (points on the base link do not move at all), and over a piece of `k` of the `count`
/// pieces no point is farther than `length * k / (2 count)` from where it is at the piece's
/// middle. Each link then stays inside its capsules at that middle configuration inflated by
/// that much: if that check is clear, so is the whole piece, ends included.
///
/// The checks work pair by pair (a capsule and an obstacle, or two capsules), each between
/// two placings of the arm: clearance falls by at most the distance the pair's points travel
/// towards each other, from either end, so a pair whose clearances at the two ends add up to
/// more than that cannot meet in between and is dropped. First over the whole motion, from
/// its ends (for one arm's own motion only up to [`WHOLE_CHECK_LENGTH`]: a longer one almost
/// never clears as a whole, and its halves would test again all it left in question); the
/// pairs left are checked on its halves (one more placing, at the middle), then
/// on the halves' halves where that fails, for those pairs alone, down to half pieces. A
/// motion is reported as colliding when a pair meets at a placing, or fails over a half
/// piece: then both are within half that piece's travel at one of its ends, a piece's
/// middle, so the piece's check at its middle inflated by [`Sweep::margin`] fails too.
///
/// A capsule's travel has a second bound, often far smaller: how far it strays from moving
/// in a straight line between where it is at the two ends ([`Sweep::reaches`]), quadratic in
/// the part of the motion, so it shrinks fast down the halves. An arm moving in its null
/// space, its hand nearly still, moves its joints far but its hand capsules little, and the
/// first bound alone counts every joint's turn at its full reach.
///
/// Cost: two placings of the arm for a motion far from everything (three for one arm's own
/// motion longer than [`WHOLE_CHECK_LENGTH`]), one more per split; the
/// bisection's stack is bounded (about `log2(2 * MAX_SWEEP_CHECKS)` levels of a few arm
/// poses). A Gen3 turning about its first joint past a ball it clears at both ends:
///
/// ```
/// use omcbsa_core::collision::{sweeps_collide, ArmPose, Sweep};
/// use omcbsa_core::geometry::{Obstacle, Shape};
/// use omcbsa_core::model::{Frame, KinovaGen3};
/// use omcbsa_core::nalgebra::Vector3;
/// use omcbsa_core::tool::Tool;
///
/// let from = [-0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
/// let to = [0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
/// let sweep = Sweep::<KinovaGen3, 7>::new(0, &Tool::NONE, &from, &to, 0.01);
/// // No point moves more than 1 cm within a piece, so the margin is at most 5 mm.
/// assert!(sweep.margin() <= 0.005);
/// // Joint 1 turns 1 rad, and no point of the arm is farther than 0.94 m from its axis.
/// assert!(sweep.length() > 0.9 && sweep.length() < 0.94);
///
/// let base = Frame::IDENTITY;
/// let ball = Obstacle {
///     shape: Shape::Sphere { radius: 0.05 },
///     pose: Frame { pos: Vector3::new(0.45, -0.02, 0.57), ..Frame::IDENTITY },
/// };
/// let [start, end] = sweep.ends(&base);
/// assert!(start.obstacle_hit(&[ball], 0.0).is_none() && end.obstacle_hit(&[ball], 0.0).is_none());
/// assert!(sweep.arm_collides(&base, &[ball]));
///
/// // Two arms moving at once: the second, 0.6 m ahead, stands still upright.
/// let base_b = Frame { pos: Vector3::new(0.6, -0.02, 0.0), ..Frame::IDENTITY };
/// let still = Sweep::<KinovaGen3, 7>::new(0, &Tool::NONE, &[0.0; 7], &[0.0; 7], 0.01);
/// assert!(sweeps_collide(&sweep, &base, &still, &base_b));
/// ```
#[derive(Debug)]
pub struct Sweep<M: Models<D>, const D: usize> {
    /// The arm's model, an index into `M`.
    model: u8,
    q0: [f64; D],
    dq: [f64; D],
    length: f64,
    /// Per capsule (link capsules, then the tool's), bound on how far its points travel
    /// (from `Model::CAPSULE_REACH` and [`Tool::reach`]).
    travel: [f64; MAX_POSE_CAPSULES],
    /// Per capsule, bound on how far its axis strays from the straight line between where it
    /// is at the two ends ([`bow`]); infinite for a model without per-capsule reach.
    bow: [f64; MAX_POSE_CAPSULES],
    count: usize,
    tool: Tool,
    /// How its checks place the arm between the ends.
    placing: Placing,
    fleet: PhantomData<M>,
}

// By hand: derived impls would require `M: Copy`, yet only a marker of `M` is held.
impl<M: Models<D>, const D: usize> Clone for Sweep<M, D> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M: Models<D>, const D: usize> Copy for Sweep<M, D> {}

/// Capsule pairs still in question: bit `j` of row `i` stands for capsule `i` of one arm and
/// capsule `j` of the other (or of the same arm). Which rows are not empty is kept too, so
/// that a check over a few pairs reads only their rows.
#[derive(Clone, Copy)]
struct Pairs {
    rows: u32,
    row: [u32; MAX_POSE_CAPSULES],
}

impl Pairs {
    const NONE: Pairs = Pairs {
        rows: 0,
        row: [0; MAX_POSE_CAPSULES],
    };

    fn insert(&mut self, i: usize, j: usize) {
        self.rows |= 1 << i;
        self.row[i] |= 1 << j;
    }

    /// Row `i` becomes `row`.
    fn set_row(&mut self, i: usize, row: u32) {
        self.rows = self.rows & !(1 << i) | u32::from(row != 0) << i;
        self.row[i] = row;
    }

    fn any(&self) -> bool {
        self.rows != 0
    }

    /// The rows that are not empty, with their columns.
    fn rows(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        bits(self.rows).map(|i| (i, self.row[i]))
    }

    /// The capsules of each side still in some pair: the rows that are not empty, and the
    /// columns set in any row.
    fn sides(&self) -> (u32, u32) {
        (self.rows, self.rows().fold(0, |c, (_, row)| c | row))
    }
}

/// What one arm's motion may still hit: per capsule, the obstacles it may meet (bit `k`: the
/// `k`-th of the obstacles near the motion), and self pairs.
#[derive(Clone, Copy)]
struct Suspects {
    /// The capsules with some obstacle in question: the rows of `obstacles` that are set.
    near: u32,
    obstacles: [u64; MAX_POSE_CAPSULES],
    pairs: Pairs,
}

// The obstacles near a motion are kept as bit sets.
const _: () = assert!(MAX_OBSTACLES <= u64::BITS as usize);

impl Suspects {
    const NONE: Suspects = Suspects {
        near: 0,
        obstacles: [0; MAX_POSE_CAPSULES],
        pairs: Pairs::NONE,
    };

    fn any(&self) -> bool {
        self.near != 0 || self.pairs.any()
    }

    /// The capsules in question.
    fn capsules(&self) -> u32 {
        let (rows, columns) = self.pairs.sides();
        self.near | rows | columns
    }

    /// The obstacles `kept` (bit `k`: obstacle `k`) stay in question for capsule `i`.
    fn set_obstacles(&mut self, i: usize, kept: u64) {
        self.near = self.near & !(1 << i) | u32::from(kept != 0) << i;
        self.obstacles[i] = kept;
    }
}

impl<M: Models<D>, const D: usize> Sweep<M, D> {
    /// The motion of the arm of model `model` carrying `tool`, in pieces short enough that no point of it
    /// moves more than `max_disp` over one (so `margin <= max_disp / 2`), unless that takes
    /// more than [`MAX_SWEEP_CHECKS`] pieces. Any count is conservative, only the margin
    /// changes: beyond the cap, or for a `max_disp` that is not positive, the margin grows.
    pub fn new(model: u8, tool: &Tool, q0: &[f64; D], q1: &[f64; D], max_disp: f64) -> Self {
        let dq: [f64; D] = core::array::from_fn(|j| q1[j] - q0[j]);
        let moved = |reach: &[f64; D]| (0..D).map(|j| reach[j] * libm::fabs(dq[j])).sum::<f64>();
        let arm_length = moved(M::reach(model));
        let (mut travel, mut bows) = ([0.0; MAX_POSE_CAPSULES], [0.0; MAX_POSE_CAPSULES]);
        let links = M::capsules(model).len();
        let rates = turn_rates(&dq, M::axis_cos(model));
        for i in 0..links + tool.capsules().len() {
            (travel[i], bows[i]) = match capsule_reach::<M, D>(model, tool, i) {
                Some(reach) => (moved(&reach), bow(&reach, &rates)),
                None => (arm_length, f64::INFINITY),
            };
        }
        let length = (travel[links..].iter()).fold(arm_length, |l, &t| if t > l { t } else { l });
        let pieces = if max_disp > 0.0 {
            libm::ceil(length / max_disp)
        } else {
            1.0
        };
        Sweep {
            model,
            q0: *q0,
            dq,
            length,
            travel,
            bow: bows,
            count: 1,
            tool: *tool,
            placing: Placing::default(),
            fleet: PhantomData,
        }
        // `as` saturates; NaN (from a NaN input) gives 0 and so one piece.
        .with_count(pieces as usize)
    }

    /// Per capsule of the arm placed at the two ends of this motion, a bound on how far its
    /// points travel towards anything between the ends, counted from both ends (what a pair
    /// test at the ends compares the clearances' sum with): the smaller of its travel, and its
    /// chord (how far its axis ends move from one end to the other) plus twice its bow (the
    /// bound of the private function `bow`). Along the motion the capsule is within its bow
    /// of the capsule that moves straight from one end to the other, whose points move at
    /// most the chord in all, so it
    /// is within `chord * s + bow` of where it is at the start a fraction `s` of the way, and
    /// within `chord * (1 - s) + bow` of where it is at the end.
    pub fn reaches(&self, ends: [&ArmPose; 2]) -> [f64; MAX_POSE_CAPSULES] {
        let all = (1u64 << ends[0].len) - 1;
        self.reaches_over(ends, 1.0, all as u32)
    }

    /// [`Sweep::reaches`] of the part of this motion between `ends`, a fraction `width` of it
    /// apart, for the capsules in the bit set `of` (0 for the others): its travel is `width`
    /// times the whole's, its bow `width^2` times (the bow is quadratic in the motion).
    fn reaches_over(&self, ends: [&ArmPose; 2], width: f64, of: u32) -> [f64; MAX_POSE_CAPSULES] {
        let mut reach = [0.0; MAX_POSE_CAPSULES];
        for i in bits(of) {
            let (c0, c1) = (&ends[0].capsules[i].segment, &ends[1].capsules[i].segment);
            // One root for the two ends' (the root is monotone: the same as two).
            let chord = libm::sqrt(
                (c1.a - c0.a)
                    .norm_squared()
                    .max((c1.b - c0.b).norm_squared()),
            );
            let straight = chord + 2.0 * self.bow[i] * width * width;
            let travel = self.travel[i] * width;
            reach[i] = if straight < travel { straight } else { travel };
        }
        reach
    }

    /// The same motion in `count` pieces (clamped to `1..=MAX_SWEEP_CHECKS`), e.g. the larger
    /// of two arms' counts when they move together.
    pub fn with_count(self, count: usize) -> Self {
        Sweep {
            count: count.clamp(1, MAX_SWEEP_CHECKS),
            ..self
        }
    }

    /// The same motion, its checks placing the arm between the ends as `placing` says (the
    /// answers are the same; [`sweeps_collide`] goes by the first sweep's).
    pub fn with_placing(self, placing: Placing) -> Self {
        Sweep { placing, ..self }
    }

    /// Number of pieces.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The motion as [`Rake::place`] reads it, the arm's base at `base`.
    fn moving<'a>(&'a self, base: &'a Frame) -> rake::Moving<'a, D> {
        rake::Moving {
            model: self.model,
            base,
            tool: &self.tool,
            q0: &self.q0,
            dq: &self.dq,
        }
    }

    /// Bound on how far any point of the arm or its tool travels over the whole motion.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// How far any link point may be from where it is at the middle of its piece.
    pub fn margin(&self) -> f64 {
        self.length / (2.0 * self.count as f64)
    }

    /// The configuration at the middle of piece `i` (`0..count`).
    pub fn config(&self, i: usize) -> [f64; D] {
        self.at((i as f64 + 0.5) / self.count as f64)
    }

    /// The arm at the middle of piece `i`.
    pub fn arm(&self, base: &Frame, i: usize) -> ArmPose {
        ArmPose::new::<M, D>(self.model, base, &self.tool, &self.config(i))
    }

    /// The configuration a fraction `s` (`0..=1`) of the way.
    pub fn at(&self, s: f64) -> [f64; D] {
        core::array::from_fn(|j| self.q0[j] + self.dq[j] * s)
    }

    /// The arm at both ends of the motion.
    pub fn ends(&self, base: &Frame) -> [ArmPose; 2] {
        [
            ArmPose::new::<M, D>(self.model, base, &self.tool, &self.q0),
            ArmPose::new::<M, D>(self.model, base, &self.tool, &self.at(1.0)),
        ]
    }

    /// Bound on how far the points of capsule `i` travel over the motion.
    pub fn travel(&self, i: usize) -> f64 {
        self.travel[i]
    }

    /// Bound on how far capsules `a` and `b` of this arm move relative to each other: a joint
    /// that carries both turns them as one body, so only the joints that carry one of them
    /// alone count (a serial chain: those between their links). A joint carries a capsule
    /// when its reach for it is positive; a capsule on the axis of a joint that carries it
    /// counts as not carried, which only makes the bound larger.
    pub fn pair_travel(&self, a: usize, b: usize) -> f64 {
        let reach = |i| capsule_reach::<M, D>(self.model, &self.tool, i);
        let (Some(ra), Some(rb)) = (reach(a), reach(b)) else {
            return self.travel(a) + self.travel(b);
        };
        (0..D)
            .filter(|&j| (ra[j] > 0.0) != (rb[j] > 0.0))
            .map(|j| (ra[j] + rb[j]) * libm::fabs(self.dq[j]))
            .sum()
    }

    /// Whether the arm may hit an obstacle or itself anywhere along the motion. More than
    /// [`MAX_OBSTACLES`] obstacles are not checked: the answer is then that it may.
    pub fn arm_collides(&self, base: &Frame, obstacles: &[Obstacle]) -> bool {
        let [e0, e1] = self.ends(base);
        let Some(obstacles) = Obstacles::new(obstacles) else {
            return true;
        };
        self.arm_collides_among(base, &obstacles, [&e0, &e1])
    }

    /// [`Sweep::arm_collides`] for a caller that already placed the arm at both ends, among
    /// obstacles whose boxes it made once for many checks.
    pub fn arm_collides_among(
        &self,
        base: &Frame,
        obstacles: &Obstacles<'_>,
        ends: [&ArmPose; 2],
    ) -> bool {
        let [e0, e1] = ends;
        let (shapes, aabbs, boxes) = (obstacles.shapes, &obstacles.aabbs, &obstacles.boxes);
        // The obstacles the moving capsules may reach at all: a point's distances from where
        // it is at the two ends add up to at most the motion's length, so it stays within half
        // that of one end or the other.
        let moving = [&e0.moving_aabb, &e1.moving_aabb];
        let near = boxes.reachable(boxes.all(), moving, self.length);
        let mut all = Suspects::NONE;
        if near != 0 {
            for i in (0..e0.len).filter(|&i| !e0.on_base(i)) {
                all.near |= 1 << i;
                all.obstacles[i] = near;
            }
        }
        for (a, b) in e0.self_pairs() {
            all.pairs.insert(a, b);
        }
        let check = &mut |ends: [[&ArmPose; 1]; 2], width: f64, sus: &Suspects| {
            let ends = [ends[0][0], ends[1][0]];
            let reach = self.reaches_over(ends, width, sus.capsules());
            let mut left = Suspects::NONE;
            for i in bits(sus.near) {
                let at = [&ends[0].boxes[i], &ends[1].boxes[i]];
                let reachable = bits64(boxes.reachable(sus.obstacles[i], at, reach[i]));
                let contact =
                    |k: usize| obstacle_contact_over(&shapes[k], &aabbs[k], ends, i, reach[i]);
                let Some(kept) = still_in_question(reachable, contact, |_| true) else {
                    return Found::Touch;
                };
                left.set_obstacles(i, kept);
            }
            for (a, row) in sus.pairs.rows() {
                let contact = |b: usize| {
                    let relative = || self.pair_travel(a, b) * width;
                    let t = reach[a] + reach[b];
                    ArmPose::pair_contact_within(ends, a, ends, b, t, relative)
                };
                let boxed = |b: usize| !ArmPose::boxes_apart(ends, a, ends, b, reach[a] + reach[b]);
                let Some(kept) = still_in_question(bits(row), contact, boxed) else {
                    return Found::Touch;
                };
                left.pairs.set_row(a, kept as u32);
            }
            Found::left(left.any(), left)
        };
        // A long motion is split before it is checked at all: checked whole, it almost never
        // clears (its capsules' reach covers more than the clearances of a work cell), and its
        // halves would test again all that it leaves in question.
        let left = if !all.any() {
            return false;
        } else if self.length > WHOLE_CHECK_LENGTH {
            all
        } else {
            match check([[e0], [e1]], 1.0, &all) {
                Found::Clear => return false,
                Found::Touch => return true,
                Found::Suspects(left) => left,
            }
        };
        let halves = 2 * self.count;
        let ends = [[e0], [e1]];
        let single = |s: f64, sus: &Suspects, at: &mut [ArmPose; 1]| {
            let q = self.at(s);
            at[0].place_only::<M, D>(self.model, base, &self.tool, &q, sus.capsules());
        };
        match self.placing {
            Placing::Single => {
                let placer = &mut Single(single);
                refine(Parts::all(halves), ends, left, None, placer, check)
            }
            Placing::Rake => {
                let place = |s: F64s, sus: &Suspects, rakes: &mut [Rake; 1]| {
                    rakes[0].place::<M, D>(&self.moving(base), s, sus.capsules());
                };
                let pose = |rakes: &[Rake; 1], k: usize, sus: &Suspects, at: &mut [ArmPose; 1]| {
                    rakes[0].pose(k, sus.capsules(), e0, &mut at[0]);
                };
                let placer = &mut Raked(place, pose, single);
                refine(Parts::all(halves), ends, left, None, placer, check)
            }
        }
    }
}

/// Which of one capsule's `candidates` (obstacles, or the other capsules of its pairs) stay
/// in question over a part of a motion, as a bit set: `contact` tests them in order up to the
/// first that stays in question (`Near`); the capsule is then split on anyway, so that one
/// and the rest that the cheap `in_reach` leaves in question are kept, untested, for the
/// halves to tell (a touch at this part's end is a touch at a half's). `None`: a touch.
fn still_in_question(
    mut candidates: impl Iterator<Item = usize>,
    mut contact: impl FnMut(usize) -> Contact,
    mut in_reach: impl FnMut(usize) -> bool,
) -> Option<u64> {
    for k in candidates.by_ref() {
        match contact(k) {
            Contact::Touch => return None,
            Contact::Near => {
                let rest = candidates.filter(|&j| in_reach(j));
                return Some(rest.fold(1 << k, |kept, j| kept | 1 << j));
            }
            Contact::Clear => {}
        }
    }
    Some(0)
}

/// Whether capsule `i` of the arm at `ends` may meet obstacle `o` (its box `ob`) while its
/// points travel at most `travel` towards it in all, from either end (as
/// [`ArmPose::pair_contact_over`]).
fn obstacle_contact_over(
    o: &Obstacle,
    ob: &Aabb,
    ends: [&ArmPose; 2],
    i: usize,
    travel: f64,
) -> Contact {
    if Aabb::apart_over([ob, ob], [&ends[0].boxes[i], &ends[1].boxes[i]], travel) {
        return Contact::Clear;
    }
    let d0 = o.distance_to_capsule(&ends[0].capsules[i]);
    if d0 == 0.0 {
        Contact::Touch
    } else if d0 > travel {
        Contact::Clear
    } else {
        o.capsule_contact(&ends[1].capsules[i], travel - d0)
    }
}

/// Whether two arms moving at the same time (each along its sweep, over the same time span)
/// may collide: both are checked at the same instants, each capsule pair with the sum of its
/// two capsules' margins, down to the finer of their pieces.
pub fn sweeps_collide<A: Models<DA>, const DA: usize, B: Models<DB>, const DB: usize>(
    a: &Sweep<A, DA>,
    base_a: &Frame,
    b: &Sweep<B, DB>,
    base_b: &Frame,
) -> bool {
    let [a0, a1] = a.ends(base_a);
    let [b0, b1] = b.ends(base_b);
    sweeps_collide_posed(a, base_a, [&a0, &a1], b, base_b, [&b0, &b1])
}

/// [`sweeps_collide`] for a caller that already placed both arms at both ends.
pub fn sweeps_collide_posed<A: Models<DA>, const DA: usize, B: Models<DB>, const DB: usize>(
    a: &Sweep<A, DA>,
    base_a: &Frame,
    a_ends: [&ArmPose; 2],
    b: &Sweep<B, DB>,
    base_b: &Frame,
    b_ends: [&ArmPose; 2],
) -> bool {
    let ([a0, _], [b0, _]) = (a_ends, b_ends);
    // A capsule whose boxes at the two ends are farther from the other arm's whole boxes
    // than both can travel towards each other meets none of its capsules: the same bound as
    // each pair's, taken once per capsule, which leaves out most rows and columns of pairs
    // of two arms working side by side.
    let near_other = |ends: [&ArmPose; 2], i: usize, other: [&ArmPose; 2], travel: f64| {
        let at = [&ends[0].boxes[i], &ends[1].boxes[i]];
        !Aabb::apart_over(at, [&other[0].aabb, &other[1].aabb], travel)
    };
    let (ra, rb) = (a.reaches(a_ends), b.reaches(b_ends));
    let (a_far, b_far) = (farthest(&ra), farthest(&rb));
    let columns = (0..b0.len)
        .filter(|&j| near_other(b_ends, j, a_ends, rb[j] + a_far))
        .fold(0u32, |m, j| m | 1 << j);
    // An arm that stands still is where its ends have it all along: never placed again.
    let (a_still, b_still) = (
        a.dq.iter().all(|&d| d == 0.0),
        b.dq.iter().all(|&d| d == 0.0),
    );
    let check = &mut |ends: [[&ArmPose; 2]; 2], width: f64, pairs: &Pairs| {
        let (rows, columns) = pairs.sides();
        let a_at = [
            if a_still { a0 } else { ends[0][0] },
            if a_still { a0 } else { ends[1][0] },
        ];
        let b_at = [
            if b_still { b0 } else { ends[0][1] },
            if b_still { b0 } else { ends[1][1] },
        ];
        let (ra, rb) = (
            a.reaches_over(a_at, width, rows),
            b.reaches_over(b_at, width, columns),
        );
        let mut left = Pairs::NONE;
        for (i, row) in pairs.rows() {
            let contact = |j: usize| ArmPose::pair_contact_over(a_at, i, b_at, j, ra[i] + rb[j]);
            let boxed = |j: usize| !ArmPose::boxes_apart(a_at, i, b_at, j, ra[i] + rb[j]);
            let Some(kept) = still_in_question(bits(row), contact, boxed) else {
                return Found::Touch;
            };
            left.set_row(i, kept as u32);
        }
        Found::left(left.any(), left)
    };
    let place = |s: f64, pairs: &Pairs, at: &mut [ArmPose; 2]| {
        let (rows, columns) = pairs.sides();
        if !a_still {
            at[0].place_only::<A, DA>(a.model, base_a, &a.tool, &a.at(s), rows);
        }
        if !b_still {
            at[1].place_only::<B, DB>(b.model, base_b, &b.tool, &b.at(s), columns);
        }
    };
    let rake = |s: F64s, pairs: &Pairs, rakes: &mut [Rake; 2]| {
        let (rows, columns) = pairs.sides();
        if !a_still {
            rakes[0].place::<A, DA>(&a.moving(base_a), s, rows);
        }
        if !b_still {
            rakes[1].place::<B, DB>(&b.moving(base_b), s, columns);
        }
    };
    let pose = |rakes: &[Rake; 2], k: usize, pairs: &Pairs, at: &mut [ArmPose; 2]| {
        let (rows, columns) = pairs.sides();
        if !a_still {
            rakes[0].pose(k, rows, a0, &mut at[0]);
        }
        if !b_still {
            rakes[1].pose(k, columns, b0, &mut at[1]);
        }
    };
    // The rows and columns the filter above keeps, as the pairs in question.
    let mut all = Pairs::NONE;
    if columns != 0 {
        for i in (0..a0.len).filter(|&i| near_other(a_ends, i, b_ends, ra[i] + b_far)) {
            all.set_row(i, columns);
        }
    }
    let ends = [[a_ends[0], b_ends[0]], [a_ends[1], b_ends[1]]];
    match check(ends, 1.0, &all) {
        Found::Clear => false,
        Found::Touch => true,
        Found::Suspects(left) => {
            // Half pieces, as one arm's sweep.
            let halves = 2 * a.count.max(b.count);
            match a.placing {
                Placing::Single => {
                    let placer = &mut Single(place);
                    refine(Parts::all(halves), ends, left, None, placer, check)
                }
                Placing::Rake => {
                    let placer = &mut Raked(rake, pose, place);
                    refine(Parts::all(halves), ends, left, None, placer, check)
                }
            }
        }
    }
}

/// Per joint, a bound on how far capsule `i` (link capsules, then the tool's) of model
/// `model` carrying `tool` travels per radian (or metre) of it: 0 for the joints that do not
/// carry it. `None` when the model has no per-capsule bound.
fn capsule_reach<M: Models<D>, const D: usize>(
    model: u8,
    tool: &Tool,
    i: usize,
) -> Option<[f64; D]> {
    let links = M::capsules(model).len();
    if i >= links {
        return Some(tool.reach(M::tool_reach(model), i - links));
    }
    match M::capsule_reach(model).get(i) {
        Some(reach) => Some(*reach),
        None if M::capsules(model)[i].link == 0 => Some([0.0; D]),
        None => None,
    }
}

/// The largest of per-capsule bounds (0 for none).
fn farthest(bounds: &[f64; MAX_POSE_CAPSULES]) -> f64 {
    bounds.iter().fold(0.0, |m, &t| if t > m { t } else { m })
}

/// How far a point strays from the straight line between where it is at the two ends of a
/// joint-space motion, for a point that joint `k` moves at most `reach[k]` per radian (or
/// metre) of it ([`capsule_reach`], 0 for joints that do not carry it), `rates` the motion's
/// [`turn_rates`]: at most an eighth of the point's largest acceleration along the motion,
/// which is at most `sum_k reach[k] rates[k]`. Quadratic in the motion: small for short ones.
fn bow<const D: usize>(reach: &[f64; D], rates: &[f64; D]) -> f64 {
    reach.iter().zip(rates).map(|(r, m)| r * m).sum::<f64>() / 8.0
}

/// Per joint `k`, a bound on `|dq_k| |dq_k w_k + 2 W_k|` along the joint-space motion `dq`,
/// `w_k` the unit vector of joint `k`'s axis (0 for a prismatic joint) and `W_k = sum_j<k dq_j
/// w_j` the angular velocity the joints before it give its link. A point's acceleration along
/// the motion is `sum_k (dq_k w_k + 2 W_k) x v_k`, `v_k` the velocity joint `k` gives it, at
/// most `reach[k] |dq_k|` long (the second derivative of a serial chain by joints `j <= k` is
/// `w_j x (w_k x r_k)`; for a prismatic joint its unit vector turns), so `sum_k reach[k]
/// rates[k]` bounds it. `|dq_k w_k + 2 W_k|^2` is bounded term by term: consecutive axes
/// meet at a fixed angle (`cos`, [`crate::model::Model::AXIS_COS`]), the others at any
/// (`|w_i . w_j| <= 1`); with `cos` all 1 the bound is `|dq_k| + 2 sum_j<k |dq_j|`.
fn turn_rates<const D: usize>(dq: &[f64; D], cos: &[f64; D]) -> [f64; D] {
    let mut rates = [0.0; D];
    // Bound on |W_k|^2; sum_j<k-1 |dq_j|; |dq_k-1|.
    let (mut turn2, mut earlier, mut last) = (0.0, 0.0, 0.0);
    for k in 0..D {
        let d = libm::fabs(dq[k]);
        // Bound on |w_k . W_k|.
        let along = last * cos[k] + earlier;
        rates[k] = d * libm::sqrt(d * d + 4.0 * d * along + 4.0 * turn2);
        turn2 += d * d + 2.0 * d * along;
        (earlier, last) = (earlier + last, d);
    }
    rates
}

/// What one check of [`refine`] found over a part of the motion, from its two ends.
enum Found<S> {
    /// Every suspect clears the part.
    Clear,
    /// These suspects may meet somewhere in the part: its halves tell.
    Suspects(S),
    /// A suspect meets at an end: the motion collides (the halves around that placing would
    /// fail too, so the answer is the one they would give, found without them).
    Touch,
}

impl<S> Found<S> {
    /// `Suspects(left)` when `any`, else `Clear`.
    fn left(any: bool, left: S) -> Self {
        if any {
            Found::Suspects(left)
        } else {
            Found::Clear
        }
    }
}

/// Where [`refine`] gets the arms at the middle of a part of the motion.
trait Placer<S, const K: usize> {
    /// Placings made ahead for a part and the parts below it (see [`rake::RAKE_PARTS`]).
    type Ahead;
    /// Places ahead for the part `first..end` of `count`, `suspects` in question there (and
    /// so no others below it).
    fn ahead(&mut self, first: usize, end: usize, count: usize, suspects: &S) -> Self::Ahead;
    /// The arms at `mid`, the middle of part `part` of `ahead`, for the suspects' capsules.
    fn at(
        &mut self,
        ahead: &Self::Ahead,
        part: usize,
        mid: usize,
        count: usize,
        suspects: &S,
        out: &mut [ArmPose; K],
    );
}

/// One configuration at a time: `place(s, suspects, poses)` places the arms a fraction `s` of
/// the way.
struct Single<F>(F);

impl<S, F: FnMut(f64, &S, &mut [ArmPose; K]), const K: usize> Placer<S, K> for Single<F> {
    type Ahead = ();

    fn ahead(&mut self, _: usize, _: usize, _: usize, _: &S) {}

    fn at(&mut self, _: &(), _: usize, mid: usize, count: usize, sus: &S, out: &mut [ArmPose; K]) {
        (self.0)(mid as f64 / count as f64, sus, out);
    }
}

/// A rake ahead where it pays: `rake(s, suspects, rakes)` places the arms at the fractions
/// `s` (a lane each), `pose(rakes, lane, suspects, poses)` reads a lane's; a part with fewer
/// than [`rake::RAKE_MIN_SPLITS`] splits below it (a short motion) is placed one at a time
/// by `place` (as [`Single`]), where a batch would cost more than the placings it holds.
struct Raked<F, G, H>(F, G, H);

impl<S, F, G, H, const K: usize> Placer<S, K> for Raked<F, G, H>
where
    F: FnMut(F64s, &S, &mut [Rake; K]),
    G: FnMut(&[Rake; K], usize, &S, &mut [ArmPose; K]),
    H: FnMut(f64, &S, &mut [ArmPose; K]),
{
    type Ahead = Option<[Rake; K]>;

    fn ahead(&mut self, first: usize, end: usize, count: usize, sus: &S) -> Self::Ahead {
        let (s, splits) = rake::rake_fractions(first, end, count);
        (splits >= rake::RAKE_MIN_SPLITS).then(|| {
            let mut rakes = [Rake::EMPTY; K];
            (self.0)(s, sus, &mut rakes);
            rakes
        })
    }

    fn at(
        &mut self,
        rakes: &Self::Ahead,
        part: usize,
        mid: usize,
        count: usize,
        sus: &S,
        out: &mut [ArmPose; K],
    ) {
        match rakes {
            Some(rakes) => (self.1)(rakes, part, sus, out),
            None => (self.2)(mid as f64 / count as f64, sus, out),
        }
    }
}

/// Parts `first..end` of a motion cut into `count`.
#[derive(Clone, Copy)]
struct Parts {
    first: usize,
    end: usize,
    count: usize,
}

impl Parts {
    /// Every one of `count` parts.
    fn all(count: usize) -> Parts {
        Parts {
            first: 0,
            end: count,
            count,
        }
    }
}

/// Whether some suspect still fails on a single one of parts `first..end` of `count` (of the
/// motion), where `suspects` fail the check over them as a whole: places the arms (`K` of
/// them) at the parts' middle boundary (for the suspects' capsules only, by `placer`, which
/// may have placed them ahead: `ahead` is where, and which of its parts this is) and checks
/// each half between its end poses by `check(ends, width, suspects)`, `width` the half's
/// share of the motion, which tells which suspects may meet inside it and whether one touches
/// at an end; then the halves' halves, for those alone. A touch ends the search. The answer
/// does not depend on how the placer places: every check reads the same poses.
///
/// Cost: one placing per split (one rake per three levels). Stack: `K` [`ArmPose`]s (about
/// 2.2 KB each) per level, and `K` rakes (about 7.8 KB each) per three, at most
/// `log2(2 * MAX_SWEEP_CHECKS)` levels.
fn refine<S: Copy, P: Placer<S, K>, const K: usize>(
    Parts { first, end, count }: Parts,
    ends: [[&ArmPose; K]; 2],
    suspects: S,
    ahead: Option<(&P::Ahead, usize)>,
    placer: &mut P,
    check: &mut impl FnMut([[&ArmPose; K]; 2], f64, &S) -> Found<S>,
) -> bool {
    if end - first <= 1 {
        return true;
    }
    let mid = (first + end) / 2;
    let made;
    let (ahead, part) = match ahead {
        Some(placed) => placed,
        None => {
            made = placer.ahead(first, end, count, &suspects);
            (&made, 0)
        }
    };
    let mut at = [ArmPose::EMPTY; K];
    placer.at(ahead, part, mid, count, &suspects, &mut at);
    let at: [&ArmPose; K] = core::array::from_fn(|k| &at[k]);
    let halves = [
        (2 * part + 1, first, mid, [ends[0], at]),
        (2 * part + 2, mid, end, [at, ends[1]]),
    ];
    for (half, lo, hi, ends) in halves {
        let found = check(ends, (hi - lo) as f64 / count as f64, &suspects);
        let hit = match found {
            Found::Clear => false,
            Found::Touch => true,
            Found::Suspects(left) => {
                let below = (half < rake::RAKE_PARTS).then_some((ahead, half));
                let parts = Parts {
                    first: lo,
                    end: hi,
                    count,
                };
                refine(parts, ends, left, below, placer, check)
            }
        };
        if hit {
            return true;
        }
    }
    false
}
