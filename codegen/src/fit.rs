//! Collision capsules fitted to a URDF's link meshes, and the link pairs of one arm that are
//! never checked against each other: `omcbsa-codegen fit-capsules` writes both to a
//! `collision.json` that code generation reads.

mod capsule;
mod mesh;
mod minimize;
mod pairs;

use std::fmt::{self, Write as _};
use std::path::Path;

use serde::{Deserialize, Serialize};

pub use capsule::{fit_capsules, total_volume, Capsule, MAX_CAPSULES};
pub use mesh::{link_meshes, Mesh};
pub use pairs::{disabled_pairs, parse_srdf, DisabledPair, SrdfEntry};

/// Added to every fitted radius so that rounding in later transforms cannot put a mesh vertex
/// outside its capsules.
pub const MARGIN: f64 = 1e-4;

/// What went wrong, naming the file, link or entry.
#[derive(Debug, Clone, PartialEq)]
pub struct FitError(String);

impl FitError {
    fn new(message: String) -> Self {
        FitError(message)
    }
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FitError {}

/// One capsule of `collision.json`: `a`, `b` in the link's frame, metres.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct LinkCapsule {
    pub link: String,
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub radius: f64,
}

/// The contents of `collision.json`.
#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct CollisionFile {
    pub model: String,
    pub capsules: Vec<LinkCapsule>,
    pub disabled_pairs: Vec<[String; 2]>,
    /// Why each of `disabled_pairs` is disabled (same order).
    #[serde(default)]
    pub disabled_reasons: Vec<String>,
}

impl CollisionFile {
    pub fn read(path: &Path) -> Result<CollisionFile, FitError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| FitError::new(format!("{}: {e}", path.display())))?;
        let file: CollisionFile = serde_json::from_str(&text)
            .map_err(|e| FitError::new(format!("{}: {e}", path.display())))?;
        for (i, c) in file.capsules.iter().enumerate() {
            let finite = c.a.iter().chain(&c.b).all(|x| x.is_finite());
            if !(finite && c.radius >= 0.0 && c.radius.is_finite()) {
                return Err(FitError::new(format!(
                    "{}: capsule {i} (link {}) has a non-finite point or a bad radius",
                    path.display(),
                    c.link
                )));
            }
        }
        if !file.disabled_reasons.is_empty()
            && file.disabled_reasons.len() != file.disabled_pairs.len()
        {
            return Err(FitError::new(format!(
                "{}: {} disabled_reasons for {} disabled_pairs",
                path.display(),
                file.disabled_reasons.len(),
                file.disabled_pairs.len()
            )));
        }
        Ok(file)
    }

    /// Pretty JSON with one capsule or pair per line (diffs stay readable), numbers at full
    /// precision.
    pub fn to_json(&self) -> String {
        fn list<T: Serialize>(items: &[T]) -> String {
            let lines: Vec<String> = items
                .iter()
                .map(|i| {
                    format!(
                        "    {}",
                        serde_json::to_string(i).expect("plain data serialises")
                    )
                })
                .collect();
            if lines.is_empty() {
                "[]".into()
            } else {
                format!("[\n{}\n  ]", lines.join(",\n"))
            }
        }
        format!(
            "{{\n  \"model\": {},\n  \"capsules\": {},\n  \"disabled_pairs\": {},\n  \"disabled_reasons\": {}\n}}\n",
            serde_json::to_string(&self.model).expect("a string serialises"),
            list(&self.capsules),
            list(&self.disabled_pairs),
            list(&self.disabled_reasons)
        )
    }
}

/// The fit of one link, for the summary table.
#[derive(Debug, Clone)]
pub struct LinkFit {
    pub link: String,
    pub vertices: usize,
    /// Extent of the mesh's axis-aligned bounding box in the link frame.
    pub extent: [f64; 3],
    /// With [`MARGIN`] added.
    pub capsules: Vec<Capsule>,
}

/// The result of [`fit_robot`].
#[derive(Debug, Clone)]
pub struct RobotFit {
    pub file: CollisionFile,
    pub links: Vec<LinkFit>,
}

/// Fits capsules to every link mesh of the URDF at `urdf` (meshes looked up by file name in
/// `mesh_dir`) and lists the disabled pairs (adjacent links, plus the SRDF's if given).
pub fn fit_robot(
    urdf: &Path,
    mesh_dir: &Path,
    srdf: Option<&Path>,
    model: &str,
) -> Result<RobotFit, FitError> {
    let robot =
        urdf_rs::read_file(urdf).map_err(|e| FitError::new(format!("{}: {e}", urdf.display())))?;
    let srdf_entries = match srdf {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .map_err(|e| FitError::new(format!("{}: {e}", path.display())))?;
            parse_srdf(&text).map_err(|e| FitError::new(format!("{}: {e}", path.display())))?
        }
        None => Vec::new(),
    };
    let meshes = link_meshes(&robot, mesh_dir)?;
    let links: Vec<LinkFit> = meshes
        .into_iter()
        .map(|(link, mesh)| {
            let mut points = mesh.vertices.clone();
            // Identical vertices of different STL files (or float duplicates) add nothing.
            points.sort_by(|p, q| {
                p.iter()
                    .zip(q.iter())
                    .map(|(a, b)| a.total_cmp(b))
                    .find(|o| o.is_ne())
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
            points.dedup();
            let capsules = fit_capsules(&points)
                .into_iter()
                .map(|c| Capsule {
                    radius: c.radius + MARGIN,
                    ..c
                })
                .collect();
            LinkFit {
                link,
                vertices: points.len(),
                extent: mesh.extent().into(),
                capsules,
            }
        })
        .collect();
    let names: Vec<String> = links.iter().map(|l| l.link.clone()).collect();
    let pairs = disabled_pairs(&robot, &names, &srdf_entries)?;
    let file = CollisionFile {
        model: model.to_owned(),
        capsules: links
            .iter()
            .flat_map(|l| {
                l.capsules.iter().map(|c| LinkCapsule {
                    link: l.link.clone(),
                    a: c.a.into(),
                    b: c.b.into(),
                    radius: c.radius,
                })
            })
            .collect(),
        disabled_pairs: pairs.iter().map(|p| p.links.clone()).collect(),
        disabled_reasons: pairs.into_iter().map(|p| p.reason).collect(),
    };
    Ok(RobotFit { file, links })
}

impl RobotFit {
    /// A Markdown table: one row per link, with its capsules' total volume over that of the
    /// mesh's bounding box in the link frame (Kinova's meshes are hollow shells, so their own
    /// enclosed volume would be no fair reference).
    pub fn table(&self) -> String {
        let mut out = String::from(
            "| link | vertices | bounding box (mm) | capsules | radius (mm) | length (mm) | capsules / box volume |\n\
             |---|---:|---:|---:|---:|---:|---:|\n",
        );
        for l in &self.links {
            let mm = |values: Vec<f64>| {
                values
                    .iter()
                    .map(|v| format!("{:.1}", v * 1e3))
                    .collect::<Vec<_>>()
            };
            let radii = mm(l.capsules.iter().map(|c| c.radius).collect());
            let lengths = mm(l.capsules.iter().map(|c| c.length()).collect());
            let ratio = total_volume(&l.capsules) / l.extent.iter().product::<f64>();
            let _ = writeln!(
                out,
                "| {} | {} | {} | {} | {} | {} | {:.2} |",
                l.link,
                l.vertices,
                mm(l.extent.to_vec()).join(" x "),
                l.capsules.len(),
                radii.join(", "),
                lengths.join(", "),
                ratio
            );
        }
        out
    }
}
