//! Any bytes as a solution file of a fixed two-arm problem (fuzz/seeds/problem.json), through
//! everything `omcbsa validate` and `omcbsa execute` do before moving an arm: decoding,
//! parsing, validation, and the plan for the arms. It must return, never panic; and a
//! solution that validates must be one the bus can carry (every joint value encodes).
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use omcbsa::execute::CheckedSolution;
use omcbsa::format::ProblemFile;
use omcbsa::load;
use omcbsa_hw::cia402::rad_to_counts;

fn problem() -> &'static ProblemFile {
    static PROBLEM: OnceLock<ProblemFile> = OnceLock::new();
    PROBLEM.get_or_init(|| {
        load::parse_problem(include_str!("../seeds/problem.json")).expect("the seed problem")
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = load::decode_text(data.to_vec()) else {
        return;
    };
    let Ok(solution) = load::parse_solution(&text) else {
        return;
    };
    let checked = CheckedSolution::new(problem().clone(), solution).expect("the seed problem");
    if !checked.report().is_valid() {
        return;
    }
    let names: Vec<&str> = problem().robots.iter().map(|r| r.name.as_str()).collect();
    let plan = checked.plan(&names).expect("a valid solution has a plan");
    for q in plan.arms.iter().flat_map(|a| &a.joint_path) {
        for &v in q {
            assert!(rad_to_counts(v).is_some(), "{v} rad validates but does not encode");
        }
    }
});
