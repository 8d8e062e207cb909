//! Link collision meshes: STL files placed in their link's frame as the URDF says.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

use super::FitError;

/// The vertices of a link's collision mesh in the link's frame, metres. (Enclosing the
/// vertices encloses the triangles: capsules are convex.)
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vector3<f64>>,
    /// Indices into `vertices`, for measuring distances to the surface.
    pub triangles: Vec<[usize; 3]>,
}

impl Mesh {
    /// The vertices of a binary or ASCII STL file, identical ones merged.
    pub fn read_stl(path: &Path) -> Result<Mesh, FitError> {
        let file =
            File::open(path).map_err(|e| FitError::new(format!("{}: {e}", path.display())))?;
        let stl = stl_io::read_stl(&mut BufReader::new(file)).map_err(|e| {
            FitError::new(format!("{}: not a readable STL file: {e}", path.display()))
        })?;
        let vertices: Vec<Vector3<f64>> = stl
            .vertices
            .iter()
            .map(|v| Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64))
            .collect();
        if let Some(bad) = vertices
            .iter()
            .position(|v| !v.iter().all(|c| c.is_finite()))
        {
            return Err(FitError::new(format!(
                "{}: vertex {bad} is not finite",
                path.display()
            )));
        }
        let triangles = stl.faces.iter().map(|f| f.vertices).collect();
        Ok(Mesh {
            vertices,
            triangles,
        })
    }

    /// The mesh scaled per axis, then moved by `pose`.
    pub fn placed(mut self, scale: &Vector3<f64>, pose: &Isometry3<f64>) -> Mesh {
        for v in &mut self.vertices {
            *v = pose
                .transform_point(&Point3::from(v.component_mul(scale)))
                .coords;
        }
        self
    }

    /// The cube `[-1, 1]^3`, as 8 vertices and 12 outward triangles.
    fn cube() -> Mesh {
        let vertices = (0..8)
            .map(|i| Vector3::from_fn(|k, _| if i >> k & 1 == 1 { 1.0 } else { -1.0 }))
            .collect();
        // Two triangles per face; vertex i has x = bit 0, y = bit 1, z = bit 2.
        let triangles = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6], // z = -1, z = +1
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7], // y = -1, y = +1
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5], // x = -1, x = +1
        ];
        Mesh {
            vertices,
            triangles,
        }
    }

    /// Adds `other`'s vertices to this mesh.
    pub fn append(&mut self, other: Mesh) {
        let offset = self.vertices.len();
        self.vertices.extend(other.vertices);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + offset)));
    }

    /// Extent of the axis-aligned bounding box.
    pub fn extent(&self) -> Vector3<f64> {
        let lo = self
            .vertices
            .iter()
            .fold(Vector3::repeat(f64::INFINITY), |m, p| m.inf(p));
        let hi = self
            .vertices
            .iter()
            .fold(Vector3::repeat(f64::NEG_INFINITY), |m, p| m.sup(p));
        hi - lo
    }
}

/// Most positions at which a moving joint off the chain (a finger) is placed: its range is
/// sampled at most this far apart, metres or radians.
const OFF_CHAIN_STEP: f64 = 0.005;

/// The collision mesh of every chain link that has one, in chain order. Mesh file names
/// (`package://...`, `file://...` or plain paths) are looked up by their last path component
/// in `mesh_dir`; a link with several collision elements gets their union; boxes are meshed.
///
/// With `ends`, the chain runs from the base link to the tool frame, and the geometry of links
/// off it (a gripper's fingers) is added to the chain link they hang from; a prismatic joint
/// between them is placed at both ends of its range and every `OFF_CHAIN_STEP` (5 mm) between, so
/// the capsules hold the fingers wherever they are. Without `ends`, every URDF link with
/// geometry is its own.
pub fn link_meshes(
    robot: &urdf_rs::Robot,
    mesh_dir: &Path,
    ends: Option<crate::Ends>,
) -> Result<Vec<(String, Mesh)>, FitError> {
    let chain: Vec<String> = match ends {
        Some(ends) => {
            crate::chain::from_urdf(robot, Some(ends))
                .map_err(|e| FitError::new(e.to_string()))?
                .links
        }
        None => robot.links.iter().map(|l| l.name.clone()).collect(),
    };
    let mut meshes: Vec<(String, Mesh)> =
        chain.iter().map(|l| (l.clone(), Mesh::default())).collect();
    for link in &robot.links {
        let (owner, poses) = placements(robot, &chain, &link.name)?;
        let Some(slot) = meshes.iter_mut().find(|(l, _)| *l == owner) else {
            continue;
        };
        for collision in &link.collision {
            let own = element_mesh(&link.name, collision, mesh_dir)?;
            for pose in &poses {
                slot.1
                    .append(own.clone().placed(&Vector3::repeat(1.0), pose));
            }
        }
    }
    meshes.retain(|(_, m)| !m.vertices.is_empty());
    for (link, mesh) in &meshes {
        // Meshes exported in millimetres would give capsules a thousand times too big.
        let extent = mesh.extent().norm();
        if extent > 10.0 {
            return Err(FitError::new(format!(
                "link {link}: mesh spans {extent:.1} units; meshes must be in metres (set the URDF mesh scale)"
            )));
        }
    }
    Ok(meshes)
}

/// The chain link that carries `link` (itself, or the chain link it hangs from) and the poses
/// of `link`'s frame in that link's frame it can take; no chain link: not part of the model.
fn placements(
    robot: &urdf_rs::Robot,
    chain: &[String],
    link: &str,
) -> Result<(String, Vec<Isometry3<f64>>), FitError> {
    let mut below = Vec::new();
    let mut at = link;
    while !chain.iter().any(|l| l == at) {
        let Some(joint) = robot.joints.iter().find(|j| j.child.link == at) else {
            // Above the base link or beside the chain: not part of the model.
            return Ok((String::new(), Vec::new()));
        };
        below.push(joint);
        at = &joint.parent.link;
    }
    let mut poses = vec![Isometry3::identity()];
    for joint in below.iter().rev() {
        let origin = origin_pose(&joint.origin);
        let values = match joint.joint_type {
            urdf_rs::JointType::Fixed => vec![0.0],
            urdf_rs::JointType::Prismatic => {
                let (lo, hi) = (joint.limit.lower, joint.limit.upper);
                if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                    return Err(FitError::new(format!(
                        "joint {} (off the chain): bad limits {lo}..{hi}",
                        joint.name
                    )));
                }
                let n = ((hi - lo) / OFF_CHAIN_STEP).ceil().max(1.0) as usize;
                (0..=n)
                    .map(|i| lo + (hi - lo) * i as f64 / n as f64)
                    .collect()
            }
            _ => {
                return Err(FitError::new(format!(
                    "joint {} (off the chain, carrying link {link}) is {:?}; only fixed and \
                     prismatic joints can be folded into the chain link they hang from",
                    joint.name, joint.joint_type
                )))
            }
        };
        let axis = Vector3::from(joint.axis.xyz.0);
        poses = poses
            .iter()
            .flat_map(|p| {
                values
                    .iter()
                    .map(move |&q| p * origin * Translation3::from(axis * q))
            })
            .collect();
    }
    Ok((at.to_string(), poses))
}

/// One collision element of `link` in the link's frame: a mesh file or a box.
fn element_mesh(
    link: &str,
    collision: &urdf_rs::Collision,
    mesh_dir: &Path,
) -> Result<Mesh, FitError> {
    let pose = origin_pose(&collision.origin);
    match &collision.geometry {
        urdf_rs::Geometry::Mesh { filename, scale } => {
            let path = mesh_path(mesh_dir, filename).ok_or_else(|| {
                FitError::new(format!("link {link}: mesh file name {filename:?} is empty"))
            })?;
            let scale = scale
                .as_ref()
                .map_or(Vector3::repeat(1.0), |s| Vector3::new(s[0], s[1], s[2]));
            Ok(Mesh::read_stl(&path)?.placed(&scale, &pose))
        }
        urdf_rs::Geometry::Box { size } => Ok(Mesh::cube().placed(
            &Vector3::new(size[0] / 2.0, size[1] / 2.0, size[2] / 2.0),
            &pose,
        )),
        other => Err(FitError::new(format!(
            "link {link}: collision geometry {other:?} is neither a mesh nor a box; only those are fitted"
        ))),
    }
}

fn mesh_path(mesh_dir: &Path, filename: &str) -> Option<PathBuf> {
    let name = filename.rsplit('/').next().filter(|n| !n.is_empty())?;
    Some(mesh_dir.join(name))
}

/// A URDF origin: translation `xyz` after fixed-axis roll-pitch-yaw `rpy`.
fn origin_pose(origin: &urdf_rs::Pose) -> Isometry3<f64> {
    let (xyz, rpy) = (&origin.xyz, &origin.rpy);
    Isometry3::from_parts(
        Translation3::new(xyz[0], xyz[1], xyz[2]),
        UnitQuaternion::from_euler_angles(rpy[0], rpy[1], rpy[2]),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The corners of the unit cube's corner tetrahedron.
    fn tetrahedron() -> Mesh {
        Mesh {
            vertices: vec![Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    #[test]
    fn extent_of_a_tetrahedron() {
        assert_eq!(tetrahedron().extent(), Vector3::repeat(1.0));
    }

    #[test]
    fn placing_scales_then_moves() {
        let pose = origin_pose(&urdf_rs::Pose {
            xyz: urdf_rs::Vec3([1.0, 0.0, 0.0]),
            rpy: urdf_rs::Vec3([0.0, 0.0, std::f64::consts::FRAC_PI_2]),
        });
        let placed = tetrahedron().placed(&Vector3::new(2.0, 1.0, 1.0), &pose);
        // x (scaled to 2) turned onto +y, then shifted by +x.
        assert!((placed.vertices[1] - Vector3::new(1.0, 2.0, 0.0)).norm() < 1e-12);
        assert!((placed.extent() - Vector3::new(1.0, 2.0, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn mesh_files_are_found_by_name() {
        let dir = Path::new("/m");
        assert_eq!(
            mesh_path(dir, "package://pkg/meshes/a.STL"),
            Some(PathBuf::from("/m/a.STL"))
        );
        assert_eq!(mesh_path(dir, "b.stl"), Some(PathBuf::from("/m/b.stl")));
        assert_eq!(mesh_path(dir, "package://pkg/"), None);
    }
}
