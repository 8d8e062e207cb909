//! Inverse kinematics as `omcbsa ik` and the Python package answer it: from a given start,
//! then from random starts drawn afresh from one seed, so the same question always gets the
//! same answer.

use omcbsa_core::ik::{ik, ik_multi_start, IkError, IkParams, MultiStart};
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::rng::Rng;

/// IK of model `model` of `M` from `start` if given, else (or if that fails) from random
/// starts seeded with `seed`.
pub fn solve<M: Models<D>, const D: usize>(
    model: u8,
    target: &Frame,
    start: Option<&[f64; D]>,
    seed: u64,
) -> Result<[f64; D], IkError> {
    let params = IkParams::default();
    if let Some(Ok(q)) = start.map(|s| ik::<M, D>(model, target, s, &params)) {
        return Ok(q);
    }
    let mut out = [[0.0; D]; 1];
    ik_multi_start::<M, D>(
        model,
        target,
        &params,
        &MultiStart::default(),
        &mut Rng::new(seed),
        &mut out,
    )?;
    Ok(out[0])
}
