//! Bounded memory: the core allocates nothing while it plans, and planning fits in a small
//! thread stack.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use omcbsa::planners::PlannerKind;
use omcbsa::planners::{Capacities, Storage, WallClock};
use omcbsa_core::planner::{Status, Until};
use omcbsa_tests::*;

/// Counts allocations of the current thread while counting is on.
struct Counting;

thread_local! {
    static COUNT: Cell<Option<usize>> = const { Cell::new(None) };
}

fn bump() {
    // `try_with`: the allocator may run while the thread's locals are being torn down.
    let _ = COUNT.try_with(|c| {
        if let Some(n) = c.get() {
            c.set(Some(n + 1));
        }
    });
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        bump();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        bump();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        bump();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Runs `f` and returns how many allocations it made on this thread.
fn allocations<R>(f: impl FnOnce() -> R) -> (R, usize) {
    COUNT.with(|c| c.set(Some(0)));
    let r = f();
    let n = COUNT.with(|c| c.replace(None)).unwrap_or(0);
    (r, n)
}

/// Stack the planners are documented to run in (README: "Memory").
const PLANNER_STACK: usize = 1024 * 1024;

#[test]
fn counting_allocator_counts() {
    let (_, n) = allocations(|| vec![1u8; 10]);
    assert!(n >= 1, "the counting allocator must see a Vec allocation");
}

/// A two-arm plan with conflicts to resolve (Ω-CBSA, without its warm start, branches and
/// replans) allocates nothing
/// inside the core call, for every planner, in a thread with a small stack.
#[test]
fn planning_allocates_nothing_in_a_small_stack() {
    let file = facing_pair_problem(120).expect("scene");
    // Boxed (210 kB), so that the thread's stack is the planners' alone.
    let problem = Box::new(core_problem(&file));
    let handle = std::thread::Builder::new()
        .stack_size(PLANNER_STACK)
        .spawn(move || {
            // The storage is allocated on the heap before the core is called.
            let mut storage = Storage::new(
                Capacities {
                    search_nodes: 1 << 14,
                    composite_nodes: 1 << 12,
                    ..Capacities::default()
                },
                problem.horizon(),
            );
            // Cold start, so that Ω-CBSA branches on conflicts and replans under constraints.
            storage.cbs_params.warm_start_seconds = 0.0;
            let mut results = Vec::with_capacity(PlannerKind::BENCH.len());
            for name in PlannerKind::BENCH {
                let clock = WallClock::start();
                let until = Until::new(&clock, 5.0);
                let (r, n) = allocations(|| storage.solve_core(name, &problem, until));
                let ran = r.expect("known planner");
                results.push((name, ran.status, n, ran.stats));
            }
            results
        })
        .expect("spawn");
    let results = handle
        .join()
        .expect("planning thread did not overflow its stack");
    for (name, status, n, stats) in &results {
        assert_eq!(*n, 0, "{name} allocated {n} times while planning");
        if *name == PlannerKind::OmCbsa {
            assert_eq!(*status, Status::Solved);
            assert!(
                stats.conflicts_resolved > 0,
                "the scene should make Ω-CBSA branch: {stats:?}"
            );
        }
    }
}

/// Storage reused run after run gives the same answers (a workspace made over buffers an
/// earlier one used must not see the earlier search's states).
#[test]
fn storage_is_reusable() {
    let (file, _) = elbow_swing_problem(42).expect("scene");
    let problem = core_problem(&file);
    let mut storage = Storage::new(Capacities::default(), problem.horizon());
    let mut first = None;
    for _ in 0..3 {
        let clock = WallClock::start();
        let ran = (storage.solve_core(PlannerKind::OmegaAstar, &problem, Until::new(&clock, 5.0)))
            .expect("planner");
        let stats = ran.stats;
        assert_eq!(ran.status, Status::Solved);
        assert_eq!(
            *first.get_or_insert(stats),
            stats,
            "the same input must give the same search"
        );
    }
}

/// Refinement allocates nothing either: a problem that Ω-CBSA and OM-PP-A*_single solve only
/// at a finer level (tests/fixtures/level0_miss_2arms.json).
#[test]
fn refinement_allocates_nothing() {
    let text = include_str!("../fixtures/level0_miss_2arms.json");
    let file = omcbsa::load::parse_problem(text).expect("fixture parses");
    let problem = Box::new(core_problem(&file));
    let handle = std::thread::Builder::new()
        .stack_size(PLANNER_STACK)
        .spawn(move || {
            let mut storage = Storage::new(Capacities::default(), problem.horizon());
            [PlannerKind::OmCbsa, PlannerKind::PpSingle].map(|name| {
                let clock = WallClock::start();
                let until = Until::new(&clock, 60.0);
                let (r, n) = allocations(|| storage.solve_core(name, &problem, until));
                let ran = r.expect("known planner");
                (name, ran.status, n, ran.stats.level)
            })
        })
        .expect("spawn");
    for (name, status, n, level) in handle.join().expect("no stack overflow") {
        assert_eq!(status, Status::Solved, "{name}");
        assert!(level >= 1, "{name} should need a finer level");
        assert_eq!(n, 0, "{name} allocated {n} times while refining");
    }
}

/// Online chunks (every robot starting exactly where it is, the assignment fixed) are planned
/// with no allocation inside the core, by Ω-CBSA and OM-PP-A*.
#[test]
fn online_chunks_allocate_nothing() {
    use omcbsa_core::problem::{Assigned, Start};
    let file = facing_pair_problem(120).expect("scene");
    let whole = Box::new(core_problem(&file));
    let h = whole.horizon();
    let handle = std::thread::Builder::new()
        // The planners' stack, and room for this test's own problem copies (kept boxed).
        .stack_size(2 * PLANNER_STACK)
        .spawn(move || {
            let mut storage = Storage::new(Capacities::default(), h);
            let outcome = storage
                .solve(omcbsa::planners::PlannerKind::OmCbsa, &whole, 5.0)
                .expect("planner");
            assert_eq!(outcome.status, Status::Solved);
            let mut results = Vec::new();
            // Chunks from steps 1, 3, 5: the arms at the whole plan's step before, the poses
            // from there on (pose 0 is where the arms are, not tracked).
            for start in [1usize, 3, 5] {
                let mut chunk = whole.clone();
                let chunk = &mut *chunk;
                for t in chunk.trajectories.iter_mut() {
                    let rest: heapless::Vec<_, { omcbsa_core::problem::MAX_STEPS }> =
                        t[start - 1..].iter().copied().collect();
                    *t = rest;
                }
                for (i, r) in chunk.robots.iter_mut().enumerate() {
                    r.initial = Some(outcome.joint_paths[i][start - 1]);
                    r.start = Start::AtInitial;
                    r.assigned =
                        outcome.assignment[i].map_or(Assigned::Hold, |j| Assigned::Track(j as u8));
                }
                for name in [PlannerKind::OmCbsa, PlannerKind::Pp] {
                    let clock = WallClock::start();
                    let until = Until::new(&clock, 5.0);
                    let (r, n) = allocations(|| storage.solve_core(name, chunk, until));
                    let ran = r.expect("known planner");
                    let (status, assignment) = (ran.status, ran.assignment);
                    results.push((
                        name,
                        start,
                        status,
                        n,
                        assignment,
                        outcome.assignment.clone(),
                    ));
                }
            }
            results
        })
        .expect("spawn");
    for (name, start, status, n, assignment, whole) in handle.join().expect("no overflow") {
        assert_eq!(
            n, 0,
            "{name} allocated {n} times planning the chunk from {start}"
        );
        assert_eq!(status, Status::Solved, "{name} chunk from {start}");
        let kept: Vec<Option<usize>> = assignment[..whole.len()]
            .iter()
            .map(|a| a.map(usize::from))
            .collect();
        assert_eq!(kept, whole, "{name} kept the assignment");
    }
}

/// The approach allocates nothing either: RRT-Connect joining arms whose hands cross
/// (straight bridges collide in every order), and the whole loop of planning from where the
/// arms stand.
#[test]
fn the_approach_allocates_nothing() {
    use omcbsa_core::approach::{
        plan_approach, ApproachParams, ApproachQuery, ApproachStorage, Method,
    };
    use omcbsa_core::model::KinovaGen3;
    use omcbsa_core::search::NoDeadline;
    let (file, goals) = (0..400)
        .find_map(approach_scenes::crossing_scene)
        .expect("a crossing scene");
    let problem = Box::new(core_problem(&file));
    let handle = std::thread::Builder::new()
        .stack_size(PLANNER_STACK)
        .spawn(move || {
            let (mut tree, mut parent, mut waypoints) =
                (vec![[0.0; 7]; 8192], vec![0u32; 4096], vec![[0.0; 7]; 1024]);
            let mut out = vec![[0.0; 7]; 2048];
            let params = ApproachParams {
                rrt_samples: ApproachParams::default().rrt_samples * 64,
                ..ApproachParams::default()
            };
            let (rrt, n_rrt) = allocations(|| {
                let mut st = ApproachStorage {
                    tree: &mut tree,
                    parent: &mut parent,
                    waypoints: &mut waypoints,
                };
                let q = ApproachQuery {
                    problem: &problem,
                    plan: &goals,
                    horizon: 1,
                    params,
                    deadline: &NoDeadline,
                };
                plan_approach::<KinovaGen3, 7>(&q, &mut st, &mut out)
            });
            let mut storage = Storage::new(Capacities::default(), problem.horizon());
            let runs = [PlannerKind::OmCbsa, PlannerKind::Pp, PlannerKind::PpSingle].map(|name| {
                let clock = WallClock::start();
                let until = Until::new(&clock, 30.0);
                let (r, n) = allocations(|| storage.solve_core(name, &problem, until));
                (name, r.expect("known planner").status, n)
            });
            (rrt.map(|a| a.method), n_rrt, runs)
        })
        .expect("spawn");
    let (rrt, n_rrt, runs) = handle.join().expect("no stack overflow");
    assert!(
        matches!(rrt, Ok(Method::OrderedRrt | Method::Rrt)),
        "{rrt:?}"
    );
    assert_eq!(n_rrt, 0, "RRT-Connect allocated {n_rrt} times");
    for (name, status, n) in runs {
        assert_eq!(status, Status::Solved, "{name}");
        assert_eq!(
            n, 0,
            "{name} allocated {n} times while planning with the approach"
        );
    }
}

/// Both models' kinematics and IK allocate nothing (the core has no allocator at all on
/// `thumbv7em-none-eabihf`; here the count shows it for the host build too).
#[test]
fn both_models_kinematics_allocate_nothing() {
    use omcbsa_core::ik::{ik_multi_start, IkParams, MultiStart};
    use omcbsa_core::model::{Frame, FrankaPanda, KinovaGen3, Model};
    use omcbsa_core::rng::Rng;
    fn run<M: Model<7>>() -> usize {
        let q = [0.3, -0.4, 0.2, -1.8, 0.1, 1.6, 0.5];
        let mut frames = [Frame::IDENTITY; 16];
        let mut out = [[0.0; 7]; 2];
        let (solved, n) = allocations(|| {
            let target = M::fk(&q);
            M::link_frames(&q, &mut frames);
            let _ = M::jacobian(&q);
            let params = IkParams::default();
            let mut rng = Rng::new(3);
            ik_multi_start::<M, 7>(
                0,
                &target,
                &params,
                &MultiStart::default(),
                &mut rng,
                &mut out,
            )
        });
        assert!(solved.is_ok(), "{}: {solved:?}", M::NAME);
        n
    }
    assert_eq!(run::<KinovaGen3>(), 0, "Gen3");
    assert_eq!(run::<FrankaPanda>(), 0, "Panda");
}

/// The batched kernel allocates nothing: 8 configurations placed, checked against obstacles,
/// themselves and a second arm, and a motion checked with a rake of placings per call (what
/// the planners use on an x86-64-v3 build, the workspace's; `lanes::WIDE` says so).
#[test]
fn batched_checks_allocate_nothing() {
    use omcbsa_core::collision::{ArmLanes, ArmPose, Placing, Sweep};
    use omcbsa_core::geometry::{Obstacle, Shape};
    use omcbsa_core::model::{Frame, KinovaGen3};
    use omcbsa_core::nalgebra::Vector3;
    use omcbsa_core::tool::Tool;
    const { assert!(!cfg!(target_arch = "x86_64") || omcbsa_core::lanes::WIDE) };
    let ball = Obstacle {
        shape: Shape::Sphere { radius: 0.1 },
        pose: Frame {
            pos: Vector3::new(0.3, 0.0, 0.6),
            ..Frame::IDENTITY
        },
    };
    let qs: Vec<[f64; 7]> = (0..8)
        .map(|k| [0.2 * k as f64, 0.5, 0.0, 1.0, 0.0, 0.5, 0.0])
        .collect();
    let other_base = Frame {
        pos: Vector3::new(0.7, 0.0, 0.0),
        ..Frame::IDENTITY
    };
    let other = ArmPose::new::<KinovaGen3, 7>(0, &other_base, &Tool::NONE, &[0.0; 7]);
    let (mut a, mut b) = (ArmLanes::EMPTY, ArmLanes::EMPTY);
    let (hits, n) = allocations(|| {
        a.place::<KinovaGen3, 7>(0, &Frame::IDENTITY, &Tool::NONE, &qs);
        b.place::<KinovaGen3, 7>(0, &other_base, &Tool::NONE, &qs);
        let sweep = Sweep::<KinovaGen3, 7>::new(0, &Tool::NONE, &qs[0], &qs[7], 0.01);
        let moving = sweep.with_placing(Placing::Rake);
        [
            a.obstacle_hits(&[ball], 0.0),
            a.self_hits(0.0),
            a.arm_hits(&b, 0.0),
            a.arm_hits_pose(&other, 0.0),
            u8::from(moving.arm_collides(&Frame::IDENTITY, &[ball])),
        ]
    });
    assert_eq!(n, 0, "the batched checks allocated {n} times ({hits:?})");
}
