//! Online embodiment: a policy emits chunks of hand poses as it runs (every 0.1-1 s, 8-50
//! poses per hand, usually replacing the tail of the previous chunk); the [`Embodier`] plans
//! each chunk as it arrives, from where the arms will be, and keeps one plan the arms can be
//! streamed without stopping.
//!
//! Steps: the policy numbers its poses by *policy step* (`start_step + k` for pose `k` of a
//! chunk); the arms' timeline numbers configurations by *timeline index* at `dt` spacing,
//! index 0 being `initial` (where the arms stand), then the approach to the first chunk, then
//! the chunks. [`Embodier::timeline_index`] converts.
//!
//! - The first chunk chooses the assignment (which arm takes which hand) and its start
//!   states; an approach from `initial` to them is planned ([`omcbsa_core::approach`]).
//! - A chunk that starts after the plan's end (the policy was late; the arms hold at the
//!   plan's last configuration) and cannot be reached in one step from the hold is planned
//!   from the hold with an approach, as the first is.
//! - Every later chunk `push_chunk(s, poses)` is planned from the configuration every arm has
//!   at step `s - 1` under the current plan (exactly there, not at sampled IK seeds), so that
//!   reaching the chunk's first pose is one step within the velocity limits, collision-checked
//!   like the others; the assignment is kept (Ω-CBSA and OM-PP-A* then only resolve
//!   conflicts). The plan from step `s` on is replaced by the chunk's.
//! - Memory stays bounded however long the run: the plan before the last step sent to the
//!   arms ([`Embodier::commit_until`]) is dropped.

pub mod aloha;
pub mod bench;
pub mod bimanual;
mod checkpoint;
mod chunk;
pub(crate) mod diagnose;
mod embody;
mod error;
pub mod policy;
pub mod reach;
pub mod record;
mod recover;
pub mod run;
mod scaling;
#[cfg(test)]
pub(crate) mod testing;
mod timeline;

pub use checkpoint::Checkpoint;
pub use embody::Embodied;
pub use error::OnlineError;
pub use timeline::Target;

use timeline::Timeline;

use omcbsa_core::approach::ApproachParams;
use omcbsa_core::planner::Stats;
use omcbsa_core::problem::{Problem, Robot, Start, Trajectory, MAX_ROBOTS, MAX_STEPS};

use crate::assignment::{nearest, AssignmentRule};
use crate::error::Errors;
use crate::format::{ObstacleSpec, Pose, ProblemFile, RobotSpec, ToleranceSpec, TrajectorySpec};
use crate::load;
use crate::models::Fleet;
use crate::planners::{Capacities, PlannerKind, Storage, DOF};
use crate::pose;

/// Where the arms are and what is around them: everything of a problem but the hands' poses.
#[derive(Clone, Debug, PartialEq)]
pub struct Setup {
    /// Every robot needs `initial`: the arm's configuration when the run starts.
    pub robots: Vec<RobotSpec>,
    /// Fixed obstacles.
    pub obstacles: Vec<ObstacleSpec>,
    /// How closely the hands must be followed.
    pub tolerance: ToleranceSpec,
    /// Time between consecutive poses and configurations, s.
    pub dt: f64,
}

impl Setup {
    /// The setup of a problem file (its trajectories left out).
    pub fn of_problem(file: &ProblemFile) -> Setup {
        Setup {
            robots: file.robots.clone(),
            obstacles: file.obstacles.clone(),
            tolerance: file.tolerance,
            dt: file.dt,
        }
    }
}

/// How chunks are planned.
#[derive(Clone, Debug)]
pub struct OnlineOptions {
    /// Ω-CBSA or OM-PP-A* (the planners that keep an assignment and start where the arms are).
    pub planner: PlannerKind,
    /// Planning time allowed per chunk, s (the core's deadline).
    pub chunk_timeout_s: f64,
    /// Longest chunk (poses per hand) the storage is made for.
    pub max_chunk_len: usize,
    /// Most configurations of the approach to the first chunk.
    pub max_approach_len: usize,
    /// The approach's settings (to the first chunk, and after a hold).
    pub approach: ApproachParams,
    /// Pool sizes of the planner (allocated once, in [`Embodier::new`]).
    pub capacities: Capacities,
    /// Which arm takes which hand: fixed, preferred, or chosen by the first chunk (`Free`:
    /// the arms with the first chunk's poses deepest in their reach are tried first, see
    /// [`crate::assignment::nearest`]).
    pub assignment: AssignmentRule,
    /// When a chunk cannot be planned with the assignment kept, plan it with a new one from
    /// where the arms stand (an approach; the poses it cannot reach in time are dropped). Off
    /// by default: a hand holding an object cannot change arms.
    pub reassign: bool,
    /// Weight of Ω-A*'s cost of two joint axes nearing one line
    /// ([`omcbsa_core::search::OmegaParams::w_a`]; 0 plans as a whole problem is planned:
    /// IK tracking to the nearest IK answer first). A chunk cannot see the hands' motion past its end; planned
    /// greedily, it may leave an arm where two of its axes nearly line up, and the next
    /// chunk then needs a joint faster than its limit (bimanual transfer 013 at 50 Hz,
    /// 16-step chunks sent just in time). The cost makes the null space keep them apart.
    pub axis_weight: f64,
    /// Weight of the joints' speed headroom in the chunks' plans
    /// ([`omcbsa_core::search::OmegaParams::w_v`]): a step costs more the nearer the hand's
    /// motion there (continued past the chunk's end) brings a joint to its speed limit, so
    /// that a chunk leaves the arm where the hands' next motion can still be followed.
    pub headroom_weight: f64,
    /// Weight of the joints' reserve at a chunk's last pose, for any motion of the hands
    /// ([`omcbsa_core::search::OmegaParams::w_r`]): a chunk ends where the hands can start
    /// the next chunk's motion, whichever it is.
    pub reserve_weight: f64,
    /// Start each arm of a first chunk of at least [`RANKED_START_S`] where its joints'
    /// reserve is largest ([`omcbsa_core::search::OmegaParams::rank_starts`]) rather than at
    /// the first pose's IK answer nearest where it stands: a self-motion family from which
    /// later fast motions can be followed, at the cost of a longer approach (on the box flip
    /// at 10 Hz, 153 steps: more than the streaming executor queues). Off by default.
    pub rank_starts: bool,
    /// When a chunk cannot be followed at the policy's rate, slow its timing (the hands'
    /// path and the order of the poses kept) by the least factor that makes it feasible,
    /// rather than stop: the arms lag behind the policy by the time added (reported per chunk
    /// and in total). Off, such a chunk is recovered by a catch-up that drops poses.
    pub time_scaling: bool,
    /// When a chunk cannot be planned otherwise, the arms hold where the plan is unsent and
    /// an approach catches up with the hands, dropping the poses it cannot reach in time
    /// ([`Recovery::CaughtUp`]). Off, such a chunk is an error (the arms finish the plan
    /// and hold) and the next chunk is tried from there.
    pub catch_up: bool,
}

/// [`OnlineOptions::axis_weight`] by default: none. On hand trajectories a real policy
/// emits (`bench-online --family aloha-sim`), keeping the arm's joint axes apart turned it away
/// from the straight wrist a fast wrist turn needs (two wrist joints sharing the turn); the
/// headroom and the reserve below keep it ready instead.
pub const AXIS_WEIGHT: f64 = 0.0;

/// [`OnlineOptions::headroom_weight`] by default.
pub const HEADROOM_WEIGHT: f64 = 2.0;

/// [`OnlineOptions::reserve_weight`] by default.
pub const RESERVE_WEIGHT: f64 = 1.0;

impl OnlineOptions {
    /// The horizon the planner needs: a chunk and the step before it, and room for time
    /// scaling to add as many steps again.
    fn horizon(&self) -> usize {
        let chunk = self.max_chunk_len + 1;
        if self.time_scaling {
            (2 * chunk).min(MAX_STEPS)
        } else {
            chunk
        }
    }
}

impl Default for OnlineOptions {
    fn default() -> Self {
        OnlineOptions {
            planner: PlannerKind::DEFAULT,
            chunk_timeout_s: 1.0,
            max_chunk_len: 64,
            max_approach_len: 1024,
            approach: ApproachParams::default(),
            capacities: Capacities {
                path_slots: 1 << 11,
                ..Capacities::default()
            },
            assignment: AssignmentRule::Free,
            reassign: false,
            axis_weight: AXIS_WEIGHT,
            headroom_weight: HEADROOM_WEIGHT,
            reserve_weight: RESERVE_WEIGHT,
            rank_starts: false,
            time_scaling: true,
            catch_up: true,
        }
    }
}

/// What one planned chunk changed.
#[derive(Clone, Debug, PartialEq)]
pub struct ChunkReport {
    /// The first policy step planned: the chunk's, an earlier one when the steps before it
    /// were planned again (a dead end), a later one when the approach after a hold could not
    /// reach its first poses in time (`dropped` of them).
    pub start_step: u64,
    /// The chunk's first poses that no arm tracks (reached by an approach instead).
    pub dropped: usize,
    /// How the chunk was planned when it could not be from where the last chunk left the
    /// arms: `None` when it could.
    pub recovery: Option<Recovery>,
    /// Timeline index of the chunk's first pose: the plan from here on is new.
    pub index: usize,
    /// Timeline index one past the plan's last configuration.
    pub end: usize,
    /// Wall time of the planner call, s.
    pub planning_time_s: f64,
    /// The planner's counters (of the last run that planned the chunk).
    pub stats: Stats,
    /// How much slower than the policy's rate the chunk was timed: timeline steps over poses
    /// (1 unless time-scaled).
    pub time_factor: f64,
    /// Seconds the arms fell behind the policy with this chunk (time scaling, a hold before a
    /// catch-up), 0 when they kept up.
    pub lag_s: f64,
    /// Seconds the arms are behind the policy in all, at the chunk's last pose.
    pub total_lag_s: f64,
    /// Why the chunk could not be planned from where the last chunk left the arms (the
    /// error that `recovery` overcame), `None` when it could.
    pub blocked: Option<String>,
}

/// How a chunk was planned that could not be from where the last chunk left the arms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recovery {
    /// The part of the plan not yet sent was planned again with the chunk.
    ReplannedUnsent,
    /// The chunk's timing was slowed so that the arms can follow it
    /// ([`OnlineOptions::time_scaling`]).
    TimeScaled,
    /// The arms hold where the plan is still unsent and an approach reaches the hands where
    /// they will be, dropping the poses it cannot reach in time; tracking resumes there.
    CaughtUp,
    /// A new assignment, from where the arms stand ([`OnlineOptions::reassign`]).
    Reassigned,
}

impl Recovery {
    /// The recovery's name in reports and tables.
    pub fn name(self) -> &'static str {
        match self {
            Recovery::ReplannedUnsent => "replanned_unsent",
            Recovery::TimeScaled => "time_scaled",
            Recovery::CaughtUp => "caught_up",
            Recovery::Reassigned => "reassigned",
        }
    }
}

/// Ω-A*'s duplicate grid for chunks, rad: finer than a whole plan's 0.6. A chunk starts from
/// one fixed state (where the arms are), so its lattice is small, and the coarse grid pruned
/// the few ways through on some chunks, exhausting level 0 and sending them to the next
/// refinement level (10-235 ms). `omcbsa bench-online /tmp/suite --stride 3`: 3-arm p99 39.5
/// ms with 0.6, 9.2 ms with 0.3 (README, "Online embodiment").
const CHUNK_RESOLUTION: f64 = 0.3;

/// Shortest first chunk, s of the hands' motion, whose arms start where their joints'
/// reserve is largest ([`omcbsa_core::search::OmegaParams::rank_starts`]) rather than at
/// the first pose's IK answer nearest where they stand. `bench-online --family aloha-sim`
/// at the rate: ranked, 100-step chunks (2 s) every 100 steps or every step lost 1 of the
/// 100 episodes on 4 Gen3s instead of 3 and 5 (the arm that takes the cube started where no
/// null-space motion leads to room for its lift in time), 64 every 16 kept 99 %; 16-step
/// chunks (0.32 s) lost all 50 transfers at the wrist turn at step 336, which the ranked
/// start needs seen coming.
const RANKED_START_S: f64 = 1.0;

/// Plans policy chunks as they arrive (see the module documentation). Its pools are
/// allocated once, in [`Embodier::new`] ([`OnlineOptions::capacities`]); the plan kept is
/// bounded by the chunk length and the approach, however long the run.
///
/// ```
/// use omcbsa::format::{Pose, RobotSpec, ToleranceSpec};
/// use omcbsa::online::{Embodier, OnlineOptions, Setup};
/// use omcbsa_core::model::{KinovaGen3, Model};
///
/// // One Gen3 standing at Kinova's retract posture.
/// let arm = RobotSpec {
///     name: "arm".to_string(),
///     model: "kinova_gen3".to_string(),
///     base: Pose::IDENTITY,
///     initial: Some(vec![0.0, 0.26, 3.14, -2.27, 0.0, 0.96, 1.57]),
///     tcp: None,
///     tool: None,
/// };
/// let setup = Setup {
///     robots: vec![arm],
///     obstacles: Vec::new(),
///     tolerance: ToleranceSpec::default(),
///     dt: 0.1,
/// };
/// let options = OnlineOptions { max_chunk_len: 8, ..OnlineOptions::default() };
/// let mut embodier = Embodier::new(&setup, options).unwrap();
///
/// // The policy's hand, pointing down, rising 1 cm a step; chunks of 4 poses, 2 apart.
/// let hand = |k: u64| Pose {
///     position: [0.5, 0.0, 0.4 + 0.01 * k as f64],
///     quat_xyzw: [1.0, 0.0, 0.0, 0.0],
/// };
/// let chunk = |start: u64| vec![(start..start + 4).map(hand).collect::<Vec<_>>()];
///
/// // The first chunk chooses the assignment and an approach from `initial`.
/// let first = embodier.push_chunk(0, &chunk(0)).unwrap();
/// assert_eq!(embodier.assignment(), Some(&[Some(0)][..]));
/// assert_eq!(first.index, embodier.approach_len() + 1);
///
/// // The arms are sent the approach; the next chunk replaces the plan from step 2 on.
/// embodier.commit_until(first.index);
/// let second = embodier.push_chunk(2, &chunk(2)).unwrap();
/// assert_eq!(embodier.timeline_index(2), Some(second.index));
/// for k in 2..6 {
///     let q = embodier.configuration(0, embodier.timeline_index(k).unwrap()).unwrap();
///     let z = KinovaGen3::fk(&q).pos.z;
///     assert!((z - (0.4 + 0.01 * k as f64)).abs() < 1e-3);
/// }
/// ```
pub struct Embodier {
    robots: heapless::Vec<Robot<DOF>, MAX_ROBOTS>,
    /// The setup as a core problem without trajectories.
    template: Problem<DOF>,
    names: Vec<String>,
    setup: Setup,
    options: OnlineOptions,
    storage: Storage,
    /// Every robot's plan from the last configuration sent on, and what each index tracks.
    timeline: Timeline,
    /// Timeline index and policy step of the first chunk's first pose: where the arms would
    /// be on every later step if they never fell behind.
    origin: Option<(usize, u64)>,
    approach_len: usize,
    /// Per robot, the hand it holds, `None` when it holds still (set by the first chunk).
    assignment: Option<Vec<Option<usize>>>,
    /// Timeline indices below this were sent to the arms.
    committed: usize,
    /// Per hand, the poses the policy sent for steps `policy_start..` not yet sent to the
    /// arms (the latest chunk's where chunks overlap): what a re-plan tracks.
    policy: Vec<Vec<omcbsa_core::model::Frame>>,
    policy_start: u64,
    /// The last chunk pushed was not planned: the arms finish the plan and hold, and the next
    /// chunk may catch up with the hands.
    missed: bool,
}

impl Embodier {
    /// Checks the setup (names the field that breaks a rule) and allocates every pool the
    /// planner will use.
    ///
    /// ```
    /// use omcbsa::format::{Pose, RobotSpec, ToleranceSpec};
    /// use omcbsa::online::{Embodier, OnlineError, OnlineOptions, Setup};
    /// use omcbsa::planners::PlannerKind;
    ///
    /// let arm = RobotSpec {
    ///     name: "arm".to_string(),
    ///     model: "kinova_gen3".to_string(),
    ///     base: Pose::IDENTITY,
    ///     initial: None, // where the arm stands is needed online
    ///     tcp: None,
    ///     tool: None,
    /// };
    /// let setup = Setup {
    ///     robots: vec![arm],
    ///     obstacles: Vec::new(),
    ///     tolerance: ToleranceSpec::default(),
    ///     dt: 0.1,
    /// };
    /// // IK tracking cannot keep an assignment from chunk to chunk.
    /// let planner = PlannerKind::IkTracking;
    /// let options = OnlineOptions { planner, ..OnlineOptions::default() };
    /// match Embodier::new(&setup, options) {
    ///     Err(OnlineError::Input(e)) => {
    ///         assert!(e.has("robots[0].initial", "missing"), "{e}");
    ///         assert!(e.has("planner", "cannot plan online"), "{e}");
    ///     }
    ///     other => panic!("{:?}", other.err()),
    /// }
    /// ```
    pub fn new(setup: &Setup, options: OnlineOptions) -> Result<Embodier, OnlineError> {
        let mut errors = Errors::default();
        if !matches!(options.planner, PlannerKind::OmCbsa | PlannerKind::Pp) {
            errors.push(
                "planner",
                format!(
                    "{} cannot plan online: use {} or {}",
                    options.planner,
                    PlannerKind::OmCbsa,
                    PlannerKind::Pp
                ),
            );
        }
        if !(options.chunk_timeout_s.is_finite() && options.chunk_timeout_s > 0.0) {
            errors.push("chunk_timeout_s", "must be a positive number of seconds");
        }
        if !(options.axis_weight.is_finite() && options.axis_weight >= 0.0) {
            errors.push("axis_weight", "must be a finite number, 0 or more");
        }
        for (field, w) in [
            ("headroom_weight", options.headroom_weight),
            ("reserve_weight", options.reserve_weight),
        ] {
            if !(w.is_finite() && w >= 0.0) {
                errors.push(field, "must be a finite number, 0 or more");
            }
        }
        if options.max_chunk_len == 0 || options.max_chunk_len >= MAX_STEPS {
            errors.push(
                "max_chunk_len",
                format!("must be 1 to {} (MAX_STEPS - 1)", MAX_STEPS - 1),
            );
        }
        for (i, r) in setup.robots.iter().enumerate() {
            if r.initial.is_none() {
                errors.push(
                    format!("robots[{i}].initial"),
                    "missing: online planning starts from where every arm stands",
                );
            }
        }
        errors.finish()?;
        // The file loader checks robots, obstacles, tolerance and dt; one placeholder hand
        // stands in for the chunks to come.
        let file = ProblemFile {
            format: crate::format::PROBLEM_FORMAT.to_string(),
            name: "online".to_string(),
            dt: setup.dt,
            robots: setup.robots.clone(),
            trajectories: vec![TrajectorySpec {
                name: "hand".to_string(),
                poses: vec![Pose::IDENTITY],
            }],
            obstacles: setup.obstacles.clone(),
            tolerance: setup.tolerance,
        };
        let mut problem = load::problem::<Fleet, DOF>(&file)?;
        crate::approach::check_initial::<Fleet, DOF>(&file, &problem)?;
        problem.trajectories.clear();
        let robots = problem.robots.clone();
        let mut storage = Storage::new(options.capacities, options.horizon());
        storage.cbs_params.low.resolution = CHUNK_RESOLUTION;
        // Ω-A* and the warm start (`tracking::Steps::Steered`) weigh the axes' separation.
        storage.cbs_params.low.w_a = options.axis_weight;
        storage.cbs_params.low.w_v = options.headroom_weight;
        storage.cbs_params.low.w_r = options.reserve_weight;
        storage.approach_params = options.approach;
        Ok(Embodier {
            robots,
            template: problem,
            names: setup.robots.iter().map(|r| r.name.clone()).collect(),
            setup: setup.clone(),
            options,
            storage,
            timeline: Timeline::default(),
            origin: None,
            approach_len: 0,
            assignment: None,
            committed: 0,
            policy: Vec::new(),
            policy_start: 0,
            missed: false,
        })
    }

    /// Robot names, in the setup's order.
    pub fn robot_names(&self) -> &[String] {
        &self.names
    }

    /// Where the arms are and what is around them, as given.
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// Per robot, the hand it holds (`None`: it holds still), once the first chunk chose it.
    pub fn assignment(&self) -> Option<&[Option<usize>]> {
        self.assignment.as_deref()
    }

    /// Configurations of the approach to the first chunk (between `initial` at index 0 and
    /// the first chunk's first pose at index `approach_len() + 1`).
    pub fn approach_len(&self) -> usize {
        self.approach_len
    }

    /// The timeline index of policy step `step`, once the first chunk placed the steps (a
    /// step not planned yet: as many indices after the last one planned as steps).
    pub fn timeline_index(&self, step: u64) -> Option<usize> {
        self.origin?;
        self.timeline.index_of(step)
    }

    /// Timeline index one past the plan's last configuration (0 before the first chunk).
    pub fn end(&self) -> usize {
        self.timeline.end()
    }

    /// Robot `robot`'s configuration at timeline index `index`, if still kept; past the
    /// plan's end, the last one (the arm holds there).
    pub fn configuration(&self, robot: usize, index: usize) -> Option<[f64; DOF]> {
        self.timeline.configuration(robot, index)
    }

    /// Robot `robot`'s planned configurations from timeline index `from` to the plan's end.
    pub fn planned(&self, robot: usize, from: usize) -> &[[f64; DOF]] {
        self.timeline.planned(robot, from)
    }

    /// What the hands track at timeline index `index` (a policy pose, a point between two of
    /// a time-scaled chunk, or nothing), while it is kept.
    pub fn target(&self, index: usize) -> Target {
        self.timeline.target(index)
    }

    /// Every hand's pose to track at timeline index `index` (in the world frame), `None` where
    /// the hands are free (the approach, a hold) or the poses are no longer kept.
    pub fn target_poses(&self, index: usize) -> Option<Vec<omcbsa_core::model::Frame>> {
        let Target::Pose { step, frac } = self.timeline.target(index) else {
            return None;
        };
        let k = usize::try_from(step.checked_sub(self.policy_start)?).ok()?;
        self.policy
            .iter()
            .map(|poses| {
                let a = poses.get(k)?;
                Some(if frac > 0.0 {
                    timeline::between(a, poses.get(k + 1)?, frac)
                } else {
                    *a
                })
            })
            .collect()
    }

    /// Seconds the arms are behind the policy at policy step `step` (time scaling, holds).
    pub fn lag_s(&self, step: u64) -> f64 {
        let (Some((i0, s0)), Some(i)) = (self.origin, self.timeline_index(step)) else {
            return 0.0;
        };
        let on_time = i0 as i64 + step as i64 - s0 as i64;
        (i as i64 - on_time).max(0) as f64 * self.setup.dt
    }

    /// The arms were sent the plan up to (not including) timeline index `index`: a chunk may no
    /// longer replace it, and it is forgotten (but for the last configuration sent, where the
    /// next chunk starts from).
    pub fn commit_until(&mut self, index: usize) {
        self.committed = self.committed.max(index);
        self.timeline.forget_before(self.committed);
        self.forget_sent_poses();
    }

    /// Plans a chunk: `hands[j][k]` is hand `j`'s pose at policy step `start_step + k`. The
    /// first chunk chooses the assignment and an approach from `initial`; a later one is
    /// planned from the arms' configurations at step `start_step - 1` and replaces the plan
    /// from `start_step` on (a chunk that starts after the plan's end has the arms hold until
    /// it). On error the plan is left as it was.
    pub fn push_chunk(
        &mut self,
        start_step: u64,
        hands: &[Vec<Pose>],
    ) -> Result<ChunkReport, OnlineError> {
        let frames = self.check_chunk(hands)?;
        match self.origin {
            None => self.first_chunk(start_step, &frames),
            Some(_) => self.next_chunk(start_step, &frames),
        }
    }

    /// Shape and value checks of a chunk; its poses as frames.
    fn check_chunk(&self, hands: &[Vec<Pose>]) -> Result<Vec<Trajectory>, OnlineError> {
        let mut errors = Errors::default();
        let n = self.robots.len();
        match &self.assignment {
            Some(a) => {
                let held = a.iter().flatten().count();
                if hands.len() != held {
                    errors.push(
                        "hands",
                        format!(
                            "{} hands, but the first chunk had {held}: the hands are kept \
                             across chunks",
                            hands.len()
                        ),
                    );
                }
            }
            None if hands.is_empty() || hands.len() > n => errors.push(
                "hands",
                format!("{} hands for {n} robots: 1 to {n} are needed", hands.len()),
            ),
            None => {}
        }
        let h = hands.first().map_or(0, Vec::len);
        if h == 0 || h > self.options.max_chunk_len {
            errors.push(
                "hands[0]",
                format!(
                    "{h} poses: a chunk has 1 to {} (max_chunk_len)",
                    self.options.max_chunk_len
                ),
            );
        }
        let mut out = Vec::with_capacity(hands.len());
        for (j, poses) in hands.iter().enumerate() {
            if poses.len() != h {
                errors.push(
                    format!("hands[{j}]"),
                    format!(
                        "{} poses, but hands[0] has {h}: all hands need as many",
                        poses.len()
                    ),
                );
            }
            let mut t = Trajectory::new();
            for (k, p) in poses.iter().enumerate().take(MAX_STEPS - 1) {
                match pose::to_frame(p) {
                    Ok(f) => {
                        let _ = t.push(f);
                    }
                    Err(e) => errors.add(e.within(&format!("hands[{j}][{k}]"))),
                }
            }
            out.push(t);
        }
        errors.finish()?;
        Ok(out)
    }

    fn first_chunk(
        &mut self,
        start_step: u64,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let mut problem = self.problem(hands.iter().cloned(), Start::Sampled, None);
        let rule = match &self.options.assignment {
            AssignmentRule::Free => nearest::<Fleet, DOF>(&problem)
                .map_or(AssignmentRule::Free, AssignmentRule::Preferred),
            given => {
                given.check("assignment", self.robots.len(), hands.len())?;
                given.clone()
            }
        };
        // Where the reserve is largest, an arm may need to prepare for a fast motion that
        // its start nearest `initial` could follow unprepared: only chunks that see it
        // coming let it.
        let long = hands.first().map_or(0, |t| t.len()) as f64 * self.setup.dt >= RANKED_START_S;
        self.storage.cbs_params.low.rank_starts = self.options.rank_starts && long;
        let outcome = self.solve_under(&mut problem, start_step, &rule);
        self.storage.cbs_params.low.rank_starts = false;
        let outcome = outcome?;
        let h = problem.horizon();
        let n = self.robots.len();
        // Planned with the chunk, from `initial` (every robot has one online).
        let approach = outcome.approach.clone().unwrap_or_default();
        let a = approach.first().map_or(0, Vec::len);
        if a > self.options.max_approach_len {
            return Err(OnlineError::Approach(format!(
                "it needs {a} configurations, more than max_approach_len {}",
                self.options.max_approach_len
            )));
        }
        let initial: Vec<[f64; DOF]> = (0..n)
            .map(|i| self.robots[i].initial.unwrap_or(outcome.joint_paths[i][0]))
            .collect();
        let paths: Vec<Vec<[f64; DOF]>> = (0..n)
            .map(|i| [&approach[i][..], &outcome.joint_paths[i][..]].concat())
            .collect();
        let targets: Vec<Target> = std::iter::repeat_n(Target::Free, a)
            .chain((0..h as u64).map(|k| Target::Pose {
                step: start_step + k,
                frac: 0.0,
            }))
            .collect();
        self.timeline = Timeline::new(&initial);
        let paths: Vec<&[[f64; DOF]]> = paths.iter().map(Vec::as_slice).collect();
        self.timeline.replace_from(1, &paths, &targets);
        self.approach_len = a;
        self.origin = Some((a + 1, start_step));
        self.assignment = Some(outcome.assignment.clone());
        self.remember(start_step, hands);
        Ok(ChunkReport {
            start_step,
            dropped: 0,
            recovery: None,
            index: a + 1,
            end: self.end(),
            planning_time_s: outcome.planning_time_s,
            stats: outcome.stats,
            time_factor: 1.0,
            lag_s: 0.0,
            total_lag_s: 0.0,
            blocked: None,
        })
    }

    fn next_chunk(
        &mut self,
        start_step: u64,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let index = self.timeline_index(start_step).unwrap_or(0);
        // The chunk's first step must not be sent yet; the one before it (its start) may be.
        if index < self.committed || index <= self.timeline.start() {
            return Err(OnlineError::DeadlineMissed {
                start_step,
                committed_step: self.sent_step(),
            });
        }
        let clock = std::time::Instant::now();
        let lag_before = self.lag_s(start_step);
        // Lookahead: the poses an earlier chunk sent past this one's end are planned too.
        let longer = self.with_sent_tail(start_step, hands);
        let first = match &longer {
            Some(l) => self
                .continue_from(start_step, index, l)
                .or_else(|_| self.continue_from(start_step, index, hands)),
            None => self.continue_from(start_step, index, hands),
        };
        let mut planned = first.clone();
        // A dead end where the last chunk left the arms: re-plan from where they are now.
        let ways: [(Recovery, bool); 4] = [
            (Recovery::ReplannedUnsent, true),
            (Recovery::TimeScaled, self.options.time_scaling),
            // The arms hold (the plan ran out, or the last chunk was not planned): an approach
            // catches up with the hands, at the cost of this chunk's first poses.
            (
                Recovery::CaughtUp,
                self.options.catch_up && (self.missed || index >= self.end()),
            ),
            (Recovery::Reassigned, self.options.reassign),
        ];
        for (way, allowed) in ways {
            if planned.is_ok() || !allowed {
                continue;
            }
            planned = match way {
                Recovery::ReplannedUnsent => self.replan_unsent(start_step, index, hands),
                Recovery::TimeScaled => self.time_scaled(start_step, index, hands),
                Recovery::CaughtUp => self.catch_up(start_step, index, hands),
                Recovery::Reassigned => self.reassign(start_step, index, hands),
            }
            .map(|r| ChunkReport {
                recovery: Some(way),
                ..r
            });
        }
        // The error of the plain try names where the chunk is blocked.
        self.missed = planned.is_err();
        let blocked = first.as_ref().err().map(ToString::to_string);
        let mut report = planned.or(first)?;
        report.blocked = blocked.filter(|_| report.recovery.is_some());
        self.remember(start_step, hands);
        let last = start_step + hands.first().map_or(0, |t| t.len() as u64).max(1) - 1;
        report.total_lag_s = self.lag_s(last);
        report.lag_s = (report.total_lag_s - lag_before).max(0.0);
        report.planning_time_s = clock.elapsed().as_secs_f64();
        Ok(report)
    }

    /// The last policy step sent to the arms (for messages).
    fn sent_step(&self) -> i64 {
        let sent = self.committed.saturating_sub(1);
        (0..=sent)
            .rev()
            .take_while(|&i| i >= self.timeline.start())
            .find_map(|i| self.timeline.target(i).exact_step())
            .map_or(-1, |s| s as i64)
    }
}
