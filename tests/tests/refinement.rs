//! Refinement (issue #12) and the soundness of Ω-CBSA's branching (issue #17): a problem whose
//! first level is exhausted is solved at a finer one, the same plan whatever the clock does,
//! and a provably infeasible problem gets `no_solution` at once with its reason.

use omcbsa::format::Status as FileStatus;
use omcbsa::load;
use omcbsa::planners::{Capacities, Storage, WallClock};
use omcbsa_core::collision::ArmPose;
use omcbsa_core::model::{KinovaGen3, Model};
use omcbsa_core::motion::{
    motions_conflict_posed, motions_contact, near_point, ArmMotion, CONFIRM, CONTACT_SAMPLES,
    MOTION_STEP,
};
use omcbsa_core::planner::{Clock, NoClock, Status, Until};
use omcbsa_core::reach::UNREACHABLE;
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;
use omcbsa_tests::*;

/// A problem of the refinement family (random_ring_2arms_022 of `omcbsa gen-bench --refine 12`,
/// which has a validated witness) on which the first level of Ω-CBSA, OM-PP-A* and
/// OM-PP-A*_single has no plan. (Found by planning the 2-arm problems of that family: since the
/// sweeps check each part of a motion between two placings, none of the 2-arm problems of
/// `gen-bench --seed 16 .. 23 --per-family 20` misses level 0 for all three.)
fn level0_miss() -> omcbsa::format::ProblemFile {
    let text = include_str!("../fixtures/level0_miss_2arms.json");
    load::parse_problem(text).expect("fixture parses")
}

/// A clock that jumps a millisecond at every look, like a machine so loaded that every check
/// of the deadline finds time gone (but far from the deadline).
struct Loaded(std::cell::Cell<f64>);

impl Clock for Loaded {
    fn seconds(&self) -> f64 {
        let t = self.0.get() + 1e-3;
        self.0.set(t);
        t
    }
}

#[test]
fn a_problem_that_exhausts_the_first_level_is_solved_at_a_finer_one() {
    for planner in ["omcbsa", "pp", "pp-single"] {
        let sol = plan_and_validate(&level0_miss(), planner, 60.0);
        assert_eq!(sol.status, FileStatus::Solved, "{planner}: {}", sol.message);
        // A planner moves to level 1 only once level 0 is exhausted.
        assert!(
            sol.stats["level"].as_u64().unwrap() >= 1,
            "{planner}: {:?}",
            sol.stats
        );
    }
}

#[test]
fn the_plan_does_not_depend_on_the_clock() {
    let problem = core_problem(&level0_miss());
    let mut storage = Storage::new(Capacities::default(), problem.horizon());
    let mut run = |clock: &dyn Clock, planner: &str| {
        let kind = omcbsa::planners::parse(planner).expect("known");
        let ran = (storage.solve_core(kind, &problem, Until::new(clock, 1e6))).expect("planner");
        (ran.status, ran.assignment, ran.stats)
    };
    for planner in ["omcbsa", "pp-single"] {
        let still = run(&NoClock, planner);
        assert_eq!(still.0, Status::Solved, "{planner}");
        assert_eq!(still, run(&WallClock::start(), planner), "{planner}");
        assert_eq!(still, run(&Loaded(0.0.into()), planner), "{planner}");
    }
}

#[test]
fn an_unreachable_pose_is_no_solution_at_once_with_the_reason() {
    let base = frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    let q = [0.0, 0.35, 0.0, 1.8, 0.0, 1.0, 0.0];
    let mut poses: Vec<_> = (0..4).map(|_| pose_json(&tool(&base, &q))).collect();
    // 3 m away: a Gen3 reaches about 1.2 m.
    poses[2] = pose_json(&frame([3.0, 0.0, 0.5], [0.0, 0.0, 0.0]));
    let file = problem_json(
        "unreachable",
        0.1,
        vec![robot_json("a", &base, Some(&q))],
        vec![serde_json::json!({"name": "far", "poses": poses})],
        vec![],
    );
    for planner in ["omcbsa", "pp", "pp-single"] {
        let sol = plan_and_validate(&file, planner, 5.0);
        assert_eq!(sol.status, FileStatus::NoSolution, "{planner}");
        assert_eq!(sol.message, UNREACHABLE, "{planner}");
        assert_eq!(sol.stats["reason"], UNREACHABLE, "{planner}");
        assert_eq!(sol.stats["expansions"], 0, "{planner}: no search needed");
    }
}

/// The witness of a motion conflict is a point inside both arms at one instant, so no plan
/// without collisions can break both children's constraints.
#[test]
fn motion_conflicts_branch_on_a_point_both_arms_hold_at_one_instant() {
    let a_base = frame([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]);
    let b_base = frame([0.9, 0.0, 0.0], [0.0, 0.0, std::f64::consts::PI]);
    let mut rng = Rng::new(7);
    let (mut exact, mut tried) = (0, 0);
    while exact < 20 && tried < 20_000 {
        tried += 1;
        // Two random configurations per arm, the second a short motion from the first.
        let mut q: [[f64; 7]; 4] =
            std::array::from_fn(|_| rng.configuration(&KinovaGen3::LOWER, &KinovaGen3::UPPER));
        for k in [1, 3] {
            q[k] = std::array::from_fn(|i| q[k - 1][i] + rng.uniform(-0.4, 0.4));
        }
        let ma = ArmMotion {
            model: 0,
            base: &a_base,
            tool: &Tool::NONE,
            from: &q[0],
            to: &q[1],
        };
        let mb = ArmMotion {
            model: 0,
            base: &b_base,
            tool: &Tool::NONE,
            from: &q[2],
            to: &q[3],
        };
        let place = |m: &ArmMotion<'_, 7>, s: f64| {
            let c: [f64; 7] = std::array::from_fn(|i| m.from[i] + s * (m.to[i] - m.from[i]));
            ArmPose::new::<KinovaGen3, 7>(0, m.base, m.tool, &c)
        };
        // Both arms overlap at the start: a step conflict, not a motion one.
        let ([a0, a1], [b0, b1]) = (
            [place(&ma, 0.0), place(&ma, 1.0)],
            [place(&mb, 0.0), place(&mb, 1.0)],
        );
        if a0.arm_hit(&b0, 0.0).is_some()
            || !motions_conflict_posed::<KinovaGen3, 7>(
                &ma,
                [&a0, &a1],
                &mb,
                [&b0, &b1],
                MOTION_STEP,
            )
        {
            continue;
        }
        let (c, is_exact) = motions_contact::<KinovaGen3, 7>(&ma, &mb, MOTION_STEP)
            .expect("a counted motion conflict always gets a witness");
        assert!(c.s > 0.0 && c.s < 1.0);
        // The instant is the first of the grid at which the arms overlap, as a scan of every
        // instant finds it (the search skips those the clearance rules out).
        let fine = MOTION_STEP / CONFIRM;
        let pieces =
            (ma.sweep::<KinovaGen3>(fine).count()).max(mb.sweep::<KinovaGen3>(fine).count());
        let count = pieces * CONTACT_SAMPLES;
        let first = (0..count)
            .map(|i| (i as f64 + 0.5) / count as f64)
            .find(|&s| place(&ma, s).arm_hit(&place(&mb, s), 0.0).is_some());
        assert_eq!(first, is_exact.then_some(c.s), "try {tried}");
        if is_exact {
            exact += 1;
            assert_eq!(c.margin, 0.0);
            assert!(near_point(&place(&ma, c.s), &c.point, 1e-9));
            assert!(near_point(&place(&mb, c.s), &c.point, 1e-9));
        }
    }
    assert!(exact >= 20, "only {exact} exact witnesses in {tried} tries");
}

/// Ω-CBSA branching from a cold start: every node it pops with conflicts gets branched on.
#[test]
fn no_constraint_tree_node_with_conflicts_is_dropped() {
    let mut storage = Storage::new(Capacities::default(), 64);
    storage.cbs_params.warm_start_seconds = 0.0;
    let mut branched = 0;
    for seed in [120, 121, 122, 123] {
        let Some(file) = facing_pair_problem(seed) else {
            continue;
        };
        let problem = core_problem(&file);
        let kind = omcbsa::planners::PlannerKind::OmCbsa;
        let ran = (storage.solve_core(kind, &problem, Until::new(&NoClock, 1e6))).expect("planner");
        let stats = ran.stats;
        assert_eq!(ran.status, Status::Solved, "seed {seed}");
        assert_eq!(stats.unbranched_nodes, 0, "seed {seed}: {stats:?}");
        branched += stats.conflicts_resolved;
    }
    assert!(branched > 0, "the scenes should make Ω-CBSA branch");
}
