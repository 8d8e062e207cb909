//! Traps: small fixtures placed where plain IK tracking would take an elbow but no arm of
//! the witness ever goes. A trapped problem is still solved by its witness, but an arm that
//! tracks its hand myopically from the witness's own start hits the fixture: solving it takes
//! the null-space motion (or another start) the witness used.

use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::model::{Frame, Model};

use super::family::Hand;
use super::frames::{at, V3};
use super::layout::NamedObstacle;
use super::witness::{Gen3, Scene, Q};

/// Radius of a fixture.
const RADIUS: f64 = 0.04;
/// Elbow positions tried per hand, farthest from the witness's elbow first.
const CANDIDATES: usize = 4;
/// The elbow: the origin of `forearm_link` (joint 4).
const ELBOW_LINK: &str = "forearm_link";

/// One fixture per hand where one fits (named `fixture_<k>`), given the witness `paths` of
/// every arm.
pub fn traps(
    scene: &Scene,
    bases: &[Frame],
    hands: &[Hand],
    paths: &[Vec<Q>],
) -> Vec<NamedObstacle> {
    let Some(elbow) = Gen3::LINK_NAMES.iter().position(|n| *n == ELBOW_LINK) else {
        return Vec::new();
    };
    let mut found = Vec::new();
    for hand in hands {
        let base = &bases[hand.arm];
        let myopic = track_plainly(scene, base, &hand.poses, &paths[hand.arm][0]);
        let mut candidates: Vec<(f64, V3)> = (myopic.iter().zip(&paths[hand.arm]))
            .map(|(q, w)| {
                let p = elbow_at(base, q, elbow);
                ((p - elbow_at(base, w, elbow)).norm(), p)
            })
            .collect();
        candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
        let clear = candidates
            .into_iter()
            .take(CANDIDATES)
            .map(|(_, p)| p)
            .find(|p| {
                let sphere = [Obstacle {
                    shape: Shape::Sphere { radius: RADIUS },
                    pose: at(*p),
                }];
                let alone = Scene {
                    obstacles: &sphere,
                    dt: scene.dt,
                    tcp: scene.tcp,
                };
                (bases.iter().zip(paths)).all(|(b, path)| alone.path_ok(b, path, &[]))
            });
        if let Some(p) = clear {
            let shape = Shape::Sphere { radius: RADIUS };
            found.push((
                format!("fixture_{}", found.len()),
                Obstacle { shape, pose: at(p) },
            ));
        }
    }
    found
}

/// IK tracking from `start` with nothing else in mind, until IK fails.
fn track_plainly(scene: &Scene, base: &Frame, poses: &[Frame], start: &Q) -> Vec<Q> {
    let params = IkParams::default();
    let mut path = vec![*start];
    for pose in &poses[1..] {
        match ik::<Gen3, 7>(&scene.target(base, pose), &path[path.len() - 1], &params) {
            Ok(q) => path.push(q),
            Err(_) => break,
        }
    }
    path
}

fn elbow_at(base: &Frame, q: &Q, link: usize) -> V3 {
    let mut frames = vec![Frame::IDENTITY; Gen3::LINK_NAMES.len()];
    Gen3::link_frames(q, &mut frames);
    base.compose(&frames[link]).pos
}
