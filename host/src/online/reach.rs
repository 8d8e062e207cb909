//! Whether every pose of an episode's hands is within some arm's reach: a benchmark counts
//! the episodes where one is not apart, instead of leaving them out.

use omcbsa_core::ik::{ik, ik_multi_start, IkParams, MultiStart};
use omcbsa_core::model::Frame;
use omcbsa_core::rng::Rng;

use super::bimanual::Episode;
use crate::format::{Pose, RobotSpec};
use crate::models::{Fleet, ModelKind, DOF};
use crate::pose::to_frame;

/// A pose no arm reaches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutOfReach {
    pub hand: usize,
    pub step: usize,
}

/// The first pose of each hand in turn that no arm of the episode's setup reaches: IK within
/// the joint limits from the arm's answer at the step before, else from seeded random starts
/// (collisions and speeds aside: this is reach, not a plan).
pub fn out_of_reach(episode: &Episode) -> Result<Option<OutOfReach>, String> {
    let arm = |r: &RobotSpec| -> Result<(u8, Frame, Frame), String> {
        let model = ModelKind::parse(&r.model)?;
        let frame = |p: &Option<Pose>| p.as_ref().map_or(Ok(Frame::IDENTITY), to_frame);
        let base = to_frame(&r.base).map_err(|e| e.to_string())?;
        Ok((model.id(), base, frame(&r.tcp).map_err(|e| e.to_string())?))
    };
    let arms: Vec<(u8, Frame, Frame)> = (episode.setup.robots.iter())
        .map(arm)
        .collect::<Result<_, _>>()?;
    let params = IkParams::default();
    let multi = MultiStart {
        attempts: 32,
        ..MultiStart::default()
    };
    let mut rng = Rng::new(0xa10a);
    for (hand, poses) in episode.hands.iter().enumerate() {
        let mut last: Vec<Option<[f64; DOF]>> = vec![None; arms.len()];
        for (step, pose) in poses.iter().enumerate() {
            let pose = to_frame(pose).map_err(|e| e.to_string())?;
            let targets: Vec<Frame> = (arms.iter())
                .map(|(_, base, tcp)| base.inverse().compose(&pose).compose(&tcp.inverse()))
                .collect();
            // The arms that reached the last pose first, from there; random starts only when
            // none of them reaches this one.
            for (i, q) in last.iter_mut().enumerate() {
                *q = q.and_then(|q| ik::<Fleet, DOF>(arms[i].0, &targets[i], &q, &params).ok());
            }
            if last.iter().all(Option::is_none) {
                for (i, q) in last.iter_mut().enumerate() {
                    let mut out = [[0.0; DOF]; 1];
                    let found = ik_multi_start::<Fleet, DOF>(
                        arms[i].0,
                        &targets[i],
                        &params,
                        &multi,
                        &mut rng,
                        &mut out,
                    );
                    *q = matches!(found, Ok(1)).then_some(out[0]);
                }
            }
            if last.iter().all(Option::is_none) {
                return Ok(Some(OutOfReach { hand, step }));
            }
        }
    }
    Ok(None)
}
