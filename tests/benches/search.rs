//! Ω-A* node expansions per second, and whole Ω-CBSA plans, on fixed scenes.
//! `cargo bench -p omcbsa-tests --bench search`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use omcbsa::planners::{Capacities, Storage, WallClock};
use omcbsa_core::planner::{Stats, Status, Until};
use omcbsa_core::problem::Problem;
use omcbsa_tests::{core_problem, elbow_swing_problem, facing_pair_problem};

fn run(storage: &mut Storage, planner: &str, problem: &Problem<7>) -> Stats {
    let clock = WallClock::start();
    let kind = omcbsa::planners::parse(planner).expect("known");
    let ran = (storage.solve_core(kind, problem, Until::new(&clock, 60.0))).expect("planner");
    assert_eq!(ran.status, Status::Solved);
    ran.stats
}

fn bench(c: &mut Criterion) {
    let scenes = [
        (
            "omega-astar/elbow_swing_42",
            "omega-astar",
            core_problem(&elbow_swing_problem(42).expect("scene").0),
        ),
        (
            "omcbsa/facing_pair_120",
            "omcbsa",
            core_problem(&facing_pair_problem(120).expect("scene")),
        ),
        (
            "pp/facing_pair_120",
            "pp",
            core_problem(&facing_pair_problem(120).expect("scene")),
        ),
    ];
    let mut group = c.benchmark_group("expansions");
    for (id, planner, problem) in &scenes {
        let mut storage = Storage::new(Capacities::default(), problem.horizon());
        let expansions = run(&mut storage, planner, problem).expansions;
        group.throughput(Throughput::Elements(expansions));
        group.bench_function(*id, |b| b.iter(|| run(&mut storage, planner, problem)));
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
