//! The collision shape of what a robot carries on its flange: a few capsules rigid in the
//! model's tool frame (the frame `tcp` is given in). They are part of the arm for every
//! check: obstacles, other arms and their tools, and the arm's own links that neither carry
//! the tool frame nor are adjacent to it ([`crate::model::Model::TOOL_SELF_CAPSULES`]).
//!
//! A tool is a fixed-size value (no heap): more than [`MAX_TOOL_CAPSULES`] capsules, or a
//! capsule that is not finite or has no positive radius, is refused with a [`ToolError`],
//! never truncated.
//!
//! ```
//! use omcbsa_core::tool::{Tool, ToolCapsule, ToolError, MAX_TOOL_CAPSULES};
//!
//! // A gripper: a 12 cm capsule of radius 4 cm along the tool frame's z axis.
//! let finger = ToolCapsule { a: [0.0, 0.0, 0.02], b: [0.0, 0.0, 0.12], radius: 0.04 };
//! let gripper = Tool::new(&[finger]).unwrap();
//! assert_eq!(gripper.capsules().len(), 1);
//! assert!(Tool::NONE.capsules().is_empty());
//!
//! // A joint that moves the tool frame's origin 0.5 m per radian moves the gripper's points
//! // at most 0.5 + 0.16 m per radian (its farthest point from the origin).
//! let reach = gripper.reach(&[0.5], 0);
//! assert!((reach[0] - 0.66).abs() < 1e-12);
//!
//! assert_eq!(Tool::new(&[finger; MAX_TOOL_CAPSULES + 1]), Err(ToolError::TooMany));
//! let flat = ToolCapsule { radius: 0.0, ..finger };
//! assert_eq!(Tool::new(&[finger, flat]), Err(ToolError::BadCapsule(1)));
//! ```

/// Most capsules one tool may have.
pub const MAX_TOOL_CAPSULES: usize = 4;

/// One capsule of a tool, in the tool frame: points within `radius` of the segment `a`-`b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolCapsule {
    /// One end of the axis, in the tool frame, metres.
    pub a: [f64; 3],
    /// The other end (equal to `a` for a sphere), metres.
    pub b: [f64; 3],
    /// Radius, metres (above 0).
    pub radius: f64,
}

impl ToolCapsule {
    /// Farthest point from the tool frame's origin.
    fn extent(&self) -> f64 {
        let norm = |p: &[f64; 3]| libm::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        norm(&self.a).max(norm(&self.b)) + self.radius
    }
}

/// Why a list of capsules is no tool.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToolError {
    /// More than [`MAX_TOOL_CAPSULES`].
    TooMany,
    /// Capsule `i` has a coordinate or radius that is not finite, or a radius not above 0.
    BadCapsule(usize),
}

/// A tool: up to [`MAX_TOOL_CAPSULES`] capsules in the tool frame (none: a bare flange).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tool {
    capsules: [ToolCapsule; MAX_TOOL_CAPSULES],
    len: usize,
}

impl Tool {
    /// No tool.
    pub const NONE: Tool = Tool {
        capsules: [ToolCapsule {
            a: [0.0; 3],
            b: [0.0; 3],
            radius: 0.0,
        }; MAX_TOOL_CAPSULES],
        len: 0,
    };

    /// A tool of these capsules; refused (never truncated) beyond the capacity or with a
    /// capsule that is not finite or has no positive radius.
    pub fn new(capsules: &[ToolCapsule]) -> Result<Tool, ToolError> {
        if capsules.len() > MAX_TOOL_CAPSULES {
            return Err(ToolError::TooMany);
        }
        let mut tool = Tool::NONE;
        for (i, c) in capsules.iter().enumerate() {
            let finite = c.a.iter().chain(&c.b).all(|v| v.is_finite());
            if !(finite && c.radius.is_finite() && c.radius > 0.0) {
                return Err(ToolError::BadCapsule(i));
            }
            tool.capsules[i] = *c;
        }
        tool.len = capsules.len();
        Ok(tool)
    }

    /// The tool's capsules (empty for [`Tool::NONE`]).
    pub fn capsules(&self) -> &[ToolCapsule] {
        &self.capsules[..self.len]
    }

    /// Per joint of a model whose tool frame origin moves at most `tool_reach[j]` per radian
    /// (or metre) of joint `j` ([`crate::model::Model::TOOL_REACH`]), a bound on how far the
    /// points of tool capsule `i` travel per radian that joint moves: the origin's bound plus
    /// the capsule's farthest point from that origin (triangle inequality). `i` must be below
    /// `capsules().len()`; past [`MAX_TOOL_CAPSULES`] it panics.
    pub fn reach<const D: usize>(&self, tool_reach: &[f64; D], i: usize) -> [f64; D] {
        let extent = self.capsules[i].extent();
        core::array::from_fn(|j| tool_reach[j] + extent)
    }
}

impl Default for Tool {
    fn default() -> Self {
        Tool::NONE
    }
}
