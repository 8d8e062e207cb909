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

/// The collision mesh of every URDF link that has one, in URDF order. Mesh file names
/// (`package://...`, `file://...` or plain paths) are looked up by their last path component
/// in `mesh_dir`; a link with several collision elements gets their union.
pub fn link_meshes(
    robot: &urdf_rs::Robot,
    mesh_dir: &Path,
) -> Result<Vec<(String, Mesh)>, FitError> {
    let mut meshes = Vec::new();
    for link in &robot.links {
        let mut mesh = Mesh::default();
        for collision in &link.collision {
            let urdf_rs::Geometry::Mesh { filename, scale } = &collision.geometry else {
                return Err(FitError::new(format!(
                    "link {}: collision geometry {:?} is not a mesh; only meshes are fitted",
                    link.name, collision.geometry
                )));
            };
            let path = mesh_path(mesh_dir, filename).ok_or_else(|| {
                FitError::new(format!(
                    "link {}: mesh file name {filename:?} is empty",
                    link.name
                ))
            })?;
            let scale = scale
                .as_ref()
                .map_or(Vector3::repeat(1.0), |s| Vector3::new(s[0], s[1], s[2]));
            let pose = origin_pose(&collision.origin);
            mesh.append(Mesh::read_stl(&path)?.placed(&scale, &pose));
        }
        if mesh.vertices.is_empty() {
            continue;
        }
        // Meshes exported in millimetres would give capsules a thousand times too big.
        let extent = mesh.extent().norm();
        if extent > 10.0 {
            return Err(FitError::new(format!(
                "link {}: mesh spans {extent:.1} units; meshes must be in metres (set the URDF mesh scale)",
                link.name
            )));
        }
        meshes.push((link.name.clone(), mesh));
    }
    Ok(meshes)
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
