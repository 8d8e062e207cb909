//! The suite generator: the same options give the same bytes whatever the number of threads,
//! every problem loads, every witness is a valid solution of its problem made as the index
//! says, the listed order is not the assignment, and myopic IK tracking solves at most half of
//! the problems.

use std::collections::BTreeMap;
use std::path::Path;

use omcbsa::format::SolutionFile;
use omcbsa::load;
use omcbsa::models::{Fleet, DOF};
use omcbsa::planners::{Capacities, Storage};
use omcbsa::suite::{
    gen_bench, gen_refine, read_index, GenOptions, RefineOptions, Tightness, INDEX_FILE,
};
use omcbsa::validate::validate;
use omcbsa_core::planner::{NoClock, Status, Until};
use omcbsa_core::search::refine::LEVEL_CAP;

/// Two problems per family: 16 problems, every family, several layouts and arm counts.
fn small() -> GenOptions {
    GenOptions {
        per_family: 2,
        ..GenOptions::default()
    }
}

fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for sub in [dir.to_path_buf(), dir.join("witnesses")] {
        for entry in std::fs::read_dir(&sub).unwrap() {
            let path = entry.unwrap().path();
            if path.is_file() {
                let key = path.strip_prefix(dir).unwrap().display().to_string();
                out.insert(key, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

/// `gen_bench` on a pool of `threads` worker threads.
fn gen_on(threads: usize, dir: &Path, opts: &GenOptions) -> omcbsa::suite::GenReport {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| gen_bench(dir, opts)).unwrap()
}

#[test]
fn generation_is_deterministic_and_every_problem_is_valid_input() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let report = gen_on(1, a.path(), &small());
    gen_on(3, b.path(), &small());
    let (fa, fb) = (files(a.path()), files(b.path()));
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    for (name, bytes) in &fa {
        assert!(bytes == &fb[name], "{name} differs between two runs");
    }
    assert!(fa.contains_key(INDEX_FILE));

    let index = read_index(a.path()).unwrap();
    assert_eq!(index.problems.len(), 16);
    assert_eq!(report.problems, 16);
    let families: std::collections::BTreeSet<_> =
        index.problems.iter().map(|e| e.family.as_str()).collect();
    assert_eq!(families.len(), 8, "{families:?}");
    for entry in &index.problems {
        let text = load::read_text(&a.path().join(&entry.file)).unwrap();
        let file = load::parse_problem(&text).unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        let problem =
            load::problem::<Fleet, DOF>(&file).unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        assert_eq!(file.name, entry.name);
        // The mixed family alternates the Gen3 and the Panda; the others are all Gen3s.
        let models: Vec<&str> = file.robots.iter().map(|r| r.model.as_str()).collect();
        let expected: Vec<&str> = (0..file.robots.len())
            .map(|i| match (entry.family.as_str(), i % 2) {
                ("mixed", 1) => "franka_panda",
                _ => "kinova_gen3",
            })
            .collect();
        assert_eq!(models, expected, "{}", entry.name);
        assert_eq!(
            (
                file.robots.len(),
                file.trajectories.len(),
                problem.horizon()
            ),
            (entry.robots, entry.trajectories, entry.horizon),
            "{}",
            entry.name
        );
        assert!((2..=6).contains(&entry.robots));
        assert!((20..=40).contains(&entry.horizon));
        // Every problem has a witness, and the index says how it was made: its paths, then its
        // approach when every arm stands somewhere (straight exactly when that is clear).
        assert!(
            entry.known_solvable && entry.witness.is_some(),
            "{}",
            entry.name
        );
        let method = entry.witness_method.as_deref().unwrap_or_default();
        let paths = if ["random", "approach", "mixed"].contains(&entry.family.as_str()) {
            "random-motion"
        } else {
            "swing-tracking"
        };
        let approach = match entry.straight_bridge_collides {
            None => "",
            Some(true) => "+rrt-connect",
            Some(false) => "+straight",
        };
        assert_eq!(method, format!("{paths}{approach}"), "{}", entry.name);
        let standing = problem
            .robots
            .iter()
            .filter(|r| r.initial.is_some())
            .count();
        assert_eq!(
            entry.straight_bridge_collides.is_some(),
            standing == entry.robots,
            "{}",
            entry.name
        );
        // Issue 22: every arm can stand where the problem puts it (the loader's own check).
        omcbsa::approach::check_initial::<Fleet, DOF>(&file, &problem)
            .unwrap_or_else(|e| panic!("{}: {e}", entry.name));
        // ... and the validator's.
        if let Some(contacts) = omcbsa::validate::initial_contacts::<Fleet, DOF>(&file, &problem) {
            assert!(contacts.is_empty(), "{}: {contacts:?}", entry.name);
        }
        // The approach family stands every arm where the straight bridge collides.
        if entry.family == "approach" {
            assert!(entry.stance.is_some(), "{}", entry.name);
            assert_eq!(
                problem
                    .robots
                    .iter()
                    .filter(|r| r.initial.is_some())
                    .count(),
                entry.robots,
                "{}",
                entry.name
            );
            assert_eq!(entry.straight_bridge_collides, Some(true), "{}", entry.name);
        }
    }
    assert_eq!(report.known_solvable, 16);
    assert!(report.undrawn.is_empty() && index.undrawn.is_empty());
}

#[test]
fn witnesses_solve_their_problems_and_ik_tracking_solves_at_most_half() {
    let dir = tempfile::tempdir().unwrap();
    gen_bench(dir.path(), &small()).unwrap();
    let index = read_index(dir.path()).unwrap();
    let mut storage = Storage::new(Capacities::default(), 40);
    let (mut known, mut tracked) = (0, 0);
    for entry in index.problems.iter().filter(|e| e.known_solvable) {
        let file =
            load::parse_problem(&load::read_text(&dir.path().join(&entry.file)).unwrap()).unwrap();
        let problem = load::problem::<Fleet, DOF>(&file).unwrap();
        let text = load::read_text(&dir.path().join(entry.witness.as_ref().unwrap())).unwrap();
        let witness: SolutionFile = load::parse_solution(&text).unwrap();
        let report = validate::<Fleet, DOF>(&file, &problem, &witness);
        assert!(report.is_valid(), "{}: {}", entry.name, report.summary());
        // Arms that stand somewhere reach the witness by its approach (validated with it).
        if problem.robots.iter().all(|r| r.initial.is_some()) {
            assert!(witness.approach.is_some(), "{}: no approach", entry.name);
        }
        // The index's word on the straight bridge is the validator's.
        if let Some(collides) = entry.straight_bridge_collides {
            let straight = SolutionFile {
                approach: Some(straight_approach(&problem, &witness, 200)),
                ..witness.clone()
            };
            let report = validate::<Fleet, DOF>(&file, &problem, &straight);
            let in_approach = |v: &omcbsa::validate::Violation| {
                v.phase == omcbsa::validate::Phase::Approach
                    && v.rule == omcbsa::validate::Rule::Collision
            };
            assert_eq!(
                report.violations.iter().any(in_approach),
                collides,
                "{}: {}",
                entry.name,
                report.summary()
            );
        }
        let listed: Vec<Option<usize>> = (0..file.robots.len()).map(Some).collect();
        if file.trajectories.len() >= 2 {
            assert_ne!(
                witness.assignment, listed,
                "{}: listed order is the assignment",
                entry.name
            );
        }
        known += 1;
        let outcome = storage
            .solve(omcbsa::planners::PlannerKind::IkTracking, &problem, 5.0)
            .unwrap();
        tracked += usize::from(outcome.status == Status::Solved);
    }
    // The suite is made so that solving takes more than myopic IK tracking (`suite::trap`);
    // these smallest problems (two arms) are its easiest, and it solves at most half of them.
    assert!(
        2 * tracked <= known,
        "IK tracking solved {tracked} of {known}"
    );
}

/// The approach that moves every arm straight from `initial` to its first configuration of
/// `witness`, all together, in `steps` equal steps.
fn straight_approach(
    problem: &omcbsa_core::problem::Problem<DOF>,
    witness: &SolutionFile,
    steps: usize,
) -> Vec<Vec<Vec<f64>>> {
    let paths = witness.joint_paths.as_ref().unwrap();
    (problem.robots.iter().zip(paths))
        .map(|(r, path)| {
            let (a, b) = (r.initial.unwrap(), &path[0]);
            (1..steps)
                .map(|k| {
                    let s = k as f64 / steps as f64;
                    (0..DOF).map(|j| a[j] + (b[j] - a[j]) * s).collect()
                })
                .collect()
        })
        .collect()
}

/// The refinement family (`gen-bench --refine`): the same bytes twice; every problem has a
/// witness that validates, and Ω-CBSA limited to level 0 exhausts it.
#[test]
fn refine_family_problems_have_witnesses_and_exhaust_level_0() {
    let opts = RefineOptions {
        problems: 2,
        max_candidates: 192,
        traps: Tightness::TIGHT,
        ..RefineOptions::default()
    };
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let report = gen_refine(a.path(), &opts).unwrap();
    gen_refine(b.path(), &opts).unwrap();
    assert_eq!(files(a.path()), files(b.path()));
    assert_eq!((report.problems, report.known_solvable), (2, 2));
    let index = read_index(a.path()).unwrap();
    let mut storage = Storage::new(Capacities::default(), 40);
    storage.cbs_params.levels = 1;
    for entry in &index.problems {
        assert!(entry.family.starts_with("refine_"), "{}", entry.family);
        let file =
            load::parse_problem(&load::read_text(&a.path().join(&entry.file)).unwrap()).unwrap();
        let problem = load::problem::<Fleet, DOF>(&file).unwrap();
        let text = load::read_text(&a.path().join(entry.witness.as_ref().unwrap())).unwrap();
        let witness: SolutionFile = load::parse_solution(&text).unwrap();
        let report = validate::<Fleet, DOF>(&file, &problem, &witness);
        assert!(report.is_valid(), "{}: {}", entry.name, report.summary());
        // Arms that stand somewhere reach the witness by its approach (validated with it).
        if problem.robots.iter().all(|r| r.initial.is_some()) {
            assert!(witness.approach.is_some(), "{}: no approach", entry.name);
        }
        let ran = storage
            .solve_core(
                omcbsa::planners::PlannerKind::OmCbsa,
                &problem,
                Until::never(&NoClock),
            )
            .unwrap();
        assert_eq!(
            (ran.status, ran.stats.reason),
            (Status::NoSolution, Some(LEVEL_CAP)),
            "{}",
            entry.name
        );
    }
}
