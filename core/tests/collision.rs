//! Arm-level checks against brute force over the capsules (no bounding boxes), on the
//! synthetic chain (revolute, prismatic and continuous joints, a capsule on the base), and the
//! conservativeness of swept checks on dense samples of the motion.

use nalgebra::{Matrix3, Rotation3, SMatrix, Vector3};
use omcbsa_core::collision::{sweeps_collide, ArmPose, Sweep, MAX_ARM_CAPSULES};
use omcbsa_core::geometry::{Obstacle, Shape};
use omcbsa_core::model::{Frame, LinkCapsule, Model, SyntheticChain};
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::{Tool, ToolCapsule};

type M = SyntheticChain;
const D: usize = 5;
const TRIALS: usize = 2000;

fn frame(rng: &mut Rng, spread: f64) -> Frame {
    let rot = Rotation3::from_euler_angles(
        rng.uniform(-3.0, 3.0),
        rng.uniform(-1.5, 1.5),
        rng.uniform(-3.0, 3.0),
    );
    let pos = Vector3::from_fn(|_, _| rng.uniform(-spread, spread));
    Frame {
        rot: *rot.matrix(),
        pos,
    }
}

/// A base placed off the origin so that two arms can reach each other.
fn base_at(x: f64) -> Frame {
    Frame {
        rot: Matrix3::identity(),
        pos: Vector3::new(x, 0.0, 0.0),
    }
}

fn configuration(rng: &mut Rng) -> [f64; D] {
    rng.configuration(&M::LOWER, &M::UPPER)
}

fn obstacle(rng: &mut Rng) -> Obstacle {
    let shape = match rng.next_u64() % 4 {
        0 => Shape::Box {
            half_extents: [0.0; 3].map(|_| rng.uniform(0.01, 0.1)),
        },
        1 => Shape::Sphere {
            radius: rng.uniform(0.01, 0.1),
        },
        2 => Shape::Capsule {
            radius: rng.uniform(0.01, 0.05),
            half_length: rng.uniform(0.0, 0.2),
        },
        _ => Shape::Cylinder {
            radius: rng.uniform(0.01, 0.05),
            half_length: rng.uniform(0.0, 0.2),
        },
    };
    let mut pose = frame(rng, 0.3);
    pose.pos.z += 0.3;
    Obstacle { shape, pose }
}

fn capsule_is_on_base(i: usize) -> bool {
    M::CAPSULES[i].link == 0
}

#[test]
fn capsules_follow_the_links() {
    let mut rng = Rng::new(1);
    for _ in 0..TRIALS {
        let base = frame(&mut rng, 1.0);
        let q = configuration(&mut rng);
        let arm = ArmPose::new::<M, D>(0, &base, &Tool::NONE, &q);
        assert_eq!(arm.capsules().len(), M::CAPSULES.len());
        for (c, model) in arm.capsules().iter().zip(M::CAPSULES) {
            // Rigidly moved: same length and radius, and inside the arm's box.
            let len = (Vector3::from(model.b) - Vector3::from(model.a)).norm();
            assert!(((c.segment.b - c.segment.a).norm() - len).abs() < 1e-12);
            assert_eq!(c.radius, model.radius);
            let aabb = c.aabb();
            assert!(arm.aabb().contains_point(&aabb.min) && arm.aabb().contains_point(&aabb.max));
        }
        // The tool link's capsule is a sphere at the tool frame's origin: compare with FK.
        let tool = M::CAPSULES
            .iter()
            .position(|c| usize::from(c.link) == M::LINK_NAMES.len() - 1);
        let tool = &arm.capsules()[tool.expect("the synthetic chain has a tool capsule")];
        let fk = base.compose(&M::fk(&q));
        assert!((tool.segment.a - fk.pos).norm() < 1e-12);
    }
}

#[test]
fn obstacle_hits_match_brute_force_and_skip_the_base() {
    let mut rng = Rng::new(2);
    let (mut hits, mut base_only) = (0, 0);
    for _ in 0..TRIALS {
        let q = configuration(&mut rng);
        let arm = ArmPose::new::<M, D>(0, &Frame::IDENTITY, &Tool::NONE, &q);
        let obstacles: Vec<Obstacle> = (0..3).map(|_| obstacle(&mut rng)).collect();
        let margin = rng.uniform(0.0, 0.02);
        let brute = obstacles.iter().position(|o| {
            arm.capsules()
                .iter()
                .enumerate()
                .any(|(i, c)| !capsule_is_on_base(i) && o.hits_capsule(c, margin))
        });
        assert_eq!(
            arm.obstacle_hit(&obstacles, margin),
            brute,
            "{q:?} {obstacles:?}"
        );
        hits += usize::from(brute.is_some());
        base_only += usize::from(
            brute.is_none()
                && obstacles
                    .iter()
                    .any(|o| o.hits_capsule(&arm.capsules()[0], margin)),
        );
    }
    assert!(
        hits > TRIALS / 10 && hits < TRIALS * 9 / 10,
        "{hits} of {TRIALS} hit"
    );
    assert!(
        capsule_is_on_base(0) && base_only > 0,
        "no obstacle met the base alone"
    );
}

#[test]
fn self_hits_match_brute_force() {
    let mut rng = Rng::new(3);
    let mut hits = 0;
    for _ in 0..TRIALS {
        let q = configuration(&mut rng);
        let arm = ArmPose::new::<M, D>(0, &Frame::IDENTITY, &Tool::NONE, &q);
        let margin = rng.uniform(0.0, 0.05);
        let c = arm.capsules();
        let brute = M::SELF_PAIRS
            .iter()
            .map(|&(a, b)| (usize::from(a), usize::from(b)))
            .find(|&(a, b)| c[a].hits(&c[b], margin));
        assert_eq!(arm.self_hit(margin), brute, "{q:?}");
        hits += usize::from(brute.is_some());
    }
    assert!(
        hits > TRIALS / 20 && hits < TRIALS * 19 / 20,
        "{hits} of {TRIALS} self-collide"
    );
}

#[test]
fn arm_hits_match_brute_force_and_witnesses_lie_in_both() {
    let mut rng = Rng::new(4);
    let mut hits = 0;
    for _ in 0..TRIALS {
        let (base_a, base_b) = (base_at(0.0), base_at(rng.uniform(0.1, 0.7)));
        let a = ArmPose::new::<M, D>(0, &base_a, &Tool::NONE, &configuration(&mut rng));
        let b = ArmPose::new::<M, D>(0, &base_b, &Tool::NONE, &configuration(&mut rng));
        let margin = rng.uniform(0.0, 0.02);
        let brute = (0..a.capsules().len()).find_map(|i| {
            (0..b.capsules().len())
                .find(|&j| a.capsules()[i].hits(&b.capsules()[j], margin))
                .map(|j| (i, j))
        });
        assert_eq!(a.arm_hit(&b, margin), brute);
        hits += usize::from(brute.is_some());
        let overlap = a.arm_hit(&b, 0.0).is_some();
        match a.witness(&b, 0.0) {
            Some(p) => assert!(
                overlap && a.contains_point(&p) && b.contains_point(&p),
                "{p}"
            ),
            None => assert!(!overlap),
        }
        // With a margin: a witness exactly when the arms come that close, within half the
        // margin of both.
        let near = |arm: &ArmPose, p: &omcbsa_core::nalgebra::Vector3<f64>| {
            arm.capsules().iter().any(|c| {
                let r = c.radius + 0.5 * margin + 1e-12;
                c.segment.distance2_to_point(p) <= r * r
            })
        };
        match a.witness(&b, margin) {
            Some(p) => assert!(brute.is_some() && near(&a, &p) && near(&b, &p), "{p}"),
            None => assert!(brute.is_none()),
        }
    }
    assert!(
        hits > TRIALS / 10 && hits < TRIALS * 9 / 10,
        "{hits} of {TRIALS} hit"
    );
}

/// The clearance between two arms is at most their true distance (the least signed distance
/// of any capsule pair), and is that distance whenever their bounding boxes overlap.
#[test]
fn arm_clearance_is_a_lower_bound_exact_when_near() {
    let mut rng = Rng::new(9);
    let mut exact = 0;
    for _ in 0..TRIALS {
        let (base_a, base_b) = (base_at(0.0), base_at(rng.uniform(0.1, 1.5)));
        let a = ArmPose::new::<M, D>(0, &base_a, &Tool::NONE, &configuration(&mut rng));
        let b = ArmPose::new::<M, D>(0, &base_b, &Tool::NONE, &configuration(&mut rng));
        let brute = (a.capsules().iter())
            .flat_map(|ca| b.capsules().iter().map(|cb| ca.signed_distance(cb)))
            .fold(f64::INFINITY, f64::min);
        let c = a.clearance(&b);
        assert!(c <= brute + 1e-12, "{c} > {brute}");
        if a.aabb().distance(b.aabb()) == 0.0 {
            assert_eq!(c, brute);
            exact += 1;
        }
        // Overlapping arms have a negative clearance, and only they.
        assert_eq!(c < 0.0, a.arm_hit(&b, 0.0).is_some() && brute < 0.0);
    }
    assert!(exact > TRIALS / 10, "{exact} of {TRIALS} near");
}

#[test]
fn point_containment_matches_brute_force() {
    let mut rng = Rng::new(5);
    let mut inside = 0;
    for _ in 0..TRIALS {
        let arm = ArmPose::new::<M, D>(0, &Frame::IDENTITY, &Tool::NONE, &configuration(&mut rng));
        for _ in 0..20 {
            // Near a random capsule.
            let c = arm.capsules()[(rng.next_u64() % M::CAPSULES.len() as u64) as usize];
            let p = c.segment.at(rng.uniform(0.0, 1.0)) + frame(&mut rng, 0.06).pos;
            let brute = arm.capsules().iter().any(|c| c.contains_point(&p));
            assert_eq!(arm.contains_point(&p), brute);
            inside += usize::from(brute);
        }
    }
    assert!(inside > TRIALS && inside < TRIALS * 19, "{inside}");
}

/// A motion within the velocity limits over one step of `dt`.
fn motion(rng: &mut Rng, dt: f64) -> ([f64; D], [f64; D]) {
    let q0 = configuration(rng);
    let q1 = std::array::from_fn(|j| {
        let v = M::VELOCITY[j] * dt;
        (q0[j] + rng.uniform(-v, v)).clamp(M::LOWER[j], M::UPPER[j])
    });
    (q0, q1)
}

/// A gripper-sized tool reaching off the flange's axis, so that its travel bound is tested.
fn tool() -> Tool {
    Tool::new(&[
        ToolCapsule {
            a: [0.0, 0.0, 0.01],
            b: [0.0, 0.0, 0.06],
            radius: 0.045,
        },
        ToolCapsule {
            a: [0.0, 0.0, 0.06],
            b: [0.05, 0.0, 0.15],
            radius: 0.02,
        },
    ])
    .unwrap()
}

fn lerp(q0: &[f64; D], q1: &[f64; D], s: f64) -> [f64; D] {
    std::array::from_fn(|j| q0[j] + (q1[j] - q0[j]) * s)
}

#[test]
fn sweep_margin_covers_every_intermediate_configuration() {
    let mut rng = Rng::new(6);
    let max_disp = 0.004;
    let mut checks = 0;
    for _ in 0..TRIALS / 4 {
        let (q0, q1) = motion(&mut rng, 0.5);
        let sweep = Sweep::<M, D>::new(0, &tool(), &q0, &q1, max_disp);
        assert!(sweep.margin() <= max_disp / 2.0 + 1e-15);
        checks += sweep.count();
        let arms: Vec<ArmPose> = (0..sweep.count())
            .map(|i| sweep.arm(&Frame::IDENTITY, i))
            .collect();
        for k in 0..=200 {
            let s = k as f64 / 200.0;
            let nearest = ((s * sweep.count() as f64) as usize).min(sweep.count() - 1);
            let arm = ArmPose::new::<M, D>(0, &Frame::IDENTITY, &tool(), &lerp(&q0, &q1, s));
            // Segment end points move the most; points between them move by a mix of theirs.
            for (c, at_check) in arm.capsules().iter().zip(arms[nearest].capsules()) {
                let moved = (c.segment.a - at_check.segment.a)
                    .norm()
                    .max((c.segment.b - at_check.segment.b).norm());
                assert!(
                    moved <= sweep.margin() * (1.0 + 1e-9),
                    "{q0:?} -> {q1:?} at {s}"
                );
            }
        }
    }
    assert!(
        checks > TRIALS / 4 * 5,
        "the motions are too short to test much: {checks}"
    );
}

/// Any two capsules of one arm come closer or part along a motion by no more than their pair
/// travel (what the self-collision sweeps allow them), on the synthetic chain and the Gen3
/// with a tool; and the bound is 0 for capsules that no joint moves apart.
fn pair_travel_bounds_how_far_capsules_move_apart<MM: Model<DD>, const DD: usize>(seed: u64) {
    let mut rng = Rng::new(seed);
    let mut rigid = 0;
    for _ in 0..200 {
        let q0 = rng.configuration(&MM::LOWER, &MM::UPPER);
        let q1: [f64; DD] = std::array::from_fn(|j| {
            let v = MM::VELOCITY[j] * 0.5;
            (q0[j] + rng.uniform(-v, v)).clamp(MM::LOWER[j], MM::UPPER[j])
        });
        let sweep = Sweep::<MM, DD>::new(0, &tool(), &q0, &q1, 0.01);
        let at = |s: f64| {
            let q = std::array::from_fn(|j| q0[j] + (q1[j] - q0[j]) * s);
            ArmPose::new::<MM, DD>(0, &Frame::IDENTITY, &tool(), &q)
        };
        let start = at(0.0);
        let n = start.capsules().len();
        for k in 1..=40 {
            let s = k as f64 / 40.0;
            let arm = at(s);
            for a in 0..n {
                for b in a + 1..n {
                    let d = |p: &ArmPose| p.capsules()[a].signed_distance(&p.capsules()[b]);
                    let bound = sweep.pair_travel(a, b);
                    assert!(
                        (d(&arm) - d(&start)).abs() <= bound * s + 1e-9,
                        "capsules {a} and {b}: {q0:?} -> {q1:?} at {s}"
                    );
                    rigid += usize::from(k == 1 && bound == 0.0);
                }
            }
        }
    }
    assert!(rigid > 0, "no pair of capsules moves as one body");
}

#[test]
fn pair_travel_bounds_how_far_two_capsules_of_an_arm_move_apart() {
    pair_travel_bounds_how_far_capsules_move_apart::<M, D>(21);
    pair_travel_bounds_how_far_capsules_move_apart::<omcbsa_core::model::KinovaGen3, 7>(22);
    pair_travel_bounds_how_far_capsules_move_apart::<omcbsa_core::model::FrankaPanda, 7>(23);
}

/// Along a motion, each capsule's axis ends move away from where they are at the two ends by
/// no more than the capsule's reach (what the pair tests at the ends allow it) in sum; the
/// chord-and-bow bound is the one that holds for most capsules of short motions, and it is
/// not the chord alone: the axis ends do leave the straight line.
fn reaches_bound_how_far_capsules_stray<MM: Model<DD>, const DD: usize>(seed: u64) {
    let mut rng = Rng::new(seed);
    let (mut tighter, mut looser, mut curved) = (0, 0, 0);
    for trial in 0..200 {
        let q0 = rng.configuration(&MM::LOWER, &MM::UPPER);
        // Short steps (as the planners' between two poses) and long ones (approaches).
        let scale = if trial % 2 == 0 { 0.2 } else { 2.0 };
        let q1: [f64; DD] = std::array::from_fn(|j| {
            let v = MM::VELOCITY[j] * scale;
            (q0[j] + rng.uniform(-v, v)).clamp(MM::LOWER[j], MM::UPPER[j])
        });
        let base = frame(&mut rng, 0.5);
        let sweep = Sweep::<MM, DD>::new(0, &tool(), &q0, &q1, 0.01);
        let at = |s: f64| {
            let q = std::array::from_fn(|j| q0[j] + (q1[j] - q0[j]) * s);
            ArmPose::new::<MM, DD>(0, &base, &tool(), &q)
        };
        let (start, end) = (at(0.0), at(1.0));
        let reach = sweep.reaches([&start, &end]);
        let n = start.capsules().len();
        let mut worst = vec![0.0f64; n];
        let ends = |p: &ArmPose, i: usize| [p.capsules()[i].segment.a, p.capsules()[i].segment.b];
        // Where the chord-and-bow bound is the reach, the bow it adds twice.
        let bow: Vec<Option<f64>> = (0..n)
            .map(|i| {
                let (first, last) = (ends(&start, i), ends(&end, i));
                let chord = (0..2)
                    .map(|e| (last[e] - first[e]).norm())
                    .fold(0.0, f64::max);
                (reach[i] < sweep.travel(i) - 1e-12).then(|| 0.5 * (reach[i] - chord))
            })
            .collect();
        for k in 1..100 {
            let s = k as f64 / 100.0;
            let arm = at(s);
            for i in 0..n {
                let (now, first, last) = (ends(&arm, i), ends(&start, i), ends(&end, i));
                if let Some(bow) = bow[i] {
                    for e in 0..2 {
                        let off = (now[e] - first[e].lerp(&last[e], s)).norm();
                        assert!(off <= bow + 1e-9, "capsule {i} bows {off} > {bow} at {s}");
                    }
                }
                for e in 0..2 {
                    let away = (now[e] - first[e]).norm() + (now[e] - last[e]).norm();
                    assert!(
                        away <= reach[i] + 1e-9,
                        "capsule {i}: {away} > {} ({q0:?} -> {q1:?})",
                        reach[i]
                    );
                    let chord = (last[e] - first[e]).norm();
                    worst[i] = worst[i].max(away - chord);
                }
            }
        }
        for i in 0..n {
            let travel = sweep.travel(i);
            tighter += usize::from(reach[i] < travel - 1e-12);
            looser += usize::from(reach[i] >= travel - 1e-12 && travel > 0.0);
            curved += usize::from(worst[i] > 1e-6);
        }
    }
    assert!(tighter > looser, "{tighter} capsules tighter, {looser} not");
    assert!(curved > 0, "no capsule left the straight line");
}

#[test]
fn reaches_bound_how_far_capsules_stray_between_the_ends() {
    reaches_bound_how_far_capsules_stray::<M, D>(31);
    reaches_bound_how_far_capsules_stray::<omcbsa_core::model::KinovaGen3, 7>(32);
    reaches_bound_how_far_capsules_stray::<omcbsa_core::model::FrankaPanda, 7>(33);
}

#[test]
fn a_clear_sweep_is_clear_throughout_and_no_stricter_than_uniform_checks() {
    let mut rng = Rng::new(7);
    let (mut clear, mut blocked) = (0, 0);
    for _ in 0..TRIALS / 4 {
        let (q0, q1) = motion(&mut rng, 0.3);
        let obstacles: Vec<Obstacle> = (0..2).map(|_| obstacle(&mut rng)).collect();
        let sweep = Sweep::<M, D>::new(0, &tool(), &q0, &q1, 0.004);
        let margin = sweep.margin();
        let uniform = (0..sweep.count()).any(|i| {
            let arm = sweep.arm(&Frame::IDENTITY, i);
            arm.obstacle_hit(&obstacles, margin).is_some() || arm.self_hit(2.0 * margin).is_some()
        });
        if sweep.arm_collides(&Frame::IDENTITY, &obstacles) {
            // A collision is reported only where a check of the pieces at their middles fails.
            assert!(uniform, "{q0:?} -> {q1:?}");
            blocked += 1;
            continue;
        }
        clear += 1;
        for k in 0..=200 {
            let arm = ArmPose::new::<M, D>(
                0,
                &Frame::IDENTITY,
                &tool(),
                &lerp(&q0, &q1, k as f64 / 200.0),
            );
            assert_eq!(arm.obstacle_hit(&obstacles, 0.0), None);
            assert_eq!(arm.self_hit(0.0), None);
        }
    }
    assert!(
        clear > TRIALS / 40 && blocked > TRIALS / 40,
        "{clear} clear, {blocked} blocked"
    );
}

#[test]
fn clear_simultaneous_sweeps_never_meet_and_no_stricter_than_uniform_checks() {
    let mut rng = Rng::new(8);
    let (base_a, base_b) = (base_at(0.0), base_at(0.3));
    let (mut clear, mut blocked) = (0, 0);
    for _ in 0..TRIALS / 4 {
        let ((a0, a1), (b0, b1)) = (motion(&mut rng, 0.3), motion(&mut rng, 0.1));
        let a = Sweep::<M, D>::new(0, &Tool::NONE, &a0, &a1, 0.004);
        let b = Sweep::<M, D>::new(0, &Tool::NONE, &b0, &b1, 0.004);
        if sweeps_collide(&a, &base_a, &b, &base_b) {
            // No stricter than checking both arms at the middle of each of the finer pieces,
            // inflated by both margins there.
            let count = a.count().max(b.count());
            let margin = (a.length() + b.length()) / (2.0 * count as f64);
            let uniform = (0..count).any(|i| {
                let s = (i as f64 + 0.5) / count as f64;
                let arm_a = ArmPose::new::<M, D>(0, &base_a, &Tool::NONE, &lerp(&a0, &a1, s));
                let arm_b = ArmPose::new::<M, D>(0, &base_b, &Tool::NONE, &lerp(&b0, &b1, s));
                arm_a.arm_hit(&arm_b, margin).is_some()
            });
            assert!(uniform, "{a0:?} -> {a1:?}, {b0:?} -> {b1:?}");
            blocked += 1;
            continue;
        }
        clear += 1;
        for k in 0..=200 {
            let s = k as f64 / 200.0;
            let arm_a = ArmPose::new::<M, D>(0, &base_a, &Tool::NONE, &lerp(&a0, &a1, s));
            let arm_b = ArmPose::new::<M, D>(0, &base_b, &Tool::NONE, &lerp(&b0, &b1, s));
            assert_eq!(arm_a.arm_hit(&arm_b, 0.0), None);
        }
    }
    assert!(
        clear > TRIALS / 40 && blocked > TRIALS / 40,
        "{clear} clear, {blocked} blocked"
    );
}

#[test]
fn sweep_counts_follow_the_motion_length() {
    let q = [0.1, 0.0, 0.3, -0.2, 0.5];
    // No motion: one check at the configuration itself, no margin.
    let still = Sweep::<M, D>::new(0, &Tool::NONE, &q, &q, 0.004);
    assert_eq!(
        (still.count(), still.margin(), still.config(0)),
        (1, 0.0, q)
    );
    // Joint 0 by 0.1 rad: at most REACH[0] * 0.1 of displacement.
    let mut q1 = q;
    q1[0] += 0.1;
    let length = M::REACH[0] * 0.1;
    let sweep = Sweep::<M, D>::new(0, &Tool::NONE, &q, &q1, 0.004);
    assert_eq!(sweep.count(), (length / 0.004).ceil() as usize);
    assert!((sweep.margin() - length / (2.0 * sweep.count() as f64)).abs() < 1e-15);
    assert!((sweep.config(0)[0] - (q[0] + 0.1 * 0.5 / sweep.count() as f64)).abs() < 1e-15);
    // A spacing that is no spacing still gives a conservative (single, wide) check.
    for bad in [0.0, -1.0, f64::NAN] {
        let wide = Sweep::<M, D>::new(0, &Tool::NONE, &q, &q1, bad);
        assert_eq!((wide.count(), wide.margin()), (1, length / 2.0));
    }
    // Fewer pieces mean a proportionally wider margin.
    let coarse = sweep.with_count(2);
    assert!((coarse.margin() - length / 4.0).abs() < 1e-15);
}

/// A model with exactly [`MAX_ARM_CAPSULES`] capsules: accepted, all of them kept. (One more
/// fails to compile: see the `compile_fail` example on the constant.)
struct Full;

impl Model<1> for Full {
    const NAME: &'static str = "full";
    const LINK_NAMES: &'static [&'static str] = &["base", "arm"];
    const JOINT_NAMES: [&'static str; 1] = ["j"];
    const LOWER: [f64; 1] = [-1.0];
    const UPPER: [f64; 1] = [1.0];
    const VELOCITY: [f64; 1] = [1.0];
    const ACCELERATION: [f64; 1] = [f64::INFINITY];
    const CAPSULES: &'static [LinkCapsule] = &[LinkCapsule {
        link: 1,
        a: [0.0; 3],
        b: [0.0, 0.0, 1.0],
        radius: 0.1,
    }; MAX_ARM_CAPSULES];
    const SELF_PAIRS: &'static [(u8, u8)] = &[];
    const REACH: [f64; 1] = [1.0];
    fn fk(_: &[f64; 1]) -> Frame {
        Frame::IDENTITY
    }
    fn link_frames(_: &[f64; 1], out: &mut [Frame]) -> Frame {
        out.fill(Frame::IDENTITY);
        Frame::IDENTITY
    }
    fn jacobian(_: &[f64; 1]) -> (Frame, SMatrix<f64, 6, 1>) {
        (Frame::IDENTITY, SMatrix::zeros())
    }
}

#[test]
fn a_model_with_the_most_capsules_fits() {
    let arm = ArmPose::new::<Full, 1>(0, &base_at(2.0), &Tool::NONE, &[0.0]);
    assert_eq!(arm.capsules().len(), MAX_ARM_CAPSULES);
    assert!(arm
        .capsules()
        .iter()
        .all(|c| c.segment.a == Vector3::new(2.0, 0.0, 0.0)));
}
