//! Inverse kinematics as `omcbsa ik` and the Python package answer it: from a given start,
//! then from random starts drawn afresh from one seed, so the same question always gets the
//! same answer.

use omcbsa_core::ik::{ik, ik_multi_start, IkError, IkParams, MultiStart};
use omcbsa_core::model::{Frame, Model};
use omcbsa_core::rng::Rng;

/// IK from `start` if given, else (or if that fails) from random starts seeded with `seed`.
pub fn solve<M: Model<D>, const D: usize>(
    target: &Frame,
    start: Option<&[f64; D]>,
    seed: u64,
) -> Result<[f64; D], IkError> {
    let params = IkParams::default();
    if let Some(Ok(q)) = start.map(|s| ik::<M, D>(target, s, &params)) {
        return Ok(q);
    }
    let mut out = [[0.0; D]; 1];
    ik_multi_start::<M, D>(
        target,
        &params,
        &MultiStart::default(),
        &mut Rng::new(seed),
        &mut out,
    )?;
    Ok(out[0])
}
