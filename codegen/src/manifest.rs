//! A model's folder: `robots/<model>/model.json` names the URDF, the chain's ends, the limits
//! with their source and the collision file, so that adding a model is adding a folder.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::chain::Ends;
use crate::{Error, Input, Limits, ModelSpec};

/// The manifest's name inside a model's folder.
pub const FILE: &str = "model.json";

/// `model.json`. Paths are relative to the model's folder.
#[derive(Deserialize, Debug, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// `Model::NAME`, the name problem files use.
    pub name: String,
    /// The generated Rust type.
    #[serde(rename = "type")]
    pub type_name: String,
    /// The URDF file.
    pub urdf: String,
    /// The link the chain starts at (the model's base frame).
    pub base_link: String,
    /// The last link of the arm proper: only fixed joints may follow it.
    pub tip_link: String,
    /// The frame `fk` reports: hand poses are poses of this frame.
    pub tool_frame: String,
    /// Why this tool frame (free text).
    #[serde(default)]
    pub tool_frame_note: String,
    /// The vendor's joint limits.
    pub limits: ManifestLimits,
    /// The collision capsules: their file and how they were fitted.
    pub capsules: FitSettings,
    /// What the plan viewer draws for the links (none: it draws the capsules).
    #[serde(default)]
    pub view: Option<ViewMeshes>,
}

/// Meshes the plan viewer (`omcbsa view`) draws, read by the host's build script.
#[derive(Deserialize, Debug, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ViewMeshes {
    /// Whose meshes these are and under which licence, as the page credits them.
    pub credit: String,
    /// The licence file the page shows.
    pub licence: String,
    /// Binary STL per link name, in the link's frame.
    pub meshes: std::collections::BTreeMap<String, String>,
}

/// Per actuated joint, in chain order.
#[derive(Deserialize, Debug, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ManifestLimits {
    /// rad/s (m/s for a prismatic joint).
    pub velocity: Vec<f64>,
    /// rad/s² (m/s²).
    pub acceleration: Vec<f64>,
    /// Where the numbers come from.
    pub source: String,
}

/// How `omcbsa-codegen fit-capsules` made the collision file, so it can be made again.
#[derive(Deserialize, Debug, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FitSettings {
    /// The collision file code generation reads (`collision.json`).
    pub file: String,
    /// Folder of the collision meshes, looked up by file name (none: capsules written by hand).
    #[serde(default)]
    pub meshes: Option<String>,
    /// MoveIt SRDF whose disabled pairs are kept.
    #[serde(default)]
    pub srdf: Option<String>,
    /// How the file was made, where not by fitting (free text).
    #[serde(default)]
    pub note: String,
}

/// A model's folder and its manifest.
#[derive(Debug, Clone)]
pub struct Folder {
    /// The folder.
    pub dir: PathBuf,
    /// Its `model.json`.
    pub manifest: Manifest,
}

impl Folder {
    /// Reads `dir`'s manifest ([`FILE`]); an unreadable or malformed one is an [`Error`]
    /// naming the file.
    pub fn read(dir: &Path) -> Result<Folder, Error> {
        let path = dir.join(FILE);
        let (source, text) = Input::File(&path).read()?;
        let manifest = serde_json::from_str(&text).map_err(|e| Error::Manifest {
            source,
            message: e.to_string(),
        })?;
        Ok(Folder {
            dir: dir.to_path_buf(),
            manifest,
        })
    }

    /// The URDF's path.
    pub fn urdf(&self) -> PathBuf {
        self.dir.join(&self.manifest.urdf)
    }

    /// The collision file's path (it may not exist yet: `fit-capsules` writes it).
    pub fn collision(&self) -> PathBuf {
        self.dir.join(&self.manifest.capsules.file)
    }

    /// The folder of the link meshes the capsules are fitted to, if any.
    pub fn meshes(&self) -> Option<PathBuf> {
        self.manifest
            .capsules
            .meshes
            .as_ref()
            .map(|m| self.dir.join(m))
    }

    /// The SRDF whose disabled collision pairs the fit keeps, if any.
    pub fn srdf(&self) -> Option<PathBuf> {
        self.manifest
            .capsules
            .srdf
            .as_ref()
            .map(|s| self.dir.join(s))
    }

    /// The chain's ends: base link, tip link and tool frame.
    pub fn ends(&self) -> Ends<'_> {
        Ends {
            base: &self.manifest.base_link,
            tip: &self.manifest.tip_link,
            tool: &self.manifest.tool_frame,
        }
    }

    /// What code generation needs; `urdf` and `collision` are the paths of [`Folder::urdf`]
    /// and [`Folder::collision`] (borrowed from the caller so the spec can refer to them).
    pub fn spec<'a>(&'a self, urdf: &'a Path, collision: &'a Path) -> ModelSpec<'a> {
        let m = &self.manifest;
        ModelSpec {
            type_name: &m.type_name,
            name: &m.name,
            urdf: Input::File(urdf),
            collision: collision.exists().then_some(Input::File(collision)),
            ends: Some(self.ends()),
            limits: Some(Limits {
                velocity: &m.limits.velocity,
                acceleration: &m.limits.acceleration,
                source: &m.limits.source,
            }),
        }
    }
}

/// Rust source for the model in `dir` (see [`crate::generate_model`]): what `core/build.rs`
/// runs for every folder it compiles in.
///
/// ```
/// use std::path::Path;
///
/// use omcbsa_codegen::manifest::{generate_folder, Folder};
///
/// let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots/synthetic");
/// let folder = Folder::read(&dir).unwrap();
/// assert_eq!(folder.manifest.type_name, "SyntheticChain");
/// let source = generate_folder(&dir).unwrap();
/// assert!(source.contains("impl crate::model::Model<5> for SyntheticChain"));
/// // The manifest's limits replace the URDF's, and their source is kept in the docs.
/// assert!(source.contains("const ACCELERATION: [f64; 5] = [5.0, 1.0, 8.0, 6.0, 7.0];"));
/// assert!(source.contains("made up for the tests"));
///
/// // A folder without a manifest is an error naming the file.
/// let err = generate_folder(&dir.join("no_such_model")).unwrap_err();
/// assert!(err.to_string().contains("model.json"), "{err}");
/// ```
pub fn generate_folder(dir: &Path) -> Result<String, Error> {
    let folder = Folder::read(dir)?;
    let (urdf, collision) = (folder.urdf(), folder.collision());
    crate::generate_model(&folder.spec(&urdf, &collision))
}
