//! Everything that can be wrong with a model's inputs, each naming the joint, link or file.

use std::fmt;
use std::path::PathBuf;

/// Why a model could not be generated: every variant names the file, link or joint at fault.
#[derive(Debug)]
pub enum Error {
    /// An input file could not be read.
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The URDF is not well-formed (as reported by `urdf-rs`).
    Urdf {
        /// The URDF's file name (`<string>` for text).
        source: String,
        /// What `urdf-rs` said.
        message: String,
    },
    /// The collision file is not valid JSON of the expected shape.
    CollisionFormat {
        /// The collision file's name.
        source: String,
        /// What is wrong with it.
        message: String,
    },
    /// The Rust type name is not a plain identifier.
    TypeName(String),
    /// A link defined twice in the URDF.
    DuplicateLink(String),
    /// A joint defined twice in the URDF.
    DuplicateJoint(String),
    /// A joint names a parent or child link the URDF does not define.
    MissingLink {
        /// The joint.
        joint: String,
        /// The link it names.
        link: String,
    },
    /// The URDF's links and joints are not a serial chain: how.
    NotSerial(NotSerial),
    /// A joint type other than revolute, continuous, prismatic and fixed.
    UnsupportedJoint {
        /// The joint.
        joint: String,
        /// Its type (`floating`, `planar`).
        kind: &'static str,
    },
    /// A mimic joint (not supported).
    Mimic(String),
    /// A moving joint whose axis is the zero vector.
    ZeroAxis(String),
    /// A number the generated code would need is NaN or infinite.
    NotFinite {
        /// The joint.
        joint: String,
        /// The field (`origin`, `axis`, `limit`).
        field: &'static str,
    },
    /// A joint whose lower limit is above its upper limit.
    BadLimits {
        /// The joint.
        joint: String,
        /// Its lower limit.
        lower: f64,
        /// Its upper limit.
        upper: f64,
    },
    /// A moving joint without a positive velocity limit.
    BadVelocity {
        /// The joint.
        joint: String,
        /// The limit given.
        velocity: f64,
    },
    /// The chain has no moving joint.
    NoActuatedJoint,
    /// More links or capsules than the generated `u8` indices can name.
    TooMany {
        /// `links` or `capsules`.
        what: &'static str,
        /// How many there are.
        count: usize,
    },
    /// The collision file was written for another model.
    CollisionModel {
        /// The model being generated.
        expected: String,
        /// The model the file names.
        found: String,
    },
    /// The collision file names a link the chain does not have.
    CollisionLink {
        /// Where in the file.
        context: String,
        /// The link it names.
        link: String,
    },
    /// A capsule of the collision file that cannot be used.
    BadCapsule {
        /// Its index in the file.
        index: usize,
        /// Its link.
        link: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The manifest names a base link, tip link or tool frame the URDF does not define.
    EndLink {
        /// `base link`, `tip link` or `tool frame`.
        role: &'static str,
        /// The link named.
        link: String,
    },
    /// The tool frame does not hang below the base link.
    NotBelow {
        /// The base link.
        base: String,
        /// The tool frame.
        tool: String,
    },
    /// The tip link is not on the path from the base to the tool frame (`joint: None`), or a
    /// moving joint follows it.
    TipOffChain {
        /// The tip link.
        tip: String,
        /// The moving joint after the tip, if that is what is wrong.
        joint: Option<String>,
    },
    /// The model's manifest is not valid JSON of the expected shape.
    Manifest {
        /// The manifest's file name.
        source: String,
        /// What is wrong with it.
        message: String,
    },
    /// A limit list has the wrong length or a value that is not a positive number.
    BadLimit {
        /// `velocity` or `acceleration`.
        what: &'static str,
        /// What is wrong with it.
        message: String,
    },
}

/// How a URDF's links and joints fail to be a serial chain.
#[derive(Debug)]
pub enum NotSerial {
    /// A link is the child of two joints (a closed loop or a malformed tree).
    TwoParents {
        /// The link.
        link: String,
        /// Its two parent joints.
        joints: [String; 2],
    },
    /// A link has two child joints: the robot is a tree, not a serial chain.
    Branch {
        /// The link.
        link: String,
        /// Two of its child joints.
        joints: [String; 2],
    },
    /// No link or more than one link is nobody's child.
    Roots(Vec<String>),
    /// Links that cannot be reached from the root (they form a loop).
    Unreachable(Vec<String>),
}

impl fmt::Display for NotSerial {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use NotSerial::*;
        match self {
            TwoParents {
                link,
                joints: [a, b],
            } => write!(f, "link `{link}` is the child of both `{a}` and `{b}`"),
            Branch {
                link,
                joints: [a, b],
            } => write!(f, "link `{link}` branches into joints `{a}` and `{b}`"),
            Roots(links) if links.is_empty() => write!(f, "every link is a child (no base link)"),
            Roots(links) => write!(
                f,
                "several links have no parent joint: {}",
                links.join(", ")
            ),
            Unreachable(links) => {
                write!(f, "links not reachable from the base: {}", links.join(", "))
            }
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Error::*;
        match self {
            Read { path, source } => write!(f, "cannot read {}: {source}", path.display()),
            Urdf { source, message } => write!(f, "{source}: invalid URDF: {message}"),
            CollisionFormat { source, message } => {
                write!(f, "{source}: invalid collision file: {message}")
            }
            TypeName(name) => write!(f, "`{name}` is not a valid Rust type name"),
            DuplicateLink(link) => write!(f, "link `{link}` is defined twice"),
            DuplicateJoint(joint) => write!(f, "joint `{joint}` is defined twice"),
            MissingLink { joint, link } => {
                write!(
                    f,
                    "joint `{joint}` refers to link `{link}`, which is not defined"
                )
            }
            NotSerial(how) => write!(f, "not a serial chain: {how}"),
            UnsupportedJoint { joint, kind } => write!(
                f,
                "joint `{joint}` has type `{kind}`; only revolute, continuous, prismatic and \
                 fixed joints are supported"
            ),
            Mimic(joint) => write!(
                f,
                "joint `{joint}` is a mimic joint, which is not supported"
            ),
            ZeroAxis(joint) => write!(f, "joint `{joint}` has a zero axis"),
            NotFinite { joint, field } => {
                write!(f, "joint `{joint}`: {field} contains NaN or an infinity")
            }
            BadLimits {
                joint,
                lower,
                upper,
            } => {
                write!(
                    f,
                    "joint `{joint}`: lower limit {lower} is above upper limit {upper}"
                )
            }
            BadVelocity { joint, velocity } => write!(
                f,
                "joint `{joint}`: velocity limit {velocity} is missing or not positive"
            ),
            NoActuatedJoint => write!(
                f,
                "the chain has no revolute, continuous or prismatic joint"
            ),
            TooMany { what, count } => write!(f, "{count} {what}: at most 255 are supported"),
            CollisionModel { expected, found } => write!(
                f,
                "collision file is for model `{found}`, expected `{expected}`"
            ),
            CollisionLink { context, link } => {
                write!(
                    f,
                    "collision file: {context} names link `{link}`, which is not in the chain"
                )
            }
            BadCapsule {
                index,
                link,
                reason,
            } => {
                write!(
                    f,
                    "collision file: capsule {index} (link `{link}`): {reason}"
                )
            }
            EndLink { role, link } => {
                write!(f, "{role} `{link}` is not a link of the URDF")
            }
            NotBelow { base, tool } => write!(
                f,
                "tool frame `{tool}` is not below base link `{base}` in the URDF's tree"
            ),
            TipOffChain { tip, joint: None } => write!(
                f,
                "tip link `{tip}` is not on the chain from the base link to the tool frame"
            ),
            TipOffChain {
                tip,
                joint: Some(joint),
            } => write!(
                f,
                "joint `{joint}` moves between tip link `{tip}` and the tool frame; only fixed \
                 joints may follow the tip"
            ),
            Manifest { source, message } => {
                write!(f, "{source}: invalid model manifest: {message}")
            }
            BadLimit { what, message } => write!(f, "{what} limits: {message}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Read { source, .. } => Some(source),
            _ => None,
        }
    }
}
