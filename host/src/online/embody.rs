//! A whole episode through the [`Embodier`], however long: planned chunk by chunk, as a policy
//! would send it, without the caller splitting it (a core problem holds at most `MAX_STEPS`
//! poses; an episode at 50 Hz is often longer).

use super::{ChunkReport, Embodier, OnlineError};
use crate::error::{Errors, InputError};
use crate::format::Pose;
use crate::planners::DOF;
use crate::pose;

/// An episode embodied.
#[derive(Clone, Debug)]
pub struct Embodied {
    /// Every robot's timeline from index 0: `initial`, the approach, then one configuration
    /// per policy step.
    pub timeline: Vec<Vec<[f64; DOF]>>,
    /// The report on the episode's last chunk (how it was planned, how far behind the arms
    /// are at its end).
    pub last: ChunkReport,
}

impl Embodier {
    /// Embodies an episode on a fresh Embodier: `hands[j][k]` is hand `j`'s pose at policy
    /// step `k`. Chunks of `chunk_len` poses (at most `max_chunk_len`) are planned in order,
    /// each from where the one before left the arms, and sent as they are planned. Returns
    /// every robot's timeline and the last chunk's report. Memory: the Embodier's window stays
    /// one chunk long; the timeline returned grows with the episode (it is the answer).
    pub fn embody(
        &mut self,
        hands: &[Vec<Pose>],
        chunk_len: usize,
    ) -> Result<Embodied, OnlineError> {
        let mut errors = Errors::default();
        if self.origin.is_some() {
            errors.push(
                "embodier",
                "has planned chunks already: an episode starts a run",
            );
        }
        if chunk_len == 0 || chunk_len > self.options.max_chunk_len {
            errors.push(
                "chunk_len",
                format!(
                    "{chunk_len}: 1 to {} (max_chunk_len)",
                    self.options.max_chunk_len
                ),
            );
        }
        let steps = hands.first().map_or(0, Vec::len);
        if steps == 0 {
            errors.push("hands", "no poses: an episode needs at least one step");
        }
        for (j, h) in hands.iter().enumerate() {
            if h.len() != steps {
                errors.push(
                    format!("hands[{j}]"),
                    format!(
                        "{} poses, but hands[0] has {steps}: all hands need as many",
                        h.len()
                    ),
                );
            }
            for (k, p) in h.iter().enumerate() {
                if let Err(e) = pose::to_frame(p) {
                    errors.add(e.within(&format!("hands[{j}][{k}]")));
                }
            }
        }
        errors
            .finish()
            .map_err(|e: InputError| OnlineError::Input(e))?;
        let n = self.robot_names().len();
        let mut timeline: Vec<Vec<[f64; DOF]>> = vec![Vec::new(); n];
        // At least one step (checked above): at least one chunk.
        let mut start = 0;
        let last = loop {
            let end = (start + chunk_len).min(steps);
            if let Some(index) = self.timeline_index(start as u64) {
                self.send(&mut timeline, index);
            }
            let chunk: Vec<Vec<Pose>> = hands.iter().map(|h| h[start..end].to_vec()).collect();
            let report = self.push_chunk(start as u64, &chunk)?;
            start = end;
            if start >= steps {
                break report;
            }
        };
        self.send(&mut timeline, self.end());
        Ok(Embodied { timeline, last })
    }

    /// Appends to `timeline` every configuration before `until` not yet in it, and commits it.
    fn send(&mut self, timeline: &mut [Vec<[f64; DOF]>], until: usize) {
        for (i, t) in timeline.iter_mut().enumerate() {
            while t.len() < until {
                match self.configuration(i, t.len()) {
                    Some(q) => t.push(q),
                    None => break,
                }
            }
        }
        self.commit_until(until);
    }
}
