//! How far capsules stand off a link's mesh: points on the capsule surfaces (those not inside
//! another capsule of the link, about every [`SPACING`]) and their distance to the mesh
//! surface. The fitter chooses its splits by this, and `tests/capsule_slack.rs` reports it.

use std::f64::consts::PI;

use nalgebra::Vector3;
use parry3d_f64::math::Vec3;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;

use super::mesh::Mesh;
use super::shape::Capsule;

type V3 = Vector3<f64>;

/// Spacing of the surface samples, metres.
pub const SPACING: f64 = 0.004;

/// Largest and mean distance from capsule surfaces to a mesh, metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slack {
    pub largest: f64,
    pub mean: f64,
}

/// A mesh prepared for distance queries.
pub struct MeshDistance(TriMesh);

impl MeshDistance {
    /// `None` for a mesh without triangles.
    pub fn new(mesh: &Mesh) -> Option<MeshDistance> {
        let vertices = (mesh.vertices.iter())
            .map(|p| Vec3::new(p.x, p.y, p.z))
            .collect();
        let indices = (mesh.triangles.iter())
            .map(|t| t.map(|i| i as u32))
            .collect();
        TriMesh::new(vertices, indices).ok().map(MeshDistance)
    }

    fn to_surface(&self, p: &V3) -> f64 {
        self.0
            .distance_to_local_point(Vec3::new(p.x, p.y, p.z), false)
    }

    /// The slack of `capsules` around this mesh.
    pub fn slack(&self, capsules: &[Capsule]) -> Slack {
        let (mut largest, mut sum, mut count) = (0.0f64, 0.0, 0usize);
        for (i, c) in capsules.iter().enumerate() {
            for p in surface(c) {
                let inside_another = (capsules.iter().enumerate())
                    .any(|(j, o)| j != i && o.axis_distance(&p) < o.radius - 1e-9);
                if inside_another {
                    continue;
                }
                let d = self.to_surface(&p);
                largest = largest.max(d);
                sum += d;
                count += 1;
            }
        }
        Slack {
            largest,
            mean: sum / count.max(1) as f64,
        }
    }
}

/// A unit vector normal to `u` and a third completing the frame.
fn normals(u: &V3) -> (V3, V3) {
    let helper = if u.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let v = u.cross(&helper).normalize();
    (v, u.cross(&v))
}

/// Points about [`SPACING`] apart on the surface of the capsule.
fn surface(c: &Capsule) -> Vec<V3> {
    let length = c.length();
    let u = if length > 0.0 {
        (c.b - c.a) / length
    } else {
        V3::z()
    };
    let (v, w) = normals(&u);
    let around = ((2.0 * PI * c.radius / SPACING).ceil() as usize).max(8);
    let mut points = Vec::new();
    let rings = (length / SPACING).ceil() as usize;
    for i in 0..=rings {
        let centre = c.a + u * (length * i as f64 / rings.max(1) as f64);
        for k in 0..around {
            let phi = 2.0 * PI * k as f64 / around as f64;
            points.push(centre + (v * phi.cos() + w * phi.sin()) * c.radius);
        }
    }
    // Hemispherical caps: Fibonacci points on the sphere, each kept on its end's side.
    let n = (((4.0 * PI * c.radius * c.radius) / (SPACING * SPACING)).ceil() as usize).max(16);
    let golden = PI * (3.0 - 5f64.sqrt());
    for k in 0..n {
        let z = 1.0 - (2.0 * k as f64 + 1.0) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = golden * k as f64;
        let d = u * z + (v * phi.cos() + w * phi.sin()) * r;
        let end = if z >= 0.0 { c.b } else { c.a };
        points.push(end + d * c.radius);
    }
    points
}
