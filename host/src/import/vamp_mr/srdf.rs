//! VAMP-MR's named poses: the `group_state`s of a MoveIt SRDF (XML, read with roxmltree),
//! each a configuration of every arm, resolved as VAMP-MR's `pose_matrix_from_named_pose`
//! does: a state of the move group (all arms at once), else states of the same name for each
//! robot group.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::import::error::ImportError;

/// The joints of an arm a pose gives (the Panda's 7; a fixed `joint8` in a group is skipped,
/// as VAMP-MR skips joints a state gives no value).
pub const ARM_JOINTS: usize = 7;

/// One `<group>`: its joints and subgroups, in file order.
#[derive(Clone, Debug, Default)]
struct Group {
    joints: Vec<String>,
    subgroups: Vec<String>,
}

/// An SRDF's groups and named states.
#[derive(Clone, Debug)]
pub struct Srdf {
    path: PathBuf,
    groups: HashMap<String, Group>,
    states: Vec<State>,
}

/// One `<group_state>`: its group, name and joint values, in file order.
#[derive(Clone, Debug)]
struct State {
    group: String,
    name: String,
    values: Vec<(String, f64)>,
}

impl Srdf {
    /// Reads the SRDF at `path`.
    pub fn read(path: &Path) -> Result<Srdf, ImportError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| ImportError::new(path, "", format!("cannot read: {e}")))?;
        Self::parse(path, &text)
    }

    /// `path` names the file in errors.
    pub fn parse(path: &Path, text: &str) -> Result<Srdf, ImportError> {
        let doc = roxmltree::Document::parse(text)
            .map_err(|e| ImportError::new(path, "", format!("not XML: {e}")))?;
        let root = doc.root_element();
        if root.tag_name().name() != "robot" {
            return Err(ImportError::new(
                path,
                format!("<{}>", root.tag_name().name()),
                "an SRDF's root element is <robot>",
            ));
        }
        let mut srdf = Srdf {
            path: path.to_path_buf(),
            groups: HashMap::new(),
            states: Vec::new(),
        };
        let name = |node: roxmltree::Node, what: &str| {
            node.attribute("name")
                .filter(|n| !n.is_empty())
                .map(str::to_string)
                .ok_or_else(|| {
                    let line = doc.text_pos_at(node.range().start).row;
                    ImportError::new(path, format!("line {line}: <{what}>"), "no name")
                })
        };
        for node in root.children().filter(|n| n.is_element()) {
            match node.tag_name().name() {
                "group" => {
                    let mut group = Group::default();
                    for child in node.children().filter(|n| n.is_element()) {
                        match child.tag_name().name() {
                            "joint" => group.joints.push(name(child, "joint")?),
                            "group" => group.subgroups.push(name(child, "group")?),
                            _ => {}
                        }
                    }
                    srdf.groups.insert(name(node, "group")?, group);
                }
                "group_state" => {
                    let state = name(node, "group_state")?;
                    let group = node.attribute("group").unwrap_or_default().to_string();
                    let at = format!("group_state {state:?} (group {group})");
                    let mut values = Vec::new();
                    for j in node.children().filter(|n| n.has_tag_name("joint")) {
                        let joint = name(j, "joint")?;
                        let text = j.attribute("value").ok_or_else(|| {
                            ImportError::new(path, &at, format!("joint {joint:?} has no value"))
                        })?;
                        let value = text.trim().parse::<f64>().ok().filter(|v| v.is_finite());
                        let value = value.ok_or_else(|| {
                            ImportError::new(
                                path,
                                &at,
                                format!("joint {joint:?}: value {text:?} is not a finite number"),
                            )
                        })?;
                        values.push((joint, value));
                    }
                    srdf.states.push(State {
                        group,
                        name: state,
                        values,
                    });
                }
                _ => {}
            }
        }
        Ok(srdf)
    }

    /// The joints of `group` with its subgroups', in order.
    fn group_joints(&self, group: &str) -> Result<Vec<&str>, ImportError> {
        let mut out = Vec::new();
        let mut visiting = Vec::new();
        self.collect(group, &mut out, &mut visiting)?;
        Ok(out)
    }

    fn collect<'a>(
        &'a self,
        group: &str,
        out: &mut Vec<&'a str>,
        visiting: &mut Vec<String>,
    ) -> Result<(), ImportError> {
        if visiting.iter().any(|g| g == group) {
            return Err(self.error(format!("group {group}"), "contains itself"));
        }
        let g = (self.groups.get(group))
            .ok_or_else(|| self.error(format!("group {group}"), "no such group"))?;
        visiting.push(group.to_string());
        out.extend(g.joints.iter().map(String::as_str));
        for sub in &g.subgroups {
            self.collect(sub, out, visiting)?;
        }
        visiting.pop();
        Ok(())
    }

    fn state(&self, group: &str, name: &str) -> Option<&[(String, f64)]> {
        (self.states.iter())
            .find(|s| s.group == group && s.name == name)
            .map(|s| &s.values[..])
    }

    fn error(&self, at: String, message: &str) -> ImportError {
        ImportError::new(&self.path, at, message)
    }

    /// The named poses of the arms `robot_groups`: the move group's states, then the names
    /// every robot group has a state of, each once, in file order.
    pub fn pose_names(&self, move_group: &str, robot_groups: &[String]) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for State { group, name, .. } in &self.states {
            let whole = group == move_group;
            let each = robot_groups.contains(group)
                && robot_groups.iter().all(|g| self.state(g, name).is_some());
            if (whole || each) && !names.contains(name) {
                names.push(name.clone());
            }
        }
        names
    }

    /// Pose `name`: one configuration per robot group, its joints in the group's order, each
    /// checked to be the arm's joint 1 to 7 in turn (`..._joint1`, ...).
    pub fn pose(
        &self,
        name: &str,
        move_group: &str,
        robot_groups: &[String],
    ) -> Result<Vec<[f64; ARM_JOINTS]>, ImportError> {
        let whole = self.state(move_group, name);
        let mut arms = Vec::with_capacity(robot_groups.len());
        for g in robot_groups {
            let (state_group, values) = match whole {
                Some(v) => (move_group, v),
                None => (
                    g.as_str(),
                    self.state(g, name).ok_or_else(|| {
                        self.error(
                            format!("pose {name:?}"),
                            &format!(
                                "neither group {move_group} nor group {g} has a state of this name"
                            ),
                        )
                    })?,
                ),
            };
            let at = format!("group_state {name:?} (group {state_group})");
            let joints = self.group_joints(g)?;
            let mut q = Vec::with_capacity(ARM_JOINTS);
            for j in joints {
                if let Some((_, v)) = values.iter().find(|(n, _)| n == j) {
                    let k = q.len() + 1;
                    if !j.ends_with(&format!("joint{k}")) {
                        return Err(self.error(
                            at,
                            &format!("joint {j:?} of group {g} is not the arm's joint {k}"),
                        ));
                    }
                    q.push(*v);
                }
            }
            let q: [f64; ARM_JOINTS] = q.as_slice().try_into().map_err(|_| {
                self.error(
                    at.clone(),
                    &format!(
                        "gives {} joint values for group {g}, expected {ARM_JOINTS} (a 7-joint arm)",
                        q.len()
                    ),
                )
            })?;
            arms.push(q);
        }
        Ok(arms)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn arm(prefix: &str) -> String {
        let joints: String = (1..=8)
            .map(|k| format!("<joint name=\"{prefix}_joint{k}\"/>"))
            .collect();
        format!("<group name=\"{prefix}_arm\">{joints}</group>")
    }

    fn state(name: &str, group: &str, prefixes: &[&str], base: f64) -> String {
        let joints: String = (prefixes.iter().enumerate())
            .flat_map(|(a, p)| {
                (1..=7).map(move |k| {
                    format!(
                        "<joint name=\"{p}_joint{k}\" value=\"{}\"/>",
                        base + a as f64 + k as f64 / 10.0
                    )
                })
            })
            .collect();
        format!("<group_state name=\"{name}\" group=\"{group}\">{joints}</group_state>")
    }

    fn doc(body: &str) -> String {
        format!("<?xml version=\"1.0\"?><robot name=\"panda\">{}{}<group name=\"both\"><group name=\"a_arm\"/><group name=\"b_arm\"/></group>{body}</robot>", arm("a"), arm("b"))
    }

    fn groups() -> Vec<String> {
        vec!["a_arm".to_string(), "b_arm".to_string()]
    }

    #[test]
    fn reads_whole_and_per_arm_states() {
        let text = doc(&format!(
            "{}{}{}{}",
            state("ready", "both", &["a", "b"], 0.0),
            state("up", "a_arm", &["a"], 1.0),
            state("up", "b_arm", &["b"], 2.0),
            state("only_a", "a_arm", &["a"], 3.0),
        ));
        let srdf = Srdf::parse(Path::new("t.srdf"), &text).unwrap();
        assert_eq!(srdf.pose_names("both", &groups()), ["ready", "up"]);
        let ready = srdf.pose("ready", "both", &groups()).unwrap();
        assert_eq!(ready[0][0], 0.1);
        assert_eq!(ready[1][6], 1.7);
        let up = srdf.pose("up", "both", &groups()).unwrap();
        assert_eq!((up[0][0], up[1][0]), (1.1, 2.1));
        let e = srdf
            .pose("only_a", "both", &groups())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.srdf: pose \"only_a\": neither group both nor group b_arm"),
            "{e}"
        );
    }

    #[test]
    fn malformed_files_name_file_and_element() {
        let bad = Srdf::parse(Path::new("x.srdf"), "<robot><group_state").unwrap_err();
        assert!(bad.to_string().starts_with("x.srdf: not XML"), "{bad}");
        let text = doc("<group_state name=\"s\" group=\"both\"><joint name=\"a_joint1\" value=\"1.x\"/></group_state>");
        let e = Srdf::parse(Path::new("x.srdf"), &text)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "x.srdf: group_state \"s\" (group both): joint \"a_joint1\": value \"1.x\" is not a finite number"
        );
        // Six joints for an arm: refused, not padded.
        let short = doc(&state("s", "both", &["a", "b"], 0.0)
            .replace("<joint name=\"b_joint7\" value=\"1.7\"/>", ""));
        let srdf = Srdf::parse(Path::new("x.srdf"), &short).unwrap();
        let e = srdf.pose("s", "both", &groups()).unwrap_err().to_string();
        assert!(
            e.contains("gives 6 joint values for group b_arm, expected 7"),
            "{e}"
        );
        // Joints out of order.
        let swapped = doc(&state("s", "both", &["a", "b"], 0.0)).replace(
            "<joint name=\"a_joint1\"/><joint name=\"a_joint2\"/>",
            "<joint name=\"a_joint2\"/><joint name=\"a_joint1\"/>",
        );
        let srdf = Srdf::parse(Path::new("x.srdf"), &swapped).unwrap();
        let e = srdf.pose("s", "both", &groups()).unwrap_err().to_string();
        assert!(
            e.contains("joint \"a_joint2\" of group a_arm is not the arm's joint 1"),
            "{e}"
        );
        let e = Srdf::parse(Path::new("x.srdf"), "<launch/>")
            .unwrap_err()
            .to_string();
        assert!(e.contains("root element is <robot>"), "{e}");
    }
}
