//! Fixtures of the online and live tests: one Gen3 at the origin and chunks of its hand's
//! poses.

use std::f64::consts::{FRAC_PI_2, PI};

use super::{Embodier, OnlineOptions, Setup};
use crate::format::{Pose, RobotSpec, ToleranceSpec};
use crate::models::DOF;

/// Kinova's home posture of the Gen3 (0, 15, 180, 230, 0, 55, 90 degrees).
pub const HOME: [f64; DOF] = [0.0, 0.26, PI, -2.27, 0.0, 0.96, FRAC_PI_2];

/// One Gen3 named "arm" at the origin, standing at `initial`, nothing around it, dt 0.1 s.
pub fn one_gen3(initial: [f64; DOF]) -> Setup {
    let arm = RobotSpec {
        name: "arm".to_string(),
        model: "kinova_gen3".to_string(),
        base: Pose::IDENTITY,
        initial: Some(initial.to_vec()),
        tcp: None,
        tool: None,
    };
    Setup {
        robots: vec![arm],
        obstacles: Vec::new(),
        tolerance: ToleranceSpec::default(),
        dt: 0.1,
    }
}

/// An Embodier for [`one_gen3`] at [`HOME`], chunks of at most 8 poses.
pub fn embodier() -> Embodier {
    let options = OnlineOptions {
        max_chunk_len: 8,
        ..OnlineOptions::default()
    };
    Embodier::new(&one_gen3(HOME), options).unwrap()
}

/// A chunk of the one hand: 4 poses from step `start`, at (0.5, 0, `z(k)`) at step `k`,
/// pointing down.
pub fn chunk(start: u64, z: impl Fn(u64) -> f64) -> Vec<Vec<Pose>> {
    vec![(start..start + 4)
        .map(|k| Pose {
            position: [0.5, 0.0, z(k)],
            quat_xyzw: [1.0, 0.0, 0.0, 0.0],
        })
        .collect()]
}
