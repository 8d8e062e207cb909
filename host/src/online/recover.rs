//! Recovery when a chunk cannot be planned from where the last chunk left the arms (a dead
//! end: the last chunk was planned greedily to its end, which the next one cannot leave):
//!
//! 1. [`Embodier::replan_unsent`]: the part of the plan not yet sent is planned again, with
//!    the new chunk, from the last configuration sent, over the poses the policy sent for
//!    it. The arms are not stopped; only what they have not been sent changes.
//! 2. With [`super::OnlineOptions::time_scaling`], the chunk slowed until the arms can follow
//!    it (`super::scaling`).
//! 3. The arms hold where the plan is still unsent and an approach reaches the hands where
//!    they will be ([`Embodier::catch_up`]); the poses it cannot reach in time are dropped,
//!    and tracking resumes from there (behind the policy when even the chunk's last pose
//!    comes too soon).
//! 4. With [`super::OnlineOptions::reassign`], a new assignment from where the arms stand
//!    ([`Embodier::reassign`]).
//!
//! An error leaves the plan as it was, so the next chunk is tried afresh: one failed chunk
//! does not fail every later one.

use omcbsa_core::problem::{Start, Trajectory};

use super::timeline::Target;
use super::{ChunkReport, Embodier, OnlineError};
use crate::models::DOF;

/// Plans of a catch-up, each dropping the poses the approach before could not reach in time.
const MAX_CATCH_UP_TRIES: usize = 4;

impl Embodier {
    /// Keeps the poses of a planned chunk that starts at policy step `start_step` (replacing
    /// what older chunks sent for those steps).
    pub(super) fn remember(&mut self, start_step: u64, hands: &[Trajectory]) {
        let policy_end = self.policy_start + self.policy.first().map_or(0, Vec::len) as u64;
        if self.policy.len() != hands.len()
            || start_step < self.policy_start
            || start_step > policy_end
        {
            // The first chunk, or one after a gap: nothing before it is kept.
            self.policy = vec![Vec::new(); hands.len()];
            self.policy_start = start_step;
        }
        // The chunk replaces what was sent for its steps; what was sent past its end stays
        // (it is planned with the chunk: lookahead).
        let from = (start_step - self.policy_start) as usize;
        for (kept, new) in self.policy.iter_mut().zip(hands) {
            let to = (from + new.len()).min(kept.len());
            kept.splice(from..to, new.iter().copied());
        }
    }

    /// Drops the poses of steps already sent to the arms (the last one sent stays: a re-plan
    /// starts there).
    pub(super) fn forget_sent_poses(&mut self) {
        if self.origin.is_none() {
            return;
        }
        let sent_step = self.sent_step();
        let drop = (sent_step - self.policy_start as i64)
            .clamp(0, self.policy.first().map_or(0, Vec::len) as i64);
        if drop > 0 {
            for p in &mut self.policy {
                p.drain(..drop as usize);
            }
            self.policy_start += drop as u64;
        }
    }

    /// The chunk followed by the poses an earlier chunk sent for the steps after it (as many
    /// as the storage's horizon allows): everything the policy sent that is not yet sent to
    /// the arms. `None` when nothing was sent past the chunk.
    pub(super) fn with_sent_tail(
        &self,
        start_step: u64,
        hands: &[Trajectory],
    ) -> Option<Vec<Trajectory>> {
        let h = hands.first().map_or(0, |t| t.len());
        let after = (start_step + h as u64).checked_sub(self.policy_start)?;
        let after = usize::try_from(after).ok()?;
        let sent = self.policy.first().map_or(0, Vec::len);
        // The pinned step before the chunk takes one place of the horizon.
        let room = self.options.max_chunk_len.saturating_sub(h + 1);
        let extra = sent.saturating_sub(after).min(room);
        if extra == 0 || self.policy.len() != hands.len() {
            return None;
        }
        Some(
            (hands.iter().zip(&self.policy))
                .map(|(new, kept)| {
                    let mut t = new.clone();
                    for f in &kept[after..after + extra] {
                        let _ = t.push(*f);
                    }
                    t
                })
                .collect(),
        )
    }

    /// Plans again, from the last configuration sent to the arms, the steps not yet sent
    /// before the chunk (over the poses the policy sent for them) together with the chunk.
    /// As long as the storage's horizon allows; an error when nothing before the chunk is
    /// unsent.
    pub(super) fn replan_unsent(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let h = hands.first().map_or(0, |t| t.len());
        let none_left = || OnlineError::NotPlanned {
            start_step,
            status: "nothing before the chunk is left unsent to plan again".to_string(),
        };
        // The first index that may change: not sent, not the first kept, and within the
        // planner's horizon with the chunk and the pinned step.
        let lowest = [
            self.committed,
            self.timeline.start() + 1,
            (index + h + 1).saturating_sub(self.options.max_chunk_len),
        ]
        .into_iter()
        .max()
        .unwrap_or(index);
        if lowest >= index || index > self.end() {
            return Err(none_left());
        }
        // From an index that reaches a policy pose kept (not a point a time-scaled chunk
        // inserted, not a hold).
        let (earliest, from_step) = (lowest..index)
            .find_map(|i| {
                let step = self.timeline.target(i).exact_step()?;
                (step >= self.policy_start && step < start_step).then_some((i, step))
            })
            .ok_or_else(none_left)?;
        let back = (start_step - from_step) as usize;
        let skip = (from_step - self.policy_start) as usize;
        let longer: Vec<Trajectory> = (self.policy.iter().zip(hands))
            .map(|(kept, new)| {
                let mut t = Trajectory::new();
                for f in kept.iter().skip(skip).take(back).chain(new.iter()) {
                    let _ = t.push(*f);
                }
                t
            })
            .collect();
        if longer.iter().any(|t| t.len() != back + h) {
            return Err(OnlineError::NotPlanned {
                start_step,
                status: "the poses before the chunk are no longer kept".to_string(),
            });
        }
        self.continue_from(from_step, earliest, &longer)
    }

    /// A chunk the arms cannot follow from where the plan leaves them: they hold where the
    /// plan is still unsent (the first index not sent), and an approach, as the first
    /// chunk's, takes them to the hands where they will be when it ends. The approach must
    /// end by the pose it reaches; the chunk's first poses it cannot reach in time are
    /// dropped (`dropped` in the report), and tracking resumes there. When even the chunk's
    /// last pose comes too soon, the approach reaches it late and the arms go on behind the
    /// policy.
    pub(super) fn catch_up(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let n = self.robots.len();
        let unsent = self.committed.max(self.timeline.start() + 1);
        let hold: Vec<[f64; DOF]> = (0..n)
            .map(|i| self.configuration(i, unsent - 1).unwrap_or([0.0; DOF]))
            .collect();
        let h = hands.first().map_or(0, |t| t.len());
        let mut skip = unsent.saturating_sub(index);
        let mut planning_time_s = 0.0;
        for attempt in 0..MAX_CATCH_UP_TRIES {
            if skip >= h {
                break;
            }
            // The last try aims at the chunk's last pose, late if need be: the arms then
            // follow the next chunk behind the policy (`lag_s`) rather than hold.
            let last = attempt + 1 == MAX_CATCH_UP_TRIES || skip + 1 == h;
            if last {
                skip = h - 1;
            }
            let rest = hands.iter().map(|t| t[skip..].iter().copied().collect());
            let mut problem = self.problem(rest, Start::Sampled, Some(&hold));
            let outcome = self.solve(&mut problem, start_step + skip as u64)?;
            planning_time_s += outcome.planning_time_s;
            let approach = outcome.approach.clone().unwrap_or_default();
            let a = approach.first().map_or(0, Vec::len);
            let first = index + skip;
            if unsent + a > first && !last {
                // Too late for these poses: aim further ahead, with some room, as a new
                // start may need a longer approach.
                let late = unsent + a - first;
                skip = (skip + late + late / 4).min(h - 1);
                continue;
            }
            // The approach starts where the arms hold, or as soon as they can when late.
            let from = first.saturating_sub(a).max(unsent);
            let paths: Vec<Vec<[f64; DOF]>> = (0..n)
                .map(|i| [&approach[i][..], &outcome.joint_paths[i][..]].concat())
                .collect();
            let targets: Vec<Target> = std::iter::repeat_n(Target::Free, a)
                .chain((0..(h - skip) as u64).map(|k| Target::Pose {
                    step: start_step + skip as u64 + k,
                    frac: 0.0,
                }))
                .collect();
            let paths: Vec<&[[f64; DOF]]> = paths.iter().map(Vec::as_slice).collect();
            // The unsent plan goes: the arms hold from `unsent` until the approach starts.
            self.timeline.truncate(unsent);
            self.timeline.replace_from(from, &paths, &targets);
            // Unchanged unless it was planned free (`reassign`).
            self.assignment = Some(outcome.assignment.clone());
            return Ok(ChunkReport {
                start_step: start_step + skip as u64,
                dropped: skip,
                recovery: None,
                index: from + a,
                end: self.end(),
                planning_time_s,
                stats: outcome.stats,
                time_factor: 1.0,
                lag_s: 0.0,
                total_lag_s: 0.0,
                blocked: None,
            });
        }
        Err(OnlineError::NotPlanned {
            start_step,
            status: "no approach from where the arms hold reaches the chunk's poses".to_string(),
        })
    }

    /// Plans the chunk with a new assignment from where the arms stand: the plan not yet sent
    /// is dropped, the arms hold at the last configuration sent, and an approach reaches the
    /// chunk (its first poses are dropped if the approach needs longer). The plan is left as
    /// it was when this fails.
    pub(super) fn reassign(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let assignment = self.assignment.take();
        let planned = self.catch_up(start_step, index, hands);
        if planned.is_err() {
            self.assignment = assignment;
        }
        planned
    }
}
