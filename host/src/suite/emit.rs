//! One problem of the suite: sample a layout and a task, look for a witness, and turn both
//! into the file formats, checking the witness with the host validator.

use omcbsa_core::geometry::Shape;
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::problem::Problem;
use omcbsa_core::rng::Rng;
use serde_json::Map;

use super::family::{Family, Hand};
use super::frames::{at, v3};
use super::layout::{Layout, NamedObstacle};
use super::myopic::ik_tracking_solves;
use super::standing::{clear_of, stand_anywhere, stand_clear, witness_approach};
use super::trap::traps;
use super::witness::{
    random_motion, retract, shuffle, task_witness, Arms, MotionSpec, Placed, Scene, Q,
};
use super::{
    Error, Spec, SuiteEntry, HARD_SAMPLES, MIXED_SAMPLES, RANDOM_SAMPLES, TASK_SAMPLES, WITNESS_DIR,
};
use crate::format::{
    ObstacleSpec, Pose, ProblemFile, RobotSpec, ShapeKind, SolutionFile, Status, ToleranceSpec,
    TrajectorySpec, PROBLEM_FORMAT, SOLUTION_FORMAT,
};
use crate::models::DOF;
use crate::{load, pose, validate};
use omcbsa_core::approach::ApproachError;

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
    pub witness: Option<SolutionFile>,
}

/// One sampled problem: its layout, hands (designed arm included) and maybe a witness.
struct Sample {
    layout: Layout,
    hands: Vec<Hand>,
    witness: Option<Vec<Vec<Q>>>,
}

pub fn generate(spec: &Spec) -> Result<Generated, Error> {
    let samples = if spec.family == Family::Mixed {
        MIXED_SAMPLES
    } else if matches!(spec.family, Family::Random | Family::Approach) {
        RANDOM_SAMPLES
    } else {
        TASK_SAMPLES
    };
    // The first sample with a witness (of the approach family, whose straight bridge
    // collides if any does), else the last one without.
    let mut fallback: Option<(Generated, bool)> = None;
    let mut solvable = 0;
    for k in 0..samples {
        let mut rng = Rng::new(
            spec.seed
                .wrapping_add(k.wrapping_mul(0x9E37_79B9_7F4A_7C15)),
        );
        let Some(sample) = sample(spec, &mut rng) else {
            continue;
        };
        let Some((generated, problem)) = files(spec, &sample, &mut rng)? else {
            continue;
        };
        let known = generated.witness.is_some();
        // The approach family wants arms whose straight bridges collide.
        let hard = spec.stance.is_none() || generated.entry.straight_bridge_collides == Some(true);
        if known && hard && !ik_tracking_solves(&problem) {
            return Ok(generated);
        }
        let better = match &fallback {
            None => true,
            Some((f, f_hard)) => known && (f.witness.is_none() || (hard && !f_hard)),
        };
        if better {
            fallback = Some((generated, hard));
        }
        solvable += usize::from(known && hard);
        if solvable == HARD_SAMPLES {
            break;
        }
    }
    let fallback = fallback.map(|(g, _)| g);
    fallback.ok_or_else(|| Error::NoMotion {
        problem: spec.name.clone(),
        samples,
    })
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
                let spec = MotionSpec {
                    model,
                    base: &base,
                    station: &layout.stations[arm],
                    h,
                    moving: holder != Some(arm),
                };
                let path = random_motion(&scene, &spec, &others, rng)?;
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

/// The problem file (trajectories shuffled) and, if the witness passes the validator, the
/// witness solution; and the problem as the planners get it. `None` when no place was found
/// for every arm to stand clear.
fn files(
    spec: &Spec,
    sample: &Sample,
    rng: &mut Rng,
) -> Result<Option<(Generated, Box<Problem<DOF>>)>, Error> {
    let n = sample.layout.bases.len();
    let models = &sample.layout.models;
    let hands = &sample.hands;
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
    let starts: Vec<Option<Q>> = (0..n)
        .map(|i| sample.witness.as_ref().map(|paths| paths[i][0]))
        .collect();
    // Holding arms hold their witness configuration; every arm needs an initial one then, and
    // the others get the retract pose. The approach family stands every arm somewhere hard.
    let initial: Vec<Option<Q>> = (0..n)
        .map(|i| match (spec.stance, starts[i], assignment[i]) {
            (Some(stance), Some(start), _) => Some(stance.initial(i, &start, &retract(models[i]))),
            (_, Some(start), None) => Some(start),
            _ => holds.then(|| retract(models[i])),
        })
        .collect();
    let mut obstacles = sample.layout.obstacles.clone();
    if let (Some(stance), Some(paths)) = (spec.stance, &sample.witness) {
        for i in 0..n {
            if let (Some(q), Some(start)) = (initial[i], starts[i]) {
                let post = stance
                    .post(models[i], &sample.layout.bases[i], &q, &start, &tcp())
                    .filter(|o| clear_of(o, models, &sample.layout.bases, paths));
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
    let problem = ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: spec.name.clone(),
        dt: DT,
        robots,
        trajectories,
        obstacles: obstacles.iter().map(obstacle_spec).collect(),
        tolerance: ToleranceSpec::default(),
    };
    let mut problem = problem;
    // A problem the loader refuses is a bug of the generator.
    let generation = |message: String| Error::Generation {
        problem: spec.name.clone(),
        message,
    };
    let mut core = load::problem::<Arms, DOF>(&problem)
        .map(Box::new)
        .map_err(|e| generation(e.to_string()))?;
    // Where the arms stand: clear of everything, with an approach to the witness.
    let mut approach = None;
    let mut straight_bridge_collides = None;
    if initial.iter().any(Option::is_some) {
        if !stand_clear(&mut core, &starts) && !stand_anywhere(&mut core, rng, 1000) {
            // No witness start to fall back on and no free configuration found.
            // Nowhere found for an arm to stand: the sample is not used.
            return Ok(None);
        }
        if let Some(paths) = &sample.witness {
            for _ in 0..=n {
                match witness_approach(&core, paths, true) {
                    Ok(a) => {
                        approach = Some(a);
                        break;
                    }
                    Err(ApproachError::Blocked { robot, other }) => {
                        for r in [Some(robot), other].into_iter().flatten() {
                            core.robots[r].initial = starts[r];
                        }
                    }
                    Err(_) => break,
                }
            }
            straight_bridge_collides = Some(witness_approach(&core, paths, false).is_err());
        }
        for (i, r) in problem.robots.iter_mut().enumerate() {
            r.initial = core.robots[i]
                .initial
                .map(|q| q.iter().map(|&x| round(x)).collect());
        }
        let rounded =
            load::problem::<Arms, DOF>(&problem).map_err(|e| generation(e.to_string()))?;
        // The validator's own check of where the arms stand (after rounding): never an
        // `initial` that collides.
        let contacts = validate::initial_contacts::<Arms, DOF>(&problem, &rounded);
        if contacts.is_some_and(|c| !c.is_empty()) {
            return Ok(None);
        }
    }
    let witness = match &sample.witness {
        Some(paths) => {
            let solution = SolutionFile {
                approach: approach.as_ref().map(|a| {
                    a.iter()
                        .map(|p| {
                            p.iter()
                                .map(|q| q.iter().map(|&x| round(x)).collect())
                                .collect()
                        })
                        .collect()
                }),
                format: SOLUTION_FORMAT.to_string(),
                problem: spec.name.clone(),
                planner: "witness".to_string(),
                status: Status::Solved,
                message: String::new(),
                planning_time_s: 0.0,
                assignment,
                joint_paths: Some(
                    paths
                        .iter()
                        .map(|p| {
                            p.iter()
                                .map(|q| q.iter().map(|&x| round(x)).collect())
                                .collect()
                        })
                        .collect(),
                ),
                stats: Map::new(),
            };
            // A witness of a problem that gives every `initial` needs its approach.
            let needs_approach = core.robots.iter().all(|r| r.initial.is_some());
            let core =
                load::problem::<Arms, DOF>(&problem).map_err(|e| generation(e.to_string()))?;
            (validate::validate::<Arms, DOF>(&problem, &core, &solution).is_valid()
                && (approach.is_some() || !needs_approach))
                .then_some(solution)
        }
        None => None,
    };
    let entry = SuiteEntry {
        name: spec.name.clone(),
        file: format!("{}.json", spec.name),
        family: spec.family.name().to_string(),
        layout: spec.layout.name().to_string(),
        robots: n,
        trajectories: hands.len(),
        horizon: hands[0].poses.len(),
        known_solvable: witness.is_some(),
        seed: spec.seed,
        stance: spec.stance.map(|s| s.name().to_string()),
        straight_bridge_collides,
        assignment: None,
        witness: witness
            .as_ref()
            .map(|_| format!("{WITNESS_DIR}/{}.json", spec.name)),
    };
    Ok(Some((
        Generated {
            entry,
            problem,
            witness,
        },
        core,
    )))
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
