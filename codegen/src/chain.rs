//! A URDF reduced to the one thing codegen accepts: a serial chain from the base link to the
//! tool link, with every value checked.

use std::collections::{BTreeMap, BTreeSet};

use crate::error::NotSerial;
use crate::transform::{norm, Transform, Vec3};
use crate::Error;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    Fixed,
    /// Rotation about the unit `axis` (continuous joints have infinite limits).
    Revolute {
        axis: Vec3,
    },
    /// Translation along the unit `axis`.
    Prismatic {
        axis: Vec3,
    },
}

#[derive(Clone, Debug)]
pub struct Joint {
    pub name: String,
    /// Pose of the child link frame in the parent link frame at zero joint value.
    pub origin: Transform,
    pub motion: Motion,
    pub lower: f64,
    pub upper: f64,
    pub velocity: f64,
}

/// `links[0]` is the base; joint `i` connects `links[i]` to `links[i + 1]`.
#[derive(Clone, Debug)]
pub struct Chain {
    pub links: Vec<String>,
    pub joints: Vec<Joint>,
}

impl Chain {
    pub fn actuated(&self) -> impl Iterator<Item = &Joint> {
        self.joints.iter().filter(|j| j.motion != Motion::Fixed)
    }
}

/// The links a chain runs between, as a model's manifest names them.
#[derive(Clone, Copy, Debug)]
pub struct Ends<'a> {
    /// The model's base frame.
    pub base: &'a str,
    /// The arm's last link (its flange): only fixed joints may follow it to the tool frame.
    pub tip: &'a str,
    /// The frame `fk` reports; the chain ends here.
    pub tool: &'a str,
}

/// The chain of `robot`: with `ends`, the path from the base link to the tool frame (links
/// hanging off it, such as a gripper's fingers, are not part of it); without, the whole URDF,
/// which must then be one serial chain.
pub fn from_urdf(robot: &urdf_rs::Robot, ends: Option<Ends>) -> Result<Chain, Error> {
    let mut links = BTreeSet::new();
    for link in &robot.links {
        if !links.insert(link.name.as_str()) {
            return Err(Error::DuplicateLink(link.name.clone()));
        }
    }
    let mut joint_names = BTreeSet::new();
    // parent link -> joint, child link -> joint
    let mut by_parent: BTreeMap<&str, &urdf_rs::Joint> = BTreeMap::new();
    let mut by_child: BTreeMap<&str, &urdf_rs::Joint> = BTreeMap::new();
    for joint in &robot.joints {
        if !joint_names.insert(joint.name.as_str()) {
            return Err(Error::DuplicateJoint(joint.name.clone()));
        }
        for link in [&joint.parent.link, &joint.child.link] {
            if !links.contains(link.as_str()) {
                return Err(Error::MissingLink {
                    joint: joint.name.clone(),
                    link: link.clone(),
                });
            }
        }
        if let Some(other) = by_child.insert(&joint.child.link, joint) {
            return Err(Error::NotSerial(NotSerial::TwoParents {
                link: joint.child.link.clone(),
                joints: [other.name.clone(), joint.name.clone()],
            }));
        }
        if let Some(other) = by_parent.insert(&joint.parent.link, joint) {
            if ends.is_none() {
                return Err(Error::NotSerial(NotSerial::Branch {
                    link: joint.parent.link.clone(),
                    joints: [other.name.clone(), joint.name.clone()],
                }));
            }
        }
    }
    let (base, path) = match ends {
        Some(ends) => (ends.base, path_between(&links, &by_child, ends)?),
        None => whole_chain(&links, &by_parent, &by_child)?,
    };
    let mut chain = Chain {
        links: vec![base.to_string()],
        joints: Vec::new(),
    };
    for joint in path {
        chain.joints.push(convert(joint)?);
        chain.links.push(joint.child.link.clone());
    }
    if chain.actuated().next().is_none() {
        return Err(Error::NoActuatedJoint);
    }
    if chain.links.len() > 255 {
        return Err(Error::TooMany {
            what: "links",
            count: chain.links.len(),
        });
    }
    Ok(chain)
}
type Joints<'r> = BTreeMap<&'r str, &'r urdf_rs::Joint>;

/// The joints from the one root of a URDF that must be a serial chain, and that root.
fn whole_chain<'r>(
    links: &BTreeSet<&'r str>,
    by_parent: &Joints<'r>,
    by_child: &Joints<'r>,
) -> Result<(&'r str, Vec<&'r urdf_rs::Joint>), Error> {
    let roots: Vec<&str> = links
        .iter()
        .copied()
        .filter(|l| !by_child.contains_key(l))
        .collect();
    let [root] = roots[..] else {
        let roots = roots.iter().map(|l| l.to_string()).collect();
        return Err(Error::NotSerial(NotSerial::Roots(roots)));
    };
    let mut path = Vec::new();
    let mut reached = BTreeSet::from([root]);
    let mut link = root;
    while let Some(joint) = by_parent.get(link) {
        path.push(*joint);
        link = &joint.child.link;
        reached.insert(link);
    }
    if reached.len() != links.len() {
        let rest = links.difference(&reached).map(|l| l.to_string()).collect();
        return Err(Error::NotSerial(NotSerial::Unreachable(rest)));
    }
    Ok((root, path))
}

/// The joints from `ends.base` down to `ends.tool`, checking that the tip lies on that path
/// with only fixed joints after it.
fn path_between<'r>(
    links: &BTreeSet<&'r str>,
    by_child: &Joints<'r>,
    ends: Ends,
) -> Result<Vec<&'r urdf_rs::Joint>, Error> {
    for (role, link) in [
        ("base link", ends.base),
        ("tip link", ends.tip),
        ("tool frame", ends.tool),
    ] {
        if !links.contains(link) {
            return Err(Error::EndLink {
                role,
                link: link.to_string(),
            });
        }
    }
    let mut path = Vec::new();
    let mut link = ends.tool;
    // At most one joint per link: a loop would have given some link two parents.
    while link != ends.base {
        let Some(joint) = by_child.get(link) else {
            return Err(Error::NotBelow {
                base: ends.base.to_string(),
                tool: ends.tool.to_string(),
            });
        };
        path.push(*joint);
        link = &joint.parent.link;
    }
    path.reverse();
    let tip_at = if ends.tip == ends.base {
        Some(0)
    } else {
        path.iter()
            .position(|j| j.child.link == ends.tip)
            .map(|i| i + 1)
    };
    let Some(tip_at) = tip_at else {
        return Err(Error::TipOffChain {
            tip: ends.tip.to_string(),
            joint: None,
        });
    };
    if let Some(moving) = path[tip_at..]
        .iter()
        .find(|j| j.joint_type != urdf_rs::JointType::Fixed)
    {
        return Err(Error::TipOffChain {
            tip: ends.tip.to_string(),
            joint: Some(moving.name.clone()),
        });
    }
    Ok(path)
}

fn convert(joint: &urdf_rs::Joint) -> Result<Joint, Error> {
    use urdf_rs::JointType as T;
    let name = &joint.name;
    let not_finite = |field| Error::NotFinite {
        joint: name.clone(),
        field,
    };
    if joint.mimic.is_some() {
        return Err(Error::Mimic(name.clone()));
    }
    let xyz = joint.origin.xyz.0;
    let rpy = joint.origin.rpy.0;
    if !xyz.iter().chain(&rpy).all(|v| v.is_finite()) {
        return Err(not_finite("origin"));
    }
    let origin = Transform::from_xyz_rpy(xyz, rpy);
    let unit_axis = || {
        let axis = joint.axis.xyz.0;
        if !axis.iter().all(|v| v.is_finite()) {
            return Err(not_finite("axis"));
        }
        let n = norm(axis);
        if n == 0.0 {
            return Err(Error::ZeroAxis(name.clone()));
        }
        Ok(axis.map(|v| v / n))
    };
    let limit = &joint.limit;
    let (motion, lower, upper) = match joint.joint_type {
        T::Fixed => (Motion::Fixed, 0.0, 0.0),
        T::Continuous => (
            Motion::Revolute { axis: unit_axis()? },
            f64::NEG_INFINITY,
            f64::INFINITY,
        ),
        T::Revolute => (
            Motion::Revolute { axis: unit_axis()? },
            limit.lower,
            limit.upper,
        ),
        T::Prismatic => (
            Motion::Prismatic { axis: unit_axis()? },
            limit.lower,
            limit.upper,
        ),
        T::Floating => return Err(unsupported(name, "floating")),
        T::Planar => return Err(unsupported(name, "planar")),
        T::Spherical => return Err(unsupported(name, "spherical")),
    };
    let velocity = match motion {
        Motion::Fixed => 0.0,
        _ => limit.velocity,
    };
    if motion != Motion::Fixed {
        if lower.is_nan() || upper.is_nan() {
            return Err(not_finite("limit"));
        }
        if lower > upper {
            return Err(Error::BadLimits {
                joint: name.clone(),
                lower,
                upper,
            });
        }
        if !(velocity > 0.0 && velocity.is_finite()) {
            return Err(Error::BadVelocity {
                joint: name.clone(),
                velocity,
            });
        }
    }
    Ok(Joint {
        name: name.clone(),
        origin,
        motion,
        lower,
        upper,
        velocity,
    })
}

fn unsupported(joint: &str, kind: &'static str) -> Error {
    Error::UnsupportedJoint {
        joint: joint.to_string(),
        kind,
    }
}
