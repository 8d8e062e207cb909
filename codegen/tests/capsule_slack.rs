//! How far the committed capsules (`robots/kinova_gen3/collision.json`) stand off Kinova's link
//! meshes (`fit::MeshDistance::slack`: points on each link's capsule surfaces, those not inside
//! another capsule of the link, about every 4 mm, and their distance to the mesh surface).
//! Prints, per link, the capsule count and the largest and mean distance:
//!
//! ```sh
//! cargo test --release -p omcbsa-codegen --test capsule_slack -- --nocapture
//! ```
//!
//! The meshes are in `robots/kinova_gen3/meshes`.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use omcbsa_codegen::fit::{self, CollisionFile, MeshDistance};
use omcbsa_codegen::manifest::Folder;

/// No link's capsules may stand farther off its mesh than this anywhere (a little above the
/// committed fit's largest: README, "Capsule slack (issue 12)").
const MAX_SLACK: f64 = 0.046;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn capsules_stand_off_their_meshes_by_little() {
    let dir = repo().join("robots/kinova_gen3");
    let f = Folder::read(&dir).unwrap();
    let meshes = f.meshes().expect("fitted to meshes");
    let file = CollisionFile::read(&f.collision()).unwrap();
    let urdf = urdf_rs::read_file(f.urdf()).unwrap();
    println!("| link | capsules | largest slack (mm) | mean slack (mm) |");
    println!("|---|---:|---:|---:|");
    let mut worst = (0.0, String::new());
    for (link, mesh) in fit::link_meshes(&urdf, &meshes, Some(f.ends())).unwrap() {
        let capsules: Vec<fit::Capsule> = (file.capsules.iter())
            .filter(|c| c.link == link)
            .map(|c| fit::Capsule {
                a: Vector3::from(c.a),
                b: Vector3::from(c.b),
                radius: c.radius,
            })
            .collect();
        let slack = MeshDistance::new(&mesh)
            .expect("a link mesh")
            .slack(&capsules);
        let (largest, mean) = (slack.largest, slack.mean);
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
