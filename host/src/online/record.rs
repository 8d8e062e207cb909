//! What an online run sent to the arms, as a problem and solution file pair the validator
//! checks whole: the timeline from `initial` through the approach and every chunk, against
//! the poses of the last chunk that covered each step.

use std::collections::BTreeMap;

use serde_json::Map;

use super::{Embodier, Setup};
use crate::format::{
    joint_paths_value, Pose, ProblemFile, SolutionFile, Status, TrajectorySpec, PROBLEM_FORMAT,
    SOLUTION_FORMAT,
};
use crate::planners::DOF;
use crate::pose;
use omcbsa_core::model::{Frame, Models};

use crate::models::{Fleet, ModelKind};

/// Records the sent timeline and the poses it tracks, as the run goes.
#[derive(Clone, Debug, Default)]
pub struct RunRecord {
    /// Per robot, every configuration sent, from timeline index 0.
    pub sent: Vec<Vec<[f64; DOF]>>,
    /// Per policy step, every hand's pose (the latest chunk's).
    poses: BTreeMap<u64, Vec<Pose>>,
}

impl RunRecord {
    /// Keeps the poses of a chunk that was planned (they replace older ones), but for its
    /// first `dropped` ones, which no arm tracks (see `ChunkReport::dropped`).
    pub fn chunk(&mut self, start_step: u64, hands: &[Vec<Pose>], dropped: usize) {
        for k in dropped..hands.first().map_or(0, Vec::len) {
            let at: Vec<Pose> = hands.iter().map(|h| h[k]).collect();
            self.poses.insert(start_step + k as u64, at);
        }
    }

    /// Records the embodier's plan up to (not including) timeline index `until` as sent; call
    /// before [`Embodier::commit_until`] forgets it.
    pub fn send(&mut self, embodier: &Embodier, until: usize) {
        let n = embodier.robot_names().len();
        self.sent.resize(n, Vec::new());
        for (i, sent) in self.sent.iter_mut().enumerate() {
            while sent.len() < until {
                match embodier.configuration(i, sent.len()) {
                    Some(q) => sent.push(q),
                    None => break,
                }
            }
        }
    }

    /// Where the robot holding hand `j` put its tool centre point at timeline index `index`
    /// (the identity when no robot holds it or nothing was sent there).
    fn planned_hand(&self, setup: &Setup, embodier: &Embodier, j: usize, index: usize) -> Pose {
        let robot = embodier
            .assignment()
            .and_then(|a| a.iter().position(|&h| h == Some(j)));
        let found = robot.and_then(|i| {
            let q = self.sent.get(i)?.get(index)?;
            let spec = setup.robots.get(i)?;
            let model = ModelKind::from_name(&spec.model)?.id();
            let base = pose::to_frame(&spec.base).ok()?;
            let tcp = spec
                .tcp
                .as_ref()
                .map_or(Ok(Frame::IDENTITY), pose::to_frame)
                .ok()?;
            Some(pose::from_frame(
                &base.compose(&Fleet::fk(model, q)).compose(&tcp),
            ))
        });
        found.unwrap_or(Pose::IDENTITY)
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
        self.poses.first_key_value()?;
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
        let first = *self.poses.first_key_value().map_or(&0, |(k, _)| k);
        let a = embodier.approach_len();
        let hands = self.poses.values().next().map_or(0, Vec::len);
        let name = format!("online_run_{}", steps.start);
        let from = a + 1 + steps.start;
        let mut robots = setup.robots.clone();
        if steps.start > 0 {
            for (r, sent) in robots.iter_mut().zip(&self.sent) {
                r.initial = Some(sent[from].to_vec());
            }
        }
        let problem = ProblemFile {
            format: PROBLEM_FORMAT.to_string(),
            name: name.clone(),
            dt: setup.dt,
            robots,
            trajectories: (0..hands)
                .map(|j| TrajectorySpec {
                    name: format!("hand_{j}"),
                    // A step no chunk gave a pose for (a late chunk's dropped steps, a hold
                    // and the approach after it) tracks where the plan put the hand.
                    poses: steps
                        .clone()
                        .map(|k| match self.poses.get(&(first + k as u64)) {
                            Some(p) => p[j],
                            None => self.planned_hand(setup, embodier, j, a + 1 + k),
                        })
                        .collect(),
                })
                .collect(),
            obstacles: setup.obstacles.clone(),
            tolerance: setup.tolerance,
        };
        let approach = (steps.start == 0).then(|| {
            joint_paths_value(
                &self
                    .sent
                    .iter()
                    .map(|s| s[1..=a].to_vec())
                    .collect::<Vec<_>>(),
            )
        });
        let solution = SolutionFile {
            format: SOLUTION_FORMAT.to_string(),
            problem: name,
            planner: "online".to_string(),
            status: Status::Solved,
            message: String::new(),
            planning_time_s: 0.0,
            assignment: embodier.assignment().unwrap_or(&[]).to_vec(),
            approach,
            joint_paths: Some(joint_paths_value(
                &self
                    .sent
                    .iter()
                    .map(|s| s[a + 1 + steps.start..a + 1 + steps.end].to_vec())
                    .collect::<Vec<_>>(),
            )),
            stats: Map::new(),
        };
        (problem, solution)
    }
}
