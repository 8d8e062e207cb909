//! `omcbsa view`: one self-contained HTML page showing a problem and its plan in 3D, working
//! offline. It bundles three.js (MIT, `host/assets/three/`) and the meshes of the models
//! drawn (from each model's folder, `view` in `robots/<model>/model.json`, with its licence
//! in the page), and embeds the scene
//! computed here with the planner's own model (`scene.rs`): the page only places meshes at the
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

/// The meshes of the models that have them (`view` in `robots/<model>/model.json`), embedded
/// by `host/build.rs`.
mod meshes {
    /// One model's meshes, with the credit and licence the page shows.
    pub struct ViewModel {
        /// `Model::NAME`.
        pub name: &'static str,
        pub credit: &'static str,
        pub licence: &'static str,
        /// Binary STL per link name, in the link's frame.
        pub meshes: &'static [(&'static str, &'static [u8])],
    }

    include!(concat!(env!("OUT_DIR"), "/view_meshes.rs"));
}

use meshes::{ViewModel, VIEW_MODELS};

/// Why no page was written.
#[derive(Debug)]
pub enum ViewError {
    /// The problem file breaks the spec.
    Input(InputError),
    /// A file could not be written.
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
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
    let all = model_names::<Fleet, DOF>();
    let text = format!("window.omcbsaAssets = {};\n", assets_json(&all));
    write(path, &text)
}

fn write(path: &Path, text: &str) -> Result<(), ViewError> {
    std::fs::write(path, text).map_err(|source| ViewError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The embedded meshes of the models named `names` (none for a model without).
fn view_models<'n>(names: &'n [&str]) -> impl Iterator<Item = &'static ViewModel> + 'n {
    VIEW_MODELS.iter().filter(|m| names.contains(&m.name))
}

/// The names of `M`'s models.
fn model_names<M: Models<D>, const D: usize>() -> Vec<&'static str> {
    (0..M::COUNT)
        .filter_map(|m| u8::try_from(m).ok())
        .map(M::name)
        .collect()
}

/// three.js, its orbit controls and the meshes of the models named `names` (per model, per
/// link), as one JSON object.
fn assets_json(names: &[&str]) -> String {
    let b64 = base64::engine::general_purpose::STANDARD;
    let meshes: serde_json::Map<String, serde_json::Value> = view_models(names)
        .map(|m| {
            let links: serde_json::Map<String, serde_json::Value> = (m.meshes.iter())
                .map(|(link, stl)| (link.to_string(), b64.encode(stl).into()))
                .collect();
            (m.name.to_string(), links.into())
        })
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
    // The models the robots use: their meshes and their licences.
    let used: Vec<&str> = (scene.robots.iter())
        .filter_map(|r| scene.models.get(usize::from(r.model)))
        .map(|m| m.name)
        .collect();
    let licences: String = view_models(&used)
        .map(|m| {
            format!(
                "<p>{}:</p><pre>{}</pre>",
                escape_html(m.credit),
                escape_html(m.licence)
            )
        })
        .collect();
    let assets = match assets {
        Assets::Inline => format!(
            "<script type=\"application/json\" id=\"assets\">{}</script>",
            assets_json(&used)
        ),
        Assets::Shared(url) => format!("<script src=\"{}\"></script>", escape_html(url)),
    };
    Ok(fill(
        TEMPLATE,
        &[
            ("TITLE", &escape_html(&file.name)),
            ("THREE_LICENSE", &escape_html(THREE_LICENSE)),
            ("MODEL_LICENSES", &licences),
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Every embedded mesh belongs to a link of a compiled-in model (a mesh for a link the
    /// model lacks would never be drawn), and every model of the fleet has meshes.
    #[test]
    fn view_meshes_name_links_of_their_models() {
        let ids = (0..Fleet::COUNT).filter_map(|m| u8::try_from(m).ok());
        let models: Vec<_> = ids
            .map(|m| (Fleet::name(m), Fleet::link_names(m)))
            .collect();
        for view in VIEW_MODELS {
            let (_, links) = (models.iter().find(|(name, _)| *name == view.name))
                .unwrap_or_else(|| panic!("meshes for {}, which is not compiled in", view.name));
            for (link, stl) in view.meshes {
                assert!(links.contains(link), "{}: no link {link}", view.name);
                assert!(stl.len() > 84, "{}: {link}: not a binary STL", view.name);
            }
        }
        for (name, _) in &models {
            assert!(
                VIEW_MODELS.iter().any(|v| v.name == *name),
                "no meshes for {name}"
            );
        }
    }
}
