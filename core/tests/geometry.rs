//! The geometry queries against an independent reference (parry3d-f64) on random poses, and
//! hand-checked special cases (parallel, point-like and touching shapes).

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use omcbsa_core::geometry::{Capsule, Contact, Obstacle, Segment, Shape};
use omcbsa_core::model::Frame;
use omcbsa_core::rng::Rng;
use parry3d_f64::math::{Pose3, Rot3, Vec3};
use parry3d_f64::query::{self, PointQuery};
use parry3d_f64::shape::{self as ps, Shape as ParryShape};

/// Distances must agree to this (metres).
const TOL: f64 = 1e-9;
/// Booleans are compared only this far from the boundary (metres).
const CLEAR: f64 = 1e-7;
/// The same for parry's intersection tests, which run GJK and stop short near the boundary.
const GJK_CLEAR: f64 = 1e-4;
const TRIALS: usize = 4000;

fn v(p: &Vector3<f64>) -> Vec3 {
    Vec3::new(p.x, p.y, p.z)
}

fn uniform3(rng: &mut Rng, lo: f64, hi: f64) -> Vector3<f64> {
    Vector3::new(
        rng.uniform(lo, hi),
        rng.uniform(lo, hi),
        rng.uniform(lo, hi),
    )
}

/// A uniformly random rotation, as both libraries' types.
fn rotation(rng: &mut Rng) -> (Matrix3<f64>, Rot3) {
    loop {
        let q = [0; 4].map(|_| rng.uniform(-1.0, 1.0));
        let n2: f64 = q.iter().map(|x| x * x).sum();
        if n2 > 0.01 && n2 <= 1.0 {
            let n = n2.sqrt();
            let uq = UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2]));
            let rq = Rot3::from_xyzw(q[0] / n, q[1] / n, q[2] / n, q[3] / n);
            return (*uq.to_rotation_matrix().matrix(), rq);
        }
    }
}

/// A random obstacle near the origin and the same shape for parry (whose cylinder axis is y,
/// hence the extra quarter turn about x).
fn obstacle(rng: &mut Rng, kind: usize) -> (Obstacle, Box<dyn ParryShape>, Pose3) {
    let (rot, rq) = rotation(rng);
    let pos = uniform3(rng, -0.3, 0.3);
    let pose = Frame { rot, pos };
    let ppose = Pose3::from_parts(v(&pos), rq);
    let r = rng.uniform(0.01, 0.3);
    let hl = rng.uniform(0.0, 0.4);
    let (shape, parry, ppose): (Shape, Box<dyn ParryShape>, Pose3) = match kind {
        0 => {
            let h = uniform3(rng, 0.005, 0.4);
            (
                Shape::Box {
                    half_extents: h.into(),
                },
                Box::new(ps::Cuboid::new(v(&h))),
                ppose,
            )
        }
        1 => (
            Shape::Sphere { radius: r },
            Box::new(ps::Ball::new(r)),
            ppose,
        ),
        2 => (
            Shape::Capsule {
                radius: r,
                half_length: hl,
            },
            Box::new(ps::Capsule::new_z(hl, r)),
            ppose,
        ),
        _ => {
            let y_to_z = Rot3::from_rotation_x(core::f64::consts::FRAC_PI_2);
            (
                Shape::Cylinder {
                    radius: r,
                    half_length: hl,
                },
                Box::new(ps::Cylinder::new(hl, r)),
                Pose3::from_parts(v(&pos), rq * y_to_z),
            )
        }
    };
    (Obstacle { shape, pose }, parry, ppose)
}

/// A random link capsule around the origin; one in eight is a sphere and one in eight a bare
/// segment.
fn capsule(rng: &mut Rng) -> Capsule {
    let a = uniform3(rng, -0.35, 0.35);
    let b = match rng.next_u64() % 8 {
        0 => a,
        _ => a + uniform3(rng, -0.5, 0.5),
    };
    let radius = match rng.next_u64() % 8 {
        0 => 0.0,
        _ => rng.uniform(0.005, 0.12),
    };
    Capsule::new(a, b, radius)
}

/// No margin, a swept check's few millimetres, or a generous clearance.
fn some_margin(rng: &mut Rng) -> f64 {
    [0.0, 0.002, 0.05][(rng.next_u64() % 3) as usize]
}

fn parry_capsule(c: &Capsule) -> ps::Capsule {
    ps::Capsule::new(v(&c.segment.a), v(&c.segment.b), c.radius)
}

fn parry_segment(s: &Segment) -> ps::Segment {
    ps::Segment::new(v(&s.a), v(&s.b))
}

/// Distance from a segment to a parry shape, found without our code: the distance from a
/// point to a convex solid is convex along the segment, so a golden-section search on parry's
/// point distance converges to the minimum. (Parry's own `distance` runs GJK for curved
/// shapes, which stops about 1e-5 short; for polytopes and balls it is exact, and used below.)
fn reference_distance(seg: &Segment, shape: &dyn ParryShape, pose: &Pose3) -> f64 {
    let f = |t: f64| shape.distance_to_point(pose, v(&seg.at(t)), true);
    let k = (5f64.sqrt() - 1.0) / 2.0;
    let (mut lo, mut hi) = (0.0, 1.0);
    let (mut x1, mut x2) = (hi - k * (hi - lo), lo + k * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..120 {
        if f1 <= f2 {
            (hi, x2, f2) = (x2, x1, f1);
            x1 = hi - k * (hi - lo);
            f1 = f(x1);
        } else {
            (lo, x1, f1) = (x1, x2, f2);
            x2 = lo + k * (hi - lo);
            f2 = f(x2);
        }
    }
    f(0.0).min(f(1.0)).min(f1).min(f2)
}

#[test]
fn segment_distances_match_parry() {
    let mut rng = Rng::new(1);
    let mut worst = 0.0f64;
    for _ in 0..TRIALS {
        let (s1, s2) = (capsule(&mut rng).segment, capsule(&mut rng).segment);
        let reference = query::distance(
            &Pose3::IDENTITY,
            &parry_segment(&s1),
            &Pose3::IDENTITY,
            &parry_segment(&s2),
        )
        .unwrap()
        .distance;
        worst = worst.max((s1.distance2_to_segment(&s2).sqrt() - reference).abs());
        let p = uniform3(&mut rng, -0.7, 0.7);
        let to_point = parry_segment(&s1).distance_to_local_point(v(&p), true);
        worst = worst.max((s1.distance2_to_point(&p).sqrt() - to_point).abs());
    }
    assert!(worst < TOL, "worst segment distance error {worst}");
}

#[test]
fn capsule_capsule_matches_parry() {
    let mut rng = Rng::new(2);
    for _ in 0..TRIALS {
        let (c1, c2) = (capsule(&mut rng), capsule(&mut rng));
        let reference =
            reference_distance(&c1.segment, &parry_segment(&c2.segment), &Pose3::IDENTITY)
                - c1.radius
                - c2.radius;
        assert!(
            (c1.signed_distance(&c2) - reference).abs() < TOL,
            "{c1:?} {c2:?}"
        );
        let margin = some_margin(&mut rng);
        if (reference - margin).abs() > CLEAR {
            assert_eq!(c1.hits(&c2, margin), reference < margin, "{c1:?} {c2:?}");
            assert_eq!(c2.hits(&c1, margin), reference < margin, "{c2:?} {c1:?}");
        }
        // A touch is told from a near miss exactly (capsule distances are exact).
        if (reference - margin).abs() > CLEAR && reference.abs() > CLEAR {
            let expected = if reference < 0.0 {
                Contact::Touch
            } else if reference < margin {
                Contact::Near
            } else {
                Contact::Clear
            };
            assert_eq!(c1.contact(&c2, margin), expected, "{c1:?} {c2:?}");
        }
        if reference.abs() > GJK_CLEAR {
            let overlap = query::intersection_test(
                &Pose3::IDENTITY,
                &parry_capsule(&c1),
                &Pose3::IDENTITY,
                &parry_capsule(&c2),
            )
            .unwrap()
            .intersecting;
            assert_eq!(c1.hits(&c2, 0.0), overlap, "{c1:?} {c2:?}");
        }
    }
}

#[test]
fn obstacle_capsule_matches_parry() {
    let mut rng = Rng::new(3);
    for kind in 0..4 {
        let (mut worst, mut touching, mut touches) = (0.0f64, 0, 0);
        for _ in 0..TRIALS {
            let (obstacle, shape, pose) = obstacle(&mut rng, kind);
            let c = capsule(&mut rng);
            let axis = reference_distance(&c.segment, shape.as_ref(), &pose);
            let reference = (axis - c.radius).max(0.0);
            worst = worst.max((obstacle.distance_to_capsule(&c) - reference).abs());
            touching += usize::from(reference == 0.0);
            // A hit when the axis comes closer than radius + margin, or meets the obstacle.
            let margin = some_margin(&mut rng);
            if axis == 0.0 || (axis - c.radius - margin).abs() > CLEAR {
                let expected = axis == 0.0 || axis < c.radius + margin;
                assert_eq!(
                    obstacle.hits_capsule(&c, margin),
                    expected,
                    "{obstacle:?} {c:?}"
                );
                // A touch is only claimed where the capsule meets the obstacle (a solid's
                // distance, found against the margin, may leave a touch as `Near`).
                let contact = obstacle.capsule_contact(&c, margin);
                assert_eq!(contact != Contact::Clear, expected, "{obstacle:?} {c:?}");
                if contact == Contact::Touch {
                    assert!(axis < c.radius + CLEAR, "{obstacle:?} {c:?}");
                    touches += 1;
                }
            }
            if (axis - c.radius).abs() > GJK_CLEAR {
                let overlap =
                    query::intersection_test(&Pose3::IDENTITY, &parry_capsule(&c), &pose, &*shape)
                        .unwrap()
                        .intersecting;
                assert_eq!(
                    obstacle.hits_capsule(&c, 0.0),
                    overlap,
                    "{obstacle:?} {c:?}"
                );
            }
        }
        assert!(worst < TOL, "shape {kind}: worst distance error {worst}");
        // The poses must exercise both separated and overlapping pairs.
        assert!(
            touching > TRIALS / 10 && touching < TRIALS * 9 / 10,
            "shape {kind}: {touching}"
        );
        assert!(
            touches > TRIALS / 20,
            "shape {kind}: {touches} touches told"
        );
    }
}

#[test]
fn point_containment_matches_parry() {
    let mut rng = Rng::new(5);
    for kind in 0..4 {
        let mut inside = 0;
        for _ in 0..TRIALS {
            let (obstacle, shape, pose) = obstacle(&mut rng, kind);
            let p = obstacle.pose.pos + uniform3(&mut rng, -0.3, 0.3);
            let proj = shape.project_point(&pose, v(&p), false);
            if (proj.point - v(&p)).length() > CLEAR {
                assert_eq!(
                    obstacle.contains_point(&p),
                    proj.is_inside,
                    "{obstacle:?} {p}"
                );
                inside += usize::from(proj.is_inside);
            }
        }
        assert!(
            inside > TRIALS / 10,
            "shape {kind}: only {inside} points inside"
        );
    }
}

#[test]
fn capsule_containment_matches_parry() {
    let mut rng = Rng::new(6);
    for _ in 0..TRIALS {
        let c = capsule(&mut rng);
        let p = c.segment.a + uniform3(&mut rng, -0.3, 0.3);
        let proj = parry_capsule(&c).project_local_point(v(&p), false);
        if (proj.point - v(&p)).length() > CLEAR {
            assert_eq!(c.contains_point(&p), proj.is_inside, "{c:?} {p}");
        }
    }
}

#[test]
fn bounding_boxes_match_parry() {
    let mut rng = Rng::new(7);
    for kind in 0..4 {
        for _ in 0..TRIALS / 4 {
            let (obstacle, shape, pose) = obstacle(&mut rng, kind);
            let ours = obstacle.aabb();
            let theirs = shape.compute_aabb(&pose);
            for i in 0..3 {
                assert!((ours.min[i] - theirs.mins[i]).abs() < TOL, "{obstacle:?}");
                assert!((ours.max[i] - theirs.maxs[i]).abs() < TOL, "{obstacle:?}");
            }
        }
    }
    for _ in 0..TRIALS / 4 {
        let c = capsule(&mut rng);
        let (ours, theirs) = (c.aabb(), parry_capsule(&c).local_aabb());
        for i in 0..3 {
            assert!((ours.min[i] - theirs.mins[i]).abs() < TOL, "{c:?}");
            assert!((ours.max[i] - theirs.maxs[i]).abs() < TOL, "{c:?}");
        }
    }
}

#[test]
fn near_boxes_are_necessary_for_hits() {
    let mut rng = Rng::new(8);
    let mut hits = 0;
    for kind in 0..4 {
        for _ in 0..TRIALS {
            let (obstacle, _, _) = obstacle(&mut rng, kind);
            let c = capsule(&mut rng);
            let margin = rng.uniform(0.0, 0.05);
            if obstacle.hits_capsule(&c, margin) {
                hits += 1;
                assert!(
                    obstacle.aabb().near(&c.aabb(), margin),
                    "{obstacle:?} {c:?}"
                );
            }
        }
    }
    assert!(hits > TRIALS, "{hits}");
}

#[test]
fn witness_lies_in_both_capsules_exactly_when_they_overlap() {
    let mut rng = Rng::new(9);
    let mut found = 0;
    // Solid capsules: a bare segment has no inside.
    let solid = |rng: &mut Rng| {
        let c = capsule(rng);
        Capsule {
            radius: c.radius.max(0.01),
            ..c
        }
    };
    for _ in 0..TRIALS {
        let (c1, c2) = (solid(&mut rng), solid(&mut rng));
        match c1.witness(&c2) {
            Some(p) => {
                found += 1;
                assert!(
                    c1.contains_point(&p) && c2.contains_point(&p),
                    "{c1:?} {c2:?} {p}"
                );
                assert!(c1.hits(&c2, 0.0));
            }
            None => assert!(!c1.hits(&c2, 0.0), "{c1:?} {c2:?}"),
        }
    }
    assert!(found > TRIALS / 20, "{found}");
}

fn seg(a: [f64; 3], b: [f64; 3]) -> Segment {
    Segment::new(a.into(), b.into())
}

#[test]
fn parallel_and_point_like_segments() {
    let x = seg([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
    // Parallel, overlapping, either direction: the gap between the lines.
    assert_eq!(
        x.distance2_to_segment(&seg([0.5, 1.0, 0.0], [2.0, 1.0, 0.0])),
        1.0
    );
    assert_eq!(
        x.distance2_to_segment(&seg([2.0, 0.0, 2.0], [0.5, 0.0, 2.0])),
        4.0
    );
    // Parallel, disjoint along the axis: end to end.
    assert_eq!(
        x.distance2_to_segment(&seg([3.0, 1.0, 0.0], [4.0, 1.0, 0.0])),
        5.0
    );
    assert_eq!(
        x.distance2_to_segment(&seg([-4.0, 1.0, 0.0], [-3.0, 1.0, 0.0])),
        10.0
    );
    assert_eq!(
        x.distance2_to_segment(&seg([-2.0, 0.0, 0.0], [-3.0, 0.0, 0.0])),
        4.0
    );
    // Nearly parallel (angle 1e-9), the far ends closest.
    let d2 = x.distance2_to_segment(&seg([2.0, 1.0, 0.0], [3.0, 1.0 - 1e-9, 0.0]));
    assert!((d2 - 2.0).abs() < 1e-12, "{d2}");
    // Collinear and overlapping.
    assert_eq!(
        x.distance2_to_segment(&seg([0.2, 0.0, 0.0], [0.7, 0.0, 0.0])),
        0.0
    );
    // Points.
    let p = seg([0.5, 2.0, 0.0], [0.5, 2.0, 0.0]);
    assert_eq!(x.distance2_to_segment(&p), 4.0);
    assert_eq!(p.distance2_to_segment(&x), 4.0);
    assert_eq!(
        p.distance2_to_segment(&seg([0.5, 0.0, 0.0], [0.5, 0.0, 0.0])),
        4.0
    );
    // Crossing.
    assert_eq!(
        x.distance2_to_segment(&seg([0.5, -1.0, 0.5], [0.5, 1.0, 0.5])),
        0.25
    );
}

fn obstacle_at(shape: Shape, pos: [f64; 3]) -> Obstacle {
    Obstacle {
        shape,
        pose: Frame {
            rot: Matrix3::identity(),
            pos: pos.into(),
        },
    }
}

#[test]
fn solids_against_segments_by_hand() {
    let cube = obstacle_at(
        Shape::Box {
            half_extents: [1.0, 1.0, 1.0],
        },
        [0.0; 3],
    );
    let pipe = obstacle_at(
        Shape::Cylinder {
            radius: 1.0,
            half_length: 1.0,
        },
        [0.0; 3],
    );
    let line = |a: [f64; 3], b: [f64; 3]| Capsule::new(a.into(), b.into(), 0.0);
    // A segment entirely inside, one through, one beside a face, one past an edge.
    let inside = line([-0.5, 0.0, 0.0], [0.5, 0.2, 0.1]);
    let through = line([-3.0, 0.1, 0.2], [3.0, -0.1, 0.0]);
    let beside = line([-3.0, 2.0, 0.0], [3.0, 2.0, 0.5]);
    let past_edge = line([3.0, 0.0, 0.0], [0.0, 3.0, 0.0]);
    for solid in [&cube, &pipe] {
        assert_eq!(solid.distance_to_capsule(&inside), 0.0);
        assert_eq!(solid.distance_to_capsule(&through), 0.0);
        assert!(solid.hits_capsule(&through, 0.0));
        assert!(!solid.hits_capsule(&beside, 0.0));
        assert!(solid.hits_capsule(&beside, 1.0 + 1e-9));
        assert!(!solid.hits_capsule(&beside, 1.0 - 1e-9));
    }
    assert!((cube.distance_to_capsule(&beside) - 1.0).abs() < 1e-12);
    assert!((cube.distance_to_capsule(&past_edge) - 0.5f64.sqrt()).abs() < 1e-12);
    assert!((pipe.distance_to_capsule(&past_edge) - (4.5f64.sqrt() - 1.0)).abs() < 1e-12);
    // Along the axis, beyond the caps.
    let above = line([0.0, 0.0, 1.5], [0.3, 0.0, 4.0]);
    assert!((pipe.distance_to_capsule(&above) - 0.5).abs() < 1e-12);
    // A rounded link closing in on a face.
    let link = Capsule::new([1.25, -3.0, 0.0].into(), [1.25, 3.0, 0.0].into(), 0.25);
    assert!(!cube.hits_capsule(&link, 0.0));
    assert!(cube.hits_capsule(&link, 1e-6));
}
