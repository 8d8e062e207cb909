//! The batched kernel against the scalar path, bit for bit: kinematics and capsule placing
//! of [`LANES`] configurations at once equal [`ArmPose`] of each, and the batched checks hit
//! in exactly the lanes where the scalar checks do. Property tests on random configurations,
//! scenes, tools, second arms and margins: 100,000 configurations per model (Gen3, Panda),
//! with hits and misses of each check counted so that both are exercised.

use std::cell::RefCell;
use std::ops::ControlFlow;

use nalgebra::{Matrix3, Rotation3, Vector3};
use omcbsa_core::collision::{sweeps_collide, ArmLanes, ArmPose, Placing, Scene, Sweep};
use omcbsa_core::geometry::lanes::Segments;
use omcbsa_core::geometry::{Aabb, Capsule, Obstacle, Segment, Shape};
use omcbsa_core::lanes::{F64s, Mask, LANES};
use omcbsa_core::model::{Frame, FrameOf, FrankaPanda, KinovaGen3, Model};
use omcbsa_core::problem::{Assigned, Robot, Start, StartExclusions};
use omcbsa_core::search::{OtherArm, OthersMode, PointConstraint, Validity};
use omcbsa_core::tool::{Tool, ToolCapsule};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

const D: usize = 7;
/// Configurations checked per model.
const CONFIGURATIONS: u32 = 100_000;
/// Motions checked per model, each three ways (an arm alone, two arms moving, one standing).
const MOTIONS: u32 = 10_000;

fn frame(p: [f64; 3], axis_angle: [f64; 3]) -> Frame {
    Frame {
        rot: *Rotation3::from_scaled_axis(Vector3::from(axis_angle)).matrix(),
        pos: Vector3::from(p),
    }
}

fn obstacle() -> impl Strategy<Value = Obstacle> {
    let shape = prop_oneof![
        prop::array::uniform3(0.01..0.3f64).prop_map(|half_extents| Shape::Box { half_extents }),
        (0.01..0.2f64).prop_map(|radius| Shape::Sphere { radius }),
        (0.01..0.1f64, 0.0..0.3f64).prop_map(|(radius, half_length)| Shape::Capsule {
            radius,
            half_length
        }),
        (0.01..0.1f64, 0.0..0.3f64).prop_map(|(radius, half_length)| Shape::Cylinder {
            radius,
            half_length
        }),
    ];
    let at = (-0.9..0.9f64, -0.9..0.9f64, -0.2..1.2f64);
    (shape, at, prop::array::uniform3(-3.0..3.0f64)).prop_map(|(shape, (x, y, z), r)| Obstacle {
        shape,
        pose: frame([x, y, z], r),
    })
}

fn tool() -> impl Strategy<Value = Tool> {
    let capsule = (
        prop::array::uniform3(-0.1..0.1f64),
        prop::array::uniform3(-0.1..0.3f64),
        0.005..0.06f64,
    )
        .prop_map(|(a, b, radius)| ToolCapsule { a, b, radius });
    prop::collection::vec(capsule, 0..3).prop_map(|c| Tool::new(&c).expect("fits"))
}

/// One case: two arms of model `M` at a batch of configurations each, a scene, a margin.
#[derive(Debug, Clone)]
struct Case {
    qs: Vec<[f64; D]>,
    others: Vec<[f64; D]>,
    base: Frame,
    other_base: Frame,
    tool: Tool,
    obstacles: Vec<Obstacle>,
    margin: f64,
}

fn case<M: Model<D>>() -> impl Strategy<Value = Case> {
    let joint = |j: usize| {
        let (lo, hi) = (M::LOWER[j].max(-3.2), M::UPPER[j].min(3.2));
        lo..=hi
    };
    let config = move || -> [std::ops::RangeInclusive<f64>; D] { core::array::from_fn(joint) };
    // Mostly full batches, some shorter.
    let lanes = prop_oneof![7 => Just(LANES), 1 => 1..LANES];
    let batches = lanes.prop_flat_map(move |n| {
        (
            prop::collection::vec(config(), n),
            prop::collection::vec(config(), n),
        )
    });
    (
        batches,
        (0.2..1.0f64, -0.6..0.6f64, -3.2..3.2f64),
        tool(),
        prop::collection::vec(obstacle(), 0..8),
        prop_oneof![Just(0.0), 0.0..0.05f64],
        (-0.1..0.1f64, -0.1..0.1f64),
    )
        .prop_map(
            |((qs, others), (x, y, yaw), tool, obstacles, margin, (bx, by))| Case {
                others,
                qs,
                base: frame([bx, by, 0.0], [0.0, 0.0, 0.0]),
                other_base: frame([x, y, 0.0], [0.0, 0.0, yaw]),
                tool,
                obstacles,
                margin,
            },
        )
}

/// Hits and misses seen per check: obstacles, self, arms; and of the any-hit questions
/// asked, how many were answered yes.
#[derive(Default, Debug)]
struct Seen {
    configurations: u32,
    hits: [u32; 3],
    questions: u32,
    any: u32,
}

/// The bits of a number, every NaN alike (which of two NaN operands an operation passes on is
/// the hardware's choice, and nothing reads a NaN's bits).
fn bits(v: &f64) -> u64 {
    if v.is_nan() {
        f64::NAN.to_bits()
    } else {
        v.to_bits()
    }
}

/// The bits of every number of `f`.
fn frame_bits(f: &Frame) -> Vec<u64> {
    f.rot.iter().chain(f.pos.iter()).map(bits).collect()
}

fn capsule_bits(c: &Capsule) -> Vec<u64> {
    let s = &c.segment;
    (s.a.iter().chain(s.b.iter()).chain([&c.radius]))
        .map(bits)
        .collect()
}

fn box_bits(b: &Aabb) -> Vec<u64> {
    b.min.iter().chain(b.max.iter()).map(bits).collect()
}

/// Lane `k` of `batch` is `pose`, bit for bit: capsules, their boxes, the arm's box.
fn same_pose(batch: &ArmLanes, k: usize, pose: &ArmPose) -> Result<(), TestCaseError> {
    let got = batch.pose(k);
    prop_assert_eq!(got.capsules().len(), pose.capsules().len());
    prop_assert_eq!(
        box_bits(got.aabb()),
        box_bits(pose.aabb()),
        "arm box, lane {}",
        k
    );
    for (i, (a, b)) in got.capsules().iter().zip(pose.capsules()).enumerate() {
        prop_assert_eq!(
            capsule_bits(a),
            capsule_bits(b),
            "capsule {}, lane {}",
            i,
            k
        );
        prop_assert_eq!(
            box_bits(&got.capsule_box(i)),
            box_bits(&pose.capsule_box(i)),
            "box {}, lane {}",
            i,
            k
        );
    }
    Ok(())
}

fn check<M: Model<D>>(c: &Case, seen: &mut Seen) -> Result<(), TestCaseError> {
    let (mut mine, mut theirs) = (ArmLanes::EMPTY, ArmLanes::EMPTY);
    mine.place::<M, D>(0, &c.base, &c.tool, &c.qs);
    theirs.place::<M, D>(0, &c.other_base, &Tool::NONE, &c.others);
    let n = c.qs.len();
    prop_assert_eq!(mine.lanes(), ((1u16 << n) - 1) as Mask);
    let (mut obstacles, mut itself, mut arms): (Mask, Mask, Mask) = (0, 0, 0);
    for k in 0..n {
        let pose = ArmPose::new::<M, D>(0, &c.base, &c.tool, &c.qs[k]);
        let other = ArmPose::new::<M, D>(0, &c.other_base, &Tool::NONE, &c.others[k]);
        same_pose(&mine, k, &pose)?;
        same_pose(&theirs, k, &other)?;
        obstacles |= Mask::from(pose.obstacle_hit(&c.obstacles, c.margin).is_some()) << k;
        itself |= Mask::from(pose.self_hit(c.margin).is_some()) << k;
        arms |= Mask::from(pose.arm_hit(&other, c.margin).is_some()) << k;
    }
    prop_assert_eq!(mine.obstacle_hits(&c.obstacles, c.margin), obstacles);
    prop_assert_eq!(mine.self_hits(c.margin), itself);
    prop_assert_eq!(mine.arm_hits(&theirs, c.margin), arms);
    // Every lane against one pose, as a planner checks a batch against an arm standing.
    let standing = ArmPose::new::<M, D>(0, &c.other_base, &Tool::NONE, &c.others[0]);
    let against: Mask = (0..n)
        .map(|k| {
            let pose = ArmPose::new::<M, D>(0, &c.base, &c.tool, &c.qs[k]);
            Mask::from(pose.arm_hit(&standing, c.margin).is_some()) << k
        })
        .fold(0, |m, b| m | b);
    prop_assert_eq!(mine.arm_hits_pose(&standing, c.margin), against);
    // Whether any lane hits, of a placed batch and placing it link by link; over every lane
    // and over the first alone (a lane of many hits more often than not).
    let scene = Scene {
        obstacles: &c.obstacles,
        boxes: &[],
        margin: c.margin,
    };
    let q: [F64s; D] =
        core::array::from_fn(|j| F64s::new(core::array::from_fn(|k| c.qs[k.min(n - 1)][j])));
    for live in [mine.lanes(), 1] {
        let any = (obstacles | itself) & live != 0;
        let mut placed = mine;
        placed.keep(live);
        prop_assert_eq!(placed.any_hit(&scene), any, "any_hit, lanes {:b}", live);
        let mut progressive = ArmLanes::EMPTY;
        let hit = progressive.place_any_hit::<M, D>(0, &c.base, &c.tool, &q, live, &scene);
        prop_assert_eq!(hit, any, "place_any_hit, lanes {:b}", live);
        if hit {
            prop_assert_eq!(progressive.lanes(), 0);
        } else {
            // Placed whole, as `place` places it.
            prop_assert_eq!(progressive.lanes(), live);
            for k in 0..n {
                same_pose(
                    &progressive,
                    k,
                    &ArmPose::new::<M, D>(0, &c.base, &c.tool, &c.qs[k]),
                )?;
            }
        }
        seen.questions += 1;
        seen.any += u32::from(any);
    }
    seen.configurations += n as u32;
    for (h, m) in seen.hits.iter_mut().zip([obstacles, itself, arms]) {
        *h += m.count_ones();
    }
    Ok(())
}

fn equals_scalar<M: Model<D>>() {
    let seen = RefCell::new(Seen::default());
    // Cases of one to LANES configurations: 7.5 each on average.
    let cases = CONFIGURATIONS.div_ceil(7);
    let mut runner = TestRunner::new(Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    });
    let result = runner.run(&case::<M>(), |c| check::<M>(&c, &mut seen.borrow_mut()));
    if let Err(e) = result {
        panic!("{}: {e}", M::NAME);
    }
    let seen = seen.into_inner();
    println!("{}: {seen:?}", M::NAME);
    assert!(seen.configurations >= CONFIGURATIONS, "{seen:?}");
    // Hits and misses alike, of every check.
    for h in seen.hits {
        let share = f64::from(h) / f64::from(seen.configurations);
        assert!((0.05..=0.95).contains(&share), "{}: {seen:?}", M::NAME);
    }
    let share = f64::from(seen.any) / f64::from(seen.questions);
    assert!((0.05..=0.95).contains(&share), "{}: {seen:?}", M::NAME);
}

#[test]
fn gen3_batches_equal_single_configurations() {
    equals_scalar::<KinovaGen3>();
}

#[test]
fn panda_batches_equal_single_configurations() {
    equals_scalar::<FrankaPanda>();
}

/// The planners' state check of a batch ([`Validity::states_met_batched`], Ω-A*'s successors)
/// answers
/// as one configuration at a time: joint limits, obstacles, itself, point constraints and
/// other arms, avoided or counted.
#[test]
fn batched_state_checks_equal_single_ones() {
    fn run<M: Model<D>>() {
        let mut runner = TestRunner::new(Config {
            cases: 2000,
            failure_persistence: None,
            ..Config::default()
        });
        let strategy = (
            case::<M>(),
            prop::bool::ANY,
            prop::array::uniform3(-0.8..0.8f64),
            0.0..0.3f64,
            prop::collection::vec(0.0..1.0f64, LANES),
        );
        let counts = RefCell::new((0, 0));
        let result = runner.run(&strategy, |(c, count, p, margin, out_of_limits)| {
            // A few configurations past a joint limit.
            let qs: Vec<[f64; D]> = (c.qs.iter().zip(&out_of_limits))
                .map(|(q, &f)| {
                    let mut q = *q;
                    if f < 0.1 {
                        q[1] = M::UPPER[1] + f;
                    }
                    q
                })
                .collect();
            let path = [c.others[0], c.others[0]];
            let others = [OtherArm {
                model: 0,
                base: c.other_base,
                tool: Tool::NONE,
                path: &path,
            }];
            let points = [PointConstraint {
                t: 1,
                segment: false,
                s: 0.0,
                p: [p[0], p[1], p[2] + 0.5],
                margin,
            }];
            let mode = if count {
                OthersMode::Count
            } else {
                OthersMode::Avoid
            };
            let robot = Robot {
                model: 0,
                base: c.base,
                tcp: Frame::IDENTITY,
                initial: None,
                tool: c.tool,
                start: Start::default(),
                assigned: Assigned::default(),
                excluded: StartExclusions::NONE,
            };
            let valid = Validity::<M, D>::new(&robot, &c.obstacles, 0.1, 0.01)
                .with_others(&others, mode)
                .with_points(&points);
            for t in [0, 1] {
                let batch = valid.states_met_batched(&qs, t);
                prop_assert_eq!(batch, valid.states_met(&qs, t));
                for (k, q) in qs.iter().enumerate() {
                    let one = valid.state_met(q, t);
                    prop_assert_eq!(batch[k], one, "lane {}, step {}", k, t);
                    let mut counts = counts.borrow_mut();
                    if one.is_some() {
                        counts.0 += 1;
                    } else {
                        counts.1 += 1;
                    }
                }
                prop_assert!(batch[qs.len()..].iter().all(Option::is_none));
            }
            Ok(())
        });
        if let Err(e) = result {
            panic!("{}: {e}", M::NAME);
        }
        let (some, none) = counts.into_inner();
        assert!(some > 1000 && none > 1000, "{some} valid, {none} not");
    }
    run::<KinovaGen3>();
    run::<FrankaPanda>();
}

/// A motion of each arm: from its configuration to another, near or far.
#[derive(Debug, Clone)]
struct Motions {
    case: Case,
    to: Vec<[f64; D]>,
    step: f64,
}

fn motions<M: Model<D>>() -> impl Strategy<Value = Motions> {
    let reach = prop_oneof![0.02..0.2f64, 0.2..1.5f64, 1.5..5.0f64];
    (
        case::<M>(),
        prop::collection::vec(prop::array::uniform7(-1.0..1.0f64), 2),
        reach,
        prop_oneof![Just(0.01), 0.005..0.05f64],
    )
        .prop_map(|(case, dirs, reach, step)| {
            let to = (case.qs.iter().zip(&case.others))
                .take(1)
                .flat_map(|(a, b)| [a, b])
                .zip(&dirs)
                .map(|(q, d)| {
                    core::array::from_fn(|j| {
                        (q[j] + reach * d[j]).clamp(M::LOWER[j].max(-3.2), M::UPPER[j].min(3.2))
                    })
                })
                .collect();
            Motions { case, to, step }
        })
}

/// Motion checks placing a rake of configurations per call answer as those placing one at a
/// time: an arm against the obstacles and itself, and two arms moving at once (or one of them
/// standing).
#[test]
fn raked_motion_checks_equal_single_placings() {
    fn run<M: Model<D>>() {
        let seen = RefCell::new([0u32; 4]);
        let mut runner = TestRunner::new(Config {
            cases: MOTIONS,
            failure_persistence: None,
            ..Config::default()
        });
        let result = runner.run(&motions::<M>(), |m| {
            let c = &m.case;
            let (from, to) = ((c.qs[0], c.others[0]), (m.to[0], m.to[1]));
            let sweep = |a: &[f64; D], b: &[f64; D], tool: &Tool, p: Placing| {
                Sweep::<M, D>::new(0, tool, a, b, m.step).with_placing(p)
            };
            let mut seen = seen.borrow_mut();
            let own = |p| sweep(&from.0, &to.0, &c.tool, p).arm_collides(&c.base, &c.obstacles);
            let hit = own(Placing::Rake);
            prop_assert_eq!(hit, own(Placing::Single), "own motion");
            seen[0] += u32::from(hit);
            seen[1] += 1;
            let pair = |p, still: bool| {
                let theirs = if still { &from.1 } else { &to.1 };
                sweeps_collide(
                    &sweep(&from.0, &to.0, &c.tool, p),
                    &c.base,
                    &sweep(&from.1, theirs, &Tool::NONE, p),
                    &c.other_base,
                )
            };
            for still in [false, true] {
                let hit = pair(Placing::Rake, still);
                prop_assert_eq!(
                    hit,
                    pair(Placing::Single, still),
                    "two arms, still {}",
                    still
                );
                seen[2] += u32::from(hit);
                seen[3] += 1;
            }
            Ok(())
        });
        if let Err(e) = result {
            panic!("{}: {e}", M::NAME);
        }
        let seen = seen.into_inner();
        println!(
            "{}: own {}/{}, pairs {}/{} collide",
            M::NAME,
            seen[0],
            seen[1],
            seen[2],
            seen[3]
        );
        for (hits, all) in [(seen[0], seen[1]), (seen[2], seen[3])] {
            let share = f64::from(hits) / f64::from(all);
            assert!((0.05..=0.95).contains(&share), "{}: {seen:?}", M::NAME);
        }
    }
    run::<KinovaGen3>();
    run::<FrankaPanda>();
}

/// Forward kinematics of a batch, tool frame and every link frame, equal single calls bit for
/// bit, out-of-range angles (the trigonometry's slow path) included.
#[test]
fn kinematics_of_a_batch_equal_single_configurations() {
    fn run<M: Model<D>>() {
        let mut runner = TestRunner::new(Config {
            cases: 2000,
            failure_persistence: None,
            ..Config::default()
        });
        let angle = prop_oneof![
            8 => -3.2..3.2f64,
            1 => -1e6..1e6f64,
            1 => Just(f64::NAN),
        ];
        let batch = prop::collection::vec(prop::array::uniform7(angle), LANES);
        let result = runner.run(&batch, |qs| {
            let q: [F64s; D] =
                core::array::from_fn(|j| F64s::new(core::array::from_fn(|k| qs[k][j])));
            let tool = M::fk_lanes(&q);
            let n = M::LINK_NAMES.len();
            let mut frames = [FrameOf::<F64s>::identity(); 16];
            let frame = |i: usize, f: &FrameOf<F64s>| {
                frames[i] = *f;
                ControlFlow::Continue(())
            };
            let ControlFlow::Continue(last) = M::link_frames_lanes(&q, frame) else {
                return Err(TestCaseError::fail("the frames stopped"));
            };
            for (k, qk) in qs.iter().enumerate() {
                let same = |a: &Frame, b: &Frame| frame_bits(a) == frame_bits(b);
                prop_assert!(same(&tool.lane(k), &M::fk(qk)), "fk, lane {k}");
                let mut one = [Frame::IDENTITY; 16];
                let single = M::link_frames(qk, &mut one[..n]);
                prop_assert!(same(&last.lane(k), &single), "tool frame, lane {k}");
                for i in 0..n {
                    prop_assert!(same(&frames[i].lane(k), &one[i]), "link {i}, lane {k}");
                }
            }
            Ok(())
        });
        if let Err(e) = result {
            panic!("{}: {e}", M::NAME);
        }
    }
    run::<KinovaGen3>();
    run::<FrankaPanda>();
}

/// A frame composed over lanes is nalgebra's product, bit for bit.
#[test]
fn composing_frames_is_nalgebras_product() {
    let mut runner = TestRunner::new(Config {
        cases: 10_000,
        failure_persistence: None,
        ..Config::default()
    });
    let m = || prop::array::uniform12(-2.0..2.0f64);
    let result = runner.run(&(m(), m()), |(a, b)| {
        let f = |v: [f64; 12]| Frame {
            rot: Matrix3::from_row_slice(&v[..9]),
            pos: Vector3::new(v[9], v[10], v[11]),
        };
        let (a, b) = (f(a), f(b));
        let ours = FrameOf::<f64>::splat(&a).compose(&FrameOf::splat(&b));
        prop_assert_eq!(frame_bits(&Frame::from(ours)), frame_bits(&a.compose(&b)));
        let p = [b.pos.x, b.pos.y, b.pos.z];
        let applied = Vector3::from(FrameOf::<f64>::splat(&a).apply(&p));
        let want = a.apply(&b.pos);
        prop_assert!(applied
            .iter()
            .zip(want.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits()));
        Ok(())
    });
    result.unwrap();
}

/// Segment distances over lanes equal the scalar ones bit for bit, degenerate segments too:
/// points, parallel and collinear ones, shared ends, zero-length pairs, NaN.
#[test]
fn segment_distances_over_lanes_equal_single_ones() {
    let mut runner = TestRunner::new(Config {
        cases: 20_000,
        failure_persistence: None,
        ..Config::default()
    });
    let coordinate = prop_oneof![8 => -1.0..1.0f64, 1 => Just(0.0), 1 => Just(0.5)];
    let point = prop::array::uniform3(coordinate);
    let segment = (point.clone(), point, 0..6u8).prop_map(|(a, mut b, kind)| {
        match kind {
            // A point.
            0 => b = a,
            // Along x, as another may be (parallel, collinear).
            1 => b = [a[0] + 0.3, a[1], a[2]],
            _ => {}
        }
        if kind == 5 && a[0] > 0.9 {
            b[1] = f64::NAN;
        }
        Segment::new(Vector3::from(a), Vector3::from(b))
    });
    let pairs = prop::collection::vec((segment.clone(), segment, 0.0..0.2f64), LANES);
    let result = runner.run(&pairs, |pairs| {
        let lanes = |f: &dyn Fn(&Segment) -> Vector3<f64>, which: usize| -> [F64s; 3] {
            core::array::from_fn(|i| {
                F64s::new(core::array::from_fn(|k| {
                    let s = if which == 0 { &pairs[k].0 } else { &pairs[k].1 };
                    f(s)[i]
                }))
            })
        };
        let mine = Segments {
            a: lanes(&|s| s.a, 0),
            b: lanes(&|s| s.b, 0),
        };
        let theirs = Segments {
            a: lanes(&|s| s.a, 1),
            b: lanes(&|s| s.b, 1),
        };
        let d2 = mine.distance2(&theirs);
        for (k, (p, q, _)) in pairs.iter().enumerate() {
            prop_assert_eq!(
                bits(&d2.as_array()[k]),
                bits(&p.distance2_to_segment(q)),
                "lane {}",
                k
            );
        }
        let reach = 0.02 + 0.03;
        let hits = mine.hits(&theirs, reach, pairs[0].2);
        for (k, (p, q, _)) in pairs.iter().enumerate() {
            let one = Capsule {
                segment: *p,
                radius: 0.02,
            }
            .hits(
                &Capsule {
                    segment: *q,
                    radius: 0.03,
                },
                pairs[0].2,
            );
            prop_assert_eq!(hits & (1 << k) != 0, one, "lane {}", k);
        }
        Ok(())
    });
    result.unwrap();
}
