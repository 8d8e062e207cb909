//! Code generation on malformed inputs: each is refused with an error naming what is wrong.
//! (The generated code itself is tested in `core/tests/kinematics.rs`, against `k`.)

use std::path::Path;

use omcbsa_codegen::{generate_model, Ends, Error, Input, Limits, ModelSpec};

fn generate(urdf: &str, collision: Option<&str>) -> Result<String, Error> {
    generate_model(&ModelSpec {
        type_name: "Arm",
        name: "arm",
        urdf: Input::Text(urdf),
        collision: collision.map(Input::Text),
        ends: None,
        limits: None,
    })
}

fn link(name: &str) -> String {
    format!(r#"<link name="{name}"/>"#)
}

fn joint(name: &str, kind: &str, parent: &str, child: &str, axis: &str) -> String {
    format!(
        r#"<joint name="{name}" type="{kind}"><origin xyz="0 0 0.1" rpy="0 0 0"/><parent link="{parent}"/>
           <child link="{child}"/><axis xyz="{axis}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#
    )
}

fn robot(parts: &[String]) -> String {
    format!(r#"<robot name="arm">{}</robot>"#, parts.concat())
}

/// base -j1-> a -j2-> b
fn two_joint_arm() -> Vec<String> {
    vec![
        link("base"),
        link("a"),
        link("b"),
        joint("j1", "revolute", "base", "a", "0 0 1"),
        joint("j2", "prismatic", "a", "b", "1 0 0"),
    ]
}

fn error_of(urdf: &str) -> String {
    match generate(urdf, None) {
        Ok(_) => panic!("accepted:\n{urdf}"),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(message: &str, words: &[&str]) {
    for w in words {
        assert!(message.contains(w), "`{message}` does not mention `{w}`");
    }
}

#[test]
fn a_well_formed_chain_generates_one_impl() {
    let code = generate(&robot(&two_joint_arm()), None).expect("valid");
    assert!(code.contains("pub struct Arm;"));
    assert!(code.contains("impl crate::model::Model<2> for Arm"));
    assert!(code.contains(r#"const LINK_NAMES: &'static [&'static str] = &["base", "a", "b"];"#));
}

#[test]
fn branching_is_refused_naming_the_link_and_joints() {
    let mut parts = two_joint_arm();
    parts.push(link("c"));
    parts.push(joint("j3", "revolute", "a", "c", "0 0 1"));
    assert_mentions(
        &error_of(&robot(&parts)),
        &["not a serial chain", "`a`", "j2", "j3"],
    );
}

#[test]
fn two_roots_are_refused() {
    let mut parts = two_joint_arm();
    parts.push(link("loose"));
    assert_mentions(
        &error_of(&robot(&parts)),
        &["not a serial chain", "base", "loose"],
    );
}

#[test]
fn a_loop_is_refused() {
    let mut parts = two_joint_arm();
    parts.push(link("c"));
    parts.push(link("d"));
    parts.push(joint("j3", "revolute", "c", "d", "0 0 1"));
    parts.push(joint("j4", "revolute", "d", "c", "0 0 1"));
    assert_mentions(&error_of(&robot(&parts)), &["not reachable", "c", "d"]);
}

#[test]
fn a_link_with_two_parents_is_refused() {
    let mut parts = two_joint_arm();
    parts.push(joint("j3", "revolute", "base", "b", "0 0 1"));
    assert_mentions(&error_of(&robot(&parts)), &["`b`", "j2", "j3"]);
}

#[test]
fn a_missing_link_is_named() {
    let parts = [
        link("base"),
        link("a"),
        joint("j1", "revolute", "base", "ghost", "0 0 1"),
    ];
    assert_mentions(&error_of(&robot(&parts)), &["j1", "ghost", "not defined"]);
}

#[test]
fn unsupported_joint_types_are_named() {
    for kind in ["floating", "planar"] {
        let mut parts = two_joint_arm();
        parts.push(link("c"));
        parts.push(joint("j3", kind, "b", "c", "0 0 1"));
        assert_mentions(&error_of(&robot(&parts)), &["j3", kind]);
    }
}

#[test]
fn a_zero_axis_is_named() {
    let parts = [
        link("base"),
        link("a"),
        joint("j1", "continuous", "base", "a", "0 0 0"),
    ];
    assert_mentions(&error_of(&robot(&parts)), &["j1", "zero axis"]);
}

#[test]
fn inverted_limits_and_a_missing_velocity_are_named() {
    let bad = robot(&two_joint_arm()).replace(r#"lower="-1" upper="1""#, r#"lower="1" upper="-1""#);
    assert_mentions(&error_of(&bad), &["j1", "lower limit"]);
    let bad = robot(&two_joint_arm()).replace(r#"velocity="1""#, r#"velocity="0""#);
    assert_mentions(&error_of(&bad), &["j1", "velocity"]);
}

#[test]
fn a_chain_without_moving_joints_is_refused() {
    let parts = [
        link("base"),
        link("a"),
        joint("f", "fixed", "base", "a", "0 0 0"),
    ];
    assert_mentions(&error_of(&robot(&parts)), &["no revolute"]);
}

#[test]
fn duplicates_and_broken_xml_are_refused() {
    let mut parts = two_joint_arm();
    parts.push(link("a"));
    assert_mentions(&error_of(&robot(&parts)), &["`a`", "twice"]);
    assert_mentions(
        &error_of("<robot name=\"x\"><link name=\"a\">"),
        &["<string>", "invalid URDF"],
    );
}

#[test]
fn a_bad_type_name_or_missing_file_is_refused() {
    let spec = ModelSpec {
        type_name: "9lives",
        name: "arm",
        urdf: Input::Text(""),
        collision: None,
        ends: None,
        limits: None,
    };
    assert_mentions(&generate_model(&spec).unwrap_err().to_string(), &["9lives"]);
    let path = Path::new("/nonexistent/arm.urdf");
    let spec = ModelSpec {
        type_name: "Arm",
        name: "arm",
        urdf: Input::File(path),
        collision: None,
        ends: None,
        limits: None,
    };
    assert_mentions(
        &generate_model(&spec).unwrap_err().to_string(),
        &["/nonexistent/arm.urdf"],
    );
}

#[test]
fn collision_file_errors_are_named() {
    let urdf = robot(&two_joint_arm());
    let capsule = |link: &str, radius: &str| {
        format!(
            r#"{{"model": "arm", "capsules": [{{"link": "{link}", "a": [0,0,0], "b": [0,0,0.1], "radius": {radius}}}]}}"#
        )
    };
    let cases = [
        (
            r#"{"model": "other", "capsules": []}"#.to_string(),
            vec!["other", "arm"],
        ),
        (capsule("ghost", "0.1"), vec!["capsule 0", "ghost"]),
        (capsule("a", "-0.1"), vec!["capsule 0", "`a`", "radius"]),
        (
            r#"{"model": "arm", "capsules": [], "disabled_pairs": [["a", "nowhere"]]}"#.to_string(),
            vec!["disabled pair", "nowhere"],
        ),
        (
            r#"{"model": "arm"}"#.to_string(),
            vec!["invalid collision file", "capsules"],
        ),
    ];
    for (file, words) in cases {
        match generate(&urdf, Some(&file)) {
            Ok(_) => panic!("accepted {file}"),
            Err(e) => assert_mentions(&e.to_string(), &words),
        }
    }
    assert!(generate(&urdf, Some(&capsule("b", "0.1"))).is_ok());
}

fn with(urdf: &str, ends: Option<Ends>, limits: Option<Limits>) -> Result<String, Error> {
    generate_model(&ModelSpec {
        type_name: "Arm",
        name: "arm",
        urdf: Input::Text(urdf),
        collision: None,
        ends,
        limits,
    })
}

const ENDS: Ends = Ends {
    base: "base",
    tip: "b",
    tool: "b",
};

#[test]
fn with_ends_a_branch_off_the_chain_is_left_out() {
    let mut parts = two_joint_arm();
    parts.push(link("finger"));
    parts.push(joint("f1", "prismatic", "a", "finger", "0 1 0"));
    let code = with(&robot(&parts), Some(ENDS), None).expect("valid");
    assert!(code.contains(r#"const LINK_NAMES: &'static [&'static str] = &["base", "a", "b"];"#));
    // Without a limit the acceleration is unbounded.
    assert!(code.contains("const ACCELERATION: [f64; 2] = [f64::INFINITY, f64::INFINITY];"));
}

#[test]
fn ends_that_are_missing_or_out_of_order_are_named() {
    let urdf = robot(&two_joint_arm());
    let error = |ends| with(&urdf, Some(ends), None).unwrap_err().to_string();
    let tool = Ends {
        tool: "ghost",
        ..ENDS
    };
    assert_mentions(&error(tool), &["tool frame", "ghost"]);
    let upside_down = Ends {
        base: "b",
        tip: "b",
        tool: "base",
    };
    assert_mentions(&error(upside_down), &["`base`", "not below", "`b`"]);
    let early_tip = Ends { tip: "a", ..ENDS };
    assert_mentions(&error(early_tip), &["j2", "tip link `a`"]);
}

#[test]
fn manifest_limits_replace_the_urdfs_and_are_checked() {
    let urdf = robot(&two_joint_arm());
    let limits = |velocity, acceleration| Limits {
        velocity,
        acceleration,
        source: "a datasheet",
    };
    let code = with(&urdf, Some(ENDS), Some(limits(&[2.0, 0.5], &[9.0, 3.0]))).unwrap();
    assert!(
        code.contains("const VELOCITY: [f64; 2] = [2.0, 0.5];"),
        "{code}"
    );
    assert!(code.contains("const ACCELERATION: [f64; 2] = [9.0, 3.0];"));
    assert!(code.contains("limits: a datasheet"));
    let e = with(&urdf, None, Some(limits(&[2.0, 0.5], &[9.0]))).unwrap_err();
    assert_mentions(&e.to_string(), &["acceleration", "1 values for 2"]);
    let e = with(&urdf, None, Some(limits(&[2.0, -1.0], &[9.0, 3.0]))).unwrap_err();
    assert_mentions(&e.to_string(), &["velocity", "value 1", "-1"]);
}
