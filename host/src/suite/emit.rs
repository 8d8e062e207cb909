//! One problem of the suite: sample a layout and a task, look for a witness, and turn both
//! into the file formats, checking the witness with the host validator.

use omcbsa_core::geometry::Shape;
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::problem::Problem;
use omcbsa_core::rng::Rng;
use serde_json::Map;

use super::connect;
use super::family::Family;
use super::frames::{at, v3};
use super::index::{Error, SuiteEntry, WITNESS_DIR};
use super::layout::{Layout, NamedObstacle};
use super::myopic::ik_tracking_solves;
use super::spec::{Spec, HARD_SAMPLES, MIXED_SAMPLES, RANDOM_SAMPLES, TASK_SAMPLES};
use super::standing::{clear_of, stand_clear};
use super::trap::traps;
use super::witness::{
    random_motion, retract, shuffle, task_witness, Arms, Hand, MotionSpec, Placed, Scene, Q,
};
use crate::format::{
    ObstacleSpec, Pose, ProblemFile, RobotSpec, ShapeKind, SolutionFile, Status, ToleranceSpec,
    TrajectorySpec, PROBLEM_FORMAT, SOLUTION_FORMAT,
};
use crate::models::DOF;
use crate::{load, pose, validate};

/// Time between poses: `velocity * dt` is 0.24 to 0.28 rad, above the planners' 0.2 rad
/// null-space step.
pub const DT: f64 = 0.2;
/// Shortest and longest horizon.
const HORIZON: (usize, usize) = (20, 40);
/// A gripper 12 cm beyond the tool flange.
const TCP_OFFSET: f64 = 0.12;

pub struct Generated {
    pub entry: SuiteEntry,
    pub problem: ProblemFile,
    pub witness: SolutionFile,
}

/// One sampled problem: its layout, hands (designed arm included) and maybe a witness.
struct Sample {
    layout: Layout,
    hands: Vec<Hand>,
    witness: Option<Vec<Vec<Q>>>,
}

/// A sample made into a problem whose arms can stand where it puts them, with the witness's
/// paths (rounded as the files hold them).
struct Candidate {
    problem: ProblemFile,
    core: Box<Problem<DOF>>,
    paths: Vec<Vec<Q>>,
    assignment: Vec<Option<usize>>,
    /// When every arm has `initial`: whether the straight motion of all arms together from
    /// there to the witness's first configurations collides.
    straight_bridge_collides: Option<bool>,
}

/// The problem of `spec` drawn from `seed`: the first of its samples with a validated witness
/// that IK tracking does not solve (of the approach family: whose straight bridge collides),
/// else the best sample with a validated witness; `None` when no sample has one.
pub fn generate(spec: &Spec, seed: u64) -> Result<Option<Generated>, Error> {
    let samples = if spec.family == Family::Mixed {
        MIXED_SAMPLES
    } else if matches!(spec.family, Family::Random | Family::Approach) {
        RANDOM_SAMPLES
    } else {
        TASK_SAMPLES
    };
    let mut fallback: Option<(Generated, bool)> = None;
    let mut tried = 0;
    for k in 0..samples {
        let mut rng = Rng::new(seed.wrapping_add(k.wrapping_mul(0x9E37_79B9_7F4A_7C15)));
        let Some(sample) = sample(spec, &mut rng) else {
            continue;
        };
        let Some(paths) = &sample.witness else {
            continue;
        };
        let Some(candidate) = candidate(spec, &sample, paths, &mut rng)? else {
            continue;
        };
        // The approach family wants arms whose straight bridges collide.
        let hard = spec.stance.is_none() || candidate.straight_bridge_collides == Some(true);
        let wanted = hard && !ik_tracking_solves(&candidate.core);
        let better = match &fallback {
            None => true,
            Some((_, fallback_hard)) => hard && !fallback_hard,
        };
        if wanted || better {
            if let Some(generated) = witness(spec, seed, candidate, &mut rng)? {
                if wanted {
                    return Ok(Some(generated));
                }
                fallback = Some((generated, hard));
            }
        }
        tried += usize::from(hard);
        if tried >= HARD_SAMPLES && fallback.is_some() {
            break;
        }
    }
    Ok(fallback.map(|(g, _)| g))
}

fn tcp() -> Frame {
    at(v3(0.0, 0.0, TCP_OFFSET))
}

fn sample(spec: &Spec, rng: &mut Rng) -> Option<Sample> {
    let mut layout = spec.family.layout(spec.layout, spec.robots, rng);
    let h = HORIZON.0 + (rng.next_u64() % (HORIZON.1 - HORIZON.0 + 1) as u64) as usize;
    let hands = spec.family.hands(&mut layout, h, rng);
    let obstacles: Vec<_> = layout.obstacles.iter().map(|(_, o)| *o).collect();
    let scene = Scene {
        obstacles: &obstacles,
        dt: DT,
        tcp: tcp(),
    };
    match hands {
        Some(hands) => {
            let witness = task_witness(&scene, &layout.models, &layout.bases, &hands, rng);
            if let Some(paths) = &witness {
                layout.obstacles.extend(traps(
                    spec.traps,
                    &scene,
                    &layout.models,
                    &layout.bases,
                    &hands,
                    paths,
                    rng,
                ));
            }
            Some(Sample {
                layout,
                hands,
                witness,
            })
        }
        None => {
            // One arm holds in a third of the problems with three or more arms.
            let n = layout.bases.len();
            let holder = (n >= 3 && rng.next_f64() < 1.0 / 3.0)
                .then(|| (rng.next_u64() % n as u64) as usize);
            let mut order: Vec<usize> = (0..n).collect();
            shuffle(&mut order, rng);
            let mut placed: Vec<(usize, Placed)> = Vec::with_capacity(n);
            for arm in order {
                let (model, base) = (layout.models[arm], layout.bases[arm]);
                let others: Vec<Placed> = placed
                    .iter()
                    .map(|(_, p)| Placed {
                        model: p.model,
                        base: p.base,
                        path: p.path.clone(),
                    })
                    .collect();
                let motion = MotionSpec {
                    model,
                    base: &base,
                    station: &layout.stations[arm],
                    steps: h,
                    moving: holder != Some(arm),
                };
                let path = random_motion(&scene, &motion, &others, rng)?;
                placed.push((arm, Placed { model, base, path }));
            }
            placed.sort_by_key(|(arm, _)| *arm);
            let paths: Vec<Vec<Q>> = placed.into_iter().map(|(_, p)| p.path).collect();
            let hands = (0..n)
                .filter(|&arm| holder != Some(arm))
                .map(|arm| Hand {
                    arm,
                    poses: paths[arm]
                        .iter()
                        .map(|q| scene.tcp_pose(layout.models[arm], &layout.bases[arm], q))
                        .collect(),
                })
                .collect::<Vec<_>>();
            layout.obstacles.extend(traps(
                spec.traps,
                &scene,
                &layout.models,
                &layout.bases,
                &hands,
                &paths,
                rng,
            ));
            Some(Sample {
                layout,
                hands,
                witness: Some(paths),
            })
        }
    }
}

/// The problem file (trajectories shuffled) of a sample with witness `paths`, with the
/// arms standing clear; `None` when some arm has nowhere to stand.
fn candidate(
    spec: &Spec,
    sample: &Sample,
    paths: &[Vec<Q>],
    rng: &mut Rng,
) -> Result<Option<Candidate>, Error> {
    let n = sample.layout.bases.len();
    let models = &sample.layout.models;
    let hands = &sample.hands;
    let paths: Vec<Vec<Q>> = (paths.iter())
        .map(|p| p.iter().map(|q| q.map(round)).collect())
        .collect();
    // listed[j] = the hand listed j-th; never the identity when it could be.
    let mut listed: Vec<usize> = (0..hands.len()).collect();
    while hands.len() >= 2 && listed.iter().enumerate().all(|(j, &k)| hands[k].arm == j) {
        shuffle(&mut listed, rng);
    }
    let mut assignment: Vec<Option<usize>> = vec![None; n];
    for (j, &k) in listed.iter().enumerate() {
        assignment[hands[k].arm] = Some(j);
    }
    let holds = hands.len() < n;
    let starts: Vec<Option<Q>> = paths.iter().map(|p| Some(p[0])).collect();
    // Holding arms hold their witness configuration; every arm needs an initial one then, and
    // the others get the retract pose. The approach family stands every arm somewhere hard.
    let initial: Vec<Option<Q>> = (0..n)
        .map(|i| match (assignment[i], spec.stance) {
            (None, _) => starts[i],
            (Some(_), Some(stance)) => Some(stance.initial(i, &paths[i][0], &retract(models[i]))),
            (Some(_), None) => holds.then(|| retract(models[i])),
        })
        .collect();
    let mut obstacles = sample.layout.obstacles.clone();
    if let Some(stance) = spec.stance {
        for i in 0..n {
            if let Some(q) = initial[i] {
                let post = stance
                    .post(models[i], &sample.layout.bases[i], &q, &paths[i][0], &tcp())
                    .filter(|o| clear_of(o, models, &sample.layout.bases, &paths));
                obstacles.extend(post.map(|o| (format!("post_{i}"), o)));
            }
        }
    }
    let robot_spec = |i: usize, base: &Frame, initial: &Option<Q>| RobotSpec {
        name: format!("arm_{i}"),
        model: Arms::name(models[i]).to_string(),
        base: rounded(base),
        initial: initial.map(|q| q.iter().map(|&x| round(x)).collect()),
        tcp: Some(rounded(&tcp())),
        tool: None,
    };
    let robots = (sample.layout.bases.iter().enumerate())
        .map(|(i, base)| robot_spec(i, base, &initial[i]))
        .collect();
    let trajectories = (listed.iter().enumerate())
        .map(|(j, &k)| TrajectorySpec {
            name: format!("hand_{j}"),
            poses: hands[k].poses.iter().map(rounded).collect(),
        })
        .collect();
    let mut problem = ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: spec.name.clone(),
        dt: DT,
        robots,
        trajectories,
        obstacles: obstacles.iter().map(obstacle_spec).collect(),
        tolerance: ToleranceSpec::default(),
    };
    let mut core = load_problem(spec, &problem)?;
    let mut straight_bridge_collides = None;
    if initial.iter().any(Option::is_some) {
        // An arm that cannot stand where it was put (limits, collisions, as the loader checks)
        // stands at its witness's start instead.
        if !stand_clear(&mut core, &starts) {
            return Ok(None);
        }
        for (i, r) in problem.robots.iter_mut().enumerate() {
            r.initial = core.robots[i].initial.map(|q| q.map(round).to_vec());
        }
        core = load_problem(spec, &problem)?;
        // The validator's own check of where the arms stand: never an `initial` that collides.
        let contacts = validate::initial_contacts::<Arms, DOF>(&problem, &core);
        if contacts.is_some_and(|c| !c.is_empty()) {
            return Ok(None);
        }
        straight_bridge_collides = initial_placing(&core)
            .map(|from| connect::straight_collides(&core, &from, &first(&paths)));
    }
    Ok(Some(Candidate {
        problem,
        core,
        paths,
        assignment,
        straight_bridge_collides,
    }))
}

/// The witness of a candidate drawn from `seed`: its paths and, when every arm has `initial`,
/// an approach from there ([`connect::approach`]); `None` when no approach is found or the
/// validator refuses the witness.
fn witness(
    spec: &Spec,
    seed: u64,
    c: Candidate,
    rng: &mut Rng,
) -> Result<Option<Generated>, Error> {
    let approach = match initial_placing(&c.core) {
        Some(from) => match connect::approach(&c.core, &from, &first(&c.paths), rng) {
            Some(a) => Some(a),
            None => return Ok(None),
        },
        None => None,
    };
    let configurations = |qs: &mut dyn Iterator<Item = &Q>| -> Vec<Vec<f64>> {
        qs.map(|q| q.iter().map(|&x| round(x)).collect()).collect()
    };
    let solution = SolutionFile {
        approach: approach.as_ref().map(|a| {
            (0..c.paths.len())
                .map(|i| configurations(&mut a.steps.iter().map(|step| &step[i])))
                .collect()
        }),
        format: SOLUTION_FORMAT.to_string(),
        problem: spec.name.clone(),
        planner: "witness".to_string(),
        status: Status::Solved,
        message: String::new(),
        planning_time_s: 0.0,
        assignment: c.assignment,
        joint_paths: Some(
            (c.paths.iter())
                .map(|p| configurations(&mut p.iter()))
                .collect(),
        ),
        stats: Map::new(),
    };
    if !validate::validate::<Arms, DOF>(&c.problem, &c.core, &solution).is_valid() {
        return Ok(None);
    }
    let paths_method = if spec.family.random_motions() {
        "random-motion"
    } else {
        "swing-tracking"
    };
    let method = match &approach {
        Some(a) => format!("{paths_method}+{}", a.method.name()),
        None => paths_method.to_string(),
    };
    let entry = SuiteEntry {
        name: spec.name.clone(),
        file: format!("{}.json", spec.name),
        family: spec.family.name().to_string(),
        layout: spec.layout.name().to_string(),
        robots: c.paths.len(),
        trajectories: c.problem.trajectories.len(),
        horizon: c.core.horizon(),
        known_solvable: true,
        seed,
        redraws: 0,
        stance: spec.stance.map(|s| s.name().to_string()),
        straight_bridge_collides: c.straight_bridge_collides,
        assignment: None,
        witness: Some(format!("{WITNESS_DIR}/{}.json", spec.name)),
        witness_method: Some(method),
    };
    Ok(Some(Generated {
        entry,
        problem: c.problem,
        witness: solution,
    }))
}

/// The problem as the planners get it; one the loader refuses is a bug of the generator.
fn load_problem(spec: &Spec, problem: &ProblemFile) -> Result<Box<Problem<DOF>>, Error> {
    load::problem::<Arms, DOF>(problem)
        .map(Box::new)
        .map_err(|e| Error::Generation {
            problem: spec.name.clone(),
            message: e.to_string(),
        })
}

/// Every robot's `initial`, when every robot has one.
fn initial_placing(problem: &Problem<DOF>) -> Option<Vec<Q>> {
    problem.robots.iter().map(|r| r.initial).collect()
}

/// Every path's first configuration.
fn first(paths: &[Vec<Q>]) -> Vec<Q> {
    paths.iter().map(|p| p[0]).collect()
}

/// Nine decimals: nanometres and nanoradians, far below every tolerance, and short files.
fn round(x: f64) -> f64 {
    (x * 1e9).round() / 1e9
}

fn rounded(frame: &Frame) -> Pose {
    let p = pose::from_frame(frame);
    Pose {
        position: p.position.map(round),
        quat_xyzw: p.quat_xyzw.map(round),
    }
}

pub(crate) fn obstacle_spec((name, o): &NamedObstacle) -> ObstacleSpec {
    let (shape, half_extents, radius, half_length) = match o.shape {
        Shape::Box { half_extents } => (ShapeKind::Box, Some(half_extents.map(round)), None, None),
        Shape::Sphere { radius } => (ShapeKind::Sphere, None, Some(round(radius)), None),
        Shape::Capsule {
            radius,
            half_length,
        } => (
            ShapeKind::Capsule,
            None,
            Some(round(radius)),
            Some(round(half_length)),
        ),
        Shape::Cylinder {
            radius,
            half_length,
        } => (
            ShapeKind::Cylinder,
            None,
            Some(round(radius)),
            Some(round(half_length)),
        ),
    };
    ObstacleSpec {
        name: name.clone(),
        shape,
        half_extents,
        radius,
        half_length,
        pose: rounded(&o.pose),
    }
}
