//! Taking a chunk back: the plan as it was before a chunk ([`Embodier::checkpoint`],
//! [`Embodier::restore`]). A caller that streams the plan to arms plans a chunk, then may find
//! it cannot send it (the arms passed its first step while it was planned, the executor or
//! the validator refused it): the Embodier must then hold the plan the arms execute, not the
//! one that was never sent. The planner's pools are scratch space and are not kept.

use super::{timeline::Timeline, Embodier};

/// The Embodier's plan and what it remembers of the policy, at one moment (not what was
/// committed: that stays committed).
#[derive(Clone, Debug)]
pub struct Checkpoint {
    timeline: Timeline,
    origin: Option<(usize, u64)>,
    approach_len: usize,
    assignment: Option<Vec<Option<usize>>>,
    policy: Vec<Vec<omcbsa_core::model::Frame>>,
    policy_start: u64,
    missed: bool,
}

impl Embodier {
    /// The plan now, to [`Embodier::restore`] if the next chunk is not sent. Costs a copy of
    /// the plan kept (bounded: from the last configuration sent to the plan's end).
    pub fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            timeline: self.timeline.clone(),
            origin: self.origin,
            approach_len: self.approach_len,
            assignment: self.assignment.clone(),
            policy: self.policy.clone(),
            policy_start: self.policy_start,
            missed: self.missed,
        }
    }

    /// Puts the plan back as it was at `checkpoint`; what was committed since stays committed
    /// (it was sent to the arms, or is about to be).
    pub fn restore(&mut self, checkpoint: Checkpoint) {
        let committed = self.committed;
        let Checkpoint {
            timeline,
            origin,
            approach_len,
            assignment,
            policy,
            policy_start,
            missed,
        } = checkpoint;
        self.timeline = timeline;
        self.origin = origin;
        self.approach_len = approach_len;
        self.assignment = assignment;
        self.policy = policy;
        self.policy_start = policy_start;
        self.missed = missed;
        self.commit_until(committed);
    }
}

#[cfg(test)]
mod tests {
    use crate::format::Pose;
    use crate::online::testing::{self, embodier};

    fn chunk(start: u64, dz: f64) -> Vec<Vec<Pose>> {
        testing::chunk(start, |k| 0.4 + dz * k as f64)
    }

    #[test]
    fn a_restored_embodier_plans_the_next_chunk_as_if_the_undone_one_never_came() {
        let mut a = embodier();
        let first = a.push_chunk(0, &chunk(0, 0.01)).unwrap();
        a.commit_until(first.index);
        let mut b = embodier();
        b.push_chunk(0, &chunk(0, 0.01)).unwrap();
        b.commit_until(first.index);
        // `a` plans a chunk and takes it back; `b` never sees it.
        let saved = a.checkpoint();
        let undone = a.push_chunk(2, &chunk(2, -0.01)).unwrap();
        assert_ne!(a.planned(0, undone.index), b.planned(0, undone.index));
        a.commit_until(first.index + 1);
        a.restore(saved);
        assert_eq!(a.end(), b.end());
        assert_eq!(a.planned(0, first.index + 1), b.planned(0, first.index + 1));
        // What was committed after the checkpoint stays committed.
        assert!(a.push_chunk(0, &chunk(0, 0.01)).is_err());
        b.commit_until(first.index + 1);
        let next_a = a.push_chunk(2, &chunk(2, 0.01)).unwrap();
        let next_b = b.push_chunk(2, &chunk(2, 0.01)).unwrap();
        assert_eq!(next_a.index, next_b.index);
        assert_eq!(a.planned(0, next_a.index), b.planned(0, next_b.index));
    }
}
