//! Property tests of the input side: any bytes give a value or an error, never a panic; any
//! mutation of a valid solution is either rejected or still valid when its rules are checked
//! again here, independently of the validator's code.

mod common;

use common::*;
use omcbsa::format::{ProblemFile, SolutionFile, MAX_JOINT_VALUE};
use omcbsa::load;
use omcbsa::models::{Fleet, DOF};
use omcbsa::validate::{validate, HOLD_TOLERANCE, VELOCITY_SLACK};
use omcbsa_core::model::{KinovaGen3, Model};
use proptest::prelude::*;

/// Everything `plan` does with a problem file's bytes before planning.
fn load_problem(bytes: &[u8]) {
    if let Ok(file) = load::decode_text(bytes.to_vec()).and_then(|t| load::parse_problem(&t)) {
        let _ = load::problem::<Fleet, DOF>(&file);
    }
}

/// Everything `validate` does with a solution file's bytes, against `problem`.
fn check_solution(problem: &ProblemFile, bytes: &[u8]) -> Option<bool> {
    let text = load::decode_text(bytes.to_vec()).ok()?;
    let solution = load::parse_solution(&text).ok()?;
    let core = load::problem::<KinovaGen3, 7>(problem).unwrap();
    Some(validate::<KinovaGen3, 7>(problem, &core, &solution).is_valid())
}

/// Byte edits of a text: (position fraction, byte, kind) with kind 0 replace, 1 insert,
/// 2 delete, 3 truncate.
fn edited(text: &str, edits: &[(f64, u8, u8)]) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    for &(at, byte, kind) in edits {
        let i = ((at * bytes.len() as f64) as usize).min(bytes.len().saturating_sub(1));
        match (kind % 4, bytes.is_empty()) {
            (_, true) => bytes.push(byte),
            (0, false) => bytes[i] = byte,
            (1, false) => bytes.insert(i, byte),
            (2, false) => {
                bytes.remove(i);
            }
            _ => bytes.truncate(i),
        }
    }
    bytes
}

/// One change to a solution.
#[derive(Clone, Debug)]
enum Mutation {
    /// Adds `delta` to joint `j` of robot `i` at step `t`.
    Nudge(usize, usize, usize, f64),
    /// Adds whole turns to a joint at every step of a path (the same poses).
    Turns(usize, usize, f64),
    /// Sets joint `j` of robot `i` at step `t`.
    Set(usize, usize, usize, f64),
    Assign(usize, Option<usize>),
    DropStep(usize, usize),
    RepeatStep(usize, usize),
    DropJoint(usize, usize),
    SwapPaths,
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let (i, t, j) = (0..2usize, 0..3usize, 0..7usize);
    prop_oneof![
        (i.clone(), t.clone(), j.clone(), -1.0..1.0f64)
            .prop_map(|(i, t, j, d)| Mutation::Nudge(i, t, j, d)),
        (i.clone(), t.clone(), j.clone(), -1e-8..1e-8f64)
            .prop_map(|(i, t, j, d)| Mutation::Nudge(i, t, j, d)),
        (i.clone(), j.clone(), -40.0..40.0f64).prop_map(|(i, j, k)| Mutation::Turns(
            i,
            j,
            k.round()
        )),
        (
            i.clone(),
            t.clone(),
            j.clone(),
            prop_oneof![any::<f64>(), Just(MAX_JOINT_VALUE), Just(1e308)]
        )
            .prop_map(|(i, t, j, v)| Mutation::Set(i, t, j, v)),
        (i.clone(), proptest::option::of(0..3usize)).prop_map(|(i, a)| Mutation::Assign(i, a)),
        (i.clone(), t.clone()).prop_map(|(i, t)| Mutation::DropStep(i, t)),
        (i.clone(), t.clone()).prop_map(|(i, t)| Mutation::RepeatStep(i, t)),
        (i.clone(), t).prop_map(|(i, t)| Mutation::DropJoint(i, t)),
        Just(Mutation::SwapPaths),
    ]
}

fn joint(paths: &mut [Vec<Vec<f64>>], i: usize, t: usize, j: usize) -> Option<&mut f64> {
    paths.get_mut(i)?.get_mut(t)?.get_mut(j)
}

fn apply(solution: &mut SolutionFile, m: &Mutation) {
    let paths = solution.joint_paths.as_mut().unwrap();
    match *m {
        Mutation::Nudge(i, t, j, d) => {
            if let Some(v) = joint(paths, i, t, j) {
                *v += d;
            }
        }
        Mutation::Turns(i, j, k) => {
            for v in paths
                .get_mut(i)
                .into_iter()
                .flatten()
                .filter_map(|q| q.get_mut(j))
            {
                *v += k * std::f64::consts::TAU;
            }
        }
        Mutation::Set(i, t, j, v) => {
            if let Some(x) = joint(paths, i, t, j) {
                *x = v;
            }
        }
        Mutation::Assign(i, a) => {
            if let Some(x) = solution.assignment.get_mut(i) {
                *x = a;
            }
        }
        Mutation::DropStep(i, t) => {
            if let Some(p) = paths.get_mut(i).filter(|p| t < p.len()) {
                p.remove(t);
            }
        }
        Mutation::RepeatStep(i, t) => {
            if let Some(p) = paths.get_mut(i).filter(|p| t < p.len()) {
                let q = p[t].clone();
                p.insert(t, q);
            }
        }
        Mutation::DropJoint(i, t) => {
            if let Some(q) = paths.get_mut(i).and_then(|p| p.get_mut(t)) {
                q.pop();
            }
        }
        Mutation::SwapPaths => paths.swap(0, 1),
    }
}

/// Rules 1, 2, 3 and 5 of docs/FORMATS.md checked again, from the spec, not the validator's
/// code (rule 4 needs a collision model: the scene's robots are 2 m apart and every
/// mutation that keeps the tool on its poses keeps the geometry). `Err` names the broken rule.
// Joint j indexes a configuration and the model's limit arrays at once.
#[allow(clippy::needless_range_loop)]
fn recheck(problem: &ProblemFile, solution: &SolutionFile) -> Result<(), String> {
    type M = KinovaGen3;
    let paths = solution.joint_paths.as_ref().ok_or("no paths")?;
    let (n, h) = (problem.robots.len(), problem.trajectories[0].poses.len());
    // Rule 5: shape, and each trajectory tracked by exactly one robot.
    if paths.len() != n || solution.assignment.len() != n {
        return Err("rule 5: one path and one assignment entry per robot".into());
    }
    let mut tracked = vec![0; problem.trajectories.len()];
    for a in solution.assignment.iter().flatten() {
        *tracked.get_mut(*a).ok_or("rule 5: no such trajectory")? += 1;
    }
    if tracked.iter().any(|&c| c != 1) {
        return Err("rule 5: a trajectory not tracked exactly once".into());
    }
    for (i, path) in paths.iter().enumerate() {
        if path.len() != h || path.iter().any(|q| q.len() != 7) {
            return Err(format!("rule 5: path {i} has the wrong shape"));
        }
        for (t, q) in path.iter().enumerate() {
            // Rule 1, with the bus's range for continuous joints.
            for j in 0..7 {
                let lower = M::LOWER[j].max(-MAX_JOINT_VALUE);
                let upper = M::UPPER[j].min(MAX_JOINT_VALUE);
                if !(lower <= q[j] && q[j] <= upper) {
                    return Err(format!("rule 1: robot {i} step {t} joint {j}"));
                }
            }
            // Rule 2.
            let robot = &problem.robots[i];
            match solution.assignment[i] {
                Some(k) => {
                    let q: [f64; 7] = q.as_slice().try_into().unwrap();
                    let base = omcbsa::pose::to_frame(&robot.base).unwrap();
                    let tcp = base.compose(&M::fk(&q));
                    let target = omcbsa::pose::to_frame(&problem.trajectories[k].poses[t]).unwrap();
                    if (tcp.pos - target.pos).norm() > problem.tolerance.position_m {
                        return Err(format!("rule 2: robot {i} step {t} position"));
                    }
                    let r = tcp.rot.transpose() * target.rot;
                    let cos = ((r.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
                    if cos.acos() > problem.tolerance.orientation_rad + 1e-9 {
                        return Err(format!("rule 2: robot {i} step {t} orientation"));
                    }
                }
                None => {
                    let initial = robot
                        .initial
                        .as_ref()
                        .ok_or("rule 5: holds without initial")?;
                    if q.iter()
                        .zip(initial)
                        .any(|(a, b)| (a - b).abs() > HOLD_TOLERANCE)
                    {
                        return Err(format!("rule 2: robot {i} step {t} does not hold"));
                    }
                }
            }
        }
        // Rule 3.
        for (t, w) in path.windows(2).enumerate() {
            for j in 0..7 {
                if (w[1][j] - w[0][j]).abs() > M::VELOCITY[j] * problem.dt + VELOCITY_SLACK {
                    return Err(format!("rule 3: robot {i} step {t} joint {j}"));
                }
            }
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn any_bytes_load_or_fail_cleanly(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        load_problem(&bytes);
        check_solution(&two_robots().0, &bytes);
    }

    #[test]
    fn edited_files_load_or_fail_cleanly(
        edits in proptest::collection::vec((0.0..1.0f64, any::<u8>(), any::<u8>()), 1..6)
    ) {
        let (problem, solution) = two_robots();
        load_problem(&edited(&serde_json::to_string(&problem).unwrap(), &edits));
        check_solution(&problem, &edited(&serde_json::to_string(&solution).unwrap(), &edits));
    }

    #[test]
    fn a_mutated_solution_is_rejected_or_still_valid(
        mutations in proptest::collection::vec(mutation(), 1..4)
    ) {
        let (problem, mut solution) = two_robots();
        prop_assert_eq!(recheck(&problem, &solution), Ok(()));
        for m in &mutations {
            apply(&mut solution, m);
        }
        let text = serde_json::to_string(&solution).unwrap();
        if check_solution(&problem, text.as_bytes()) == Some(true) {
            prop_assert_eq!(recheck(&problem, &solution), Ok(()));
        }
    }
}
