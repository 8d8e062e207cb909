//! Link pairs of one arm that are never checked against each other: links joined by a joint
//! (their shapes touch at the joint by design) and the pairs the robot's SRDF disables.

use super::FitError;

/// One disabled pair, links in URDF order, with why.
#[derive(Clone, Debug, PartialEq)]
pub struct DisabledPair {
    pub links: [String; 2],
    pub reason: String,
}

/// A `<disable_collisions link1= link2= reason=/>` entry of an SRDF (plain or xacro).
#[derive(Clone, Debug, PartialEq)]
pub struct SrdfEntry {
    pub link1: String,
    pub link2: String,
    pub reason: String,
}

/// The `disable_collisions` entries of an SRDF, with xacro substitutions (`$(arg prefix)`,
/// `${prefix}`) taken as empty, as for a single arm with no prefix.
pub fn parse_srdf(xml: &str) -> Result<Vec<SrdfEntry>, FitError> {
    let doc = roxmltree::Document::parse(xml)
        .map_err(|e| FitError::new(format!("SRDF is not valid XML: {e}")))?;
    doc.descendants()
        .filter(|n| n.has_tag_name("disable_collisions"))
        .map(|n| {
            let attr = |name: &str| -> Result<String, FitError> {
                let value = n.attribute(name).ok_or_else(|| {
                    FitError::new(format!(
                        "SRDF line {}: disable_collisions has no {name} attribute",
                        doc.text_pos_at(n.range().start).row
                    ))
                })?;
                strip_substitutions(value).map_err(|e| {
                    FitError::new(format!(
                        "SRDF line {}: {name}: {e}",
                        doc.text_pos_at(n.range().start).row
                    ))
                })
            };
            Ok(SrdfEntry {
                link1: attr("link1")?,
                link2: attr("link2")?,
                reason: n.attribute("reason").unwrap_or("").to_owned(),
            })
        })
        .collect()
}

/// `value` without its `$(...)` and `${...}` xacro substitutions.
fn strip_substitutions(value: &str) -> Result<String, String> {
    let mut out = String::new();
    let mut rest = value;
    while let Some(start) = rest.find(['$']) {
        out.push_str(&rest[..start]);
        let close = match rest[start..].chars().nth(1) {
            Some('(') => ')',
            Some('{') => '}',
            _ => return Err(format!("{value:?}: '$' not followed by ( or {{")),
        };
        let end = rest[start..]
            .find(close)
            .ok_or_else(|| format!("{value:?}: unclosed substitution"))?;
        rest = &rest[start + end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Adjacent pairs among `links` (the links that have collision geometry, in URDF order) and
/// the SRDF's pairs, each once, ordered by the links' places in `links`. Reasons of a pair
/// named by both are joined.
pub fn disabled_pairs(
    robot: &urdf_rs::Robot,
    links: &[String],
    srdf: &[SrdfEntry],
) -> Result<Vec<DisabledPair>, FitError> {
    let index = |name: &str| links.iter().position(|l| l == name);
    let mut pairs: Vec<((usize, usize), String)> = Vec::new();
    let mut add = |i: usize, j: usize, reason: String| {
        let key = (i.min(j), i.max(j));
        match pairs.iter_mut().find(|(k, _)| *k == key) {
            Some((_, reasons)) => *reasons = format!("{reasons}; {reason}"),
            None => pairs.push((key, reason)),
        }
    };
    for joint in &robot.joints {
        if let (Some(i), Some(j)) = (index(&joint.parent.link), index(&joint.child.link)) {
            add(i, j, format!("adjacent (joint {})", joint.name));
        }
    }
    for entry in srdf {
        let known = |name: &str| {
            if robot.links.iter().any(|l| l.name == name) {
                Ok(index(name))
            } else {
                Err(FitError::new(format!(
                    "SRDF disables link {name:?}, which the URDF does not have"
                )))
            }
        };
        // Pairs with a link that has no geometry have nothing to check anyway.
        if let (Some(i), Some(j)) = (known(&entry.link1)?, known(&entry.link2)?) {
            if i == j {
                return Err(FitError::new(format!(
                    "SRDF disables link {:?} against itself",
                    entry.link1
                )));
            }
            add(i, j, format!("SRDF: {}", entry.reason));
        }
    }
    pairs.sort_by_key(|(k, _)| *k);
    Ok(pairs
        .into_iter()
        .map(|((i, j), reason)| DisabledPair {
            links: [links[i].clone(), links[j].clone()],
            reason,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SRDF: &str = r#"<?xml version="1.0" ?>
<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
    <xacro:arg name="prefix" default="" />
    <group name="arm"><joint name="$(arg prefix)j1" /></group>
    <disable_collisions link1="$(arg prefix)b" link2="$(arg prefix)c" reason="Never" />
    <disable_collisions link1="${prefix}a" link2="b" reason="Adjacent" />
</robot>"#;

    fn robot() -> urdf_rs::Robot {
        urdf_rs::read_from_string(
            r#"<robot name="r">
  <link name="a"/><link name="b"/><link name="c"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="continuous"><parent link="b"/><child link="c"/></joint>
  <joint name="j3" type="fixed"><parent link="c"/><child link="tool"/></joint>
</robot>"#,
        )
        .unwrap()
    }

    #[test]
    fn srdf_entries_lose_their_prefix() {
        let entries = parse_srdf(SRDF).unwrap();
        let names: Vec<_> = entries
            .iter()
            .map(|e| (e.link1.as_str(), e.link2.as_str(), e.reason.as_str()))
            .collect();
        assert_eq!(names, [("b", "c", "Never"), ("a", "b", "Adjacent")]);
    }

    #[test]
    fn bad_srdf_is_reported_with_its_line() {
        let err = parse_srdf("<robot>\n<disable_collisions link1=\"a\" reason=\"x\"/></robot>")
            .unwrap_err();
        assert!(
            err.to_string().contains("line 2") && err.to_string().contains("link2"),
            "{err}"
        );
        let err = parse_srdf("<robot><disable_collisions link1=\"$(arg p\" link2=\"b\"/></robot>")
            .unwrap_err();
        assert!(err.to_string().contains("unclosed"), "{err}");
        assert!(parse_srdf("<robot>").is_err());
    }

    #[test]
    fn adjacent_and_srdf_pairs_are_merged_in_link_order() {
        let links = ["a", "b", "c"].map(String::from);
        let pairs = disabled_pairs(&robot(), &links, &parse_srdf(SRDF).unwrap()).unwrap();
        let got: Vec<_> = pairs
            .iter()
            .map(|p| (p.links[0].as_str(), p.links[1].as_str(), p.reason.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                ("a", "b", "adjacent (joint j1); SRDF: Adjacent"),
                ("b", "c", "adjacent (joint j2); SRDF: Never")
            ]
        );
    }

    #[test]
    fn srdf_naming_an_unknown_link_is_an_error() {
        let entries = [SrdfEntry {
            link1: "a".into(),
            link2: "nope".into(),
            reason: "Never".into(),
        }];
        let err = disabled_pairs(&robot(), &["a".into()], &entries).unwrap_err();
        assert!(err.to_string().contains("\"nope\""), "{err}");
    }
}
