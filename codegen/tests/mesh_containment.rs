//! Every vertex of a model's link meshes (for the Panda, the fingers' boxes over their whole
//! travel too) lies inside one of its link's committed capsules (`robots/<model>/collision.json`),
//! and the file's disabled pairs are the adjacent links plus the SRDF's. The meshes and SRDFs
//! are in the models' folders.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;
use omcbsa_codegen::fit::{self, CollisionFile};
use omcbsa_codegen::manifest::Folder;

fn folder(model: &str) -> Folder {
    let dir: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../robots")
        .join(model);
    Folder::read(&dir).unwrap()
}

fn committed(f: &Folder) -> CollisionFile {
    CollisionFile::read(&f.collision()).unwrap()
}

fn urdf(f: &Folder) -> urdf_rs::Robot {
    urdf_rs::read_file(f.urdf()).unwrap()
}

/// Checks every vertex of `model`'s link meshes; returns the links with meshes.
fn vertices_inside(model: &str) -> Vec<String> {
    let f = folder(model);
    let file = committed(&f);
    let meshes = f.meshes().expect("fitted to meshes");
    let link_meshes = fit::link_meshes(&urdf(&f), &meshes, Some(f.ends())).unwrap();
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
    println!("{model}: {checked} vertices inside their link's capsules");
    assert!(file.capsules.len() <= fit::CAPSULE_BUDGET);
    // No capsule for a link without a mesh (the tool frame).
    assert!(file
        .capsules
        .iter()
        .all(|c| link_meshes.iter().any(|(l, _)| *l == c.link)));
    link_meshes.into_iter().map(|(l, _)| l).collect()
}

#[test]
fn every_gen3_mesh_vertex_is_inside_a_capsule_of_its_link() {
    assert_eq!(
        vertices_inside("kinova_gen3").len(),
        8,
        "Gen3 has 8 links with meshes"
    );
}

#[test]
fn every_panda_vertex_fingers_included_is_inside_a_capsule_of_its_link() {
    let links = vertices_inside("franka_panda");
    let mut expected: Vec<String> = (0..8).map(|i| format!("panda_link{i}")).collect();
    expected.push("panda_hand".into());
    assert_eq!(links, expected, "the fingers are folded into panda_hand");
}

#[test]
fn the_fingers_are_folded_in_at_every_opening() {
    let f = folder("franka_panda");
    let meshes = f.meshes().unwrap();
    let all = fit::link_meshes(&urdf(&f), &meshes, Some(f.ends())).unwrap();
    let hand = &all.iter().find(|(l, _)| l == "panda_hand").unwrap().1;
    // The left fingertip's outer top corner in the hand frame: the finger joint sits 58.4 mm
    // up and slides 0 to 40 mm along +y; its rubber tip box is centred at y 7.58 mm, z 45.25
    // mm, 17.5 x 15.2 x 18.5 mm.
    let (x, z) = (0.0175 / 2.0, 0.0584 + 0.04525 + 0.0185 / 2.0);
    for opening in [0.0, 0.02, 0.04] {
        let corner = Vector3::new(x, opening + 0.00758 + 0.0152 / 2.0, z);
        assert!(
            hand.vertices.iter().any(|v| (v - corner).norm() < 1e-9),
            "no fingertip corner at opening {opening}"
        );
    }
}

#[test]
fn disabled_pairs_are_the_adjacent_links_and_the_srdfs() {
    let f = folder("kinova_gen3");
    let file = committed(&f);
    assert_eq!(file.disabled_pairs.len(), file.disabled_reasons.len());
    let links: Vec<String> = urdf(&f).links.iter().map(|l| l.name.clone()).collect();
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
    let srdf = f.srdf().expect("Kinova's SRDF");
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

/// Each model's rest configuration is the SRDF's group state its manifest names.
#[test]
fn rest_configurations_are_the_srdfs_group_states() {
    for (model, state) in [("kinova_gen3", "retract"), ("franka_panda", "default")] {
        let f = folder(model);
        let rest = f.manifest.rest.as_ref().unwrap();
        assert!(rest.source.contains(&format!("\"{state}\"")), "{model}");
        let xml = std::fs::read_to_string(f.srdf().unwrap()).unwrap();
        let doc = roxmltree::Document::parse(&xml).unwrap();
        let group = doc
            .descendants()
            .find(|n| n.has_tag_name("group_state") && n.attribute("name") == Some(state))
            .unwrap();
        let value = |joint: &str| {
            group
                .children()
                .find(|j| j.attribute("name").is_some_and(|n| n.ends_with(joint)))
                .and_then(|j| j.attribute("value"))
                .map(|v| v.parse::<f64>().unwrap())
        };
        // The joints in chain order, as the generated model names them.
        let code = omcbsa_codegen::manifest::generate_folder(&f.dir).unwrap();
        let line = code
            .lines()
            .find(|l| l.contains("const JOINT_NAMES"))
            .unwrap();
        let list = &line[line.find("= [").unwrap() + 3..line.rfind(']').unwrap()];
        let names: Vec<&str> = list.split(", ").map(|n| n.trim_matches('"')).collect();
        assert!(
            code.contains("const REST: Option<[f64; 7]> = Some(["),
            "{model}"
        );
        assert_eq!(names.len(), rest.q.len(), "{model}");
        for (name, &q) in names.iter().zip(&rest.q) {
            assert_eq!(value(name), Some(q), "{model} {name}");
        }
    }
}
