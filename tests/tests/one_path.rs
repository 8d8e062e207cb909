//! One path, one result: `omcbsa plan`, one run of `omcbsa bench` and pools kept from call to
//! call (Python's `plan`, the benchmark's workers) give the same answer on the same problem,
//! whatever horizon their pools were made for.

use omcbsa::bench::plan_one;
use omcbsa::format::{ProblemFile, SolutionFile};
use omcbsa::load;
use omcbsa::plan::{load_problem, plan_file, plan_loaded};
use omcbsa::planners::{Capacities, PlannerKind, Pools, Storage};
use omcbsa_core::planner::{NoClock, Status, Until};
use omcbsa_tests::facing_pair_problem;

fn fixture() -> ProblemFile {
    let text = include_str!("../fixtures/level0_miss_2arms.json");
    load::parse_problem(text).expect("fixture parses")
}

/// What must agree: status, assignment, joint paths and the search's counters.
fn answer(s: &SolutionFile) -> impl PartialEq + std::fmt::Debug {
    let mut stats = s.stats.clone();
    stats.remove("approach_planning_time_ms");
    (
        s.status,
        s.assignment.clone(),
        s.joint_paths.clone(),
        s.approach.clone(),
        stats,
    )
}

#[test]
fn plan_bench_and_kept_pools_agree() {
    let mut files = vec![fixture()];
    files.extend([120, 121].into_iter().filter_map(facing_pair_problem));
    for file in &files {
        let problem = load_problem(file).expect("valid");
        for kind in [PlannerKind::OmCbsa, PlannerKind::PpSingle] {
            let plan = plan_file(file, kind, 60.0).expect("plans");
            let bench = plan_one(kind.name(), file, &problem, 60.0, true).expect("runs");
            // Pools made for a far longer horizon first, as a worker's after a long problem.
            let mut pools = Pools::default();
            pools.for_horizon(200);
            let kept = plan_loaded(
                pools.for_horizon(problem.horizon()),
                file,
                &problem,
                kind,
                60.0,
            )
            .expect("plans");
            assert_eq!(answer(&plan), answer(&bench), "{} {kind}", file.name);
            assert_eq!(answer(&plan), answer(&kept), "{} {kind}", file.name);
        }
    }
}

/// With a path pool small enough to fill, the search ends the same way whether the storage
/// was made for the problem's horizon or a far longer one (the pool holds as many paths).
#[test]
fn a_full_path_pool_does_not_depend_on_the_storage_horizon() {
    let file = facing_pair_problem(120).expect("scene");
    let problem = load_problem(&file).expect("valid");
    let caps = Capacities {
        path_slots: 2,
        ..Capacities::default()
    };
    let run = |max_h: usize| {
        let mut storage = Storage::new(caps, max_h);
        storage.cbs_params.warm_start_seconds = 0.0;
        let ran = storage
            .solve_core(PlannerKind::OmCbsa, &problem, Until::never(&NoClock))
            .expect("runs");
        (ran.status, ran.assignment, ran.stats)
    };
    let fitted = run(problem.horizon());
    // The scene branches: two paths cannot hold the root and a child.
    assert_eq!(fitted.0, Status::OutOfMemory("CBS path pool"));
    assert_eq!(fitted, run(8 * problem.horizon()));
}
