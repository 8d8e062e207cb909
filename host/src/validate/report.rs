//! The validator's report: the rules, a violation with where and what, and the report that
//! collects them (bounded).

use std::fmt;

use serde::Serialize;

/// The rule a violation breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Rule {
    /// Not a solved solution of this problem.
    Solution,
    /// Rule 1: a joint outside its limits.
    JointLimits,
    /// Rule 2: a tool centre point off its pose.
    Tracking,
    /// Rule 3: a joint faster than its velocity limit.
    Velocity,
    /// Rule 4: a collision, at a step or between two.
    Collision,
    /// Rule 5: an assignment that is not one robot per trajectory.
    Assignment,
    /// Rule 6: a joint faster to change speed than its acceleration limit, at the plan's steps.
    Acceleration,
    /// Rule 7: the same in the commands streamed at the control rate.
    StreamAcceleration,
    /// Rule 8: a joint's jerk over its limit in the commands streamed at the control rate.
    StreamJerk,
}

impl Rule {
    /// The rule's number in the spec (none for [`Rule::Solution`]).
    pub fn number(self) -> Option<u8> {
        match self {
            Rule::Solution => None,
            Rule::JointLimits => Some(1),
            Rule::Tracking => Some(2),
            Rule::Velocity => Some(3),
            Rule::Collision => Some(4),
            Rule::Assignment => Some(5),
            Rule::Acceleration => Some(6),
            Rule::StreamAcceleration => Some(7),
            Rule::StreamJerk => Some(8),
        }
    }

    pub(super) fn title(self) -> &'static str {
        match self {
            Rule::Solution => "solution",
            Rule::JointLimits => "joint limits",
            Rule::Tracking => "tracking",
            Rule::Velocity => "velocity",
            Rule::Collision => "collision",
            Rule::Assignment => "assignment",
            Rule::Acceleration => "acceleration",
            Rule::StreamAcceleration => "acceleration at the control rate",
            Rule::StreamJerk => "jerk at the control rate",
        }
    }
}

/// Which part of a robot's timeline a step number counts in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// The joint paths: step `t` is `joint_paths[i][t]`.
    #[default]
    Path,
    /// The approach: step 0 is `initial`, step `k` is `approach[i][k - 1]`, step `A + 1` is
    /// `joint_paths[i][0]`.
    Approach,
}

/// One broken rule.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Violation {
    /// The rule broken.
    pub rule: Rule,
    /// The robot (index into `robots`) the violation is about, if one.
    pub robot: Option<usize>,
    /// The step (0-based) in `phase`, or for a motion the step it starts from.
    pub step: Option<usize>,
    /// What `step` counts.
    pub phase: Phase,
    /// What failed, naming joints, links, obstacles and trajectories.
    pub detail: String,
    /// For a collision, the links in contact as `(robot, link)` with `link` an index into
    /// `Model::LINK_NAMES` (so a viewer can mark them); empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<(usize, usize)>,
    /// For a limit broken by a quantity (rules 6 to 8), the joint, the value and the limit.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub measured: Option<Measured>,
}

/// A joint's quantity over its limit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Measured {
    /// The joint (0-based, chain order).
    pub joint: usize,
    /// The value reached (signed).
    pub value: f64,
    /// The limit (the model's, under the cell's scale).
    pub limit: f64,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.rule.number() {
            Some(n) => write!(f, "rule {n} ({})", self.rule.title())?,
            None => f.write_str(self.rule.title())?,
        }
        if let Some(r) = self.robot {
            write!(f, ", robot {r}")?;
        }
        match (self.step, self.phase) {
            (Some(t), Phase::Path) => write!(f, ", step {t}")?,
            (Some(t), Phase::Approach) => write!(f, ", approach step {t}")?,
            (None, Phase::Approach) => write!(f, ", approach")?,
            (None, Phase::Path) => {}
        }
        write!(f, ": {}", self.detail)
    }
}

/// Violations kept in a report; beyond, they are only counted, so that a report stays small
/// however large the solution (22 million malformed configurations are one line each
/// otherwise).
pub const MAX_VIOLATIONS: usize = 1000;

/// The outcome of a validation: valid when there are no violations.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    /// The first [`MAX_VIOLATIONS`] violations.
    pub violations: Vec<Violation>,
    /// How many more there are.
    pub omitted: usize,
}

impl Report {
    /// Whether no rule is broken.
    pub fn is_valid(&self) -> bool {
        self.violations.is_empty()
    }

    /// A one-line human answer: `valid`, or the first violation and how many there are.
    pub fn summary(&self) -> String {
        match self.violations.as_slice() {
            [] => "valid".to_string(),
            [only] => format!("invalid: {only}"),
            [first, rest @ ..] => {
                format!("invalid: {first} (and {} more)", rest.len() + self.omitted)
            }
        }
    }

    /// Violations found so far, listed or not.
    pub fn count(&self) -> usize {
        self.violations.len() + self.omitted
    }

    pub(super) fn add(
        &mut self,
        rule: Rule,
        robot: Option<usize>,
        step: Option<usize>,
        detail: String,
    ) {
        if self.violations.len() == MAX_VIOLATIONS {
            self.omitted += 1;
            return;
        }
        self.violations.push(Violation {
            rule,
            robot,
            step,
            phase: Phase::Path,
            detail,
            links: Vec::new(),
            measured: None,
        });
    }
}
