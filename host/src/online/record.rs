//! What an online run sent to the arms, as a problem and solution file pair the validator
//! checks whole: the timeline from `initial` through the approach and every chunk, against
//! what each index tracked when it was sent (the poses of the last chunk that covered it, or
//! points between two of them where a chunk was time-scaled), and the order of the policy's
//! poses along it ([`RunRecord::check_order`]).

use serde_json::Map;

use super::{Embodier, Setup, Target};
use crate::format::{
    joint_paths_value, Pose, ProblemFile, SolutionFile, Status, TrajectorySpec, PROBLEM_FORMAT,
    SOLUTION_FORMAT,
};
use crate::planners::DOF;
use crate::pose;
use omcbsa_core::model::{Frame, Models};

use crate::models::{Fleet, ModelKind};

/// Records the sent timeline and what it tracks, as the run goes.
#[derive(Clone, Debug, Default)]
pub struct RunRecord {
    /// Per robot, every configuration sent, from timeline index 0.
    pub sent: Vec<Vec<[f64; DOF]>>,
    /// Per index sent, what it tracked, and every hand's pose there (none where the hands
    /// were free: the approach, a hold).
    targets: Vec<(Target, Option<Vec<Pose>>)>,
}

/// How the policy's poses lie along a sent timeline ([`RunRecord::check_order`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Order {
    /// Policy steps reached exactly, in order.
    pub reached: usize,
    /// Policy steps passed over by a catch-up (not tracked).
    pub dropped: usize,
}

impl RunRecord {
    /// Records the embodier's plan up to (not including) timeline index `until` as sent, with
    /// what it tracks; call before [`Embodier::commit_until`] forgets it.
    pub fn send(&mut self, embodier: &Embodier, until: usize) {
        let n = embodier.robot_names().len();
        self.sent.resize(n, Vec::new());
        let from = self.sent.first().map_or(0, Vec::len);
        for (i, sent) in self.sent.iter_mut().enumerate() {
            while sent.len() < until {
                match embodier.configuration(i, sent.len()) {
                    Some(q) => sent.push(q),
                    None => break,
                }
            }
        }
        let to = self.sent.first().map_or(0, Vec::len);
        for index in from..to {
            let poses = (embodier.target_poses(index))
                .map(|frames| frames.iter().map(pose::from_frame).collect());
            let target = match poses {
                Some(_) => embodier.target(index),
                None => Target::Free,
            };
            self.targets.push((target, poses));
        }
    }

    /// Checks that the policy's poses were tracked in order along what was sent: each index
    /// after the first pose tracks the same step further on, or the next step; a later step
    /// only after indices where the hands were free (a catch-up, which drops the steps it
    /// passes over). The error names the first index out of order.
    pub fn check_order(&self) -> Result<Order, String> {
        let mut order = Order::default();
        let mut last: Option<(u64, f64)> = None;
        let mut free_since = false;
        for (index, (target, _)) in self.targets.iter().enumerate() {
            let Target::Pose { step, frac } = *target else {
                free_since = true;
                continue;
            };
            match last {
                None => {}
                Some((s, f)) if step == s && frac > f => {}
                Some((s, _)) if step == s + 1 && (frac == 0.0 || free_since) => {}
                Some((s, _)) if step > s + 1 && free_since => {
                    order.dropped += (step - s - 1) as usize;
                }
                Some((s, f)) => {
                    return Err(format!(
                        "timeline index {index} tracks step {step} + {frac:.3} after step \
                         {s} + {f:.3}: the policy's poses are not tracked in order"
                    ))
                }
            }
            if frac == 0.0 {
                order.reached += 1;
            }
            last = Some((step, frac));
            free_since = false;
        }
        Ok(order)
    }

    /// The problem (poses of the steps sent) and the solution (approach and paths sent).
    /// `None` before the first chunk's first step was sent.
    pub fn files(&self, setup: &Setup, embodier: &Embodier) -> Option<(ProblemFile, SolutionFile)> {
        let h = self.tracked(embodier)?;
        Some(self.window(setup, embodier, 0..h))
    }

    /// The run as files of at most `max_len` steps each, for a run longer than a problem may
    /// be (`MAX_STEPS`): the first carries the approach; each later one starts where the one
    /// before ended (its `initial` and first step are that step), so every pair of
    /// consecutive steps is checked in one of them. Empty before the first step was sent.
    pub fn windows(
        &self,
        setup: &Setup,
        embodier: &Embodier,
        max_len: usize,
    ) -> Vec<(ProblemFile, SolutionFile)> {
        let Some(h) = self.tracked(embodier) else {
            return Vec::new();
        };
        let max_len = max_len.max(2);
        let mut out = vec![self.window(setup, embodier, 0..h.min(max_len))];
        let mut from = max_len;
        while from < h {
            out.push(self.window(setup, embodier, from - 1..h.min(from - 1 + max_len)));
            from += max_len - 1;
        }
        out
    }

    /// Steps of the path sent (after the approach), once any was.
    fn tracked(&self, embodier: &Embodier) -> Option<usize> {
        let sent = self.sent.first()?.len();
        sent.checked_sub(embodier.approach_len() + 1)
            .filter(|&h| h > 0)
    }

    /// Path steps `steps` as a problem and solution: with the approach when they start at 0,
    /// else from the configurations at their first step.
    fn window(
        &self,
        setup: &Setup,
        embodier: &Embodier,
        steps: std::ops::Range<usize>,
    ) -> (ProblemFile, SolutionFile) {
        let a = embodier.approach_len();
        let from = a + 1 + steps.start;
        let span = |r: std::ops::Range<usize>| -> Vec<Vec<[f64; DOF]>> {
            self.sent.iter().map(|s| s[r.clone()].to_vec()).collect()
        };
        let (initial, approach) = match steps.start {
            0 => (None, Some(span(1..a + 1))),
            _ => (Some(self.sent.iter().map(|s| s[from]).collect()), None),
        };
        let window = Window {
            name: format!("online_run_{}", steps.start),
            initial,
            approach,
            path: span(a + 1 + steps.start..a + 1 + steps.end),
        };
        window.files(setup, embodier, |k| match self.targets.get(from + k) {
            Some((_, Some(p))) => Some(p.clone()),
            _ => None,
        })
    }
}

/// Part of a timeline as a problem and solution file pair, for the validator.
#[derive(Clone, Debug)]
pub struct Window {
    /// The problem's and the solution's name.
    pub name: String,
    /// Per robot, where it stands before the window (`None`: the setup's `initial`).
    pub initial: Option<Vec<[f64; DOF]>>,
    /// Per robot, the configurations between `initial` and `path` (the solution's approach:
    /// its limits, speeds and collisions are checked, from `initial` to `path[0]`, an empty one
    /// for that step alone), or `None`.
    pub approach: Option<Vec<Vec<[f64; DOF]>>>,
    /// Per robot, the configurations tracking the hands (the solution's joint paths).
    pub path: Vec<Vec<[f64; DOF]>>,
}

impl Window {
    /// The problem and the solution; `poses(k)` gives every hand's pose at path step `k`, or
    /// `None` where the hands were free (the approach, a hold): there a hand is taken to be
    /// where the robot holding it put it.
    pub fn files(
        &self,
        setup: &Setup,
        embodier: &Embodier,
        poses: impl Fn(usize) -> Option<Vec<Pose>>,
    ) -> (ProblemFile, SolutionFile) {
        let assignment = embodier.assignment().unwrap_or(&[]);
        let hands = assignment.iter().flatten().count();
        let mut robots = setup.robots.clone();
        if let Some(initial) = &self.initial {
            for (r, q) in robots.iter_mut().zip(initial) {
                r.initial = Some(q.to_vec());
            }
        }
        let steps = self.path.first().map_or(0, Vec::len);
        let tracked: Vec<Vec<Pose>> = (0..steps)
            .map(|k| {
                poses(k).unwrap_or_else(|| {
                    (0..hands)
                        .map(|j| {
                            let robot = assignment.iter().position(|&h| h == Some(j));
                            let q = robot.and_then(|i| Some((i, self.path.get(i)?.get(k)?)));
                            q.and_then(|(i, q)| hand_pose(setup.robots.get(i)?, q))
                                .unwrap_or(Pose::IDENTITY)
                        })
                        .collect()
                })
            })
            .collect();
        let problem = ProblemFile {
            format: PROBLEM_FORMAT.to_string(),
            name: self.name.clone(),
            dt: setup.dt,
            robots,
            trajectories: (0..hands)
                .map(|j| TrajectorySpec {
                    name: format!("hand_{j}"),
                    poses: tracked.iter().map(|p| p[j]).collect(),
                })
                .collect(),
            obstacles: setup.obstacles.clone(),
            tolerance: setup.tolerance,
        };
        let solution = SolutionFile {
            format: SOLUTION_FORMAT.to_string(),
            problem: self.name.clone(),
            planner: "online".to_string(),
            status: Status::Solved,
            message: String::new(),
            planning_time_s: 0.0,
            assignment: assignment.to_vec(),
            approach: self.approach.as_deref().map(joint_paths_value),
            joint_paths: Some(joint_paths_value(&self.path)),
            stats: Map::new(),
        };
        (problem, solution)
    }
}

/// Where robot `spec` at `q` puts its tool centre point, in the world (`None` for an unknown
/// model or a pose that is not one).
fn hand_pose(spec: &crate::format::RobotSpec, q: &[f64; DOF]) -> Option<Pose> {
    let model = ModelKind::from_name(&spec.model)?.id();
    let base = pose::to_frame(&spec.base).ok()?;
    let tcp = (spec.tcp.as_ref())
        .map_or(Ok(Frame::IDENTITY), pose::to_frame)
        .ok()?;
    Some(pose::from_frame(
        &base.compose(&Fleet::fk(model, q)).compose(&tcp),
    ))
}
