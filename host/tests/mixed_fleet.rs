//! A problem mixing models: two Kinova Gen3s and two Franka Pandas side by side, each hand made
//! by forward kinematics of its own arm's smooth joint motion. Every planner solves it (the
//! single-robot Ω-A* a one-Panda problem) and its plan passes the validator, with an approach
//! from the arms' `initial` configurations; the loader gives each robot its own model.

use omcbsa::format::{
    Pose, ProblemFile, RobotSpec, Status, ToleranceSpec, TrajectorySpec, PROBLEM_FORMAT,
};
use omcbsa::load;
use omcbsa::models::{Fleet, ModelKind, DOF};
use omcbsa::plan::plan_file;
use omcbsa::planners::PlannerKind;
use omcbsa::pose;
use omcbsa::validate::validate;
use omcbsa_core::model::{KinovaGen3, Models};

type Q = [f64; DOF];

/// A clear, comfortable configuration of each model: the Gen3 with its elbow bent and the tool
/// forward and down, the Panda at Franka's "ready" pose.
fn home(model: &str) -> Q {
    match model {
        "kinova_gen3" => [0.0, 0.35, 0.0, 1.8, 0.0, 1.0, 0.0],
        _ => [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
    }
}

/// `home` moved smoothly: joint j by up to 0.15 rad over the horizon, well within the speed
/// limits at dt = 0.1 s.
fn path(model: &str, h: usize, phase: f64) -> Vec<Q> {
    (0..h)
        .map(|t| {
            let s = t as f64 / (h - 1) as f64;
            std::array::from_fn(|j| home(model)[j] + 0.15 * (s * 2.0 + phase + j as f64).sin())
        })
        .collect()
}

fn at(x: f64, y: f64) -> Pose {
    Pose {
        position: [x, y, 0.0],
        quat_xyzw: [0.0, 0.0, 0.0, 1.0],
    }
}

/// Robots of `models` 1.2 m apart along x, each with a hand that follows its own motion and
/// its `initial` a little off that motion's start (so the approach has work to do).
fn mixed(models: &[&str], h: usize) -> ProblemFile {
    let mut robots = Vec::new();
    let mut trajectories = Vec::new();
    for (i, &model) in models.iter().enumerate() {
        let id = ModelKind::parse(model).unwrap().id();
        let base = at(1.2 * i as f64, 0.0);
        let motion = path(model, h, i as f64);
        let frame = pose::to_frame(&base).unwrap();
        trajectories.push(TrajectorySpec {
            name: format!("hand_{i}"),
            poses: (motion.iter())
                .map(|q| pose::from_frame(&frame.compose(&Fleet::fk(id, q))))
                .collect(),
        });
        let initial: Vec<f64> = motion[0].iter().map(|v| v + 0.1).collect();
        robots.push(RobotSpec {
            name: format!("{model}_{i}"),
            model: model.to_string(),
            base,
            initial: Some(initial),
            tcp: None,
            tool: None,
        });
    }
    ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: "mixed".to_string(),
        dt: 0.1,
        robots,
        trajectories,
        obstacles: Vec::new(),
        tolerance: ToleranceSpec::default(),
    }
}

const TWO_AND_TWO: [&str; 4] = ["kinova_gen3", "franka_panda", "kinova_gen3", "panda"];

#[test]
fn each_robot_is_loaded_with_its_own_model() {
    let file = mixed(&TWO_AND_TWO, 6);
    let problem = load::problem::<Fleet, DOF>(&file).unwrap();
    let models: Vec<&str> = problem
        .robots
        .iter()
        .map(|r| Fleet::name(r.model))
        .collect();
    assert_eq!(
        models,
        ["kinova_gen3", "franka_panda", "kinova_gen3", "franka_panda"]
    );
    // Loaded for the Gen3 alone, the Pandas are named as what it cannot take.
    let e = load::problem::<KinovaGen3, DOF>(&file)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("robots[1].model: franka_panda, but the problem was loaded for kinova_gen3")
            && e.contains("robots[3].model"),
        "{e}"
    );
    // A Panda's initial is checked against the Panda's limits (joint 4 must be negative).
    let mut bad = file.clone();
    bad.robots[1].initial = Some(home("kinova_gen3").to_vec());
    let e = load::problem::<Fleet, DOF>(&bad).unwrap_err().to_string();
    assert!(
        e.contains("robots[1].initial[3]: 1.8 is outside the limits [-3.0718, -0.0698] of joint panda_joint4"),
        "{e}"
    );
}

#[test]
fn every_planner_solves_two_gen3s_and_two_pandas_and_the_plan_validates() {
    let file = mixed(&TWO_AND_TWO, 8);
    let problem = load::problem::<Fleet, DOF>(&file).unwrap();
    for kind in PlannerKind::BENCH {
        let solution = plan_file(&file, kind, 20.0).unwrap();
        assert_eq!(
            solution.status,
            Status::Solved,
            "{kind}: {}",
            solution.message
        );
        // `plan_file` reports a plan as solved only after validating it; checked again here.
        let report = validate::<Fleet, DOF>(&file, &problem, &solution);
        assert!(report.is_valid(), "{kind}: {}", report.summary());
        assert!(
            solution.approach.is_some(),
            "{kind}: no approach from initial"
        );
    }
}

#[test]
fn omega_astar_solves_a_panda() {
    let file = mixed(&["franka_panda"], 8);
    let solution = plan_file(&file, PlannerKind::OmegaAstar, 20.0).unwrap();
    assert_eq!(solution.status, Status::Solved, "{}", solution.message);
}

/// What `validate` accepts, `execute` runs: the executor holds each arm to its own model's
/// limits. The Gen3s' elbows stand at 1.8 rad, outside the Panda's joint 4 range
/// [-3.07, -0.07]: one table for the whole fleet would refuse them.
#[test]
fn each_arm_is_executed_within_its_own_models_limits() {
    use omcbsa::execute::CheckedSolution;
    use omcbsa_hw::{ArmPorts, ExecConfig, Executor};
    let file = mixed(&TWO_AND_TWO, 8);
    let solution = plan_file(&file, PlannerKind::OmCbsa, 20.0).unwrap();
    assert_eq!(solution.status, Status::Solved, "{}", solution.message);
    let checked = CheckedSolution::new(file.clone(), solution).unwrap();
    assert!(
        checked.report().is_valid(),
        "{}",
        checked.report().summary()
    );
    let names: Vec<&str> = file.robots.iter().map(|r| r.name.as_str()).collect();
    let plan = checked.plan(&names).unwrap();
    let limits = checked.joint_limits(&plan).unwrap();
    assert_eq!(limits.len(), 4);
    assert_eq!(limits[0][3].position, Some((-2.57, 2.57)));
    assert_eq!(limits[1][3].position, Some((-3.0718, -0.0698)));
    assert_eq!((limits[2], limits[3]), (limits[0], limits[1]));
    let config = ExecConfig {
        dry_run: true,
        ..ExecConfig::default()
    };
    let report = Executor::new(plan, limits, ArmPorts::new(), config)
        .unwrap()
        .run(&checked)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(report.dry_run && report.cycles > 0);
}
