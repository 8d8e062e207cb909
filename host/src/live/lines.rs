//! Hand chunks as JSON lines, the form `omcbsa online --hands` reads (from a policy in any
//! language, over a pipe, or a file): one chunk per line,
//!
//! ```text
//! {"start_step": 32, "hands": [[{"position": [x, y, z], "quat_xyzw": [x, y, z, w]}, ...], ...]}
//! ```
//!
//! `hands[j][k]` is hand `j`'s pose at policy step `start_step + k` (metres, a unit quaternion
//! in ROS order, in the world frame of the setup's robots); every line has the same hands, in
//! the same order, and as many poses for each. A line is parsed here (its syntax, its fields
//! and their types); the values (a unit quaternion, as many poses per hand, the number of
//! hands) are checked when the chunk is planned, and errors name the field
//! (`hands[1][4].quat_xyzw`).

use serde::{Deserialize, Serialize};

use crate::error::InputError;
use crate::format::Pose;

/// One line: a chunk of the policy's hand poses.
#[derive(Clone, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ChunkLine {
    /// The policy step of every hand's first pose.
    pub start_step: u64,
    /// Per hand, its poses at steps `start_step`, `start_step + 1`, ...
    pub hands: Vec<Vec<Pose>>,
}

/// Parses one line; the error names the field (`hands[0][2].position`) or says where the
/// JSON stopped.
///
/// ```
/// use omcbsa::live::lines::parse_line;
///
/// let line = r#"{"start_step": 3, "hands": [[{"position": [0.5, 0, 0.4], "quat_xyzw": [1, 0, 0, 0]}]]}"#;
/// let chunk = parse_line(line)?;
/// assert_eq!((chunk.start_step, chunk.hands[0].len()), (3, 1));
/// let bad = parse_line(r#"{"start_step": 3, "hands": [[{"position": [0.5, 0], "quat_xyzw": [1, 0, 0, 0]}]]}"#);
/// assert!(bad.unwrap_err().to_string().starts_with("hands[0][0].position: "));
/// # Ok::<(), omcbsa::error::InputError>(())
/// ```
pub fn parse_line(text: &str) -> Result<ChunkLine, InputError> {
    let mut json = serde_json::Deserializer::from_str(text);
    let line: ChunkLine = serde_path_to_error::deserialize(&mut json).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        InputError::one(path, e.into_inner().to_string())
    })?;
    json.end()
        .map_err(|e| InputError::one("", format!("more than one JSON value: {e}")))?;
    Ok(line)
}

/// A chunk as one line (no newline), as [`parse_line`] reads it.
pub fn to_line(chunk: &ChunkLine) -> String {
    // Plain numbers and strings only: writing them cannot fail.
    serde_json::to_string(chunk).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_field_and_a_line_round_trips() {
        for (text, field) in [
            (r#"{"hands": []}"#, ""),
            (r#"{"start_step": -1, "hands": []}"#, "start_step"),
            (
                r#"{"start_step": 0, "hands": [[{"position": [0,0,0]}]]}"#,
                "hands[0][0]",
            ),
            (r#"{"start_step": 0, "hands": [], "speed": 2}"#, "speed"),
            (r#"{"start_step": 0, "hands": []} {}"#, ""),
            ("not json", ""),
        ] {
            let e = parse_line(text).unwrap_err();
            assert_eq!(e.errors[0].path, field, "{text}: {e}");
        }
        let e = parse_line(r#"{"hands": []}"#).unwrap_err();
        assert!(e.to_string().contains("missing field `start_step`"), "{e}");
        let chunk = ChunkLine {
            start_step: 7,
            hands: vec![vec![Pose::IDENTITY; 2]; 2],
        };
        assert_eq!(parse_line(&to_line(&chunk)).unwrap(), chunk);
    }
}
