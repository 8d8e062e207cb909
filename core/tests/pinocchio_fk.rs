//! The generated models' FK against Pinocchio: committed vectors (tool poses of 1,000 random
//! configurations each, made by `core/tests/pinocchio/make_vectors.py` from example-robot-data's
//! Panda URDF and Kinova's Gen3 URDF) agree to 1e-9 m and 1e-9 rad.

use std::path::PathBuf;

use nalgebra::{Matrix3, Vector3};
use omcbsa_core::kinematics::orientation_angle;
use omcbsa_core::model::{Frame, FrankaPanda, KinovaGen3, Model};

/// `(q, tool pose)` per line of `core/tests/pinocchio/{model}.txt`.
fn vectors<const D: usize>(model: &str) -> Vec<([f64; D], Frame)> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/pinocchio")
        .join(format!("{model}.txt"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.starts_with('#'))
        .map(|(n, line)| {
            let v: Vec<f64> = line
                .split_whitespace()
                .map(|x| {
                    x.parse()
                        .unwrap_or_else(|e| panic!("line {}: {x}: {e}", n + 1))
                })
                .collect();
            assert_eq!(v.len(), D + 12, "line {}: {} numbers", n + 1, v.len());
            let q = std::array::from_fn(|j| v[j]);
            let rot = Matrix3::from_fn(|i, j| v[D + 3 * i + j]);
            let pos = Vector3::from_fn(|i, _| v[D + 9 + i]);
            (q, Frame { rot, pos })
        })
        .collect()
}

/// Largest position (m) and rotation (rad) difference of `M::fk` to Pinocchio's poses.
fn worst<M: Model<D>, const D: usize>() -> (f64, f64) {
    let cases = vectors::<D>(M::NAME);
    assert_eq!(cases.len(), 1000, "{}: 1,000 configurations", M::NAME);
    let mut worst = (0.0f64, 0.0f64);
    for (q, theirs) in &cases {
        for j in 0..D {
            assert!(
                M::LOWER[j] <= q[j] && q[j] <= M::UPPER[j],
                "{q:?} outside the limits"
            );
        }
        let ours = M::fk(q);
        let dp = (ours.pos - theirs.pos).norm();
        let da = orientation_angle(&ours.rot, &theirs.rot);
        worst = (worst.0.max(dp), worst.1.max(da));
    }
    println!(
        "{}: worst difference to Pinocchio over {} configurations: {:e} m, {:e} rad",
        M::NAME,
        cases.len(),
        worst.0,
        worst.1
    );
    worst
}

#[test]
fn panda_fk_matches_pinocchio() {
    let (dp, da) = worst::<FrankaPanda, 7>();
    assert!(dp < 1e-9 && da < 1e-9, "{dp:e} m, {da:e} rad");
}

#[test]
fn gen3_fk_matches_pinocchio() {
    let (dp, da) = worst::<KinovaGen3, 7>();
    assert!(dp < 1e-9 && da < 1e-9, "{dp:e} m, {da:e} rad");
}
