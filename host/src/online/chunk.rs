//! Planning one chunk from where the arms are: the core problem of a chunk (the robots
//! pinned at the configurations they have one step before it, the assignment kept), its
//! poses as timed targets (one timeline step per pose, or more where a time-scaled chunk is
//! slowed), and writing the plan into the timeline.

use omcbsa_core::ik::{ik, ik_multi_start, MultiStart};
use omcbsa_core::model::Frame;
use omcbsa_core::planner::Status;
use omcbsa_core::problem::{Assigned, Problem, Robot, Start, Trajectory};
use omcbsa_core::rng::Rng;

use super::diagnose;
use super::timeline::{between, Target};
use super::{ChunkReport, Embodier, OnlineError};
use crate::assignment::{self, AssignmentRule};
use crate::error::InputError;
use crate::models::{Fleet, DOF};
use crate::planners::Outcome;

/// A chunk's poses as the planner tracks them from the configurations the arms have one
/// step before it (index `index - 1`, the pins).
pub(super) struct Pinned {
    /// The chunk's first policy step.
    pub start_step: u64,
    /// Timeline index of the chunk's first pose.
    pub index: usize,
    /// Every robot's configuration at `index - 1`.
    pub pins: Vec<[f64; DOF]>,
    /// Per hand: the pinned step's pose (not tracked), then one pose per timeline index.
    pub trajectories: Vec<Trajectory>,
    /// What each timeline index from `index` on tracks.
    pub targets: Vec<Target>,
}

impl Embodier {
    /// The chunk `hands` (from policy step `start_step`, at timeline index `index`) pinned
    /// where the arms are one index before it, pose `k` reached after `timing[k]` timeline
    /// steps (1: the policy's rate; more: the steps in between track points between pose
    /// `k - 1` and pose `k`; for `k = 0`, from the pose the pinned index tracks, which must be
    /// the policy's pose at the step before). `None` when the timed chunk is longer than the
    /// planner's horizon.
    pub(super) fn pinned(
        &self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
        timing: Option<&[usize]>,
    ) -> Option<Pinned> {
        let pins: Vec<[f64; DOF]> = (0..self.robots.len())
            .map(|i| self.configuration(i, index - 1).unwrap_or([0.0; DOF]))
            .collect();
        let h = hands.first().map_or(0, |t| t.len());
        // The poses before the chunk's first: the step before's, where the pin tracks it.
        let before = start_step
            .checked_sub(1)
            .filter(|&s| self.timeline.target(index - 1).exact_step() == Some(s));
        let previous: Option<Vec<Frame>> = before.and_then(|s| {
            let k = usize::try_from(s.checked_sub(self.policy_start)?).ok()?;
            self.policy.iter().map(|p| p.get(k).copied()).collect()
        });
        let steps = |k: usize| match (k, &previous) {
            (0, None) => 1,
            _ => timing.and_then(|t| t.get(k)).copied().unwrap_or(1).max(1),
        };
        let mut targets = Vec::with_capacity(h);
        for k in 0..h {
            let n = steps(k);
            for i in 1..n {
                targets.push(Target::Pose {
                    step: (start_step + k as u64) - 1,
                    frac: i as f64 / n as f64,
                });
            }
            targets.push(Target::Pose {
                step: start_step + k as u64,
                frac: 0.0,
            });
        }
        if targets.len() + 1 > self.storage.max_horizon() {
            return None;
        }
        // Step 0 is where the arms are; its pose is not tracked (it repeats the first).
        let trajectories = (hands.iter().enumerate())
            .map(|(j, t)| {
                let pose = |step: u64| {
                    let k = step.wrapping_sub(start_step) as usize;
                    match (t.get(k), &previous) {
                        (Some(f), _) => *f,
                        // The step before the chunk (its first segment is slowed).
                        (None, Some(prev)) => prev[j],
                        (None, None) => t[0],
                    }
                };
                let mut timed = Trajectory::new();
                let _ = timed.push(t[0]);
                for target in &targets {
                    if let Target::Pose { step, frac } = *target {
                        let at = if frac > 0.0 {
                            between(&pose(step), &pose(step + 1), frac)
                        } else {
                            pose(step)
                        };
                        // The horizon was checked above.
                        let _ = timed.push(at);
                    }
                }
                timed
            })
            .collect();
        Some(Pinned {
            start_step,
            index,
            pins,
            trajectories,
            targets,
        })
    }

    /// Plans a pinned chunk, its steps `dt_scale` times as long as the policy's (1: at the
    /// policy's rate; more: a relaxed plan that time scaling measures).
    pub(super) fn plan_pinned(
        &mut self,
        p: &Pinned,
        dt_scale: f64,
    ) -> Result<Outcome, OnlineError> {
        let mut problem = self.problem(
            p.trajectories.iter().cloned(),
            Start::AtInitial,
            Some(&p.pins),
        );
        problem.dt *= dt_scale;
        self.solve(&mut problem, p.start_step)
    }

    /// Writes a planned pinned chunk into the timeline from its index on.
    pub(super) fn write_pinned(&mut self, p: &Pinned, outcome: &Outcome) -> ChunkReport {
        let paths: Vec<&[[f64; DOF]]> = (outcome.joint_paths.iter()).map(|q| &q[1..]).collect();
        self.timeline.replace_from(p.index, &paths, &p.targets);
        let poses = p
            .trajectories
            .first()
            .map_or(1, |t| t.len().saturating_sub(1))
            .max(1);
        ChunkReport {
            start_step: p.start_step,
            dropped: 0,
            recovery: None,
            index: p.index,
            end: self.end(),
            planning_time_s: outcome.planning_time_s,
            stats: outcome.stats,
            time_factor: p.targets.len() as f64 / poses as f64,
            lag_s: 0.0,
            total_lag_s: 0.0,
            blocked: None,
        }
    }

    /// Plans a chunk from the configurations the arms have one step before it (holding at
    /// the plan's end when it starts later), at the policy's rate.
    pub(super) fn continue_from(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let Some(p) = self.pinned(start_step, index, hands, None) else {
            return Err(OnlineError::NotPlanned {
                start_step,
                status: "the chunk is longer than the planner's horizon".to_string(),
            });
        };
        let outcome = self.plan_pinned(&p, 1.0)?;
        Ok(self.write_pinned(&p, &outcome))
    }

    /// The core problem of a chunk: robots start as `start` (from `pins` when given) with the
    /// assignment kept once chosen.
    pub(super) fn problem(
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

    pub(super) fn solve(
        &mut self,
        problem: &mut Problem<DOF>,
        start_step: u64,
    ) -> Result<crate::planners::Outcome, OnlineError> {
        self.solve_under(problem, start_step, &AssignmentRule::Free)
    }

    /// [`Embodier::solve`] with the robots' assignment set by `rule` (a checked one); `Free`
    /// keeps the problem's.
    pub(super) fn solve_under(
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
