//! IK on the generated Kinova Gen3 model: success rate on random reachable poses, validity of
//! every answer, and errors (never panics) on unreachable, singular and malformed input.

use omcbsa_core::ik::{ik, ik_multi_start, IkError, IkParams, MultiStart};
use omcbsa_core::kinematics::orientation_angle;
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::nalgebra::Vector3;
use omcbsa_core::rng::Rng;

type Gen3 = KinovaGen3;
const D: usize = 7;

/// Asserts that `q` is within the joint limits and reaches `target` within the tolerances.
fn assert_valid(q: &[f64; D], target: &Frame, params: &IkParams) {
    for (i, x) in q.iter().enumerate() {
        let (lo, hi) = (Gen3::LOWER[i], Gen3::UPPER[i]);
        assert!(
            lo <= *x && *x <= hi,
            "joint {} = {x} outside [{lo}, {hi}]",
            i + 1
        );
    }
    let reached = Gen3::fk(q);
    let dp = (reached.pos - target.pos).norm();
    let da = orientation_angle(&reached.rot, &target.rot);
    assert!(
        dp <= params.position_tolerance,
        "position error {dp} at {q:?}"
    );
    assert!(
        da <= params.orientation_tolerance,
        "orientation error {da} at {q:?}"
    );
}

fn random_pose(rng: &mut Rng) -> Frame {
    Gen3::fk(&rng.configuration(&Gen3::LOWER, &Gen3::UPPER))
}

/// The acceptance test: at least 99.5 % of 10,000 random reachable poses solved from
/// random seeds, allowing up to 3 seeds (2 restarts) per pose.
#[test]
fn reaches_random_reachable_poses_from_random_seeds() {
    const POSES: usize = 10_000;
    const SEEDS_PER_POSE: usize = 3;
    let params = IkParams::default();
    let mut rng = Rng::new(2024);
    let (mut solved, mut first_seed) = (0, 0);
    for _ in 0..POSES {
        let target = random_pose(&mut rng);
        for attempt in 0..SEEDS_PER_POSE {
            let seed = rng.configuration(&Gen3::LOWER, &Gen3::UPPER);
            if let Ok(q) = ik::<Gen3, D>(0, &target, &seed, &params) {
                assert_valid(&q, &target, &params);
                solved += 1;
                first_seed += usize::from(attempt == 0);
                break;
            }
        }
    }
    println!(
        "solved {solved}/{POSES} with up to {SEEDS_PER_POSE} seeds, {first_seed} from the first"
    );
    assert!(
        solved * 1000 >= POSES * 995,
        "solved only {solved} of {POSES}"
    );
}

/// From a nearby seed (the tracking case) IK succeeds and stays near the seed.
#[test]
fn projects_nearby_seeds_to_nearby_solutions() {
    let params = IkParams::default();
    let mut rng = Rng::new(5);
    for _ in 0..1000 {
        let q0 = rng.configuration(&Gen3::LOWER, &Gen3::UPPER);
        let target = Gen3::fk(&q0);
        let seed: [f64; D] = core::array::from_fn(|i| {
            (q0[i] + rng.uniform(-0.02, 0.02)).clamp(Gen3::LOWER[i], Gen3::UPPER[i])
        });
        let q = ik::<Gen3, D>(0, &target, &seed, &params).expect("nearby seed must converge");
        assert_valid(&q, &target, &params);
        let moved = (0..D).map(|i| (q[i] - seed[i]).abs()).fold(0.0, f64::max);
        assert!(
            moved < 0.2,
            "solution {q:?} jumped {moved} rad from seed {seed:?}"
        );
    }
}

#[test]
fn answers_are_within_limits_even_from_seeds_outside_them() {
    let params = IkParams::default();
    let mut rng = Rng::new(9);
    let target = random_pose(&mut rng);
    let seed = [10.0, 3.0, -10.0, -3.0, 0.0, 2.5, 0.0];
    match ik::<Gen3, D>(0, &target, &seed, &params) {
        Ok(q) => assert_valid(&q, &target, &params),
        Err(e) => assert!(
            matches!(
                e,
                IkError::NoConvergence { .. } | IkError::BlockedByLimit { .. }
            ),
            "{e}"
        ),
    }
}

#[test]
fn unreachable_poses_give_errors() {
    let params = IkParams::default();
    let mut rng = Rng::new(11);
    for _ in 0..200 {
        let mut target = random_pose(&mut rng);
        target.pos = target.pos.normalize() * 2.0; // Gen3 reaches about 1.2 m from its base.
        let seed = rng.configuration(&Gen3::LOWER, &Gen3::UPPER);
        let e = ik::<Gen3, D>(0, &target, &seed, &params).expect_err("2 m away is unreachable");
        assert!(matches!(
            e,
            IkError::NoConvergence { .. } | IkError::BlockedByLimit { .. }
        ));
    }
}

#[test]
fn singular_configurations_never_give_wrong_answers() {
    let params = IkParams::default();
    let zero = [0.0; D]; // arm stretched straight up: shoulder, elbow and wrist singular
    let stretched = Gen3::fk(&zero);
    // Exactly the singular pose from the singular seed: already there.
    assert_eq!(ik::<Gen3, D>(0, &stretched, &zero, &params), Ok(zero));
    // A hair beyond full stretch along the arm is unreachable.
    let mut beyond = stretched;
    beyond.pos += stretched.pos.normalize() * 0.005;
    let e = ik::<Gen3, D>(0, &beyond, &zero, &params).expect_err("beyond full stretch");
    assert!(
        matches!(
            e,
            IkError::NoConvergence { .. } | IkError::BlockedByLimit { .. }
        ),
        "{e}"
    );
    // Reachable poses near the singularity, from the singular seed and from random seeds:
    // any answer must be valid.
    let mut rng = Rng::new(13);
    for _ in 0..200 {
        let q0: [f64; D] = core::array::from_fn(|_| rng.uniform(-0.05, 0.05));
        let target = Gen3::fk(&q0);
        for seed in [zero, rng.configuration(&Gen3::LOWER, &Gen3::UPPER)] {
            if let Ok(q) = ik::<Gen3, D>(0, &target, &seed, &params) {
                assert_valid(&q, &target, &params);
            }
        }
    }
}

#[test]
fn malformed_input_gives_the_matching_error() {
    let params = IkParams::default();
    let good = Gen3::fk(&[0.1; D]);
    let seed = [0.0; D];
    let mut nan_pos = good;
    nan_pos.pos.x = f64::NAN;
    assert_eq!(
        ik::<Gen3, D>(0, &nan_pos, &seed, &params),
        Err(IkError::NonFiniteTarget)
    );
    let mut inf_rot = good;
    inf_rot.rot[(1, 2)] = f64::INFINITY;
    assert_eq!(
        ik::<Gen3, D>(0, &inf_rot, &seed, &params),
        Err(IkError::NonFiniteTarget)
    );
    let mut skewed = good;
    skewed.rot[(0, 0)] *= 1.01;
    assert_eq!(
        ik::<Gen3, D>(0, &skewed, &seed, &params),
        Err(IkError::NotARotation)
    );
    let mut mirrored = good;
    mirrored.rot = -mirrored.rot;
    assert_eq!(
        ik::<Gen3, D>(0, &mirrored, &seed, &params),
        Err(IkError::NotARotation)
    );
    let mut nan_seed = seed;
    nan_seed[3] = f64::NAN;
    assert_eq!(
        ik::<Gen3, D>(0, &good, &nan_seed, &params),
        Err(IkError::NonFiniteSeed)
    );
    for bad in [
        IkParams {
            position_tolerance: 0.0,
            ..params
        },
        IkParams {
            orientation_tolerance: f64::NAN,
            ..params
        },
        IkParams {
            damping: -1.0,
            ..params
        },
        IkParams {
            max_step: 0.0,
            ..params
        },
        IkParams {
            max_iterations: 0,
            ..params
        },
        IkParams {
            max_stalled: 0,
            ..params
        },
    ] {
        assert_eq!(
            ik::<Gen3, D>(0, &good, &seed, &bad),
            Err(IkError::InvalidParams)
        );
    }
    // Huge but finite coordinates must not overflow into a wrong answer or a panic.
    let mut far = good;
    far.pos = Vector3::new(1e300, -1e300, 1e300);
    assert!(ik::<Gen3, D>(0, &far, &seed, &params).is_err());
}

#[test]
fn multi_start_finds_distinct_valid_solutions_deterministically() {
    let params = IkParams::default();
    let multi = MultiStart::default();
    let mut rng = Rng::new(17);
    let target = random_pose(&mut rng);
    let run = |seed: u64| {
        let mut out = [[0.0; D]; 8];
        let n =
            ik_multi_start::<Gen3, D>(0, &target, &params, &multi, &mut Rng::new(seed), &mut out)
                .expect("a reachable pose has solutions");
        (n, out)
    };
    let (n, out) = run(1);
    assert!(
        n >= 4,
        "only {n} distinct solutions from {} seeds",
        multi.attempts
    );
    for (i, a) in out[..n].iter().enumerate() {
        assert_valid(a, &target, &params);
        for b in &out[..i] {
            let gap = (0..D).map(|j| (a[j] - b[j]).abs()).fold(0.0, f64::max);
            assert!(
                gap > multi.min_separation,
                "solutions {a:?} and {b:?} are not distinct"
            );
        }
    }
    assert_eq!(run(1), (n, out), "same RNG seed, same solutions");

    let mut first = [[0.0; D]; 1];
    assert_eq!(
        ik_multi_start::<Gen3, D>(0, &target, &params, &multi, &mut Rng::new(2), &mut first),
        Ok(1)
    );
    assert_valid(&first[0], &target, &params);

    let mut far = target;
    far.pos *= 10.0;
    let e = ik_multi_start::<Gen3, D>(0, &far, &params, &multi, &mut Rng::new(3), &mut first)
        .expect_err("unreachable");
    assert!(matches!(
        e,
        IkError::NoConvergence { .. } | IkError::BlockedByLimit { .. }
    ));
}
