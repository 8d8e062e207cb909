//! Every vertex of Kinova's link meshes lies inside one of its link's committed capsules
//! (`robots/kinova_gen3/collision.json`), and the file's disabled pairs are the adjacent links
//! plus the SRDF's. The meshes come from `../shared/` beside the repository; without them the
//! mesh checks are skipped, saying so.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use omcbsa_codegen::fit::{self, CollisionFile};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn committed() -> CollisionFile {
    CollisionFile::read(&repo().join("robots/kinova_gen3/collision.json")).unwrap()
}

fn urdf() -> urdf_rs::Robot {
    urdf_rs::read_file(repo().join("robots/kinova_gen3/gen3.urdf")).unwrap()
}

fn shared() -> PathBuf {
    repo().join("../shared/robots/kinova_gen3")
}

#[test]
fn every_mesh_vertex_is_inside_a_capsule_of_its_link() {
    let meshes = shared().join("meshes");
    if !meshes.is_dir() {
        println!("SKIPPED: meshes not found at {}", meshes.display());
        return;
    }
    let file = committed();
    let link_meshes = fit::link_meshes(&urdf(), &meshes).unwrap();
    assert_eq!(link_meshes.len(), 8, "Gen3 has 8 links with meshes");
    let mut checked = 0;
    for (link, mesh) in &link_meshes {
        let capsules: Vec<fit::Capsule> = file
            .capsules
            .iter()
            .filter(|c| &c.link == link)
            .map(|c| fit::Capsule {
                a: Vector3::from(c.a),
                b: Vector3::from(c.b),
                radius: c.radius,
            })
            .collect();
        assert!(
            (1..=fit::MAX_CAPSULES).contains(&capsules.len()),
            "{link}: {} capsules",
            capsules.len()
        );
        for (i, v) in mesh.vertices.iter().enumerate() {
            let gap = capsules
                .iter()
                .map(|c| c.axis_distance(v) - c.radius)
                .fold(f64::INFINITY, f64::min);
            assert!(
                gap <= 0.0,
                "{link}: vertex {i} {v:?} is {gap} m outside every capsule"
            );
        }
        checked += mesh.vertices.len();
    }
    println!("{checked} vertices inside their link's capsules");
    assert!(file.capsules.len() <= fit::CAPSULE_BUDGET);
    // No capsule for a link without a mesh (the tool frame).
    assert!(file
        .capsules
        .iter()
        .all(|c| link_meshes.iter().any(|(l, _)| *l == c.link)));
}

#[test]
fn disabled_pairs_are_the_adjacent_links_and_the_srdfs() {
    let file = committed();
    assert_eq!(file.disabled_pairs.len(), file.disabled_reasons.len());
    let links: Vec<String> = urdf().links.iter().map(|l| l.name.clone()).collect();
    let has_pair = |a: &str, b: &str| {
        file.disabled_pairs
            .iter()
            .any(|p| (p[0] == a && p[1] == b) || (p[0] == b && p[1] == a))
    };
    // Every joint between two links with geometry.
    for pair in links[..8].windows(2) {
        assert!(
            has_pair(&pair[0], &pair[1]),
            "adjacent {pair:?} not disabled"
        );
    }
    let srdf = shared().join("gen3.srdf.xacro");
    if !srdf.is_file() {
        println!("SKIPPED: SRDF not found at {}", srdf.display());
        return;
    }
    let entries = fit::parse_srdf(&std::fs::read_to_string(&srdf).unwrap()).unwrap();
    assert_eq!(entries.len(), 22);
    for e in &entries {
        assert!(has_pair(&e.link1, &e.link2), "SRDF pair {e:?} not disabled");
    }
    // Nothing else: the adjacent pairs are all in Kinova's SRDF too.
    assert_eq!(file.disabled_pairs.len(), entries.len());
    // A pair Kinova leaves enabled: the base against the wrist.
    assert!(!has_pair("base_link", "spherical_wrist_1_link"));
}
