//! Collision capsules fitted to a URDF's link meshes, and the link pairs of one arm that are
//! never checked against each other: `omcbsa-codegen fit-capsules` writes both to a
//! `collision.json` that code generation reads.

mod capsule;
mod mesh;
mod minimize;
mod pairs;
mod shape;
mod slack;

use std::fmt::{self, Write as _};
use std::path::Path;

use serde::{Deserialize, Serialize};

pub use capsule::{refine, Fit};
pub use mesh::{link_meshes, Mesh};
pub use pairs::{disabled_pairs, parse_srdf, DisabledPair, SrdfEntry};
pub use shape::{total_volume, Capsule};
pub use slack::{MeshDistance, Slack, SPACING};

/// Added to every fitted radius so that rounding in later transforms cannot put a mesh vertex
/// outside its capsules.
pub const MARGIN: f64 = 1e-4;

/// Most capsules of one arm: the core's `MAX_ARM_CAPSULES` (a generated model with more does
/// not compile).
pub const CAPSULE_BUDGET: usize = 16;

/// What a capsule costs when the budget is shared out, metres of [`Fit::score`]: one that takes
/// less off its link's score is not worth the distance queries it adds to the planner's inner
/// loop.
const CAPSULE_COST: f64 = 0.002;

/// Most capsules fitted to one link.
pub const MAX_CAPSULES: usize = 5;

/// Fits of a link carried from one capsule count to the next (the best split of the best fit
/// is not always on the way to the best fit with one capsule more).
const BEAM: usize = 3;

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
    /// Of the capsules before the margin.
    pub slack: Slack,
}

/// The result of [`fit_robot`].
#[derive(Debug, Clone)]
pub struct RobotFit {
    pub file: CollisionFile,
    pub links: Vec<LinkFit>,
}

/// Fits capsules to every link mesh of the URDF at `urdf` (meshes looked up by file name in
/// `mesh_dir`; with `ends`, of the chain's links, see [`link_meshes`]) and lists the disabled
/// pairs (adjacent links, plus the SRDF's if given).
pub fn fit_robot(
    urdf: &Path,
    mesh_dir: &Path,
    srdf: Option<&Path>,
    model: &str,
    ends: Option<crate::Ends>,
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
    let meshes = link_meshes(&robot, mesh_dir, ends)?;
    let mut links = Vec::new();
    for (link, mesh) in meshes {
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
        let distance = MeshDistance::new(&mesh)
            .ok_or_else(|| FitError::new(format!("link {link}: a mesh without triangles")))?;
        // A beam search: the best few fits with one capsule more split one group of a fit
        // with one less; the best with each count is kept.
        let mut beam = vec![Fit::one(&points, &distance)];
        let mut fits = vec![beam[0].clone()];
        while fits.len() < MAX_CAPSULES {
            let mut next: Vec<Fit> = beam.iter().flat_map(|f| refine(f, &distance)).collect();
            // Stable: equal scores stay in the order made, so the fit is deterministic.
            next.sort_by(|a, b| a.score().total_cmp(&b.score()));
            next.truncate(BEAM);
            let Some(best) = next.first() else {
                break;
            };
            fits.push(best.clone());
            beam = next;
        }
        links.push((link, points.len(), mesh.extent(), fits));
    }
    let counts =
        allocate(&links.iter().map(|l| &l.3[..]).collect::<Vec<_>>()).ok_or_else(|| {
            FitError::new(format!(
                "{} links with meshes, more than the budget of {CAPSULE_BUDGET} capsules",
                links.len()
            ))
        })?;
    let links: Vec<LinkFit> = (links.into_iter().zip(counts))
        .map(|((link, vertices, extent, mut fits), count)| {
            (link, vertices, extent, fits.swap_remove(count - 1))
        })
        .map(|(link, vertices, extent, fit)| LinkFit {
            link,
            vertices,
            extent: extent.into(),
            slack: fit.slack,
            capsules: (fit.capsules.into_iter())
                .map(|c| Capsule {
                    radius: c.radius + MARGIN,
                    ..c
                })
                .collect(),
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

/// How many capsules each link gets, given its fits with 1, 2, ... capsules: at most
/// [`CAPSULE_BUDGET`] in all, the least sum over links of [`Fit::score`], each capsule
/// counting as [`CAPSULE_COST`] more (a small knapsack, solved exactly); `None` when there are
/// more links than capsules.
fn allocate(links: &[&[Fit]]) -> Option<Vec<usize>> {
    let cost = |f: &Fit| f.score() + CAPSULE_COST * f.capsules.len() as f64;
    // best[n]: least cost of the links so far with n capsules, and each link's count.
    let mut best: Vec<Option<(f64, Vec<usize>)>> = vec![None; CAPSULE_BUDGET + 1];
    best[0] = Some((0.0, Vec::new()));
    for fits in links {
        let mut after: Vec<Option<(f64, Vec<usize>)>> = vec![None; CAPSULE_BUDGET + 1];
        for (n, so_far) in best.iter().enumerate() {
            let Some((total, counts)) = so_far else {
                continue;
            };
            for (k, fit) in (1..).zip(fits.iter()) {
                if n + k > CAPSULE_BUDGET {
                    break;
                }
                let candidate = total + cost(fit);
                if after[n + k].as_ref().is_none_or(|(t, _)| candidate < *t) {
                    let mut counts = counts.clone();
                    counts.push(k);
                    after[n + k] = Some((candidate, counts));
                }
            }
        }
        best = after;
    }
    (best.into_iter().flatten())
        .reduce(|b, c| if c.0 < b.0 { c } else { b })
        .map(|(_, counts)| counts)
}

impl RobotFit {
    /// A Markdown table: one row per link, with its capsules' total volume over that of the
    /// mesh's bounding box in the link frame (Kinova's meshes are hollow shells, so their own
    /// enclosed volume would be no fair reference).
    pub fn table(&self) -> String {
        let mut out = String::from(
            "| link | vertices | bounding box (mm) | capsules | radius (mm) | length (mm) | capsules / box volume | largest slack (mm) | mean slack (mm) |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
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
                "| {} | {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.1} |",
                l.link,
                l.vertices,
                mm(l.extent.to_vec()).join(" x "),
                l.capsules.len(),
                radii.join(", "),
                lengths.join(", "),
                ratio,
                l.slack.largest * 1e3,
                l.slack.mean * 1e3
            );
        }
        out
    }
}
