//! Kinematics speed of the generated Kinova Gen3 model against the `k` crate reading the same
//! URDF at run time: FK, Jacobian, null-space basis and IK, side by side in one run.
//!
//! `cargo bench -p omcbsa-core --bench kinematics -- --warm-up-time 0.5 --measurement-time 2`
//!
//! Before timing, it prints the IK success rates of both solvers on the same poses from the
//! same seeds. Two IK cases: `ik_near` starts from the pose's configuration moved by up to
//! 0.05 rad per joint (trajectory tracking, the planner's hot path); `ik_random` starts from a
//! random configuration (the first pose of a trajectory).

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use k::nalgebra as kna;
use omcbsa_core::ik::{ik, IkParams};
use omcbsa_core::kinematics::null_space_basis;
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::rng::Rng;

const D: usize = 7;
const CASES: usize = 1000;
const URDF: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../robots/kinova_gen3/gen3.urdf"
);

/// Configurations, their tool poses, and IK seeds near and far from them.
struct Cases {
    qs: Vec<[f64; D]>,
    poses: Vec<Frame>,
    near: Vec<[f64; D]>,
    random: Vec<[f64; D]>,
}

fn cases() -> Cases {
    let mut rng = Rng::new(42);
    let (lo, hi) = (KinovaGen3::LOWER, KinovaGen3::UPPER);
    let qs: Vec<[f64; D]> = (0..CASES).map(|_| rng.configuration(&lo, &hi)).collect();
    let near = qs
        .iter()
        .map(|q| core::array::from_fn(|i| (q[i] + rng.uniform(-0.05, 0.05)).clamp(lo[i], hi[i])))
        .collect();
    let random = (0..CASES).map(|_| rng.configuration(&lo, &hi)).collect();
    let poses = qs.iter().map(KinovaGen3::fk).collect();
    Cases {
        qs,
        poses,
        near,
        random,
    }
}

fn k_arm() -> k::SerialChain<f64> {
    let chain = k::Chain::<f64>::from_urdf_file(URDF).expect("robots/kinova_gen3/gen3.urdf loads");
    let tool = chain
        .find_link("end_effector_link")
        .expect("URDF has end_effector_link");
    k::SerialChain::from_end(tool)
}

fn k_pose(f: &Frame) -> kna::Isometry3<f64> {
    let m = kna::Matrix3::from_column_slice(f.rot.as_slice());
    let rot = kna::UnitQuaternion::from_rotation_matrix(&kna::Rotation3::from_matrix_unchecked(m));
    kna::Isometry3::from_parts(kna::Translation3::new(f.pos.x, f.pos.y, f.pos.z), rot)
}

/// k's solver with our IK's tolerances and iteration budget. Full steps (multiplier 1 instead
/// of k's default 0.5) make k about 6x faster here at the same success rates: its best showing.
fn k_solver() -> k::JacobianIkSolver<f64> {
    let p = IkParams::default();
    let mut s = k::JacobianIkSolver::default();
    s.jacobian_multiplier = 1.0;
    s.allowable_target_distance = p.position_tolerance;
    s.allowable_target_angle = p.orientation_tolerance;
    s.num_max_try = p.max_iterations as usize;
    s
}

fn k_ik(
    arm: &k::SerialChain<f64>,
    solver: &k::JacobianIkSolver<f64>,
    target: &kna::Isometry3<f64>,
    seed: &[f64; D],
) -> bool {
    use k::InverseKinematicsSolver;
    arm.set_joint_positions_unchecked(seed);
    solver.solve(arm, target).is_ok()
}

/// The right singular vector of the smallest singular value of k's 6x7 Jacobian: the usual
/// way to get the null space with a general linear-algebra library.
fn k_null_space(j: &kna::DMatrix<f64>) -> kna::DVector<f64> {
    let square = j.clone().insert_row(6, 0.0); // 7x7, so the SVD has all 7 right vectors
    let svd = square.svd(false, true);
    let v_t = svd.v_t.expect("v_t requested");
    let smallest = svd.singular_values.imin();
    v_t.row(smallest).transpose()
}

fn success_rates(c: &Cases, arm: &k::SerialChain<f64>, solver: &k::JacobianIkSolver<f64>) {
    let params = IkParams::default();
    for (name, seeds) in [("ik_near", &c.near), ("ik_random", &c.random)] {
        let ours = c
            .poses
            .iter()
            .zip(seeds)
            .filter(|(x, s)| ik::<KinovaGen3, D>(0, x, s, &params).is_ok())
            .count();
        let theirs = c
            .poses
            .iter()
            .zip(seeds)
            .filter(|(x, s)| k_ik(arm, solver, &k_pose(x), s))
            .count();
        println!(
            "{name}: success omcbsa {:.1} %, k {:.1} % ({CASES} poses, one seed each)",
            100.0 * ours as f64 / CASES as f64,
            100.0 * theirs as f64 / CASES as f64
        );
    }
}

fn kinematics(cr: &mut Criterion) {
    let c = cases();
    let arm = k_arm();
    let solver = k_solver();
    success_rates(&c, &arm, &solver);
    let k_targets: Vec<_> = c.poses.iter().map(k_pose).collect();
    let params = IkParams::default();

    let mut g = cr.benchmark_group("fk");
    g.bench_function("omcbsa", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            KinovaGen3::fk(black_box(&c.qs[i]))
        })
    });
    g.bench_function("k", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            arm.set_joint_positions_unchecked(black_box(&c.qs[i]));
            arm.end_transform()
        })
    });
    g.finish();

    let mut g = cr.benchmark_group("jacobian");
    g.bench_function("omcbsa", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            KinovaGen3::jacobian(black_box(&c.qs[i]))
        })
    });
    g.bench_function("k", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            arm.set_joint_positions_unchecked(black_box(&c.qs[i]));
            k::jacobian(&arm)
        })
    });
    g.finish();

    // From the configuration: Jacobian, then its null space.
    let mut g = cr.benchmark_group("null_space");
    g.bench_function("omcbsa", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            null_space_basis(&KinovaGen3::jacobian(black_box(&c.qs[i])).1)
        })
    });
    g.bench_function("k", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            arm.set_joint_positions_unchecked(black_box(&c.qs[i]));
            k_null_space(&k::jacobian(&arm))
        })
    });
    g.finish();

    for (name, seeds) in [("ik_near", &c.near), ("ik_random", &c.random)] {
        let mut g = cr.benchmark_group(name);
        g.bench_function("omcbsa", |b| {
            let mut i = 0;
            b.iter(|| {
                i = (i + 1) % CASES;
                ik::<KinovaGen3, D>(0, black_box(&c.poses[i]), black_box(&seeds[i]), &params)
            })
        });
        g.bench_function("k", |b| {
            let mut i = 0;
            b.iter(|| {
                i = (i + 1) % CASES;
                k_ik(
                    &arm,
                    &solver,
                    black_box(&k_targets[i]),
                    black_box(&seeds[i]),
                )
            })
        });
        g.finish();
    }
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
