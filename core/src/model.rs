//! Robot models.
//!
//! A model is a serial chain compiled in at build time: `build.rs` runs `omcbsa-codegen` on a
//! URDF and emits one zero-sized type per model implementing [`Model`]. Nothing parses a URDF at
//! run time. Everything a model knows is a `const` or an unrolled function, so evaluating it
//! costs a fixed number of flops and no memory.
//!
//! The compiled models are [`KinovaGen3`] and [`FrankaPanda`] (7 joints) and
//! [`SyntheticChain`] (5 joints, for tests); [`Fleet7`] and [`Fleet5`] dispatch over the
//! models of one DoF by index ([`Models`]). Lengths are in metres, angles in radians.
//!
//! Forward kinematics of the Gen3, and the same query through the fleet by model index:
//!
//! ```
//! use omcbsa_core::model::{Frame, KinovaGen3, Model};
//!
//! let q = [0.1, 0.5, -0.2, 1.2, 0.0, 0.8, 0.3];
//! let hand: Frame = KinovaGen3::fk(&q);
//! // The tool frame is the last link frame, and the Jacobian comes with the same pose.
//! let mut links = [Frame::IDENTITY; 9];
//! assert_eq!(KinovaGen3::LINK_NAMES.len(), 9);
//! let tool = KinovaGen3::link_frames(&q, &mut links);
//! let (at, _jacobian) = KinovaGen3::jacobian(&q);
//! assert!((tool.pos - hand.pos).norm() < 1e-12 && (at.pos - hand.pos).norm() < 1e-12);
//! // The Gen3 reaches about 1.2 m from its base.
//! assert!(hand.pos.norm() < 1.3);
//! ```

use core::ops::ControlFlow;

use nalgebra::{Matrix3, SMatrix, Vector3};

use crate::lanes::{lane, F64s, Real, LANES};

/// Most collision capsules one arm model may have. A model with more is refused when
/// [`crate::collision::ArmPose::new`] is compiled for it (or for a fleet holding it), never
/// truncated:
///
/// ```compile_fail
/// use omcbsa_core::collision::ArmPose;
/// use omcbsa_core::model::MAX_ARM_CAPSULES;
/// use omcbsa_core::model::{Frame, LinkCapsule, Model};
/// use omcbsa_core::nalgebra::SMatrix;
///
/// struct TooMany;
/// impl Model<1> for TooMany {
///     const NAME: &'static str = "too_many";
///     const LINK_NAMES: &'static [&'static str] = &["base"];
///     const JOINT_NAMES: [&'static str; 1] = ["j"];
///     const LOWER: [f64; 1] = [-1.0];
///     const UPPER: [f64; 1] = [1.0];
///     const VELOCITY: [f64; 1] = [1.0];
///     const ACCELERATION: [f64; 1] = [1.0];
///     const CAPSULES: &'static [LinkCapsule] =
///         &[LinkCapsule { link: 0, a: [0.0; 3], b: [0.0; 3], radius: 0.1 }; MAX_ARM_CAPSULES + 1];
///     const SELF_PAIRS: &'static [(u8, u8)] = &[];
///     const REACH: [f64; 1] = [1.0];
///     fn fk(_: &[f64; 1]) -> Frame {
///         Frame::IDENTITY
///     }
///     fn link_frames(_: &[f64; 1], out: &mut [Frame]) -> Frame {
///         out[0] = Frame::IDENTITY;
///         Frame::IDENTITY
///     }
///     fn jacobian(_: &[f64; 1]) -> (Frame, SMatrix<f64, 6, 1>) {
///         (Frame::IDENTITY, SMatrix::zeros())
///     }
/// }
///
/// ArmPose::new::<TooMany, 1>(0, &Frame::IDENTITY, &omcbsa_core::tool::Tool::NONE, &[0.0]);
/// ```
pub const MAX_ARM_CAPSULES: usize = 16;
/// Most link frames one arm model may have (a model with more does not compile).
pub const MAX_LINK_FRAMES: usize = 16;

/// Fails compilation (through [`Models::CHECKED`], which
/// [`crate::collision::ArmPose::new`] evaluates) for a model an
/// `ArmPose` cannot hold, or whose capsule and pair indices point nowhere, so that indexing
/// with them cannot fail.
pub const fn check_model<M: Model<D>, const D: usize>() {
    assert!(
        M::CAPSULES.len() <= MAX_ARM_CAPSULES,
        "model has more than MAX_ARM_CAPSULES"
    );
    assert!(
        M::LINK_NAMES.len() <= MAX_LINK_FRAMES,
        "model has more than MAX_LINK_FRAMES"
    );
    let mut i = 0;
    while i < M::CAPSULES.len() {
        assert!(
            (M::CAPSULES[i].link as usize) < M::LINK_NAMES.len(),
            "capsule on no link"
        );
        // The batched placing takes each link's capsules as its frame is computed.
        assert!(
            i == 0 || M::CAPSULES[i - 1].link <= M::CAPSULES[i].link,
            "capsules not in link order"
        );
        i += 1;
    }
    let mut i = 0;
    while i < M::SELF_PAIRS.len() {
        let (a, b) = M::SELF_PAIRS[i];
        let n = M::CAPSULES.len();
        assert!(
            (a as usize) < n && (b as usize) < n,
            "self pair names no capsule"
        );
        i += 1;
    }
    let mut i = 0;
    while i < M::TOOL_SELF_CAPSULES.len() {
        assert!(
            (M::TOOL_SELF_CAPSULES[i] as usize) < M::CAPSULES.len(),
            "tool self capsule names no capsule"
        );
        i += 1;
    }
}

/// A rigid transform kept as a rotation matrix and a translation: composing and applying
/// these is cheaper than going through quaternions in the hot loops.
///
/// A frame maps points given in the child frame to the parent frame: `p_parent = rot * p +
/// pos`. Nothing checks that `rot` is a rotation; the file loader and
/// [`crate::ik::ik`] do, at the boundary.
///
/// ```
/// use omcbsa_core::model::Frame;
/// use omcbsa_core::nalgebra::{Matrix3, Vector3};
///
/// // A quarter turn about z, then 1 m along x.
/// let turn = Frame {
///     rot: Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0),
///     pos: Vector3::new(1.0, 0.0, 0.0),
/// };
/// let p = turn.apply(&Vector3::new(1.0, 0.0, 0.0));
/// assert!((p - Vector3::new(1.0, 1.0, 0.0)).norm() < 1e-15);
/// // A frame composed with its inverse is the identity.
/// let id = turn.compose(&turn.inverse());
/// assert!((id.rot - Matrix3::identity()).norm() < 1e-15 && id.pos.norm() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Rotation matrix: the child frame's axes as columns, in the parent frame.
    pub rot: Matrix3<f64>,
    /// The child frame's origin in the parent frame, metres.
    pub pos: Vector3<f64>,
}

impl Frame {
    /// No rotation, no translation.
    pub const IDENTITY: Frame = Frame {
        rot: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        pos: Vector3::new(0.0, 0.0, 0.0),
    };

    /// `self * other`.
    #[inline]
    pub fn compose(&self, other: &Frame) -> Frame {
        Frame {
            rot: self.rot * other.rot,
            pos: self.rot * other.pos + self.pos,
        }
    }

    /// Maps a point given in this frame to the parent frame.
    #[inline]
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rot * p + self.pos
    }

    /// The inverse transform (maps parent coordinates to the child frame); uses the
    /// transpose, so `rot` must be a rotation.
    #[inline]
    pub fn inverse(&self) -> Frame {
        let rt = self.rot.transpose();
        Frame {
            rot: rt,
            pos: -(rt * self.pos),
        }
    }
}

/// [`Frame`] over any numbers ([`Real`]): one pose, or a batch of them ([`F64s`], a pose per
/// lane). Rows of the rotation, then the translation. Composing and applying take the
/// operations of [`Frame`]'s (nalgebra's) in their order, so that lane `k` of a batch is,
/// bit for bit, the `Frame` of configuration `k`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameOf<T> {
    /// The rotation's rows.
    pub rot: [[T; 3]; 3],
    /// The translation.
    pub pos: [T; 3],
}

impl<T: Real> FrameOf<T> {
    /// The identity in every lane.
    #[inline(always)]
    pub fn identity() -> Self {
        let (o, z) = (T::splat(1.0), T::splat(0.0));
        FrameOf {
            rot: [[o, z, z], [z, o, z], [z, z, o]],
            pos: [z; 3],
        }
    }

    /// `f` in every lane.
    #[inline(always)]
    pub fn splat(f: &Frame) -> Self {
        FrameOf {
            rot: core::array::from_fn(|i| core::array::from_fn(|j| T::splat(f.rot[(i, j)]))),
            pos: core::array::from_fn(|i| T::splat(f.pos[i])),
        }
    }

    /// `self * other`, as [`Frame::compose`].
    #[inline(always)]
    pub fn compose(&self, other: &Self) -> Self {
        let (a, b) = (&self.rot, &other.rot);
        FrameOf {
            rot: core::array::from_fn(|i| {
                core::array::from_fn(|j| a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j])
            }),
            pos: self.apply(&other.pos),
        }
    }

    /// Maps a point given in this frame to the parent frame, as [`Frame::apply`].
    #[inline(always)]
    pub fn apply(&self, p: &[T; 3]) -> [T; 3] {
        let r = &self.rot;
        core::array::from_fn(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + self.pos[i])
    }
}

impl FrameOf<F64s> {
    /// The pose of lane `k`.
    pub fn lane(&self, k: usize) -> Frame {
        Frame {
            rot: Matrix3::from_fn(|i, j| lane(self.rot[i][j], k)),
            pos: Vector3::from_fn(|i, _| lane(self.pos[i], k)),
        }
    }

    /// Sets lane `k` to `f`.
    pub fn set_lane(&mut self, k: usize, f: &Frame) {
        for i in 0..3 {
            for j in 0..3 {
                self.rot[i][j].as_mut_array()[k] = f.rot[(i, j)];
            }
            self.pos[i].as_mut_array()[k] = f.pos[i];
        }
    }
}

impl From<FrameOf<f64>> for Frame {
    #[inline(always)]
    fn from(f: FrameOf<f64>) -> Frame {
        (&f).into()
    }
}

impl From<&FrameOf<f64>> for Frame {
    #[inline(always)]
    fn from(f: &FrameOf<f64>) -> Frame {
        let r = &f.rot;
        Frame {
            rot: Matrix3::new(
                r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2],
            ),
            pos: Vector3::new(f.pos[0], f.pos[1], f.pos[2]),
        }
    }
}

/// Where a batch's link frames go, one at a time: `(link index, frame)`. Breaking stops the
/// kinematics: no further frame is computed.
pub trait LinkSink: FnMut(usize, &FrameOf<F64s>) -> ControlFlow<()> {}

impl<F: FnMut(usize, &FrameOf<F64s>) -> ControlFlow<()>> LinkSink for F {}

/// Configuration `k` of a batch.
#[inline]
pub fn lane_config<const D: usize>(q: &[F64s; D], k: usize) -> [f64; D] {
    core::array::from_fn(|j| lane(q[j], k))
}

/// One collision primitive of a link, in the link's frame: the set of points within `radius`
/// of the segment `a`-`b` (a sphere when `a == b`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkCapsule {
    /// Index into [`Model::LINK_NAMES`].
    pub link: u8,
    /// One end of the capsule's axis, in the link frame, metres.
    pub a: [f64; 3],
    /// The other end of the axis (equal to `a` for a sphere), metres.
    pub b: [f64; 3],
    /// Radius, metres.
    pub radius: f64,
}

/// A serial-chain robot model with `D` actuated joints.
///
/// Link frames are numbered in chain order: `0` is the base link, and every joint (fixed ones
/// included) adds the frame of its child link. The chain runs from the manifest's base link
/// to its tool frame (the last of [`Model::LINK_NAMES`]); links off it (a gripper's fingers)
/// are in the capsules of the link they hang from.
pub trait Model<const D: usize>: 'static {
    /// Degrees of freedom (the number of actuated joints), equal to `D`.
    const DOF: usize = D;
    /// The name problem files use for this model (`kinova_gen3`).
    const NAME: &'static str;
    /// Names of the link frames, base first.
    const LINK_NAMES: &'static [&'static str];
    /// Names of the actuated joints, in chain order.
    const JOINT_NAMES: [&'static str; D];
    /// Lower position limits; `-inf` for continuous joints.
    const LOWER: [f64; D];
    /// Upper position limits; `+inf` for continuous joints.
    const UPPER: [f64; D];
    /// Velocity limits (rad/s or m/s): the vendor's, from the model's manifest
    /// (`robots/<model>/model.json`, which names their source).
    const VELOCITY: [f64; D];
    /// Acceleration limits (rad/s² or m/s²), from the manifest like [`Model::VELOCITY`];
    /// `f64::INFINITY` for a model generated without one.
    const ACCELERATION: [f64; D];
    /// Collision primitives of all links.
    const CAPSULES: &'static [LinkCapsule];
    /// Pairs of indices into [`Model::CAPSULES`] that are checked for self-collision: all
    /// pairs on different links except adjacent links and pairs the model's SRDF disables.
    const SELF_PAIRS: &'static [(u8, u8)];
    /// For each joint, an upper bound on the distance from its axis (or, for a prismatic
    /// joint, 1) to any point of a collision primitive downstream of it. Moving joint `j` by
    /// `dq` moves no point of the arm by more than `REACH[j] * |dq|`.
    const REACH: [f64; D];
    /// Per capsule (in the order of [`Model::CAPSULES`]), the same bound for that capsule's
    /// points alone: 0 for joints downstream of its link. Empty: [`Model::REACH`] stands in.
    const CAPSULE_REACH: &'static [[f64; D]] = &[];
    /// Indices into [`Model::CAPSULES`] that a tool (capsules rigid on the tool frame, see
    /// [`crate::tool::Tool`]) is checked against for self-collision: those on links neither
    /// carrying the tool frame nor adjacent to it.
    const TOOL_SELF_CAPSULES: &'static [u8] = &[];
    /// For each joint, an upper bound on the distance from its axis to the tool frame's origin
    /// ([`Model::REACH`] bounds it too): a tool point `r` from that origin moves at most
    /// `(TOOL_REACH[j] + r) * |dq|` when joint `j` moves by `dq`.
    const TOOL_REACH: [f64; D] = Self::REACH;
    /// For each joint `k`, a bound on `|cos|` of the angle between its axis and joint
    /// `k - 1`'s, the same in every configuration when only a rigid link lies between them
    /// (0 for the perpendicular axes of most arms): it tightens the bound on how far a
    /// straight joint-space motion bows. 1 (no bound) for joint 0, next to a prismatic joint,
    /// and by default.
    const AXIS_COS: [f64; D] = [1.0; D];

    /// Pose of the tool frame in the base frame.
    fn fk(q: &[f64; D]) -> Frame;

    /// Writes every link frame (base frame first, `LINK_NAMES.len()` of them) into `out` and
    /// returns the tool frame. `out` must hold at least `LINK_NAMES.len()` frames
    /// ([`MAX_LINK_FRAMES`] holds any model's): frames that do not fit are not written, and a
    /// debug build asserts.
    fn link_frames(q: &[f64; D], out: &mut [Frame]) -> Frame;

    /// Tool pose and the geometric Jacobian at the tool frame's origin, in the base frame:
    /// rows 0-2 linear velocity, rows 3-5 angular velocity.
    fn jacobian(q: &[f64; D]) -> (Frame, SMatrix<f64, 6, D>);

    /// [`Model::fk`] of a batch of configurations, lane by lane the same. By default one
    /// configuration at a time; the generated models compute every lane at once.
    fn fk_lanes(q: &[F64s; D]) -> FrameOf<F64s> {
        let mut tool = FrameOf::identity();
        for k in 0..LANES {
            tool.set_lane(k, &Self::fk(&lane_config(q, k)));
        }
        tool
    }

    /// [`Model::link_frames`] of a batch of configurations, as [`Model::fk_lanes`]: link
    /// frame `i` goes to `out(i, ..)`, in chain order, as it is computed; the tool frame
    /// comes back unless `out` breaks, which stops the kinematics there (a caller that has
    /// its answer before the last link).
    fn link_frames_lanes(q: &[F64s; D], mut out: impl LinkSink) -> ControlFlow<(), FrameOf<F64s>> {
        const N: usize = MAX_LINK_FRAMES;
        let n = Self::LINK_NAMES.len().min(N);
        let (mut one, mut all) = ([Frame::IDENTITY; N], [FrameOf::identity(); N]);
        let mut tool = FrameOf::identity();
        for k in 0..LANES {
            tool.set_lane(k, &Self::link_frames(&lane_config(q, k), &mut one[..n]));
            for (o, f) in all.iter_mut().zip(&one[..n]) {
                o.set_lane(k, f);
            }
        }
        for (i, f) in all[..n].iter().enumerate() {
            out(i, f)?;
        }
        ControlFlow::Continue(tool)
    }
}

/// The models a planner is compiled for, each robot naming its own by index
/// ([`crate::problem::Robot::model`]): one [`Model`] (through the blanket impl, index 0), or
/// a fleet generated over every compiled model of one DoF (`Fleet7`) that dispatches by
/// index. The per-model queries of [`Model`] as functions of that index.
///
/// An index out of range reads as the fleet's last model, so that nothing here can fail;
/// the host's loader only gives indices below [`Models::COUNT`].
///
/// ```
/// use omcbsa_core::model::{Fleet7, KinovaGen3, Models};
///
/// let q = [0.1, 0.5, -0.2, 1.2, 0.0, 0.8, 0.3];
/// let gen3 = Fleet7::find("kinova_gen3").unwrap();
/// assert_eq!(Fleet7::fk(gen3, &q), <KinovaGen3 as Models<7>>::fk(0, &q));
/// assert_eq!(Fleet7::find("franka_panda"), Some(1));
/// assert_eq!(Fleet7::find("ur5"), None);
/// // One model is a fleet of one.
/// assert_eq!(<KinovaGen3 as Models<7>>::COUNT, 1);
/// ```
pub trait Models<const D: usize>: 'static {
    /// How many models; indices run `0..COUNT`.
    const COUNT: usize;
    /// Evaluating it fails compilation for a model an [`crate::collision::ArmPose`] cannot
    /// hold (see [`check_model`]).
    const CHECKED: ();
    /// [`Model::NAME`] of model `id`.
    fn name(id: u8) -> &'static str;
    /// [`Model::LINK_NAMES`] of model `id`.
    fn link_names(id: u8) -> &'static [&'static str];
    /// [`Model::JOINT_NAMES`] of model `id`.
    fn joint_names(id: u8) -> &'static [&'static str; D];
    /// [`Model::LOWER`] of model `id`.
    fn lower(id: u8) -> &'static [f64; D];
    /// [`Model::UPPER`] of model `id`.
    fn upper(id: u8) -> &'static [f64; D];
    /// [`Model::VELOCITY`] of model `id`.
    fn velocity(id: u8) -> &'static [f64; D];
    /// [`Model::ACCELERATION`] of model `id`.
    fn acceleration(id: u8) -> &'static [f64; D];
    /// [`Model::CAPSULES`] of model `id`.
    fn capsules(id: u8) -> &'static [LinkCapsule];
    /// [`Model::SELF_PAIRS`] of model `id`.
    fn self_pairs(id: u8) -> &'static [(u8, u8)];
    /// [`Model::REACH`] of model `id`.
    fn reach(id: u8) -> &'static [f64; D];
    /// [`Model::CAPSULE_REACH`] of model `id`.
    fn capsule_reach(id: u8) -> &'static [[f64; D]];
    /// [`Model::TOOL_SELF_CAPSULES`] of model `id`.
    fn tool_self_capsules(id: u8) -> &'static [u8];
    /// [`Model::TOOL_REACH`] of model `id`.
    fn tool_reach(id: u8) -> &'static [f64; D];
    /// [`Model::AXIS_COS`] of model `id`.
    fn axis_cos(id: u8) -> &'static [f64; D];
    /// [`Model::fk`] of model `id`.
    fn fk(id: u8, q: &[f64; D]) -> Frame;
    /// [`Model::link_frames`] of model `id`.
    fn link_frames(id: u8, q: &[f64; D], out: &mut [Frame]) -> Frame;
    /// [`Model::jacobian`] of model `id`.
    fn jacobian(id: u8, q: &[f64; D]) -> (Frame, SMatrix<f64, 6, D>);
    /// [`Model::fk_lanes`] of model `id`.
    fn fk_lanes(id: u8, q: &[F64s; D]) -> FrameOf<F64s>;
    /// [`Model::link_frames_lanes`] of model `id`.
    fn link_frames_lanes(
        id: u8,
        q: &[F64s; D],
        out: impl LinkSink,
    ) -> ControlFlow<(), FrameOf<F64s>>;

    /// The index of the model called `name` ([`Model::NAME`]).
    fn find(name: &str) -> Option<u8> {
        (0..Self::COUNT)
            .filter_map(|i| u8::try_from(i).ok())
            .find(|&i| Self::name(i) == name)
    }
}

/// One model: every index is this model.
impl<M: Model<D>, const D: usize> Models<D> for M {
    const COUNT: usize = 1;
    const CHECKED: () = check_model::<M, D>();
    fn name(_: u8) -> &'static str {
        M::NAME
    }
    fn link_names(_: u8) -> &'static [&'static str] {
        M::LINK_NAMES
    }
    fn joint_names(_: u8) -> &'static [&'static str; D] {
        &M::JOINT_NAMES
    }
    fn lower(_: u8) -> &'static [f64; D] {
        &M::LOWER
    }
    fn upper(_: u8) -> &'static [f64; D] {
        &M::UPPER
    }
    fn velocity(_: u8) -> &'static [f64; D] {
        &M::VELOCITY
    }
    fn acceleration(_: u8) -> &'static [f64; D] {
        &M::ACCELERATION
    }
    fn capsules(_: u8) -> &'static [LinkCapsule] {
        M::CAPSULES
    }
    fn self_pairs(_: u8) -> &'static [(u8, u8)] {
        M::SELF_PAIRS
    }
    fn reach(_: u8) -> &'static [f64; D] {
        &M::REACH
    }
    fn capsule_reach(_: u8) -> &'static [[f64; D]] {
        M::CAPSULE_REACH
    }
    fn tool_self_capsules(_: u8) -> &'static [u8] {
        M::TOOL_SELF_CAPSULES
    }
    fn tool_reach(_: u8) -> &'static [f64; D] {
        &M::TOOL_REACH
    }
    fn axis_cos(_: u8) -> &'static [f64; D] {
        &M::AXIS_COS
    }
    #[inline]
    fn fk(_: u8, q: &[f64; D]) -> Frame {
        M::fk(q)
    }
    #[inline]
    fn link_frames(_: u8, q: &[f64; D], out: &mut [Frame]) -> Frame {
        M::link_frames(q, out)
    }
    #[inline]
    fn jacobian(_: u8, q: &[f64; D]) -> (Frame, SMatrix<f64, 6, D>) {
        M::jacobian(q)
    }
    #[inline]
    fn fk_lanes(_: u8, q: &[F64s; D]) -> FrameOf<F64s> {
        M::fk_lanes(q)
    }
    #[inline]
    fn link_frames_lanes(
        _: u8,
        q: &[F64s; D],
        out: impl LinkSink,
    ) -> ControlFlow<(), FrameOf<F64s>> {
        M::link_frames_lanes(q, out)
    }
}

// The generated models (see `build.rs`).
include!(concat!(env!("OUT_DIR"), "/models.rs"));
