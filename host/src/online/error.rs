//! What can go wrong when a chunk is pushed.

use std::fmt;

use crate::error::InputError;

/// Why [`super::Embodier::new`] or [`super::Embodier::push_chunk`] gave no plan. After an
/// error the plan already made is kept unchanged: the arms finish it and then hold.
#[derive(Clone, Debug, PartialEq)]
pub enum OnlineError {
    /// The setup or the chunk breaks a rule; the error names the field (`robots[1].initial`,
    /// `hands[2][5].quat_xyzw`).
    Input(InputError),
    /// No arm can reach hand `hand`'s pose at policy step `step` (with the assignment fixed:
    /// not the arm holding that hand, `robot`).
    Unreachable {
        /// The hand (index into the chunk's hands).
        hand: usize,
        /// The policy step.
        step: u64,
        /// The arm holding that hand, when the assignment is fixed.
        robot: Option<usize>,
    },
    /// The chunk starts at policy step `start_step`, but the arms have been sent everything up
    /// to step `committed_step` already: it came too late to replace that part.
    DeadlineMissed {
        /// The chunk's first policy step.
        start_step: u64,
        /// The last policy step already sent to the arms.
        committed_step: i64,
    },
    /// No plan for the chunk, and where it is blocked: following the hands from where the
    /// arms are, robot `robot_index` (named `robot`), holding `hand`, cannot go on at policy
    /// step `step` because of `what` (out of reach, a joint limit, a joint's speed, a
    /// collision and with what).
    Blocked {
        /// The chunk's first policy step.
        start_step: u64,
        /// The blocked robot's name.
        robot: String,
        /// Its index in the setup.
        robot_index: usize,
        /// The hand it holds (`None`: it holds still).
        hand: Option<usize>,
        /// The policy step it cannot reach.
        step: u64,
        /// What stops it.
        what: String,
    },
    /// The planner ended without a plan for the chunk (`status`: no_solution, timeout, ...).
    NotPlanned {
        /// The chunk's first policy step.
        start_step: u64,
        /// How the planner ended.
        status: String,
    },
    /// The first chunk was planned, but no approach from where the arms stand to its start
    /// was found.
    Approach(String),
}

impl fmt::Display for OnlineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OnlineError::Input(e) => write!(f, "{e}"),
            OnlineError::Unreachable {
                hand,
                step,
                robot: None,
            } => write!(f, "hand {hand}: no arm can reach its pose at step {step}"),
            OnlineError::Unreachable {
                hand,
                step,
                robot: Some(r),
            } => write!(
                f,
                "hand {hand}: robot {r}, which holds it, cannot reach its pose at step {step}"
            ),
            OnlineError::DeadlineMissed {
                start_step,
                committed_step,
            } => write!(
                f,
                "chunk for step {start_step} missed its deadline: the arms were already sent \
                 the plan up to step {committed_step}"
            ),
            OnlineError::Blocked {
                start_step,
                robot,
                robot_index,
                hand,
                step,
                what,
            } => {
                let holding =
                    hand.map_or("holding still".to_string(), |h| format!("holding hand {h}"));
                write!(
                    f,
                    "chunk for step {start_step} not planned: robot {robot_index} ({robot:?}), \
                     {holding}, cannot go on at step {step}: {what}"
                )
            }
            OnlineError::NotPlanned { start_step, status } => {
                write!(f, "chunk for step {start_step} not planned: {status}")
            }
            OnlineError::Approach(why) => write!(f, "no approach to the first chunk: {why}"),
        }
    }
}

impl std::error::Error for OnlineError {}

impl From<InputError> for OnlineError {
    fn from(e: InputError) -> Self {
        OnlineError::Input(e)
    }
}
