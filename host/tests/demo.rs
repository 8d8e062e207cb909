//! The built-in problem of `omcbsa demo`.

use omcbsa::demo::{box_flip, NAME, ROBOTS, STEPS};
use omcbsa::format::Status;
use omcbsa::planners::plan_file;

#[test]
fn scratch() {
    let demo = box_flip().unwrap_or_else(|e| panic!("{e}"));
    for p in demo.witness.joint_paths.as_ref().unwrap() {
        eprintln!("{:?}\n{:?}", p[0], p[p.len() - 1]);
    }
    let t = std::time::Instant::now();
    let s = plan_file(&demo.problem, "omcbsa", 5.0).unwrap();
    eprintln!(
        "{:?} {} {:?} {:?} {:?}",
        s.status,
        s.message,
        s.assignment,
        t.elapsed(),
        s.stats
    );
}
