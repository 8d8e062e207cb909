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
pub(crate) mod diagnose;
mod embody;
mod error;
pub mod policy;
pub mod reach;
pub mod record;
mod recover;
pub mod run;

pub use error::OnlineError;

use omcbsa_core::approach::ApproachParams;
use omcbsa_core::ik::{ik, ik_multi_start, MultiStart};
use omcbsa_core::planner::{Stats, Status};
use omcbsa_core::problem::{Assigned, Problem, Robot, Start, Trajectory, MAX_ROBOTS, MAX_STEPS};
use omcbsa_core::rng::Rng;

use crate::assignment::{self, nearest, AssignmentRule};
use crate::error::{Errors, InputError};
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
    pub obstacles: Vec<ObstacleSpec>,
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
}

/// [`OnlineOptions::axis_weight`] by default. `bench-online --family bimanual` at 50 Hz, 2
/// arms, 16-step chunks just in time: weights from 0.5 to 8 embody all 40 episodes; 0.25 loses
/// transfer 013 (the dead end this cost is for), 16 steers so hard that two others lose a
/// wrist joint's speed. 4 is in the middle (log scale).
pub const AXIS_WEIGHT: f64 = 4.0;

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
    /// arms (see [`recover`]): `None` when it could.
    pub recovery: Option<Recovery>,
    /// Timeline index of the chunk's first pose: the plan from here on is new.
    pub index: usize,
    /// Timeline index one past the plan's last configuration.
    pub end: usize,
    /// Wall time of the planner call, s.
    pub planning_time_s: f64,
    pub stats: Stats,
}

/// How a chunk was planned that could not be from where the last chunk left the arms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recovery {
    /// The part of the plan not yet sent was planned again with the chunk.
    ReplannedUnsent,
    /// The arms hold at the plan's end and an approach reaches the chunk.
    AfterHold,
    /// A new assignment, from where the arms stand ([`OnlineOptions::reassign`]).
    Reassigned,
}

impl Recovery {
    pub fn name(self) -> &'static str {
        match self {
            Recovery::ReplannedUnsent => "replanned_unsent",
            Recovery::AfterHold => "after_hold",
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

/// Plans of a chunk after a hold (see `Embodier::chunk_after_hold`), each dropping the poses
/// the approach before could not reach in time.
const MAX_HOLD_TRIES: usize = 3;

/// Plans policy chunks as they arrive (see the module documentation).
pub struct Embodier {
    robots: heapless::Vec<Robot<DOF>, MAX_ROBOTS>,
    /// The setup as a core problem without trajectories.
    template: Problem<DOF>,
    names: Vec<String>,
    setup: Setup,
    options: OnlineOptions,
    storage: Storage,
    /// Per robot, its configurations from timeline index `window_start` on.
    window: Vec<Vec<[f64; DOF]>>,
    window_start: usize,
    /// Timeline index of policy step 0 (set by the first chunk).
    offset: Option<i64>,
    approach_len: usize,
    /// Per robot, the hand it holds, `None` when it holds still (set by the first chunk).
    assignment: Option<Vec<Option<usize>>>,
    /// Timeline indices below this were sent to the arms.
    committed: usize,
    /// Per hand, the poses the policy sent for steps `policy_start..` not yet sent to the
    /// arms (the latest chunk's where chunks overlap): what a re-plan tracks.
    policy: Vec<Vec<omcbsa_core::model::Frame>>,
    policy_start: u64,
}

impl Embodier {
    /// Checks the setup (names the field that breaks a rule) and allocates every pool the
    /// planner will use.
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
        let mut storage = Storage::new(options.capacities, options.max_chunk_len + 1);
        storage.cbs_params.low.resolution = CHUNK_RESOLUTION;
        // Ω-A* and the warm start (`tracking::Steps::Steered`) weigh the axes' separation.
        storage.cbs_params.low.w_a = options.axis_weight;
        storage.approach_params = options.approach;
        Ok(Embodier {
            robots,
            template: problem,
            names: setup.robots.iter().map(|r| r.name.clone()).collect(),
            setup: setup.clone(),
            options,
            storage,
            window: Vec::new(),
            window_start: 0,
            offset: None,
            approach_len: 0,
            assignment: None,
            committed: 0,
            policy: Vec::new(),
            policy_start: 0,
        })
    }

    /// Robot names, in the setup's order.
    pub fn robot_names(&self) -> &[String] {
        &self.names
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

    /// The timeline index of policy step `step`, once the first chunk fixed it.
    pub fn timeline_index(&self, step: u64) -> Option<usize> {
        let i = self.offset? + step as i64;
        usize::try_from(i).ok()
    }

    /// Timeline index one past the plan's last configuration (0 before the first chunk).
    pub fn end(&self) -> usize {
        self.window_start + self.window.first().map_or(0, Vec::len)
    }

    /// Robot `robot`'s configuration at timeline index `index`, if still kept; past the
    /// plan's end, the last one (the arm holds there).
    pub fn configuration(&self, robot: usize, index: usize) -> Option<[f64; DOF]> {
        let path = self.window.get(robot)?;
        let k = index.checked_sub(self.window_start)?;
        path.get(k.min(path.len().checked_sub(1)?)).copied()
    }

    /// Robot `robot`'s planned configurations from timeline index `from` to the plan's end.
    pub fn planned(&self, robot: usize, from: usize) -> &[[f64; DOF]] {
        let path = self.window.get(robot).map_or(&[][..], Vec::as_slice);
        let k = from.saturating_sub(self.window_start).min(path.len());
        &path[k..]
    }

    /// The arms were sent the plan up to (not including) timeline index `index`: a chunk may no
    /// longer replace it, and it is forgotten (but for the last configuration sent, where the
    /// next chunk starts from).
    pub fn commit_until(&mut self, index: usize) {
        self.committed = self.committed.max(index);
        let keep_from = self
            .committed
            .saturating_sub(1)
            .min(self.end().saturating_sub(1));
        let drop = keep_from.saturating_sub(self.window_start);
        if drop > 0 {
            self.window.iter_mut().for_each(|p| {
                p.drain(..drop);
            });
            self.window_start += drop;
        }
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
        match self.offset {
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
        let outcome = self.solve_under(&mut problem, start_step, &rule)?;
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
        self.window = (0..n)
            .map(|i| {
                let mut w = Vec::with_capacity(1 + a + h);
                w.push(self.robots[i].initial.unwrap_or(outcome.joint_paths[i][0]));
                w.extend_from_slice(&approach[i]);
                w.extend_from_slice(&outcome.joint_paths[i]);
                w
            })
            .collect();
        self.window_start = 0;
        self.approach_len = a;
        self.offset = Some((a + 1) as i64 - start_step as i64);
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
        })
    }

    fn next_chunk(
        &mut self,
        start_step: u64,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let index = self.offset.unwrap_or(0) + start_step as i64;
        // The chunk's first step must not be sent yet; the one before it (its start) may be.
        if index < self.committed as i64 || index <= self.window_start as i64 {
            return Err(OnlineError::DeadlineMissed {
                start_step,
                committed_step: self.committed as i64 - 1 - self.offset.unwrap_or(0),
            });
        }
        let index = index as usize;
        let clock = std::time::Instant::now();
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
        let ways: [(Recovery, bool); 3] = [
            (Recovery::ReplannedUnsent, true),
            // The arms hold, too far from the chunk for one step: an approach may reach it.
            (Recovery::AfterHold, index > self.end()),
            (Recovery::Reassigned, self.options.reassign),
        ];
        for (way, allowed) in ways {
            if planned.is_ok() || !allowed {
                continue;
            }
            planned = match way {
                Recovery::ReplannedUnsent => self.replan_unsent(start_step, index, hands),
                Recovery::AfterHold => self.chunk_after_hold(start_step, index, hands),
                Recovery::Reassigned => self.reassign(start_step, index, hands),
            }
            .map(|r| ChunkReport {
                recovery: Some(way),
                ..r
            });
        }
        // The error of the plain try names where the chunk is blocked.
        let mut report = planned.or(first)?;
        self.remember(start_step, hands);
        report.planning_time_s = clock.elapsed().as_secs_f64();
        Ok(report)
    }

    /// Plans a chunk from the configurations the arms have one step before it (holding at
    /// the plan's end when it starts later).
    fn continue_from(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let pins: Vec<[f64; DOF]> = (0..self.robots.len())
            .map(|i| self.configuration(i, index - 1).unwrap_or([0.0; DOF]))
            .collect();
        // Step 0 is where the arms are; its pose is not tracked (it repeats the first).
        let trajectories = hands.iter().map(|t| {
            let mut with_pin = Trajectory::new();
            let _ = with_pin.push(t[0]);
            t.iter().for_each(|f| {
                let _ = with_pin.push(*f);
            });
            with_pin
        });
        let mut problem = self.problem(trajectories, Start::AtInitial, Some(&pins));
        let outcome = self.solve(&mut problem, start_step)?;
        let keep = index - self.window_start;
        for (w, path) in self.window.iter_mut().zip(&outcome.joint_paths) {
            // A chunk after the plan's end: the arms hold until it starts.
            let last = *w.last().unwrap_or(&path[0]);
            w.resize(keep, last);
            w.extend_from_slice(&path[1..]);
        }
        Ok(ChunkReport {
            start_step,
            dropped: 0,
            recovery: None,
            index,
            end: self.end(),
            planning_time_s: outcome.planning_time_s,
            stats: outcome.stats,
        })
    }

    /// A chunk that starts after the plan's end (the policy was late and the arms hold at the
    /// plan's last configuration) that cannot be reached in one step from the hold: planned
    /// from where the arms hold with an approach, as the first chunk is (issue 22). The approach must end by
    /// the chunk's first step; the chunk's first poses that it cannot reach in time are
    /// dropped, as a late chunk's are, and the rest planned again.
    fn chunk_after_hold(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let n = self.robots.len();
        let end = self.end();
        let hold: Vec<[f64; DOF]> = (0..n)
            .map(|i| self.configuration(i, end - 1).unwrap_or([0.0; DOF]))
            .collect();
        let h = hands.first().map_or(0, |t| t.len());
        let (mut skip, mut planning_time_s) = (0, 0.0);
        // A few tries: each drops the poses the last approach could not reach in time.
        for _ in 0..MAX_HOLD_TRIES {
            if skip >= h {
                break;
            }
            let rest = hands.iter().map(|t| t[skip..].iter().copied().collect());
            let mut problem = self.problem(rest, Start::Sampled, Some(&hold));
            let outcome = self.solve(&mut problem, start_step + skip as u64)?;
            planning_time_s += outcome.planning_time_s;
            let approach = outcome.approach.clone().unwrap_or_default();
            let a = approach.first().map_or(0, Vec::len);
            let first = index + skip;
            if end + a > first {
                // The approach is longer than the hold: drop what it cannot reach in time.
                skip += end + a - first;
                continue;
            }
            let keep = first - a - self.window_start;
            for (i, w) in self.window.iter_mut().enumerate() {
                w.resize(keep, hold[i]);
                w.extend_from_slice(&approach[i]);
                w.extend_from_slice(&outcome.joint_paths[i]);
            }
            // Unchanged unless it was planned free (`reassign`).
            self.assignment = Some(outcome.assignment.clone());
            return Ok(ChunkReport {
                start_step: start_step + skip as u64,
                dropped: skip,
                recovery: None,
                index: first,
                end: self.end(),
                planning_time_s,
                stats: outcome.stats,
            });
        }
        Err(OnlineError::NotPlanned {
            start_step,
            status: "the approach from where the arms hold takes longer than the chunk lasts"
                .to_string(),
        })
    }

    /// The core problem of a chunk: robots start as `start` (from `pins` when given) with the
    /// assignment kept once chosen.
    fn problem(
        &self,
        trajectories: impl Iterator<Item = Trajectory>,
        start: Start,
        pins: Option<&[[f64; DOF]]>,
    ) -> Box<Problem<DOF>> {
        // Boxed: a problem is hundreds of kilobytes, and a caller's thread may have a small
        // stack.
        let mut problem = Box::new(self.template.clone());
        problem.trajectories = trajectories.collect();
        problem.robots = (self.robots.iter().enumerate())
            .map(|(i, r)| Robot {
                initial: pins.map_or(r.initial, |p| Some(p[i])),
                start,
                assigned: match &self.assignment {
                    None => Assigned::Free,
                    Some(a) => a[i].map_or(Assigned::Hold, |j| Assigned::Track(j as u8)),
                },
                ..*r
            })
            .collect();
        problem
    }

    fn solve(
        &mut self,
        problem: &mut Problem<DOF>,
        start_step: u64,
    ) -> Result<crate::planners::Outcome, OnlineError> {
        self.solve_under(problem, start_step, &AssignmentRule::Free)
    }

    /// [`Embodier::solve`] with the robots' assignment set by `rule` (a checked one); `Free`
    /// keeps the problem's.
    fn solve_under(
        &mut self,
        problem: &mut Problem<DOF>,
        start_step: u64,
        rule: &AssignmentRule,
    ) -> Result<crate::planners::Outcome, OnlineError> {
        let timeout = self.options.chunk_timeout_s;
        let kind = self.options.planner;
        let outcome = match rule {
            AssignmentRule::Free => self.storage.solve(kind, problem, timeout),
            // Kept in the problem, where the diagnosis below sees it too.
            AssignmentRule::Fixed(list) => {
                AssignmentRule::apply(Some(list), problem);
                self.storage.solve(kind, problem, timeout)
            }
            AssignmentRule::Preferred(_) => {
                assignment::solve(&mut self.storage, kind, problem, rule, timeout)
            }
        }
        .map_err(|e| OnlineError::Input(InputError::one("planner", e)))?;
        if outcome.status == Status::Solved {
            return Ok(outcome);
        }
        if let Some(e) = self.unreachable(problem, start_step) {
            return Err(e);
        }
        let first = usize::from(problem.robots.first().map(|r| r.start) == Some(Start::AtInitial));
        let assigned = (problem.robots.iter()).all(|r| r.assigned != Assigned::Free);
        if assigned {
            if let Some(b) = diagnose::first_blocking::<Fleet, DOF>(problem, first, &self.setup) {
                return Err(OnlineError::Blocked {
                    start_step,
                    robot: self.names[b.robot].clone(),
                    robot_index: b.robot,
                    hand: b.hand,
                    step: start_step + (b.step - first) as u64,
                    what: b.what,
                });
            }
        }
        let status = match outcome.status {
            Status::Solved => unreachable!("handled above"),
            Status::NoSolution => "no plan exists in the search space".to_string(),
            Status::Timeout => format!(
                "not planned within the chunk timeout of {} s",
                self.options.chunk_timeout_s
            ),
            Status::OutOfMemory(pool) => format!("{pool} is full"),
            Status::InvalidProblem(why) => why.to_string(),
        };
        Err(OnlineError::NotPlanned { start_step, status })
    }

    /// The first hand pose (earliest step) that no arm allowed to take the hand can reach:
    /// IK from the previous step's answer, else from random seeds.
    fn unreachable(&self, problem: &Problem<DOF>, start_step: u64) -> Option<OnlineError> {
        let pinned = problem.robots.first()?.start == Start::AtInitial;
        let first = usize::from(pinned);
        let h = problem.horizon();
        let mut last: Vec<Vec<Option<[f64; DOF]>>> =
            vec![vec![None; self.robots.len()]; problem.trajectories.len()];
        let ik_params = Default::default();
        let multi = MultiStart {
            attempts: 32,
            ..MultiStart::default()
        };
        for k in first..h {
            for (j, traj) in problem.trajectories.iter().enumerate() {
                let fixed = problem
                    .robots
                    .iter()
                    .position(|r| r.assigned == Assigned::Track(j as u8));
                let mut reached = false;
                for (i, r) in problem.robots.iter().enumerate() {
                    if fixed.is_some_and(|f| f != i) {
                        continue;
                    }
                    let target = r.base.inverse().compose(&traj[k]).compose(&r.tcp.inverse());
                    let seed = last[j][i].or(r.initial);
                    let mut q =
                        seed.and_then(|s| ik::<Fleet, DOF>(r.model, &target, &s, &ik_params).ok());
                    if q.is_none() {
                        let mut rng = Rng::new(0x0e1b ^ (k as u64) << 8 ^ j as u64);
                        let mut out = [[0.0; DOF]; 1];
                        if let Ok(1) = ik_multi_start::<Fleet, DOF>(
                            r.model, &target, &ik_params, &multi, &mut rng, &mut out,
                        ) {
                            q = Some(out[0]);
                        }
                    }
                    last[j][i] = q;
                    reached |= q.is_some();
                }
                if !reached {
                    return Some(OnlineError::Unreachable {
                        hand: j,
                        step: start_step + (k - first) as u64,
                        robot: fixed,
                    });
                }
            }
        }
        None
    }
}
