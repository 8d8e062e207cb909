//! Time scaling: a chunk the arms cannot follow at the policy's rate (a joint would have to
//! turn faster than its limit, whatever the null space does) is slowed where it must be,
//! rather than stopped. The hands' path and the order of their poses stay the same: a slowed
//! segment between two consecutive poses gets more timeline steps, each tracking a point
//! between them (position along the segment, rotation along the shortest arc), and every
//! pose of the chunk is still reached exactly, in order. The arms fall behind the policy by
//! the steps added ([`super::ChunkReport::lag_s`]).
//!
//! How much each segment needs: the chunk is planned once with steps [`RELAX`] times longer
//! (a plan that only the joints' speed kept from existing); each segment's joint speed in it,
//! against the limits at the policy's rate, says how many steps it needs. The chunk is then
//! planned at the policy's rate with that many steps per segment, within a speed budget that
//! tightens ([`BUDGETS`]) until it plans: slowed only where it is fast, no slower than that.

use omcbsa_core::model::Models;
use omcbsa_core::problem::Trajectory;

use super::{ChunkReport, Embodier, OnlineError};
use crate::models::Fleet;

/// How many times longer than the policy's steps the relaxed plan's are: the most a segment
/// is slowed.
pub(super) const RELAX: f64 = 4.0;

/// Shares of the joints' speed limits each slowed segment is timed for, tried in turn.
const BUDGETS: [f64; 5] = [0.95, 0.8, 0.65, 0.5, 0.35];

impl Embodier {
    /// Plans a chunk that cannot be followed at the policy's rate from where the arms are,
    /// slowed as the module says.
    pub(super) fn time_scaled(
        &mut self,
        start_step: u64,
        index: usize,
        hands: &[Trajectory],
    ) -> Result<ChunkReport, OnlineError> {
        let too_long = || OnlineError::NotPlanned {
            start_step,
            status: "the chunk is longer than the planner's horizon".to_string(),
        };
        let h = hands.first().map_or(0, |t| t.len());
        let relaxed_chunk = (self.pinned(start_step, index, hands, None)).ok_or_else(too_long)?;
        // A chunk that cannot be planned even with slower steps is not a matter of speed.
        let relaxed = self.plan_pinned(&relaxed_chunk, RELAX)?;
        let dt = self.setup.dt;
        // Per segment (pose k-1 to pose k; segment 0 from the pinned step), the share of the
        // policy-rate limit its fastest joint needs.
        let need: Vec<f64> = (0..h)
            .map(|k| {
                (self.robots.iter().zip(&relaxed.joint_paths))
                    .map(|(r, path)| {
                        let v = Fleet::velocity(r.model);
                        (0..v.len())
                            .map(|j| (path[k + 1][j] - path[k][j]).abs() / (v[j] * dt))
                            .fold(0.0, f64::max)
                    })
                    .fold(0.0, f64::max)
            })
            .collect();
        let mut last = None;
        for budget in BUDGETS {
            let timing: Vec<usize> = (need.iter())
                .map(|r| ((r / budget).ceil() as usize).clamp(1, RELAX as usize))
                .collect();
            if last.as_ref() == Some(&timing) {
                continue;
            }
            let Some(p) = self.pinned(start_step, index, hands, Some(&timing)) else {
                break;
            };
            last = Some(timing);
            if p.targets.len() == h {
                // Not slowed anywhere: the plain plan failed already.
                continue;
            }
            if let Ok(outcome) = self.plan_pinned(&p, 1.0) {
                return Ok(self.write_pinned(&p, &outcome));
            }
        }
        Err(OnlineError::NotPlanned {
            start_step,
            status: format!(
                "not even slowed {RELAX} times can the arms follow the chunk from where they are"
            ),
        })
    }
}
