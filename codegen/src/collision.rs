//! Link collision capsules (from the fitting tool's JSON file), the self-collision pairs worth
//! checking, and per-joint reach bounds.

use serde::Deserialize;

use crate::chain::{Chain, Motion};
use crate::transform::{dot, norm, Vec3};
use crate::Error;

/// The collision file: `{"model", "capsules": [{"link", "a", "b", "radius"}], "disabled_pairs"}`.
#[derive(Deserialize)]
struct File {
    model: String,
    capsules: Vec<CapsuleEntry>,
    #[serde(default)]
    disabled_pairs: Vec<[String; 2]>,
}

#[derive(Deserialize)]
struct CapsuleEntry {
    link: String,
    a: Vec3,
    b: Vec3,
    radius: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    /// Index into the chain's links.
    pub link: usize,
    pub a: Vec3,
    pub b: Vec3,
    pub radius: f64,
}

#[derive(Debug, Default, PartialEq)]
pub struct Geometry {
    /// Sorted by link (stably), so each link's capsules are contiguous.
    pub capsules: Vec<Capsule>,
    /// Index pairs `(i, j)`, `i < j`, into `capsules`.
    pub self_pairs: Vec<(u8, u8)>,
    /// Per actuated joint; see [`reach`].
    pub reach: Vec<f64>,
    /// Per capsule, per actuated joint; see [`capsule_reach`].
    pub capsule_reach: Vec<Vec<f64>>,
    /// Indices into `capsules` that a tool on the tool frame is checked against; see
    /// [`tool_self_capsules`].
    pub tool_self_capsules: Vec<u8>,
    /// Per actuated joint; see [`tool_reach`].
    pub tool_reach: Vec<f64>,
    /// Per actuated joint; see [`axis_cos`].
    pub axis_cos: Vec<f64>,
}

/// `file` is `(name for messages, JSON text)`; without one the model has no capsules.
pub fn geometry(chain: &Chain, model: &str, file: Option<(&str, &str)>) -> Result<Geometry, Error> {
    let (capsules, disabled) = match file {
        Some((source, text)) => parse(chain, model, source, text)?,
        None => (Vec::new(), Vec::new()),
    };
    let self_pairs = self_pairs(chain, &capsules, &disabled);
    let reach = reach(chain, &capsules);
    let capsule_reach = capsule_reach(chain, &capsules);
    let tool_self_capsules = tool_self_capsules(chain, &capsules);
    let tool_reach = tool_reach(chain);
    let axis_cos = axis_cos(chain);
    Ok(Geometry {
        capsules,
        self_pairs,
        reach,
        capsule_reach,
        tool_self_capsules,
        tool_reach,
        axis_cos,
    })
}

type LinkPair = (usize, usize);

fn parse(
    chain: &Chain,
    model: &str,
    source: &str,
    text: &str,
) -> Result<(Vec<Capsule>, Vec<LinkPair>), Error> {
    let file: File = serde_json::from_str(text).map_err(|e| Error::CollisionFormat {
        source: source.to_string(),
        message: e.to_string(),
    })?;
    if file.model != model {
        return Err(Error::CollisionModel {
            expected: model.to_string(),
            found: file.model,
        });
    }
    let link_index = |link: &str, context: String| {
        chain
            .links
            .iter()
            .position(|l| l == link)
            .ok_or_else(|| Error::CollisionLink {
                context,
                link: link.to_string(),
            })
    };
    let mut capsules = Vec::with_capacity(file.capsules.len());
    for (index, c) in file.capsules.iter().enumerate() {
        let bad = |reason| Error::BadCapsule {
            index,
            link: c.link.clone(),
            reason,
        };
        if !c.a.iter().chain(&c.b).all(|v| v.is_finite()) {
            return Err(bad("an end point is not finite"));
        }
        if !(c.radius >= 0.0 && c.radius.is_finite()) {
            return Err(bad("the radius is negative or not finite"));
        }
        let link = link_index(&c.link, format!("capsule {index}"))?;
        capsules.push(Capsule {
            link,
            a: c.a,
            b: c.b,
            radius: c.radius,
        });
    }
    if capsules.len() > 255 {
        return Err(Error::TooMany {
            what: "capsules",
            count: capsules.len(),
        });
    }
    capsules.sort_by_key(|c| c.link);
    let disabled = file
        .disabled_pairs
        .iter()
        .map(|[x, y]| {
            let context = format!("disabled pair ({x}, {y})");
            Ok((link_index(x, context.clone())?, link_index(y, context)?))
        })
        .collect::<Result<_, Error>>()?;
    Ok((capsules, disabled))
}

/// The rigid body each link belongs to: links attached by fixed joints share their parent's.
fn bodies(chain: &Chain) -> Vec<usize> {
    let mut body = vec![0];
    for joint in &chain.joints {
        let last = body[body.len() - 1];
        body.push(if joint.motion == Motion::Fixed {
            last
        } else {
            last + 1
        });
    }
    body
}

/// Every pair of capsules on bodies that are neither the same nor adjacent in the chain, and
/// whose links are not a disabled pair.
fn self_pairs(chain: &Chain, capsules: &[Capsule], disabled: &[LinkPair]) -> Vec<(u8, u8)> {
    let body = bodies(chain);
    let is_disabled = |x, y| {
        disabled
            .iter()
            .any(|&(a, b)| (a, b) == (x, y) || (a, b) == (y, x))
    };
    let mut pairs = Vec::new();
    for (i, ci) in capsules.iter().enumerate() {
        for (j, cj) in capsules.iter().enumerate().skip(i + 1) {
            if body[ci.link].abs_diff(body[cj.link]) >= 2 && !is_disabled(ci.link, cj.link) {
                // capsules.len() <= 255 was checked
                pairs.push((i as u8, j as u8));
            }
        }
    }
    pairs
}

/// For each actuated joint, an upper bound valid in every configuration on the distance from
/// the joint's axis to any downstream capsule point or link frame origin: by the triangle
/// inequality, the sum of the downstream joint offsets (plus each downstream prismatic joint's
/// largest extension) plus the point's distance from its own link's origin, where what is
/// rigid with the joint's child link (its capsules, the next joint's origin) counts only its
/// distance from the axis, the same in every configuration ([`off_axis`]). A prismatic joint
/// moves every downstream point by exactly `|dq|`: 1.
fn reach(chain: &Chain, capsules: &[Capsule]) -> Vec<f64> {
    // farthest[l]: farthest point of link l's capsules from the link's origin (0: its origin)
    let mut farthest = vec![0.0f64; chain.links.len()];
    for c in capsules {
        farthest[c.link] = farthest[c.link].max(capsule_extent(c));
    }
    let mut reach = Vec::new();
    for (j, joint) in chain.joints.iter().enumerate() {
        match joint.motion {
            Motion::Fixed => {}
            Motion::Prismatic { .. } => reach.push(1.0),
            Motion::Revolute { axis } => {
                // joint j's origin is the origin of link j + 1, on its axis
                let own = capsules.iter().filter(|c| c.link == j + 1);
                let mut bound = own.fold(0.0f64, |b, c| b.max(capsule_off_axis(c, axis)));
                let mut path = 0.0;
                for (k, next) in chain.joints.iter().enumerate().skip(j + 1) {
                    path += if k == j + 1 {
                        offset_off_axis(next, axis)
                    } else {
                        joint_offset(next)
                    };
                    bound = bound.max(path + farthest[k + 1]);
                }
                reach.push(bound);
            }
        }
    }
    reach
}

/// For each capsule and actuated joint, the same bound as [`reach`] for that capsule's points
/// alone: 0 for a joint downstream of the capsule's link (it does not move it), else the
/// offsets from the joint to the capsule's link plus the capsule's extent (off the axis only,
/// for what is rigid with the joint's child link). Proximal capsules get far smaller bounds
/// than the whole arm's, so their motions are checked with far smaller margins.
fn capsule_reach(chain: &Chain, capsules: &[Capsule]) -> Vec<Vec<f64>> {
    capsules
        .iter()
        .map(|c| {
            let mut row = Vec::new();
            for (j, joint) in chain.joints.iter().enumerate() {
                let upstream = j < c.link;
                match joint.motion {
                    Motion::Fixed => {}
                    _ if !upstream => row.push(0.0),
                    Motion::Prismatic { .. } => row.push(1.0),
                    // joint j's origin is the origin of link j + 1; joint k leads to k + 1
                    Motion::Revolute { axis } if c.link == j + 1 => {
                        row.push(capsule_off_axis(c, axis));
                    }
                    Motion::Revolute { axis } => {
                        let rest: f64 = chain.joints[j + 2..c.link].iter().map(joint_offset).sum();
                        let first = offset_off_axis(&chain.joints[j + 1], axis);
                        row.push(first + rest + capsule_extent(c));
                    }
                }
            }
            row
        })
        .collect()
}

/// The capsules a tool (rigid on the tool frame, the chain's last link) may hit: those on
/// bodies neither the tool frame's nor adjacent to it. The SRDF's disabled pairs are not
/// applied: they were judged for the bare arm, and a tool reaches where the flange did not.
fn tool_self_capsules(chain: &Chain, capsules: &[Capsule]) -> Vec<u8> {
    let body = bodies(chain);
    let tool = body[body.len() - 1];
    (capsules.iter().enumerate())
        .filter(|(_, c)| body[c.link].abs_diff(tool) >= 2)
        // capsules.len() <= 255 was checked
        .map(|(i, _)| i as u8)
        .collect()
}

/// For each actuated joint, the bound of [`capsule_reach`] for the tool frame's origin: the
/// offsets from the joint to the chain's last link (1 for a prismatic joint). A tool point at
/// distance `r` from that origin is bounded by this plus `r` (the core adds it per tool).
fn tool_reach(chain: &Chain) -> Vec<f64> {
    let mut row = Vec::new();
    for (j, joint) in chain.joints.iter().enumerate() {
        match joint.motion {
            Motion::Fixed => {}
            Motion::Prismatic { .. } => row.push(1.0),
            Motion::Revolute { axis } => {
                // joint j's origin is the origin of link j + 1
                let rest = chain.joints[j + 1..].iter().enumerate();
                row.push(
                    rest.map(|(k, next)| match k {
                        0 => offset_off_axis(next, axis),
                        _ => joint_offset(next),
                    })
                    .sum(),
                );
            }
        }
    }
    row
}

/// Per actuated joint `k`, a bound on `|cos|` of the angle between its axis and the axis of
/// the actuated joint before it: only fixed joints lie between the two, so one rigid body
/// carries both axes and the angle is the same in every configuration. 1 (no bound) for the
/// first joint and next to a prismatic one. Rounded up, so that the core's bounds on how far a
/// motion bows stay bounds.
fn axis_cos(chain: &Chain) -> Vec<f64> {
    let mut out = Vec::new();
    // The previous revolute joint's axis, in the frame of the link the walk has reached.
    let mut previous: Option<Vec3> = None;
    for joint in &chain.joints {
        let rot = &joint.origin.rot;
        match joint.motion {
            Motion::Fixed => {
                // Into the child frame: the transpose of the origin's rotation.
                previous =
                    previous.map(|a| [0, 1, 2].map(|j| (0..3).map(|i| rot[i][j] * a[i]).sum()));
            }
            Motion::Revolute { axis } => {
                let here = joint.origin.rotate(axis);
                out.push(previous.map_or(1.0, |a| (dot(a, here).abs() + 1e-9).min(1.0)));
                // The axis is the same in the child frame, whatever the joint's angle.
                previous = Some(axis);
            }
            Motion::Prismatic { .. } => {
                out.push(1.0);
                previous = None;
            }
        }
    }
    out
}

/// Distance of `p` from the line through the origin along the unit vector `axis`.
fn off_axis(p: Vec3, axis: Vec3) -> f64 {
    let along = dot(p, axis);
    norm([0, 1, 2].map(|i| p[i] - along * axis[i]))
}

/// Farthest point of capsule `c` from the axis `axis` through its link's origin (the axis of
/// the joint that leads to its link, which turns it about that axis).
fn capsule_off_axis(c: &Capsule, axis: Vec3) -> f64 {
    off_axis(c.a, axis).max(off_axis(c.b, axis)) + c.radius
}

/// [`joint_offset`] of `joint`, its origin counted by its distance from `axis` through its
/// parent link's origin (the axis of the joint that leads to that link): the origin is rigid
/// with the link, so it turns about that axis at that distance.
fn offset_off_axis(joint: &crate::chain::Joint, axis: Vec3) -> f64 {
    joint_offset(joint) - norm(joint.origin.pos) + off_axis(joint.origin.pos, axis)
}

/// Farthest point of a capsule from its link's origin.
fn capsule_extent(c: &Capsule) -> f64 {
    norm(c.a).max(norm(c.b)) + c.radius
}

/// How far a joint's child origin can be from its parent's origin: the fixed offset plus, for
/// a prismatic joint, its largest extension.
fn joint_offset(joint: &crate::chain::Joint) -> f64 {
    let extension = match joint.motion {
        Motion::Prismatic { .. } => joint.lower.abs().max(joint.upper.abs()),
        _ => 0.0,
    };
    norm(joint.origin.pos) + extension
}

#[cfg(test)]
mod tests {
    use std::f64::consts::FRAC_PI_3;

    use super::*;
    use crate::chain::Joint;
    use crate::transform::Transform;

    fn joint(name: &str, motion: Motion, x: f64) -> Joint {
        let origin = Transform {
            pos: [x, 0.0, 0.0],
            ..Transform::IDENTITY
        };
        Joint {
            name: name.into(),
            origin,
            motion,
            lower: -0.5,
            upper: 0.25,
            velocity: 1.0,
        }
    }

    /// base -r1-> a -fixed-> b -r2-> c -p3-> d -r4-> e
    fn chain() -> Chain {
        let z = [0.0, 0.0, 1.0];
        Chain {
            links: ["base", "a", "b", "c", "d", "e"].map(String::from).to_vec(),
            joints: vec![
                joint("r1", Motion::Revolute { axis: z }, 1.0),
                joint("f", Motion::Fixed, 2.0),
                joint("r2", Motion::Revolute { axis: z }, 3.0),
                joint("p3", Motion::Prismatic { axis: z }, 4.0),
                joint("r4", Motion::Revolute { axis: z }, 5.0),
            ],
        }
    }

    fn capsule(link: usize, far: f64) -> Capsule {
        Capsule {
            link,
            a: [0.0; 3],
            b: [far, 0.0, 0.0],
            radius: 0.1,
        }
    }

    #[test]
    fn pairs_skip_same_and_adjacent_bodies_and_disabled_links() {
        let chain = chain();
        // bodies: base 0, a 1, b 1, c 2, d 3, e 4
        let caps: Vec<Capsule> = (0..6).map(|l| capsule(l, 0.0)).collect();
        let pairs = self_pairs(&chain, &caps, &[(4, 0)]);
        let expected = vec![(0, 3), (0, 5), (1, 4), (1, 5), (2, 4), (2, 5), (3, 5)];
        assert_eq!(pairs, expected);
    }

    #[test]
    fn reach_sums_downstream_offsets_and_extensions() {
        let chain = chain();
        let caps = [capsule(2, 1.0), capsule(5, 0.5)];
        let reach = reach(&chain, &caps);
        // r1: origin of `a`; to `b` capsule: 2 + 1.1; to `e` capsule: 2+3+(4+0.5)+5 + 0.6
        // r2: origin of `c`; to `e` capsule: (4+0.5)+5+0.6; p3: 1; r4: 0.6
        let expected = [15.1, 10.1, 1.0, 0.6];
        for (r, e) in reach.iter().zip(expected) {
            assert!((r - e).abs() < 1e-12, "{reach:?}");
        }
        assert_eq!(reach.len(), 4);
    }

    /// What is rigid with a joint's child link counts only its distance from the joint's axis:
    /// here the next origin lies 3 along x, 1 off a joint turning about x.
    #[test]
    fn reach_counts_the_child_link_off_the_axis_only() {
        let mut chain = chain();
        chain.joints[2].motion = Motion::Revolute {
            axis: [1.0, 0.0, 0.0],
        };
        chain.joints[3].origin.pos = [4.0, 1.0, 0.0];
        let caps = [capsule(3, 1.0), capsule(5, 0.5)];
        // r2 (about x): `c` capsule off the axis by its radius only; `e` capsule: 1 (the
        // next origin off the axis) + 0.5 (extension) + 5 + 0.6.
        let reach = reach(&chain, &caps);
        assert!((reach[1] - 7.1).abs() < 1e-12, "{reach:?}");
        let rows = capsule_reach(&chain, &caps);
        assert!((rows[0][1] - 0.1).abs() < 1e-12, "{rows:?}");
        assert!((rows[1][1] - 7.1).abs() < 1e-12, "{rows:?}");
        // r1 (about z): everything downstream as before, the fixed joint's origin 2 off it.
        let offsets = 2.0 + 3.0 + (17.0f64.sqrt() + 0.5) + 5.0;
        assert!((rows[1][0] - (offsets + 0.6)).abs() < 1e-12, "{rows:?}");
        assert!((tool_reach(&chain)[1] - 6.5).abs() < 1e-12);
    }

    /// Consecutive axes at a fixed angle, carried through a fixed joint's rotation; no bound
    /// for the first joint nor across a prismatic one.
    #[test]
    fn axis_cosines_follow_the_rigid_links_between_joints() {
        let mut chain = chain();
        assert_eq!(axis_cos(&chain), [1.0, 1.0, 1.0, 1.0]);
        // The fixed joint turns the next frame by 60 degrees about x: r2's z axis meets r1's
        // at 60 degrees.
        chain.joints[1].origin = Transform::from_xyz_rpy([2.0, 0.0, 0.0], [FRAC_PI_3, 0.0, 0.0]);
        let cos = axis_cos(&chain);
        assert!((cos[1] - 0.5).abs() < 1e-8 && cos[1] >= 0.5, "{cos:?}");
        // r2 about x, turned as above: its axis stays perpendicular to r1's z.
        chain.joints[2].motion = Motion::Revolute {
            axis: [1.0, 0.0, 0.0],
        };
        let cos = axis_cos(&chain);
        assert!(cos[1] < 1e-8, "{cos:?}");
        assert_eq!((cos[0], cos[2], cos[3]), (1.0, 1.0, 1.0));
    }
}
