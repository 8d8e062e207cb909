//! The generated models against the `k` crate (an independent URDF kinematics library),
//! against finite differences of themselves, and the null-space basis on real Jacobians.

use std::path::PathBuf;

use nalgebra::{Matrix3, SMatrix, Vector3};
use omcbsa_core::kinematics::{null_space_basis, orientation_angle, pose_error};
use omcbsa_core::model::{Frame, FrankaPanda, KinovaGen3, Model, SyntheticChain};
use omcbsa_core::rng::Rng;

fn robot_file(path: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../robots")
        .join(path)
}

const GEN3_URDF: &str = "kinova_gen3/gen3.urdf";
const SYNTHETIC_URDF: &str = "synthetic/chain.urdf";

fn from_k(iso: &k::nalgebra::Isometry3<f64>) -> Frame {
    let rot = iso.rotation.to_rotation_matrix();
    Frame {
        rot: Matrix3::from_fn(|i, j| rot[(i, j)]),
        pos: Vector3::from_fn(|i, _| iso.translation.vector[i]),
    }
}

/// Position error (m) and rotation angle (rad) between two frames.
fn distance(a: &Frame, b: &Frame) -> (f64, f64) {
    ((a.pos - b.pos).norm(), orientation_angle(&a.rot, &b.rot))
}

/// FK, every link frame and the Jacobian's pose agree with `k` on `n` random configurations.
fn matches_k<M: Model<D>, const D: usize>(urdf: &str, n: usize, seed: u64) {
    let chain = k::Chain::<f64>::from_urdf_file(robot_file(urdf)).expect("k reads the URDF");
    let k_joints: Vec<String> = chain
        .iter_joints()
        .filter(|j| j.is_movable())
        .map(|j| j.name.clone())
        .collect();
    assert_eq!(k_joints, M::JOINT_NAMES, "joint order");
    let k_links: Vec<&k::Node<f64>> = M::LINK_NAMES
        .iter()
        .map(|l| {
            chain
                .find_link(l)
                .unwrap_or_else(|| panic!("k has no link {l}"))
        })
        .collect();
    let mut frames = vec![Frame::IDENTITY; M::LINK_NAMES.len()];
    let mut rng = Rng::new(seed);
    let mut worst = (0.0f64, 0.0f64);
    for _ in 0..n {
        let q = rng.configuration(&M::LOWER, &M::UPPER);
        chain.set_joint_positions_unchecked(&q);
        chain.update_transforms();
        let tool = M::link_frames(&q, &mut frames);
        let fk = M::fk(&q);
        let (jac_frame, _) = M::jacobian(&q);
        for (link, (ours, theirs)) in M::LINK_NAMES.iter().zip(frames.iter().zip(&k_links)) {
            let (dp, da) = distance(ours, &from_k(&theirs.world_transform().expect("updated")));
            worst = (worst.0.max(dp), worst.1.max(da));
            assert!(
                dp < 1e-9 && da < 1e-9,
                "{link} at {q:?}: {dp:e} m, {da:e} rad"
            );
        }
        let last = frames.last().expect("at least the base frame");
        for (what, frame) in [("fk", fk), ("link_frames", tool), ("jacobian", jac_frame)] {
            let (dp, da) = distance(last, &frame);
            assert!(
                dp < 1e-12 && da < 1e-12,
                "{what} disagrees with the last link frame at {q:?}"
            );
        }
    }
    println!(
        "{}: worst difference to k over {n} configurations: {:e} m, {:e} rad",
        M::NAME,
        worst.0,
        worst.1
    );
}

/// Central differences of FK: position by component, rotation through the log map.
fn finite_difference_jacobian<M: Model<D>, const D: usize>(q: &[f64; D]) -> SMatrix<f64, 6, D> {
    let h = 1e-6;
    let mut jac = SMatrix::<f64, 6, D>::zeros();
    for j in 0..D {
        let (mut lo, mut hi) = (*q, *q);
        lo[j] -= h;
        hi[j] += h;
        let twist = pose_error(&M::fk(&lo), &M::fk(&hi)) / (2.0 * h);
        jac.set_column(j, &twist);
    }
    jac
}

fn jacobian_matches_finite_differences<M: Model<D>, const D: usize>(n: usize, seed: u64) {
    let mut rng = Rng::new(seed);
    for _ in 0..n {
        let q = rng.configuration(&M::LOWER, &M::UPPER);
        let (_, jac) = M::jacobian(&q);
        let fd = finite_difference_jacobian::<M, D>(&q);
        let err = (jac - fd).amax();
        assert!(err < 1e-6, "{}: Jacobian off by {err:e} at {q:?}", M::NAME);
    }
}

#[test]
fn gen3_fk_and_link_frames_match_k() {
    matches_k::<KinovaGen3, 7>(GEN3_URDF, 1000, 1);
}

#[test]
fn synthetic_fk_and_link_frames_match_k() {
    matches_k::<SyntheticChain, 5>(SYNTHETIC_URDF, 1000, 2);
}

#[test]
fn gen3_jacobian_matches_finite_differences() {
    jacobian_matches_finite_differences::<KinovaGen3, 7>(300, 3);
}

#[test]
fn panda_jacobian_matches_finite_differences() {
    jacobian_matches_finite_differences::<FrankaPanda, 7>(300, 8);
}

#[test]
fn synthetic_jacobian_matches_finite_differences() {
    jacobian_matches_finite_differences::<SyntheticChain, 5>(300, 4);
}

#[test]
fn gen3_null_space_is_one_unit_vector_that_j_annihilates() {
    let mut rng = Rng::new(5);
    for _ in 0..1000 {
        let q = rng.configuration(&KinovaGen3::LOWER, &KinovaGen3::UPPER);
        let (_, jac) = KinovaGen3::jacobian(&q);
        let basis = null_space_basis(&jac);
        assert_eq!(basis.len(), 1, "at {q:?}");
        let n = basis[0];
        assert!((n.norm() - 1.0).abs() < 1e-12);
        assert!(
            (jac * n).norm() < 1e-9,
            "|J n| = {:e} at {q:?}",
            (jac * n).norm()
        );
        let first = n.iter().find(|x| x.abs() > 1e-12).expect("nonzero");
        assert!(*first > 0.0, "sign convention");
    }
}

/// Moving joint `j` by `dq` moves no capsule surface point or link origin by more than
/// `REACH[j] * |dq|`.
fn reach_bounds_motion<M: Model<D>, const D: usize>(seed: u64) {
    let mut rng = Rng::new(seed);
    let n = M::LINK_NAMES.len();
    let (mut before, mut after) = (vec![Frame::IDENTITY; n], vec![Frame::IDENTITY; n]);
    for _ in 0..200 {
        let q = rng.configuration(&M::LOWER, &M::UPPER);
        M::link_frames(&q, &mut before);
        for j in 0..D {
            let dq = 1e-3;
            let mut moved = q;
            moved[j] += dq;
            M::link_frames(&moved, &mut after);
            let bound = M::REACH[j] * dq * (1.0 + 1e-9);
            for (link, (b, a)) in before.iter().zip(&after).enumerate() {
                assert!(
                    (b.pos - a.pos).norm() <= bound,
                    "link {link} origin, joint {j}"
                );
            }
            for c in M::CAPSULES {
                let (b, a) = (&before[usize::from(c.link)], &after[usize::from(c.link)]);
                let dir = Vector3::new(
                    rng.uniform(-1.0, 1.0),
                    rng.uniform(-1.0, 1.0),
                    rng.uniform(-1.0, 1.0),
                );
                let surface = dir.normalize() * c.radius;
                for end in [c.a, c.b] {
                    let p = Vector3::from(end) + surface;
                    assert!(
                        (b.apply(&p) - a.apply(&p)).norm() <= bound,
                        "capsule on link {}, joint {j}",
                        c.link
                    );
                }
            }
        }
    }
}

#[test]
fn reach_bounds_point_motion() {
    reach_bounds_motion::<KinovaGen3, 7>(6);
    reach_bounds_motion::<SyntheticChain, 5>(7);
    reach_bounds_motion::<FrankaPanda, 7>(9);
}

#[test]
fn gen3_constants_come_from_the_urdf() {
    assert_eq!(KinovaGen3::NAME, "kinova_gen3");
    assert_eq!(KinovaGen3::LINK_NAMES.first(), Some(&"base_link"));
    assert_eq!(KinovaGen3::LINK_NAMES.last(), Some(&"end_effector_link"));
    assert_eq!(KinovaGen3::LINK_NAMES.len(), 9);
    assert_eq!(KinovaGen3::JOINT_NAMES[6], "joint_7");
    let inf = f64::INFINITY;
    assert_eq!(
        KinovaGen3::LOWER,
        [-inf, -2.24, -inf, -2.57, -inf, -2.09, -inf]
    );
    assert_eq!(KinovaGen3::UPPER, [inf, 2.24, inf, 2.57, inf, 2.09, inf]);
    assert_eq!(
        KinovaGen3::VELOCITY,
        [1.3963, 1.3963, 1.3963, 1.3963, 1.2218, 1.2218, 1.2218]
    );
    // From the manifest (Kinova's joint_limits.yaml).
    assert_eq!(
        KinovaGen3::ACCELERATION,
        [1.0, 1.0, 1.0, 1.0, 10.0, 10.0, 10.0]
    );
    // Kinova's zero configuration: the arm points straight up, the tool 1.187385 m above the
    // base (0.15643 + 0.12838 + 0.21038 + 0.21038 + 0.20843 + 0.10593 + 0.10593 + 0.061525).
    let tool = KinovaGen3::fk(&[0.0; 7]);
    assert!((tool.pos.z - 1.187385).abs() < 1e-4, "{:?}", tool.pos);
}

#[test]
fn panda_constants_come_from_its_folder() {
    assert_eq!(FrankaPanda::NAME, "franka_panda");
    assert_eq!(FrankaPanda::LINK_NAMES.first(), Some(&"panda_link0"));
    // The chain ends at the TCP; the fingers are off it.
    assert_eq!(FrankaPanda::LINK_NAMES.last(), Some(&"panda_hand_tcp"));
    assert!(!FrankaPanda::LINK_NAMES.iter().any(|l| l.contains("finger")));
    assert_eq!(FrankaPanda::JOINT_NAMES[6], "panda_joint7");
    // Franka's published limits (robots/franka_panda/model.json names the page).
    assert_eq!(FrankaPanda::LOWER[3], -3.0718);
    assert_eq!(FrankaPanda::UPPER[5], 3.7525);
    assert_eq!(
        FrankaPanda::VELOCITY,
        [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61]
    );
    assert_eq!(
        FrankaPanda::ACCELERATION,
        [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0]
    );
    // Capsules on the 8 links and the hand (fingers folded in); none on the TCP.
    let tcp = (FrankaPanda::LINK_NAMES.len() - 1) as u8;
    assert!(FrankaPanda::CAPSULES.iter().all(|c| c.link != tcp));
    assert!(FrankaPanda::CAPSULES.len() <= 16);
    // Zero configuration: link0 to joint 2 0.333 m, then 0.316, 0.384 up, 0.088 out, the
    // flange 0.107 and the TCP 0.1034 down.
    let tool = FrankaPanda::fk(&[0.0; 7]);
    let expected = Vector3::new(
        0.0825 - 0.0825 + 0.088,
        0.0,
        0.333 + 0.316 + 0.384 - 0.107 - 0.1034,
    );
    assert!((tool.pos - expected).norm() < 1e-9, "{:?}", tool.pos);
}

#[test]
fn synthetic_collision_data_comes_from_its_file() {
    assert_eq!(
        SyntheticChain::LINK_NAMES,
        ["base", "l1", "l2", "l3", "l4", "l5", "l6", "l7", "tool"]
    );
    assert_eq!(
        SyntheticChain::JOINT_NAMES,
        ["swivel", "slide", "spin", "elbow", "wrist"]
    );
    assert_eq!(SyntheticChain::LOWER[2], f64::NEG_INFINITY);
    // sorted by link: base, l1, l2, l3, l4, l7, tool
    let links: Vec<u8> = SyntheticChain::CAPSULES.iter().map(|c| c.link).collect();
    assert_eq!(links, [0, 1, 2, 3, 4, 7, 8]);
    // bodies: base | l1 l2 | l3 | l4 | l5 l6 | l7 tool; (base, l4) disabled in the file
    let expected = [
        (0, 3),
        (0, 5),
        (0, 6),
        (1, 4),
        (1, 5),
        (1, 6),
        (2, 4),
        (2, 5),
        (2, 6),
        (3, 5),
        (3, 6),
        (4, 5),
        (4, 6),
    ];
    assert_eq!(SyntheticChain::SELF_PAIRS, expected);
    assert_eq!(SyntheticChain::REACH[1], 1.0, "prismatic");
}

#[test]
fn gen3_urdf_is_kinovas_file_with_a_licence_header() {
    let kinova = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/robots/kinova_gen3/GEN3-7DOF-NOVISION_FOR_URDF_ARM_V12.urdf");
    let Ok(original) = std::fs::read_to_string(&kinova) else {
        println!(
            "SKIPPED: Kinova's reference URDF not found at {}",
            kinova.display()
        );
        return;
    };
    let ours = std::fs::read_to_string(robot_file(GEN3_URDF)).expect("project URDF");
    let (header, body) = ours.split_once("-->\r\n").expect("licence comment first");
    assert!(header.contains("Kinova inc.") && header.contains("LICENSE"));
    assert_eq!(
        body, original,
        "figures must stay exactly as Kinova published them"
    );
}

/// `speed_ratio` is the least, over the null space, of the fastest joint's share of its limit:
/// a joint velocity that makes the twist bounds it from above, a dense scan of the null space
/// from below, and it grows in proportion to the twist.
fn speed_ratio_is_the_least_share<M: Model<D>, const D: usize>(n: usize, seed: u64) {
    use omcbsa_core::kinematics::speed_ratio;
    let mut rng = Rng::new(seed);
    for _ in 0..n {
        let q = rng.configuration(&M::LOWER, &M::UPPER);
        let (_, jac) = M::jacobian(&q);
        let qdot: nalgebra::SVector<f64, D> =
            nalgebra::SVector::from_fn(|j, _| rng.uniform(-0.8, 0.8) * M::VELOCITY[j]);
        let twist = jac * qdot;
        let r = speed_ratio::<D>(&jac, &twist, &M::VELOCITY);
        let share = |v: &nalgebra::SVector<f64, D>| {
            (0..D)
                .map(|j| v[j].abs() / M::VELOCITY[j])
                .fold(0.0, f64::max)
        };
        assert!(
            r <= share(&qdot) + 1e-9,
            "{r} above a feasible {}",
            share(&qdot)
        );
        // Any joint velocity that makes the twist: the least-norm one plus the null space.
        let pinv = jac.transpose() * (jac * jac.transpose()).try_inverse().unwrap();
        let p = pinv * twist;
        let dir = null_space_basis::<D>(&jac)[0];
        let scanned = (-4000..=4000)
            .map(|k| share(&(p + dir * (k as f64 * 1e-3))))
            .fold(f64::INFINITY, f64::min);
        assert!(
            r <= scanned + 1e-9 && scanned <= r + 1e-2,
            "{r} vs scan {scanned}"
        );
        let doubled = speed_ratio::<D>(&jac, &(twist * 2.0), &M::VELOCITY);
        assert!(
            (doubled - 2.0 * r).abs() < 1e-9 * (1.0 + r),
            "{doubled} vs 2 * {r}"
        );
    }
}

#[test]
fn gen3_speed_ratio_is_the_least_share() {
    speed_ratio_is_the_least_share::<KinovaGen3, 7>(200, 31);
}

#[test]
fn panda_speed_ratio_is_the_least_share() {
    speed_ratio_is_the_least_share::<FrankaPanda, 7>(200, 32);
}
