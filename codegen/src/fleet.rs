//! Rust source for a fleet: one type over every compiled model of one DoF, implementing
//! `crate::model::Models<D>` by dispatching each query on the robot's model index to the
//! generated model types (so nothing but generated code names a robot).

use std::fmt::Write;

/// One `Models` function: its name, its parameters after `id: u8` and its return type.
const QUERIES: [(&str, &str, &str); 19] = [
    ("name", "", "&'static str"),
    ("link_names", "", "&'static [&'static str]"),
    ("joint_names", "", "&'static [&'static str; D]"),
    ("lower", "", "&'static [f64; D]"),
    ("upper", "", "&'static [f64; D]"),
    ("velocity", "", "&'static [f64; D]"),
    ("acceleration", "", "&'static [f64; D]"),
    ("capsules", "", "&'static [crate::model::LinkCapsule]"),
    ("self_pairs", "", "&'static [(u8, u8)]"),
    ("reach", "", "&'static [f64; D]"),
    ("capsule_reach", "", "&'static [[f64; D]]"),
    ("tool_self_capsules", "", "&'static [u8]"),
    ("tool_reach", "", "&'static [f64; D]"),
    ("axis_cos", "", "&'static [f64; D]"),
    ("fk", "q: &[f64; D]", "crate::model::Frame"),
    (
        "link_frames",
        "q: &[f64; D], out: &mut [crate::model::Frame]",
        "crate::model::Frame",
    ),
    (
        "fk_lanes",
        "q: &[crate::lanes::F64s; D]",
        "crate::model::FrameOf<crate::lanes::F64s>",
    ),
    (
        "link_frames_lanes",
        "q: &[crate::lanes::F64s; D], out: impl crate::model::LinkSink",
        "::core::ops::ControlFlow<(), crate::model::FrameOf<crate::lanes::F64s>>",
    ),
    (
        "jacobian",
        "q: &[f64; D]",
        "(crate::model::Frame, ::nalgebra::SMatrix<f64, 6, D>)",
    ),
];

/// The argument names of a parameter list (`"q: &[f64; D], out: ..."` -> `"q, out"`).
fn arguments(params: &str) -> String {
    (params.split(", ").filter(|p| !p.is_empty()))
        .map(|p| p.split(':').next().unwrap_or(p).trim())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Source of the unit struct `type_name` implementing `Models<dof>` over `models` (type
/// names, in index order; at least one). An index past the last reads as the last model.
///
/// ```
/// use omcbsa_codegen::generate_fleet;
///
/// let models = [("KinovaGen3", "kinova_gen3"), ("FrankaPanda", "franka_panda")];
/// let source = generate_fleet("Fleet7", 7, &models);
/// assert!(source.contains("pub struct Fleet7;"));
/// assert!(source.contains("impl crate::model::Models<7> for Fleet7"));
/// assert!(source.contains("const COUNT: usize = 2;"));
/// // Each query dispatches on the model index.
/// assert!(source.contains("0 => <KinovaGen3 as crate::model::Models<7>>::fk(0, q),"));
/// assert!(source.contains("_ => <FrankaPanda as crate::model::Models<7>>::fk(0, q),"));
/// ```
pub fn fleet(type_name: &str, dof: usize, models: &[(&str, &str)]) -> String {
    let mut out = String::new();
    let w = &mut out;
    let listed: Vec<String> = (models.iter().enumerate())
        .map(|(i, (ty, name))| format!("{i} `{name}` ([`{ty}`])"))
        .collect();
    let _ = writeln!(
        w,
        "/// Every compiled model with {dof} actuated joints, by index: {}.",
        listed.join(", ")
    );
    let _ = writeln!(w, "#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]");
    let _ = writeln!(w, "pub struct {type_name};\n");
    // A fleet of one model is a match of one arm, kept for uniform code.
    let _ = writeln!(w, "#[allow(clippy::match_single_binding)]");
    let _ = writeln!(w, "impl crate::model::Models<{dof}> for {type_name} {{");
    let _ = writeln!(w, "    const COUNT: usize = {};", models.len());
    let checks: String = (models.iter())
        .map(|(ty, _)| format!(" crate::model::check_model::<{ty}, {dof}>();"))
        .collect();
    let _ = writeln!(w, "    const CHECKED: () = {{{checks} }};");
    for (query, params, ret) in QUERIES {
        let ret = ret.replace('D', &dof.to_string());
        let params = params.replace('D', &dof.to_string());
        let sep = if params.is_empty() { "" } else { ", " };
        let args = arguments(&params);
        let _ = writeln!(w, "    #[inline]");
        let _ = writeln!(w, "    fn {query}(id: u8{sep}{params}) -> {ret} {{");
        let _ = writeln!(w, "        match id {{");
        let last = models.len().saturating_sub(1);
        for (i, (ty, _)) in models.iter().enumerate() {
            let pattern = if i == last {
                "_".to_string()
            } else {
                i.to_string()
            };
            let _ = writeln!(
                w,
                "            {pattern} => <{ty} as crate::model::Models<{dof}>>::{query}(0{sep}{args}),"
            );
        }
        let _ = writeln!(w, "        }}\n    }}");
    }
    let _ = writeln!(w, "}}");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatches_every_query_by_index_with_the_last_taking_the_rest() {
        let code = fleet("Fleet7", 7, &[("A", "a"), ("B", "b")]);
        assert_eq!(code.matches("match id").count(), QUERIES.len());
        assert!(
            code.contains("0 => <A as crate::model::Models<7>>::fk(0, q),"),
            "{code}"
        );
        assert!(code.contains("_ => <B as crate::model::Models<7>>::link_frames(0, q, out),"));
        assert!(code.contains("const COUNT: usize = 2;"));
        assert!(code.contains("SMatrix<f64, 6, 7>"));
    }
}
