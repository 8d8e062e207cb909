//! Collision checking speed, single configurations against batches of [`LANES`], with parry's
//! capsule queries as an in-process peer, in one run.
//!
//! `cargo bench -p omcbsa-core --bench collision -- --warm-up-time 0.5 --measurement-time 2`
//! (the workspace builds x86_64 for AVX2, `x86-64-v3`; the machine's best:
//! `RUSTFLAGS="-C target-cpu=native"`; see `omcbsa_core::lanes`).
//!
//! The scene: per arm, 3 boxes, 2 spheres and a capsule around it (a low table in front, a
//! post, a shelf behind, two balls, a bar), the arms in a row 0.8 m apart (6 arms: two rows
//! facing each other). Groups, per model (Gen3, Panda) and number of arms (1, 2, 3, 6):
//! - `fk`: the tool frame, one configuration at a time against a batch (time per
//!   configuration: criterion's throughput).
//! - `config`: one composite configuration, every arm against the obstacles and itself and
//!   every pair of arms, on random configurations (most collide: the checks stop at the first
//!   hit) and on collision-free ones (every check runs to the end). `single` places each arm
//!   and checks it as the planners do one configuration at a time (`ArmPose`); `batched`
//!   places and checks [`LANES`] composite configurations per call (`ArmLanes`), time per
//!   configuration; `parry` places the arms as `single` and runs parry's intersection tests
//!   on the pairs whose boxes meet (the same box tests first).
//! - `motion` (1 and 3 arms): a valid composite motion, each arm moving straight in joint space
//!   by 0.1, 1 or 5 rad of Euclidean joint distance (the length of a motion in VAMP and in
//!   `docs/bench/collision.md`'s peer scene), in a random direction, within its limits, from
//!   a collision-free configuration to another, clear of everything by 1 cm at samples at
//!   most 4 mm apart (a test independent of the check measured, so every version of it is
//!   timed on the same motions, which it must find free): each arm against
//!   the obstacles and itself along the motion, and every pair (`sweeps_collide`), as the
//!   planners check a composite step. `single` (the default placing) places one configuration
//!   at a time, `batched` a rake of them per call. Both give the same answer
//!   (`core/tests/batch.rs`).

use std::cell::OnceCell;
use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::{Rotation3, Vector3};
use omcbsa_core::collision::{
    sweeps_collide_posed, ArmLanes, ArmPose, Obstacles, Placing, Scene, Sweep,
};
use omcbsa_core::geometry::{Aabb, Capsule, Obstacle, Shape};
use omcbsa_core::lanes::{F64s, LANES};
use omcbsa_core::model::{Frame, FrankaPanda, KinovaGen3, Model};
use omcbsa_core::motion::MOTION_STEP;
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;
use parry3d_f64::math::{Pose3, Rot3, Vec3};
use parry3d_f64::query;
use parry3d_f64::shape::{self as ps, Shape as ParryShape};

const D: usize = 7;
/// Configurations (or motions) drawn per case; the benchmarks cycle through them.
const CASES: usize = 256;

fn at(x: f64, y: f64, yaw: f64) -> Frame {
    Frame {
        rot: *Rotation3::from_euler_angles(0.0, 0.0, yaw).matrix(),
        pos: Vector3::new(x, y, 0.0),
    }
}

/// The arms' bases: in a row 0.8 m apart, or two facing rows of three 1.3 m apart.
fn bases(arms: usize) -> Vec<Frame> {
    (0..arms)
        .map(|i| match arms {
            6 if i >= 3 => at(0.8 * (i - 3) as f64, 1.3, std::f64::consts::PI),
            _ => at(0.8 * i as f64, 0.0, 0.0),
        })
        .collect()
}

/// Each arm's share of the scene, placed in its base frame.
fn scene(bases: &[Frame]) -> Vec<Obstacle> {
    let placed = |base: &Frame, shape: Shape, p: [f64; 3], roll: f64| Obstacle {
        shape,
        pose: base.compose(&Frame {
            rot: *Rotation3::from_euler_angles(roll, 0.0, 0.0).matrix(),
            pos: Vector3::from(p),
        }),
    };
    let box_ = |h: [f64; 3]| Shape::Box { half_extents: h };
    bases
        .iter()
        .flat_map(|b| {
            [
                placed(b, box_([0.25, 0.3, 0.02]), [0.55, 0.0, 0.05], 0.0),
                placed(b, box_([0.04, 0.04, 0.3]), [0.35, 0.4, 0.3], 0.0),
                placed(b, box_([0.15, 0.05, 0.2]), [-0.35, -0.45, 0.55], 0.0),
                placed(b, Shape::Sphere { radius: 0.07 }, [0.45, -0.3, 0.65], 0.0),
                placed(b, Shape::Sphere { radius: 0.05 }, [-0.1, 0.45, 0.95], 0.0),
                placed(
                    b,
                    Shape::Capsule {
                        radius: 0.03,
                        half_length: 0.15,
                    },
                    [0.6, 0.25, 0.45],
                    std::f64::consts::FRAC_PI_2,
                ),
            ]
        })
        .collect()
}

/// A problem's arms and scene.
struct Setup {
    bases: Vec<Frame>,
    /// Kept for the whole run (leaked), as a planner keeps a problem's.
    obstacles: &'static [Obstacle],
    /// The obstacles' boxes, made once as a planner makes them: for configurations, and in
    /// lanes for motions.
    boxes: Vec<Aabb>,
    scene: Obstacles<'static>,
}

impl Setup {
    fn new(arms: usize) -> Setup {
        let bases = bases(arms);
        let obstacles: &'static [Obstacle] = scene(&bases).leak();
        Setup {
            boxes: obstacles.iter().map(Obstacle::aabb).collect(),
            scene: Obstacles::new(obstacles).expect("at most MAX_OBSTACLES obstacles"),
            obstacles,
            bases,
        }
    }

    fn poses<M: Model<D>>(&self, qs: &[[f64; D]]) -> Vec<ArmPose> {
        (self.bases.iter().zip(qs))
            .map(|(b, q)| ArmPose::new::<M, D>(0, b, &Tool::NONE, q))
            .collect()
    }

    /// Whether the composite configuration collides: one configuration at a time.
    fn collides<M: Model<D>>(&self, qs: &[[f64; D]], poses: &mut [ArmPose]) -> bool {
        self.closer_than::<M>(qs, poses, 0.0)
    }

    /// Whether some part of the composite configuration is within `clearance` of an obstacle,
    /// another part of its arm it may hit, or another arm.
    fn closer_than<M: Model<D>>(
        &self,
        qs: &[[f64; D]],
        poses: &mut [ArmPose],
        clearance: f64,
    ) -> bool {
        for ((p, b), q) in poses.iter_mut().zip(&self.bases).zip(qs) {
            p.place::<M, D>(0, b, &Tool::NONE, q);
            if p.obstacle_hit(self.obstacles, clearance).is_some()
                || p.self_hit(clearance).is_some()
            {
                return true;
            }
        }
        (0..poses.len())
            .any(|i| (i + 1..poses.len()).any(|k| poses[i].arm_hit(&poses[k], clearance).is_some()))
    }

    /// Which of [`LANES`] composite configurations (`qs[arm][lane]`) collide, a lane bit each.
    fn collide_lanes<M: Model<D>>(&self, qs: &[[F64s; D]], arms: &mut [ArmLanes]) -> u8 {
        let mut hit = 0;
        for ((a, b), q) in arms.iter_mut().zip(&self.bases).zip(qs) {
            a.place_lanes::<M, D>(0, b, &Tool::NONE, q, !hit, u32::MAX);
            hit |= a.obstacle_hits_boxed(&Scene {
                obstacles: self.obstacles,
                boxes: &self.boxes,
                margin: 0.0,
            });
            hit |= a.self_hits(0.0);
        }
        for i in 0..arms.len() {
            for k in i + 1..arms.len() {
                if hit == u8::MAX {
                    return hit;
                }
                hit |= arms[i].arm_hits(&arms[k], 0.0);
            }
        }
        hit
    }
}

fn config<M: Model<D>>(rng: &mut Rng) -> [f64; D] {
    let (lo, hi) = (M::LOWER.map(|l| l.max(-3.1)), M::UPPER.map(|u| u.min(3.1)));
    rng.configuration(&lo, &hi)
}

/// A composite configuration, collision-free if `free`: drawn arm by arm (collision-free
/// configurations of many arms are rare drawn all at once). `None` when an arm found no place.
fn composite<M: Model<D>>(
    setup: &Setup,
    free: bool,
    rng: &mut Rng,
    poses: &mut [ArmPose],
) -> Option<Vec<[f64; D]>> {
    let mut qs: Vec<[f64; D]> = Vec::new();
    for n in 1..=setup.bases.len() {
        let part = Setup {
            bases: setup.bases[..n].to_vec(),
            obstacles: setup.obstacles,
            boxes: setup.boxes.clone(),
            scene: setup.scene,
        };
        let q = (0..10_000).map(|_| config::<M>(rng)).find(|q| {
            qs.push(*q);
            let ok = !free || !part.collides::<M>(&qs, &mut poses[..n]);
            qs.pop();
            ok
        })?;
        qs.push(q);
    }
    Some(qs)
}

/// `CASES` composite configurations, collision-free ones only if `free`.
fn configs<M: Model<D>>(setup: &Setup, free: bool, rng: &mut Rng) -> Vec<Vec<[f64; D]>> {
    let mut poses = setup.poses::<M>(&vec![[0.0; D]; setup.bases.len()]);
    let mut out = Vec::new();
    while out.len() < CASES {
        out.extend(composite::<M>(setup, free, rng, &mut poses));
    }
    out
}

/// Per arm, per joint, [`LANES`] configurations from `cases` starting at `first`.
fn lanes_of(cases: &[Vec<[f64; D]>], first: usize) -> Vec<[F64s; D]> {
    let arms = cases[0].len();
    (0..arms)
        .map(|a| {
            core::array::from_fn(|j| {
                F64s::new(core::array::from_fn(|k| {
                    cases[(first + k) % cases.len()][a][j]
                }))
            })
        })
        .collect()
}

fn v(p: &Vector3<f64>) -> Vec3 {
    Vec3::new(p.x, p.y, p.z)
}

/// The scene as parry shapes.
fn parry_scene(obstacles: &[Obstacle]) -> Vec<(Box<dyn ParryShape>, Pose3, Aabb)> {
    obstacles
        .iter()
        .map(|o| {
            let m = o.pose.rot;
            let q = nalgebra::UnitQuaternion::from_rotation_matrix(
                &nalgebra::Rotation3::from_matrix_unchecked(m),
            );
            let rot = Rot3::from_xyzw(q.i, q.j, q.k, q.w);
            let pose = Pose3::from_parts(v(&o.pose.pos), rot);
            let shape: Box<dyn ParryShape> = match o.shape {
                Shape::Box { half_extents } => {
                    Box::new(ps::Cuboid::new(v(&Vector3::from(half_extents))))
                }
                Shape::Sphere { radius } => Box::new(ps::Ball::new(radius)),
                Shape::Capsule {
                    radius,
                    half_length,
                } => Box::new(ps::Capsule::new_z(half_length, radius)),
                Shape::Cylinder { .. } => unreachable!("no cylinders in this scene"),
            };
            (shape, pose, o.aabb())
        })
        .collect()
}

fn parry_capsule(c: &Capsule) -> ps::Capsule {
    ps::Capsule::new(v(&c.segment.a), v(&c.segment.b), c.radius)
}

/// [`Setup::collides`] with parry's intersection tests in place of ours, after the same box
/// tests.
fn parry_collides<M: Model<D>>(
    setup: &Setup,
    scene: &[(Box<dyn ParryShape>, Pose3, Aabb)],
    qs: &[[f64; D]],
    poses: &mut [ArmPose],
) -> bool {
    let id = Pose3::IDENTITY;
    let meet = |a: &Capsule, b: &Capsule| {
        query::intersection_test(&id, &parry_capsule(a), &id, &parry_capsule(b))
            .is_ok_and(|i| i.intersecting)
    };
    for ((p, b), q) in poses.iter_mut().zip(&setup.bases).zip(qs) {
        p.place::<M, D>(0, b, &Tool::NONE, q);
        let caps = p.capsules();
        for (shape, pose, ob) in scene {
            for (i, c) in caps.iter().enumerate() {
                if !p.on_base(i)
                    && p.capsule_box(i).near(ob, 0.0)
                    && query::intersection_test(&id, &parry_capsule(c), pose, shape.as_ref())
                        .is_ok_and(|i| i.intersecting)
                {
                    return true;
                }
            }
        }
        for &(a, b) in M::SELF_PAIRS {
            let (a, b) = (usize::from(a), usize::from(b));
            if p.capsule_box(a).near(&p.capsule_box(b), 0.0) && meet(&caps[a], &caps[b]) {
                return true;
            }
        }
    }
    for i in 0..poses.len() {
        for k in i + 1..poses.len() {
            let (p, o) = (&poses[i], &poses[k]);
            if !p.aabb().near(o.aabb(), 0.0) {
                continue;
            }
            for (a, ca) in p.capsules().iter().enumerate() {
                for (b, cb) in o.capsules().iter().enumerate() {
                    if p.capsule_box(a).near(&o.capsule_box(b), 0.0) && meet(ca, cb) {
                        return true;
                    }
                }
            }
        }
    }
    false
}

fn fk<M: Model<D>>(c: &mut Criterion, name: &str) {
    let mut rng = Rng::new(1);
    let qs: Vec<[f64; D]> = (0..CASES).map(|_| config::<M>(&mut rng)).collect();
    let cases: Vec<Vec<[f64; D]>> = qs.iter().map(|q| vec![*q]).collect();
    let mut g = c.benchmark_group(format!("fk/{name}"));
    g.throughput(Throughput::Elements(1));
    g.bench_function("single", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % CASES;
            M::fk(black_box(&qs[i]))
        })
    });
    g.throughput(Throughput::Elements(LANES as u64));
    let batches: Vec<[F64s; D]> = (0..CASES / LANES)
        .map(|i| lanes_of(&cases, i * LANES)[0])
        .collect();
    g.bench_function("batched", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % batches.len();
            M::fk_lanes(black_box(&batches[i]))
        })
    });
    g.finish();
}

fn configurations<M: Model<D>>(c: &mut Criterion, name: &str) {
    for arms in [1, 2, 3, 6] {
        let setup = Setup::new(arms);
        let scene = parry_scene(setup.obstacles);
        for free in [false, true] {
            // Drawn once, when a benchmark of the group first runs (not at all when filtered
            // out: collision-free configurations of six arms take a while to find).
            let cases = OnceCell::new();
            let cases = || {
                cases.get_or_init(|| {
                    let cases = configs::<M>(&setup, free, &mut Rng::new(7 + arms as u64));
                    let batches: Vec<Vec<[F64s; D]>> = (0..CASES / LANES)
                        .map(|i| lanes_of(&cases, i * LANES))
                        .collect();
                    (cases, batches)
                })
            };
            let kind = if free { "free" } else { "random" };
            let mut g = c.benchmark_group(format!("config/{name}/{arms}arms/{kind}"));
            let mut poses = setup.poses::<M>(&vec![[0.0; D]; arms]);
            g.throughput(Throughput::Elements(1));
            g.bench_function("single", |b| {
                let (cases, _) = cases();
                let mut i = 0;
                b.iter(|| {
                    i = (i + 1) % CASES;
                    setup.collides::<M>(black_box(&cases[i]), &mut poses)
                })
            });
            g.bench_function("parry", |b| {
                let (cases, _) = cases();
                let mut i = 0;
                b.iter(|| {
                    i = (i + 1) % CASES;
                    parry_collides::<M>(&setup, &scene, black_box(&cases[i]), &mut poses)
                })
            });
            let mut lanes = vec![ArmLanes::EMPTY; arms];
            g.throughput(Throughput::Elements(LANES as u64));
            g.bench_function("batched", |b| {
                let (_, batches) = cases();
                let mut i = 0;
                b.iter(|| {
                    i = (i + 1) % batches.len();
                    setup.collide_lanes::<M>(black_box(&batches[i]), &mut lanes)
                })
            });
            g.finish();
        }
    }
}

/// Whether the composite motion `from -> to` collides, placing as `placing` says: each arm
/// against the obstacles and itself, then every pair, as the approach's composite check. The
/// arms are placed at the ends into `ends` (per arm, its poses at both ends), as a planner
/// places the states it keeps.
fn motion_collides<M: Model<D>>(
    setup: &Setup,
    from: &[[f64; D]],
    to: &[[f64; D]],
    placing: Placing,
    ends: &mut [[ArmPose; 2]],
) -> bool {
    match setup.bases.len() {
        1 => arms_collide::<M, 1>(setup, from, to, placing, ends),
        3 => arms_collide::<M, 3>(setup, from, to, placing, ends),
        n => unreachable!("motions of {n} arms are not measured"),
    }
}

/// [`motion_collides`] for `N` arms, their sweeps kept on the stack as a planner keeps them.
fn arms_collide<M: Model<D>, const N: usize>(
    setup: &Setup,
    from: &[[f64; D]],
    to: &[[f64; D]],
    placing: Placing,
    ends: &mut [[ArmPose; 2]],
) -> bool {
    let sweep: [Sweep<M, D>; N] = core::array::from_fn(|i| {
        Sweep::new(0, &Tool::NONE, &from[i], &to[i], MOTION_STEP).with_placing(placing)
    });
    for (i, (e, b)) in ends.iter_mut().zip(&setup.bases).enumerate() {
        e[0].place::<M, D>(0, b, &Tool::NONE, &from[i]);
        e[1].place::<M, D>(0, b, &Tool::NONE, &to[i]);
    }
    let ends = &*ends;
    let posed = |i: usize| [&ends[i][0], &ends[i][1]];
    let obstacles = &setup.scene;
    if (0..N).any(|i| sweep[i].arm_collides_among(&setup.bases[i], obstacles, posed(i))) {
        return true;
    }
    (0..N).any(|i| {
        (i + 1..N).any(|k| {
            let (b, c) = (&setup.bases[i], &setup.bases[k]);
            sweeps_collide_posed(&sweep[i], b, posed(i), &sweep[k], c, posed(k))
        })
    })
}

/// A composite motion: every arm's configuration before and after.
type Motion = (Vec<[f64; D]>, Vec<[f64; D]>);

/// Composite motions drawn per length.
const MOTIONS: usize = CASES / 4;
/// How far apart a drawn motion is sampled, at most, by any point's travel.
const DRAWN_STEP: f64 = 0.004;
/// How far a drawn motion clears everything at its samples.
const DRAWN_CLEARANCE: f64 = 0.01;

/// Whether the composite motion `from -> to` clears everything by [`DRAWN_CLEARANCE`] at
/// samples [`DRAWN_STEP`] apart, ends included.
fn clear_sampled<M: Model<D>>(setup: &Setup, from: &[[f64; D]], to: &[[f64; D]]) -> bool {
    let mut poses = setup.poses::<M>(from);
    let sweeps: Vec<Sweep<M, D>> = (from.iter().zip(to))
        .map(|(a, b)| Sweep::new(0, &Tool::NONE, a, b, DRAWN_STEP))
        .collect();
    let pieces = sweeps.iter().map(Sweep::count).max().unwrap_or(1);
    (0..=pieces).all(|k| {
        let s = k as f64 / pieces as f64;
        let qs: Vec<[f64; D]> = sweeps.iter().map(|w| w.at(s)).collect();
        !setup.closer_than::<M>(&qs, &mut poses, DRAWN_CLEARANCE)
    })
}

/// `MOTIONS` collision-free composite motions from collision-free configurations: each arm
/// moves `length` rad of Euclidean joint distance, straight, in a random direction (uniform
/// per joint in `-1..1`, scaled to the length), staying within its limits. A motion is kept
/// when every arm clears everything by [`DRAWN_CLEARANCE`] at placings no point of it moves
/// more than [`DRAWN_STEP`] between: a test that does not depend on the motion check under
/// measure, so every version of the check is timed on the same motions (the check must then
/// find each one clear, asserted: by its margin, at most half of [`MOTION_STEP`]).
fn motions<M: Model<D>>(setup: &Setup, length: f64, rng: &mut Rng) -> Vec<Motion> {
    let (lo, hi) = (M::LOWER.map(|l| l.max(-3.1)), M::UPPER.map(|u| u.min(3.1)));
    let within = |q: &[f64; D]| (0..D).all(|j| (lo[j]..=hi[j]).contains(&q[j]));
    let mut out = Vec::new();
    let mut poses = setup.poses::<M>(&vec![[0.0; D]; setup.bases.len()]);
    let mut ends = vec![[ArmPose::EMPTY; 2]; setup.bases.len()];
    while out.len() < MOTIONS {
        let Some(from) = composite::<M>(setup, true, rng, &mut poses) else {
            continue;
        };
        let mut step = |q: &[f64; D]| {
            (0..1000).find_map(|_| {
                let dir: [f64; D] = core::array::from_fn(|_| rng.uniform(-1.0, 1.0));
                let norm = dir.iter().map(|v| v * v).sum::<f64>().sqrt();
                let to = core::array::from_fn(|j| q[j] + length * dir[j] / norm);
                within(&to).then_some(to)
            })
        };
        for _ in 0..100 {
            let Some(to) = from.iter().map(&mut step).collect::<Option<Vec<_>>>() else {
                break;
            };
            if clear_sampled::<M>(setup, &from, &to) {
                assert!(!motion_collides::<M>(
                    setup,
                    &from,
                    &to,
                    Placing::Single,
                    &mut ends
                ));
                out.push((from, to));
                break;
            }
        }
    }
    out
}

fn motion_checks<M: Model<D>>(c: &mut Criterion, name: &str) {
    for arms in [1, 3] {
        let setup = Setup::new(arms);
        for length in [0.1, 1.0, 5.0] {
            let cases = OnceCell::new();
            let cases = || {
                cases.get_or_init(|| motions::<M>(&setup, length, &mut Rng::new(11 + arms as u64)))
            };
            let mut g = c.benchmark_group(format!("motion/{name}/{arms}arms/{length}rad"));
            for (label, placing) in [("single", Placing::Single), ("batched", Placing::Rake)] {
                g.bench_function(label, |b| {
                    let cases = cases();
                    let mut ends = vec![[ArmPose::EMPTY; 2]; arms];
                    let mut i = 0;
                    b.iter(|| {
                        i = (i + 1) % cases.len();
                        let (from, to) = &cases[i];
                        let (from, to) = (black_box(from), black_box(to));
                        motion_collides::<M>(&setup, from, to, placing, &mut ends)
                    })
                });
            }
            g.finish();
        }
    }
}

fn collision(c: &mut Criterion) {
    fk::<KinovaGen3>(c, "gen3");
    fk::<FrankaPanda>(c, "panda");
    configurations::<KinovaGen3>(c, "gen3");
    configurations::<FrankaPanda>(c, "panda");
    motion_checks::<KinovaGen3>(c, "gen3");
    motion_checks::<FrankaPanda>(c, "panda");
}

criterion_group!(benches, collision);
criterion_main!(benches);
