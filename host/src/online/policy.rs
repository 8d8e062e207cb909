//! A scripted stand-in for a policy: the demo's three-arm box flip ([`crate::demo`]) as a
//! closed loop would emit it, the box flipped and flipped back over and over, in chunks of
//! `chunk_len` poses every `stride` poses (each chunk overlapping the previous one's tail).
//! Each chunk moves the box by a small offset drawn from a seeded generator, so consecutive
//! chunks disagree where they overlap and every chunk replaces a tail that was planned.

use std::f64::consts::PI;

use omcbsa_core::model::Frame;

use crate::models::ModelKind;
use omcbsa_core::nalgebra::Vector3;
use omcbsa_core::rng::Rng;

use super::Setup;
use crate::demo::{base, hand, tcp, DT, ORDER, ROBOTS};
use crate::format::{Pose, RobotSpec, ToleranceSpec};
use crate::pose::from_frame;

/// Where the arms stand when the run starts: Kinova's "retract" posture (folded back over
/// the base, clear of the box and of each other).
pub const RETRACT: [f64; 7] = [0.0, -0.35, PI, -2.54, 0.0, -0.87, PI / 2.0];

/// Policy steps for one flip (3 s at dt = 0.1 s, as the demo).
const FLIP_STEPS: f64 = 30.0;

/// The scripted box-flip policy.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxFlipPolicy {
    /// Poses per hand in one chunk.
    pub chunk_len: usize,
    /// Policy steps between the starts of consecutive chunks (`chunk_len - stride` overlap).
    pub stride: usize,
    /// Largest offset of the box in one chunk, per axis, metres.
    pub jitter: f64,
    /// Seed of the box's jitter.
    pub seed: u64,
}

impl Default for BoxFlipPolicy {
    fn default() -> Self {
        BoxFlipPolicy {
            chunk_len: 16,
            stride: 8,
            jitter: 0.004,
            seed: 7,
        }
    }
}

/// One chunk as the policy emits it.
#[derive(Clone, Debug, PartialEq)]
pub struct Chunk {
    /// The policy step of the chunk's first pose.
    pub start_step: u64,
    /// `hands[j][k]`: hand `j` at policy step `start_step + k`.
    pub hands: Vec<Vec<Pose>>,
}

impl BoxFlipPolicy {
    /// The demo's three arms, standing at [`RETRACT`].
    pub fn setup(&self) -> Setup {
        Setup {
            robots: (ROBOTS.iter().enumerate())
                .map(|(k, name)| RobotSpec {
                    name: name.to_string(),
                    model: ModelKind::default().name().to_string(),
                    base: from_frame(&base(k)),
                    initial: Some(RETRACT.to_vec()),
                    tcp: Some(from_frame(&tcp())),
                    tool: Some(crate::demo::gripper()),
                })
                .collect(),
            obstacles: Vec::new(),
            tolerance: ToleranceSpec::default(),
            dt: DT,
        }
    }

    /// How far the box is flipped at policy step `t` (0 at rest, 1 flipped), with zero speed
    /// at both ends of every flip.
    pub fn flip(t: u64) -> f64 {
        0.5 - 0.5 * (PI * t as f64 / FLIP_STEPS).cos()
    }

    /// Chunk number `c`.
    pub fn chunk(&self, c: usize) -> Chunk {
        let start = (c * self.stride) as u64;
        let mut rng = Rng::new(self.seed ^ (c as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let offset = Vector3::from_fn(|_, _| rng.uniform(-self.jitter, self.jitter));
        let moved = |f: Frame| Frame {
            rot: f.rot,
            pos: f.pos + offset,
        };
        Chunk {
            start_step: start,
            hands: (ORDER.iter())
                .map(|&k| {
                    (0..self.chunk_len as u64)
                        .map(|i| from_frame(&moved(hand(k, Self::flip(start + i)))))
                        .collect()
                })
                .collect(),
        }
    }
}
