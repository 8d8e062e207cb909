//! Hardware-in-the-loop with tool geometry: arm `a` tracks a hand trajectory while arm `b`
//! holds still with its gripper reaching into the place where `a`'s elbow goes when grippers
//! are ignored. Planned without tools, the plan passes `b`'s bare links but drives `a`'s
//! elbow through `b`'s gripper, and the validator, given the grippers, rejects it naming the
//! tool. Planned with tools (Ω-CBSA), the plan swings the elbow clear: it validates, and
//! streams over SLCAN pseudo-terminals to two Python mock Gen3 arms, which must receive
//! exactly the interpolated plan (`run_on_mock_arms`; run `bash hw-adapter/mock/setup_venv.sh`
//! first).

use std::f64::consts::PI;

use omcbsa::demo::{gripper, run_on_mock_arms};
use omcbsa::execute::CheckedSolution;
use omcbsa::format::{ProblemFile, SolutionFile, Status};
use omcbsa::plan::plan_file;
use omcbsa::planners::DOF;
use omcbsa_core::collision::ArmPose;
use omcbsa_core::ik::{ik_multi_start, IkParams, MultiStart};
use omcbsa_core::model::{Frame, KinovaGen3, Model};
use omcbsa_core::nalgebra::{Matrix3, Vector3};
use omcbsa_core::rng::Rng;
use omcbsa_core::tool::Tool;
use omcbsa_mock::arms::MockKind;
use omcbsa_mock::mock::venv_python;
use omcbsa_tests::{frame, problem_json, robot_json, smooth_path, trajectory_json};

type Q = [f64; DOF];

const H: usize = 16;
const DT: f64 = 0.2;
/// Index of `forearm_link` in `KinovaGen3::LINK_NAMES`: its origin is the elbow.
const FOREARM: usize = 4;
/// How far along its tool z axis `b`'s gripper reaches past `a`'s elbow origin (the
/// fingers' capsule ends at 12 cm).
const GRIP_DEPTH: f64 = 0.10;

/// Kinova's home posture (its `initial` in ros2_kortex).
const HOME: Q = [0.0, 0.26, PI, -2.27, 0.0, 0.96, PI / 2.0];

fn base_a() -> Frame {
    frame([0.0; 3], [0.0; 3])
}

/// `b` stands beside `a`, facing it.
fn base_b() -> Frame {
    frame([0.0, 0.75, 0.0], [0.0, 0.0, -PI / 2.0])
}

/// `a`'s hand path: reaching forward, elbow up, bending a little in its plane.
fn path_a() -> Vec<Q> {
    let q0 = [0.0, 0.6, 0.0, 1.8, 0.0, 0.7, PI / 2.0];
    smooth_path(&q0, &[0.0, 0.1, 0.0, -0.1, 0.0, 0.1, 0.0], H)
}

/// The problem: `a` tracks its hand path, `b` holds `b_at`; both carry the demo's gripper
/// when `tools`.
fn scene(b_at: &Q, tools: bool) -> ProblemFile {
    let (a, b) = (base_a(), base_b());
    let mut robots = vec![
        // `a` stands at Kinova's home posture; its plan begins there (with an approach).
        robot_json("a", &a, Some(&HOME)),
        robot_json("b", &b, Some(b_at)),
    ];
    if tools {
        let gripper = serde_json::to_value(gripper()).unwrap();
        for r in &mut robots {
            r["tool"] = gripper.clone();
        }
    }
    let name = if tools { "gripper_elbow" } else { "bare_elbow" };
    problem_json(
        name,
        DT,
        robots,
        vec![trajectory_json("hand", &a, &path_a())],
        vec![],
    )
}

fn plan(problem: &ProblemFile) -> SolutionFile {
    let solution = plan_file(problem, omcbsa::planners::PlannerKind::OmCbsa, 10.0).unwrap();
    assert_eq!(solution.status, Status::Solved, "{}", solution.message);
    assert_eq!(
        solution.assignment,
        [Some(0), None],
        "b cannot reach the hand"
    );
    solution
}

/// A configuration of `b` whose gripper reaches `GRIP_DEPTH` past `elbow` (world), pointing
/// at it horizontally from `b`'s side (across the plane `a`'s arm moves in), with `b`'s bare
/// links clear of `a` along `a_path`: the IK answer that keeps farthest from `a`.
fn gripping(elbow: &Vector3<f64>, a_path: &[Q]) -> Q {
    let b = base_b();
    let z = -Vector3::y();
    let x = Vector3::z();
    let tool = Frame {
        rot: Matrix3::from_columns(&[x, z.cross(&x), z]),
        pos: elbow - z * GRIP_DEPTH,
    };
    let target = b.inverse().compose(&tool);
    let mut found = [[0.0; DOF]; 16];
    let n = ik_multi_start::<KinovaGen3, DOF>(
        0,
        &target,
        &IkParams::default(),
        &MultiStart::default(),
        &mut Rng::new(7),
        &mut found,
    )
    .expect("b reaches a's elbow");
    let bare = |base: &Frame, q: &Q| ArmPose::new::<KinovaGen3, DOF>(0, base, &Tool::NONE, q);
    // Largest margin (1 cm steps up to 5 cm) by which `b`'s bare links miss `a` everywhere.
    let margin = |q: &Q| {
        let arm = bare(&b, q);
        let clear =
            |m: f64| (a_path.iter()).all(|qa| arm.arm_hit(&bare(&base_a(), qa), m).is_none());
        (arm.self_hit(0.0).is_none() && clear(0.0))
            .then(|| (1..=5).take_while(|&cm| clear(0.01 * cm as f64)).count())
    };
    let (q, m) = (found[..n].iter())
        .filter_map(|q| margin(q).map(|m| (*q, m)))
        .max_by_key(|&(_, m)| m)
        .expect("an IK answer keeps b's bare links off a");
    println!("b grips with its bare links {m} cm or more from a: {q:?}");
    q
}

#[test]
fn grippers_that_would_collide_are_planned_around_and_streamed() {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    // `b` parked facing away: where `a`'s elbow goes when nothing is in its way.
    let parked: Q = [PI, 0.6, 0.0, 1.8, 0.0, 0.7, PI / 2.0];
    let free = plan(&scene(&parked, false));
    let a_path: Vec<Q> = (free.joint_paths.as_ref().unwrap()[0].iter())
        .map(|q| q.as_slice().try_into().unwrap())
        .collect();
    let mut frames = [Frame::IDENTITY; 16];
    KinovaGen3::link_frames(&a_path[H / 2], &mut frames[..KinovaGen3::LINK_NAMES.len()]);
    let b_at = gripping(&base_a().apply(&frames[FOREARM].pos), &a_path);

    // Without tools: solved and valid for bare flanges, but with the grippers it is not.
    let bare = plan(&scene(&b_at, false));
    let mut as_tooled = bare.clone();
    as_tooled.problem = "gripper_elbow".to_string();
    let rejected = CheckedSolution::new(scene(&b_at, true), as_tooled).unwrap();
    let report = rejected.report();
    assert!(!report.is_valid(), "the bare plan passes the grippers");
    assert!(
        (report.violations.iter()).all(|v| v.detail.contains("tool \"gripper\"")),
        "only the tools collide: {:#?}",
        report.violations
    );

    // With tools: solved, valid, and streamed.
    let problem = scene(&b_at, true);
    let solution = plan(&problem);
    let checked = CheckedSolution::new(problem, solution).unwrap();
    assert!(
        checked.report().is_valid(),
        "{}",
        checked.report().summary()
    );
    let plan = checked.plan(&["a", "b"]).unwrap();
    let dir = std::env::temp_dir().join(format!("omcbsa-hil-tools-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let streamed = run_on_mock_arms(&python, MockKind::Can, plan, &checked, &dir, |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    println!("{streamed}");
    assert_eq!(streamed.arms.len(), 2);
    let _ = std::fs::remove_dir_all(dir);
}
