//! Drawing a problem again from its next seed, and the index that records it.

use super::*;

/// The spec of the default suite's problem `name`.
fn spec(name: &str) -> Spec {
    let specs = specs(&GenOptions::default(), Tightness::SUITE);
    (specs.into_iter().find(|s| s.name == name)).unwrap_or_else(|| panic!("no problem {name}"))
}

/// pushing_ring_5arms_056: no sample of its first seed has a witness (the witness search of
/// its first seed's ten tasks all fail), so it is drawn from its second seed, and the index
/// says so; allowed only one seed, it is left out, never an error.
#[test]
fn a_problem_no_sample_of_a_seed_draws_is_drawn_from_the_next_seed() {
    let spec = spec("pushing_ring_5arms_056");
    let seeds: Vec<u64> = spec.seeds().take(3).collect();
    assert_eq!(seeds.len(), 3);
    assert!(seeds[0] != seeds[1] && seeds[1] != seeds[2]);
    // The same stream every time.
    assert_eq!(spec.seeds().take(3).collect::<Vec<_>>(), seeds);

    match draw(&spec, 1).unwrap() {
        Drawn::Undrawn(u) => {
            assert_eq!(u.name, "pushing_ring_5arms_056");
            assert_eq!(u.seeds, seeds[..1]);
        }
        Drawn::Problem(g) => panic!("drawn from its first seed: {:?}", g.entry),
    }
    match draw(&spec, MAX_DRAWS).unwrap() {
        Drawn::Problem(g) => {
            assert_eq!((g.entry.seed, g.entry.redraws), (seeds[1], 1));
            assert!(g.entry.known_solvable);
            assert_eq!(g.entry.witness_method.as_deref(), Some("swing-tracking"));
        }
        Drawn::Undrawn(u) => panic!("not drawn: {u:?}"),
    }
}

/// A problem left out is listed in the index, which reads back.
#[test]
fn problems_left_out_are_listed_in_the_index() {
    let dir = tempfile::tempdir().unwrap();
    let undrawn = vec![Undrawn {
        name: "sweep_row_2arms_000".to_string(),
        seeds: vec![1, 2, 3],
    }];
    let report = write_suite(dir.path(), 7, Vec::new(), undrawn.clone(), Instant::now()).unwrap();
    assert_eq!(report.undrawn, ["sweep_row_2arms_000"]);
    assert_eq!((report.problems, report.redrawn), (0, 0));
    let index = read_index(dir.path()).unwrap();
    assert_eq!((index.seed, index.undrawn), (7, undrawn));
}
