//! VAMP-MR's multi-arm planning benchmark (Huang, Gao, Li: "Vector-Accelerated Motion
//! Planning and Execution for Multi-Robot-Arms") as a suite of omcbsa problems, read from a
//! VAMP-MR checkout the user gives.
//!
//! VAMP-MR's benchmark (`mr_planner_core/scripts/benchmarks/core_planning_benchmark.py`)
//! plans, in each environment, from every named pose of its SRDF to every other: each arm
//! from its configuration in one pose to its configuration in the other, among tables, bins
//! and the other arms, some arms holding a rod. Here each such pair is a problem: the start
//! pose is every arm's `initial`; the goal pose becomes a one-pose trajectory per arm, the
//! hand pose forward kinematics gives for the goal configuration (the planners choose any
//! configuration on that pose's self-motion manifold, and the approach plans the motion from
//! `initial` to it); the assignment is fixed, arm `i` to its own goal, since VAMP-MR's problem
//! says which arm goes where ([`Assignment::Free`] lets the planner choose). A pose that our
//! model refuses (a joint outside the Panda's limits, or a collision in our capsule model,
//! where VAMP-MR's spheres found none) is left out with the reason, as VAMP-MR's script
//! leaves out poses its checker finds in collision.

mod scene;
mod srdf;

use std::path::{Path, PathBuf};

use omcbsa_core::collision::ArmPose;
use omcbsa_core::model::Models;
use omcbsa_core::nalgebra::Vector3;

use crate::format::{
    ObstacleSpec, Pose, ProblemFile, RobotSpec, ShapeKind, ToleranceSpec, ToolCapsuleSpec,
    ToolSpec, TrajectorySpec, PROBLEM_FORMAT,
};
use crate::import::error::ImportError;
use crate::load;
use crate::models::{Fleet, ModelKind, DOF};
use crate::plan::{load_problem, InputOrPlanError};
use crate::pose::from_frame;
use crate::suite::{SuiteEntry, SuiteIndex, INDEX_FILE, INDEX_FORMAT};

pub use scene::{parse_transforms, Config, Rod, Scene, SceneBox};
pub use srdf::Srdf;

use scene::Factory;

/// The environments VAMP-MR's planning benchmark runs when given none.
pub const DEFAULT_ENVIRONMENTS: [&str; 3] = ["panda_two_rod", "panda_four", "panda_four_bins"];

/// The files read, relative to a VAMP-MR checkout's `mr_planner_core` (or to a checkout of
/// that directory alone).
const SRDF_DIR: &str = "config/srdf";
const FACTORY: &str = "src/backends/vamp_env_factory.cpp";
const PAIR_BASES: &str = "scripts/plugins/config/panda_two_base_transforms.json";

/// The model VAMP's `vamp::robots::Panda` is.
const PANDA: &str = "franka_panda";

/// Who chooses which arm takes which goal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Assignment {
    /// Arm `i` to its own goal, as VAMP-MR's problems say.
    #[default]
    Fixed,
    /// The planner chooses.
    Free,
}

/// What to import.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Environments (SRDF names); empty: [`DEFAULT_ENVIRONMENTS`].
    pub environments: Vec<String>,
    /// Who chooses which arm takes which goal.
    pub assignment: Assignment,
    /// Seconds per step of the problems (VAMP-MR's benchmark's `--dt` default).
    pub dt: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            environments: Vec::new(),
            assignment: Assignment::Fixed,
            dt: 0.1,
        }
    }
}

/// What was imported from one environment.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentReport {
    /// Its name (the SRDF's).
    pub environment: String,
    /// Arms.
    pub robots: usize,
    /// Boxes.
    pub obstacles: usize,
    /// Arms holding a rod.
    pub rods: usize,
    /// The named poses used, in the SRDF's order.
    pub poses: Vec<String>,
    /// Poses left out, with why.
    pub left_out: Vec<(String, String)>,
    /// Problems written.
    pub problems: usize,
}

/// What [`import`] did: the environments imported, and those not, with why.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Report {
    /// Each environment imported.
    pub environments: Vec<EnvironmentReport>,
    /// Environments not imported, with why.
    pub not_imported: Vec<(String, String)>,
}

impl Report {
    /// Problems written in all.
    pub fn problems(&self) -> usize {
        self.environments.iter().map(|e| e.problems).sum()
    }

    /// The report in Markdown: a table per environment and the poses left out.
    pub fn markdown(&self) -> String {
        let mut s = String::from(
            "| environment | arms | boxes | arms with a rod | poses used | left out | problems |\n\
             |---|---:|---:|---:|---:|---:|---:|\n",
        );
        for e in &self.environments {
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} |\n",
                e.environment,
                e.robots,
                e.obstacles,
                e.rods,
                e.poses.len(),
                e.left_out.len(),
                e.problems
            );
        }
        for e in &self.environments {
            for (pose, why) in &e.left_out {
                s += &format!("\n- {} pose `{pose}` left out: {why}", e.environment);
            }
        }
        for (env, why) in &self.not_imported {
            s += &format!("\n- {env} not imported: {why}");
        }
        s + "\n"
    }
}

/// The directory the files are read under: `from/mr_planner_core`, or `from` itself.
fn core_dir(from: &Path) -> Result<PathBuf, ImportError> {
    let dirs = [from.join("mr_planner_core"), from.to_path_buf()];
    (dirs.iter())
        .find(|d| d.join(FACTORY).is_file())
        .cloned()
        .ok_or_else(|| {
            ImportError::new(
                from,
                "",
                format!(
                    "not a VAMP-MR checkout: neither mr_planner_core/{FACTORY} nor {FACTORY} \
                     is there"
                ),
            )
        })
}

/// Writes the problems of VAMP-MR's benchmark under `from` into the suite directory `out`
/// (created if missing): `out/NAME.json` per problem and the index `out/suite.json`.
pub fn import(from: &Path, out: &Path, opts: &Options) -> Result<Report, ImportError> {
    let core = core_dir(from)?;
    let panda = ModelKind::parse(PANDA)
        .map_err(|e| ImportError::new(from, "", e))?
        .id();
    let factory = Factory::read(&core.join(FACTORY))?;
    let environments: Vec<String> = if opts.environments.is_empty() {
        DEFAULT_ENVIRONMENTS.iter().map(|e| e.to_string()).collect()
    } else {
        opts.environments.clone()
    };
    let mut report = Report::default();
    let mut entries = Vec::new();
    let mut problems = Vec::new();
    for env in &environments {
        let srdf_path = core.join(SRDF_DIR).join(format!("{env}.srdf"));
        let srdf = Srdf::read(&srdf_path)?;
        let config = factory.config(env)?;
        if !config.is_panda() {
            let why = format!(
                "its arms are VampVariant::{}, not Franka Pandas (the models compiled in: {})",
                config.variant,
                ModelKind::all()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            report.not_imported.push((env.clone(), why));
            continue;
        }
        let scene = factory.scene(env, &config, &core.join(PAIR_BASES))?;
        let arms = Arms {
            panda,
            config: &config,
            scene: &scene,
            dt: opts.dt,
        };
        let (env_report, env_problems) = environment(env, &srdf, &arms)?;
        for p in env_problems {
            entries.push(entry(env, &p, opts.assignment));
            problems.push(p);
        }
        report.environments.push(env_report);
    }
    write_suite(out, &entries, &problems)?;
    Ok(report)
}

/// A name or file name made of the pose names: letters, digits, `_` and `-` kept, anything
/// else `_`.
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// What every problem of an environment shares.
struct Arms<'a> {
    /// The model index of the Panda.
    panda: u8,
    config: &'a Config,
    scene: &'a Scene,
    dt: f64,
}

/// The problems of one environment: every usable pose to every other.
fn environment(
    env: &str,
    srdf: &Srdf,
    arms: &Arms,
) -> Result<(EnvironmentReport, Vec<ProblemFile>), ImportError> {
    let Arms { config, scene, .. } = *arms;
    let mut poses = Vec::new();
    let mut left_out = Vec::new();
    for name in srdf.pose_names(&config.move_group, &config.robot_groups) {
        let q = srdf.pose(&name, &config.move_group, &config.robot_groups)?;
        // The pose to itself: loading it checks limits and collisions at `initial`.
        let file = problem(&format!("{env}_{}", slug(&name)), arms, &q, &q);
        let why = match load_problem(&file) {
            Ok(_) => {
                poses.push((name, q));
                continue;
            }
            Err(InputOrPlanError::Input(e)) => e.to_string().replace('\n', "; "),
            Err(InputOrPlanError::Plan(e)) => e,
        };
        let depth = match deepest_arm_overlap(&file) {
            Some(d) => format!(
                " (the deepest overlap of two arms' capsules: {:.1} mm)",
                d * 1e3
            ),
            None => String::new(),
        };
        left_out.push((name, why + &depth));
    }
    let mut problems = Vec::new();
    for (start, qs) in &poses {
        for (goal, qg) in &poses {
            if start != goal {
                let name = format!("{env}_{}_to_{}", slug(start), slug(goal));
                problems.push(problem(&name, arms, qs, qg));
            }
        }
    }
    let report = EnvironmentReport {
        environment: env.to_string(),
        robots: config.robot_groups.len(),
        obstacles: scene.boxes.len(),
        rods: scene.rods.iter().flatten().count(),
        poses: poses.into_iter().map(|(n, _)| n).collect(),
        left_out,
        problems: problems.len(),
    };
    Ok((report, problems))
}

/// How deep the capsules of two arms of `file` overlap at `initial`, at the deepest, if any
/// do: how far VAMP-MR's sphere model and our capsules disagree on a pose.
fn deepest_arm_overlap(file: &ProblemFile) -> Option<f64> {
    let p = load::problem::<Fleet, DOF>(file).ok()?;
    let arms: Vec<ArmPose> = (p.robots.iter())
        .map(|r| (r.initial).map(|q| ArmPose::new::<Fleet, DOF>(r.model, &r.base, &r.tool, &q)))
        .collect::<Option<_>>()?;
    let least = (0..arms.len())
        .flat_map(|i| (i + 1..arms.len()).map(move |j| (i, j)))
        .map(|(i, j)| arms[i].clearance(&arms[j]))
        .fold(f64::INFINITY, f64::min);
    (least < 0.0).then_some(-least)
}

/// The arms at `start`, each to track the hand pose of its arm at `goal`.
fn problem(name: &str, arms: &Arms, start: &[[f64; 7]], goal: &[[f64; 7]]) -> ProblemFile {
    let Arms {
        panda,
        config,
        scene,
        dt,
    } = *arms;
    let arm = |g: &str| g.strip_suffix("_arm").unwrap_or(g).to_string();
    let robots = (config.robot_groups.iter().enumerate())
        .map(|(i, g)| RobotSpec {
            name: arm(g),
            model: PANDA.to_string(),
            base: from_frame(&scene.bases[i]),
            initial: Some(start[i].to_vec()),
            tcp: None,
            tool: scene.rods[i].as_ref().map(tool),
        })
        .collect();
    let trajectories = (config.robot_groups.iter().enumerate())
        .map(|(i, g)| TrajectorySpec {
            name: format!("{}_goal", arm(g)),
            poses: vec![from_frame(
                &scene.bases[i].compose(&Fleet::fk(panda, &goal[i])),
            )],
        })
        .collect();
    let obstacles = (scene.boxes.iter())
        .map(|b| ObstacleSpec {
            name: b.name.clone(),
            shape: ShapeKind::Box,
            half_extents: Some(b.size.map(|s| s / 2.0)),
            radius: None,
            half_length: None,
            pose: Pose {
                position: b.center,
                quat_xyzw: [0.0, 0.0, 0.0, 1.0],
            },
        })
        .collect();
    ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: name.to_string(),
        dt,
        robots,
        trajectories,
        obstacles,
        tolerance: ToleranceSpec::default(),
    }
}

/// A rod as a tool capsule: the segment of its axis, its radius (the capsule holds the
/// cylinder and reaches `radius` past each end). VAMP's end-effector frame
/// (`panda_grasptarget`) is taken as our model's tool frame (`panda_hand_tcp`).
fn tool(rod: &Rod) -> ToolSpec {
    let frame = scene::frame(&rod.translation, &rod.rpy);
    let end = |s: f64| {
        let p = frame.apply(&Vector3::new(0.0, 0.0, s * rod.length / 2.0));
        [p.x, p.y, p.z]
    };
    ToolSpec {
        name: rod.name.clone(),
        capsules: vec![ToolCapsuleSpec {
            a: end(-1.0),
            b: end(1.0),
            radius: rod.radius,
        }],
    }
}

fn entry(env: &str, p: &ProblemFile, assignment: Assignment) -> SuiteEntry {
    let n = p.robots.len();
    SuiteEntry {
        name: p.name.clone(),
        file: format!("{}.json", p.name),
        family: env.to_string(),
        layout: "vamp-mr".to_string(),
        robots: n,
        trajectories: p.trajectories.len(),
        horizon: 1,
        known_solvable: false,
        seed: 0,
        redraws: 0,
        witness: None,
        witness_method: None,
        stance: None,
        straight_bridge_collides: None,
        assignment: (assignment == Assignment::Fixed).then(|| (0..n).map(Some).collect()),
    }
}

fn write_suite(
    out: &Path,
    entries: &[SuiteEntry],
    problems: &[ProblemFile],
) -> Result<(), ImportError> {
    let mut files = std::collections::HashSet::new();
    if let Some(e) = entries.iter().find(|e| !files.insert(&e.file)) {
        let message = format!("two problems would both be written to {} (pose names that differ only in characters a file name cannot hold)", e.file);
        return Err(ImportError::new(out, "", message));
    }
    std::fs::create_dir_all(out)
        .map_err(|e| ImportError::new(out, "", format!("cannot create: {e}")))?;
    let write = |path: &Path, text: Result<String, serde_json::Error>| {
        let text = text.map_err(|e| ImportError::new(path, "", e.to_string()))?;
        std::fs::write(path, text + "\n")
            .map_err(|e| ImportError::new(path, "", format!("cannot write: {e}")))
    };
    for (e, p) in entries.iter().zip(problems) {
        write(&out.join(&e.file), serde_json::to_string(p))?;
    }
    let index = SuiteIndex {
        format: INDEX_FORMAT.to_string(),
        seed: 0,
        problems: entries.to_vec(),
        undrawn: Vec::new(),
    };
    write(&out.join(INDEX_FILE), serde_json::to_string_pretty(&index))
}
