//! `omcbsa view`: one self-contained HTML page showing a problem and its plan in 3D, working
//! offline. It bundles three.js (MIT, `host/assets/three/`), Kinova's Gen3 meshes decimated
//! for the page (BSD, `host/assets/gen3/`) and the Panda's collision meshes (Apache-2.0,
//! `robots/franka_panda/meshes/`; notices in the page), and embeds the scene
//! computed here with the planner's own model ([`scene`]): the page only places meshes at the
//! link frames it is given, so what it draws is what the planner and the validator checked.
//!
//! The page exposes `window.omcbsaView` (`ready`, `error`, `arms()`, `steps`, `step()`,
//! `setStep(t)`, `jointAngles()`) for tests and scripts; `jointAngles()` reads the angles back
//! from the drawn meshes' frames.

mod scene;

use std::fmt;
use std::path::{Path, PathBuf};

use base64::Engine;
use omcbsa_core::model::Models;

use crate::models::{Fleet, DOF};

use crate::error::InputError;
use crate::format::{ProblemFile, SolutionFile};
use crate::load;
use crate::validate::{validate, Report};

pub use scene::Scene;

const TEMPLATE: &str = include_str!("../../assets/view/page.html");
const VIEWER_JS: &str = include_str!("../../assets/view/viewer.js");
const THREE_JS: &str = include_str!("../../assets/three/three.module.min.js");
const ORBIT_JS: &str = include_str!("../../assets/three/OrbitControls.js");
const THREE_LICENSE: &str = include_str!("../../assets/three/LICENSE");
const KINOVA_LICENSE: &str = include_str!("../../assets/gen3/LICENSE");
const PANDA_LICENSE: &str = include_str!("../../../robots/franka_panda/LICENSE");

/// The links that have a mesh, by link name (unique across the models), with it (binary STL):
/// the Gen3's decimated by `host/assets/gen3/decimate.py`, the Panda's collision meshes as
/// its model folder keeps them (200 to 300 triangles each).
const MESHES: [(&str, &[u8]); 17] = [
    (
        "base_link",
        include_bytes!("../../assets/gen3/base_link.stl"),
    ),
    (
        "shoulder_link",
        include_bytes!("../../assets/gen3/shoulder_link.stl"),
    ),
    (
        "half_arm_1_link",
        include_bytes!("../../assets/gen3/half_arm_1_link.stl"),
    ),
    (
        "half_arm_2_link",
        include_bytes!("../../assets/gen3/half_arm_2_link.stl"),
    ),
    (
        "forearm_link",
        include_bytes!("../../assets/gen3/forearm_link.stl"),
    ),
    (
        "spherical_wrist_1_link",
        include_bytes!("../../assets/gen3/spherical_wrist_1_link.stl"),
    ),
    (
        "spherical_wrist_2_link",
        include_bytes!("../../assets/gen3/spherical_wrist_2_link.stl"),
    ),
    (
        "bracelet_link",
        include_bytes!("../../assets/gen3/bracelet_no_vision_link.stl"),
    ),
    (
        "panda_link0",
        include_bytes!("../../../robots/franka_panda/meshes/link0.stl"),
    ),
    (
        "panda_link1",
        include_bytes!("../../../robots/franka_panda/meshes/link1.stl"),
    ),
    (
        "panda_link2",
        include_bytes!("../../../robots/franka_panda/meshes/link2.stl"),
    ),
    (
        "panda_link3",
        include_bytes!("../../../robots/franka_panda/meshes/link3.stl"),
    ),
    (
        "panda_link4",
        include_bytes!("../../../robots/franka_panda/meshes/link4.stl"),
    ),
    (
        "panda_link5",
        include_bytes!("../../../robots/franka_panda/meshes/link5.stl"),
    ),
    (
        "panda_link6",
        include_bytes!("../../../robots/franka_panda/meshes/link6.stl"),
    ),
    (
        "panda_link7",
        include_bytes!("../../../robots/franka_panda/meshes/link7.stl"),
    ),
    (
        "panda_hand",
        include_bytes!("../../../robots/franka_panda/meshes/hand.stl"),
    ),
];

/// Why no page was written.
#[derive(Debug)]
pub enum ViewError {
    /// The problem file breaks the spec.
    Input(InputError),
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The scene could not be written as JSON.
    Encode(String),
}

impl fmt::Display for ViewError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ViewError::Input(e) => e.fmt(f),
            ViewError::Io { path, source } => {
                write!(f, "cannot write {}: {source}", path.display())
            }
            ViewError::Encode(e) => write!(f, "cannot encode the scene: {e}"),
        }
    }
}

impl std::error::Error for ViewError {}

/// Where a page finds three.js and the meshes (2 MB together).
#[derive(Clone, Copy, Debug)]
pub enum Assets<'a> {
    /// In the page itself: one file that works anywhere.
    Inline,
    /// In the script [`write_assets`] writes, at this URL relative to the page: many pages
    /// of one directory share it.
    Shared(&'a str),
}

/// The page for `problem`, and `solution` when given. `report` is the solution's validation;
/// when `None` the solution is validated here. The page marks the clashing links and the step
/// of every collision the report names.
pub fn html(
    problem: &ProblemFile,
    solution: Option<&SolutionFile>,
    report: Option<&Report>,
    assets: Assets,
) -> Result<String, ViewError> {
    page::<Fleet, DOF>(problem, solution, report, assets)
}

/// Writes the self-contained [`html`] page to `path`.
pub fn write_html(
    problem: &ProblemFile,
    solution: Option<&SolutionFile>,
    report: Option<&Report>,
    path: &Path,
) -> Result<(), ViewError> {
    write(path, &html(problem, solution, report, Assets::Inline)?)
}

/// Writes the script that pages made with [`Assets::Shared`] load.
pub fn write_assets(path: &Path) -> Result<(), ViewError> {
    let text = format!("window.omcbsaAssets = {};\n", assets_json::<Fleet, DOF>());
    write(path, &text)
}

fn write(path: &Path, text: &str) -> Result<(), ViewError> {
    std::fs::write(path, text).map_err(|source| ViewError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// three.js, its orbit controls and the meshes of the links of `M`'s models, as one JSON
/// object.
fn assets_json<M: Models<D>, const D: usize>() -> String {
    let b64 = base64::engine::general_purpose::STANDARD;
    let of_a_model = |link: &str| {
        (0..M::COUNT).any(|m| u8::try_from(m).is_ok_and(|m| M::link_names(m).contains(&link)))
    };
    let meshes: serde_json::Map<String, serde_json::Value> = (MESHES.iter())
        .filter(|(link, _)| of_a_model(link))
        .map(|(link, stl)| (link.to_string(), b64.encode(stl).into()))
        .collect();
    let assets = serde_json::json!({ "three": THREE_JS, "orbit": ORBIT_JS, "meshes": meshes });
    script_safe(&assets.to_string())
}

/// JSON inside a <script> element: `</` could end it early; `<\/` is the same JSON.
fn script_safe(json: &str) -> String {
    json.replace("</", "<\\/")
}

fn page<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    solution: Option<&SolutionFile>,
    report: Option<&Report>,
    assets: Assets,
) -> Result<String, ViewError> {
    let problem = load::problem::<M, D>(file).map_err(ViewError::Input)?;
    let own_report;
    let report = match (solution, report) {
        (Some(s), None) => {
            own_report = validate::<M, D>(file, &problem, s);
            Some(&own_report)
        }
        (_, r) => r,
    };
    let scene = scene::scene::<M, D>(file, &problem, solution.zip(report));
    let data = serde_json::to_string(&scene).map_err(|e| ViewError::Encode(e.to_string()))?;
    let assets = match assets {
        Assets::Inline => format!(
            "<script type=\"application/json\" id=\"assets\">{}</script>",
            assets_json::<M, D>()
        ),
        Assets::Shared(url) => format!("<script src=\"{}\"></script>", escape_html(url)),
    };
    Ok(fill(
        TEMPLATE,
        &[
            ("TITLE", &escape_html(&file.name)),
            ("THREE_LICENSE", &escape_html(THREE_LICENSE)),
            ("KINOVA_LICENSE", &escape_html(KINOVA_LICENSE)),
            ("PANDA_LICENSE", &escape_html(PANDA_LICENSE)),
            ("ASSETS", &assets),
            ("VIEWER_JS", VIEWER_JS),
            ("DATA", &script_safe(&data)),
        ],
    ))
}

/// `template` with every `{{NAME}}` replaced by its value, in one pass (so a value is never
/// searched for placeholders).
fn fill(template: &str, values: &[(&str, &str)]) -> String {
    let mut out =
        String::with_capacity(template.len() + values.iter().map(|v| v.1.len()).sum::<usize>());
    let mut rest = template;
    while let Some(start) = rest.find("{{") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 2..];
        match after.find("}}").and_then(|end| {
            let name = &after[..end];
            values
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| (end, *v))
        }) {
            Some((end, value)) => {
                out.push_str(value);
                rest = &after[end + 2..];
            }
            None => {
                out.push_str("{{");
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

fn escape_html(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
