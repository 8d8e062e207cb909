//! Recovery when a chunk cannot be planned from where the last chunk left the arms (a dead
//! end: the last chunk was planned greedily to its end, which the next one cannot leave):
//!
//! 1. [`Embodier::replan_unsent`]: the part of the plan not yet sent is planned again, with
//!    the new chunk, from the last configuration sent, over the poses the policy sent for
//!    it. The arms are not stopped; only what they have not been sent changes.
//! 2. The arms hold where the plan ends and an approach reaches the chunk
//!    (`Embodier::chunk_after_hold`, in the module above).
//! 3. With [`super::OnlineOptions::reassign`], a new assignment from where the arms stand
//!    ([`Embodier::reassign`]).
//!
//! An error leaves the plan as it was, so the next chunk is tried afresh: one failed chunk
//! does not fail every later one.

use omcbsa_core::problem::Trajectory;

use super::{ChunkReport, Embodier, OnlineError};

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
        let Some(offset) = self.offset else { return };
        let sent_step = self.committed as i64 - 1 - offset;
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
        let offset = self.offset.unwrap_or(0);
        let h = hands.first().map_or(0, |t| t.len());
        // The first step that may change: not sent, not before the kept plan or the poses.
        let earliest = [
            self.committed,
            self.window_start + 1,
            usize::try_from(offset + self.policy_start as i64).unwrap_or(usize::MAX),
            // The storage's horizon: the chunk and the steps before it, plus the pinned step.
            (index + h + 1).saturating_sub(self.options.max_chunk_len),
        ]
        .into_iter()
        .max()
        .unwrap_or(index);
        if earliest >= index || index > self.end() {
            return Err(OnlineError::NotPlanned {
                start_step,
                status: "nothing before the chunk is left unsent to plan again".to_string(),
            });
        }
        let from_step = (earliest as i64 - offset) as u64;
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
        let (window, assignment) = (self.window.clone(), self.assignment.take());
        let keep = self.committed.max(self.window_start + 1) - self.window_start;
        for w in &mut self.window {
            w.truncate(keep);
        }
        let planned = self.chunk_after_hold(start_step, index, hands);
        if planned.is_err() {
            self.window = window;
            self.assignment = assignment;
        }
        planned
    }
}
