//! How far the committed capsules (`robots/kinova_gen3/collision.json`) stand off Kinova's link
//! meshes: points on each link's capsule surfaces (those not inside another capsule of the
//! link, about every 4 mm) and their distance to the mesh surface (parry3d). Prints, per link,
//! the capsule count and the largest and mean distance:
//!
//! ```sh
//! cargo test --release -p omcbsa-codegen --test capsule_slack -- --nocapture
//! ```
//!
//! The meshes come from `../shared/` beside the repository; without them the test is skipped,
//! saying so.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use omcbsa_codegen::fit::{self, CollisionFile, Mesh};
use parry3d_f64::math::Vec3;
use parry3d_f64::query::PointQuery;
use parry3d_f64::shape::TriMesh;

type V3 = Vector3<f64>;

/// Spacing of the surface samples, metres.
const SPACING: f64 = 0.004;
/// No link's capsules may stand farther off its mesh than this anywhere (a little above the
/// committed fit's 52.4 mm on half_arm_1_link: README, "Collision geometry").
const MAX_SLACK: f64 = 0.055;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A unit vector normal to `u` and a third completing the frame.
fn normals(u: &V3) -> (V3, V3) {
    let helper = if u.x.abs() < 0.9 { V3::x() } else { V3::y() };
    let v = u.cross(&helper).normalize();
    (v, u.cross(&v))
}

/// Points about [`SPACING`] apart on the surface of the capsule.
fn surface(c: &fit::Capsule) -> Vec<V3> {
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
    let n = ((4.0 * PI * c.radius * c.radius) / (SPACING * SPACING)).ceil() as usize;
    let golden = PI * (3.0 - 5f64.sqrt());
    for k in 0..n.max(16) {
        let z = 1.0 - (2.0 * k as f64 + 1.0) / n.max(16) as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = golden * k as f64;
        let d = u * z + (v * phi.cos() + w * phi.sin()) * r;
        let end = if z >= 0.0 { c.b } else { c.a };
        points.push(end + d * c.radius);
    }
    points
}

/// (largest, mean) distance from the link's capsule surfaces to its mesh.
fn slack(capsules: &[fit::Capsule], mesh: &Mesh) -> (f64, f64) {
    let vertices = (mesh.vertices.iter())
        .map(|p| Vec3::new(p.x, p.y, p.z))
        .collect();
    let indices = (mesh.triangles.iter())
        .map(|t| t.map(|i| i as u32))
        .collect();
    let trimesh = TriMesh::new(vertices, indices).expect("a link mesh");
    let (mut largest, mut sum, mut count) = (0.0f64, 0.0, 0usize);
    for (i, c) in capsules.iter().enumerate() {
        for p in surface(c) {
            let inside_another = (capsules.iter().enumerate())
                .any(|(j, o)| j != i && o.axis_distance(&p) < o.radius - 1e-9);
            if inside_another {
                continue;
            }
            let d = trimesh.distance_to_local_point(Vec3::new(p.x, p.y, p.z), false);
            largest = largest.max(d);
            sum += d;
            count += 1;
        }
    }
    (largest, sum / count.max(1) as f64)
}

#[test]
fn capsules_stand_off_their_meshes_by_little() {
    // Kinova's files: beside the repository, or where OMCBSA_KINOVA_DIR says.
    let kinova = std::env::var_os("OMCBSA_KINOVA_DIR").map_or_else(
        || repo().join("../shared/robots/kinova_gen3"),
        PathBuf::from,
    );
    let meshes = kinova.join("meshes");
    if !meshes.is_dir() {
        println!("SKIPPED: meshes not found at {}", meshes.display());
        return;
    }
    let file = CollisionFile::read(&repo().join("robots/kinova_gen3/collision.json")).unwrap();
    let urdf = urdf_rs::read_file(repo().join("robots/kinova_gen3/gen3.urdf")).unwrap();
    println!("| link | capsules | largest slack (mm) | mean slack (mm) |");
    println!("|---|---:|---:|---:|");
    let mut worst = (0.0, String::new());
    for (link, mesh) in fit::link_meshes(&urdf, &meshes).unwrap() {
        let capsules: Vec<fit::Capsule> = (file.capsules.iter())
            .filter(|c| c.link == link)
            .map(|c| fit::Capsule {
                a: V3::from(c.a),
                b: V3::from(c.b),
                radius: c.radius,
            })
            .collect();
        let (largest, mean) = slack(&capsules, &mesh);
        println!(
            "| {link} | {} | {:.1} | {:.1} |",
            capsules.len(),
            largest * 1e3,
            mean * 1e3
        );
        if largest > worst.0 {
            worst = (largest, link);
        }
    }
    assert!(
        worst.0 <= MAX_SLACK,
        "{} stands {:.1} mm off its mesh",
        worst.1,
        worst.0 * 1e3
    );
}
