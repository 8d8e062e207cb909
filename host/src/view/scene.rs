//! What the plan page draws, computed on the host with the planner's own model: every link
//! frame of every robot at every step (the core's forward kinematics), the joints' axes (so the
//! page can read the drawn joint angles back from its meshes), the collision capsules, the
//! trajectories with their assigned robot, the obstacles and the validator's findings.

use serde::Serialize;

use omcbsa_core::model::{Frame, Models};
use omcbsa_core::nalgebra::Matrix3;
use omcbsa_core::problem::Problem;

use crate::format::{ObstacleSpec, ProblemFile, SolutionFile};
use crate::validate::{Report, Violation};

/// A frame as the page reads it: rotation columns (x, y, z axes), then the position.
type FrameData = [f32; 12];

/// Everything the page draws, as it reads it (JSON).
#[derive(Serialize)]
pub struct Scene<'a> {
    /// The problem's name.
    pub name: &'a str,
    /// Time between steps, s.
    pub dt: f64,
    /// Frames of the timeline: the approach's (`lead`), then the path's.
    pub steps: usize,
    /// Timeline index of the path's step 0: frames `0..lead` are the approach, frame 0 being
    /// `initial` (0 when the solution has no approach).
    pub lead: usize,
    /// Absent when only the problem is shown.
    pub solution: Option<SolutionInfo<'a>>,
    /// The models the robots use (every compiled one), indexed by `RobotView::model`.
    pub models: Vec<ModelView>,
    /// Each robot: its name, model, base and timeline.
    pub robots: Vec<RobotView<'a>>,
    /// Each hand trajectory.
    pub trajectories: Vec<TrajectoryView<'a>>,
    /// The obstacles, as the file gives them.
    pub obstacles: &'a [ObstacleSpec],
}

#[derive(Serialize)]
pub struct SolutionInfo<'a> {
    pub planner: &'a str,
    pub status: &'a str,
    pub message: &'a str,
    pub planning_time_s: f64,
    pub valid: bool,
    pub summary: String,
    pub violations: &'a [Violation],
}

/// One model: its links (named as the page's meshes are), joints and capsules.
#[derive(Serialize)]
pub struct ModelView {
    pub name: &'static str,
    pub links: &'static [&'static str],
    pub joints: Vec<Joint>,
    pub capsules: Vec<CapsuleData>,
}

/// A joint between two links of a serial chain.
#[derive(Serialize)]
pub struct Joint {
    pub name: &'static str,
    pub parent: usize,
    pub child: usize,
    /// Rotation of the child's frame in the parent's at joint value 0 (columns).
    pub origin: [f32; 9],
    /// The axis in the child's frame at 0, which the joint turns about.
    pub axis: [f32; 3],
}

#[derive(Serialize)]
pub struct CapsuleData {
    pub link: usize,
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub radius: f64,
}

#[derive(Serialize)]
pub struct RobotView<'a> {
    pub name: &'a str,
    /// Index into [`Scene::models`].
    pub model: u8,
    /// The trajectory it tracks, when a solution assigns one.
    pub trajectory: Option<usize>,
    /// Whether the frames follow the solution's joint path (else they hold one configuration:
    /// `initial`, or all joints at 0 without one).
    pub planned: bool,
    /// `frames[t][link]` in the world; a single entry when not `planned`.
    pub frames: Vec<Vec<FrameData>>,
}

#[derive(Serialize)]
pub struct TrajectoryView<'a> {
    pub name: &'a str,
    pub robot: Option<usize>,
    /// Per step: position and quaternion (x, y, z, w) of the hand.
    pub poses: Vec<[f64; 7]>,
}

fn frame_data(f: &Frame) -> FrameData {
    let r = &f.rot;
    let p = &f.pos;
    std::array::from_fn(|k| if k < 9 { r[(k % 3, k / 3)] } else { p[k - 9] } as f32)
}

fn columns(r: &Matrix3<f64>) -> [f32; 9] {
    std::array::from_fn(|k| r[(k % 3, k / 3)] as f32)
}

/// Every link frame of model `model` of `M` at `q`, in the model's base frame.
fn link_frames<M: Models<D>, const D: usize>(model: u8, q: &[f64; D]) -> Vec<Frame> {
    let mut frames = vec![Frame::IDENTITY; M::link_names(model).len()];
    M::link_frames(model, q, &mut frames);
    frames
}

/// Model `model` of `M` as the page draws it.
fn model_view<M: Models<D>, const D: usize>(model: u8) -> ModelView {
    ModelView {
        name: M::name(model),
        links: M::link_names(model),
        joints: joints::<M, D>(model),
        capsules: (M::capsules(model).iter())
            .map(|c| CapsuleData {
                link: usize::from(c.link),
                a: c.a,
                b: c.b,
                radius: c.radius,
            })
            .collect(),
    }
}

/// The joints of model `model`, found from its forward kinematics: joint `j` turns the first
/// link whose frame moves when only `j` does, about the axis of that small rotation.
fn joints<M: Models<D>, const D: usize>(model: u8) -> Vec<Joint> {
    let zero = link_frames::<M, D>(model, &[0.0; D]);
    const PROBE: f64 = 0.5;
    (0..D)
        .filter_map(|j| {
            let mut q = [0.0; D];
            q[j] = PROBE;
            let moved = link_frames::<M, D>(model, &q);
            let child = (1..zero.len()).find(|&l| (moved[l].rot - zero[l].rot).norm() > 1e-9)?;
            let parent = child - 1;
            let origin = zero[parent].rot.transpose() * zero[child].rot;
            // origin * R(axis, PROBE) = moved relative rotation.
            let turn = origin.transpose() * moved[parent].rot.transpose() * moved[child].rot;
            let skew = turn - turn.transpose();
            let axis = [skew[(2, 1)], skew[(0, 2)], skew[(1, 0)]];
            let s = 2.0 * PROBE.sin();
            Some(Joint {
                name: M::joint_names(model)[j],
                parent,
                child,
                origin: columns(&origin),
                axis: axis.map(|a| (a / s) as f32),
            })
        })
        .collect()
}

/// The scene of `file` (checked and loaded as `problem`), with `solution` and its validation
/// `report` when given.
pub fn scene<'a, M: Models<D>, const D: usize>(
    file: &'a ProblemFile,
    problem: &Problem<D>,
    solution: Option<(&'a SolutionFile, &'a Report)>,
) -> Scene<'a> {
    let h = problem.horizon();
    let paths = solution.and_then(|(s, _)| planned_paths::<D>(s, problem.robots.len(), h));
    // The approach, played before the path: `initial`, then its configurations.
    let approach = paths
        .as_ref()
        .and_then(|_| solution.and_then(|(s, _)| approach_timelines::<D>(s, problem)));
    let lead = approach
        .as_ref()
        .and_then(|a| a.first())
        .map_or(0, Vec::len);
    let steps = lead + h;
    let paths = paths.map(|paths| match approach {
        Some(approach) => (approach.into_iter().zip(paths))
            .map(|(mut a, p)| {
                a.extend(p);
                a
            })
            .collect(),
        None => paths,
    });
    let assignment = |i: usize| {
        solution
            .and_then(|(s, _)| s.assignment.get(i).copied().flatten())
            .filter(|&j| j < file.trajectories.len())
    };
    let robots = (file.robots.iter().zip(&problem.robots))
        .enumerate()
        .map(|(i, (spec, robot))| {
            let at = |q: &[f64; D]| -> Vec<FrameData> {
                (link_frames::<M, D>(robot.model, q).iter())
                    .map(|f| frame_data(&robot.base.compose(f)))
                    .collect()
            };
            let frames = match &paths {
                Some(paths) => paths[i].iter().map(at).collect(),
                None => vec![at(&robot.initial.unwrap_or([0.0; D]))],
            };
            RobotView {
                name: &spec.name,
                model: robot.model,
                trajectory: assignment(i),
                planned: paths.is_some(),
                frames,
            }
        })
        .collect();
    let trajectories = (file.trajectories.iter().enumerate())
        .map(|(j, t)| TrajectoryView {
            name: &t.name,
            robot: (0..file.robots.len()).find(|&i| assignment(i) == Some(j)),
            poses: (t.poses.iter())
                .map(|p| {
                    let [x, y, z] = p.position;
                    let [qx, qy, qz, qw] = p.quat_xyzw;
                    [x, y, z, qx, qy, qz, qw]
                })
                .collect(),
        })
        .collect();
    Scene {
        name: &file.name,
        dt: file.dt,
        steps,
        lead,
        solution: solution.map(|(s, report)| SolutionInfo {
            planner: &s.planner,
            status: s.status.as_str(),
            message: &s.message,
            planning_time_s: s.planning_time_s,
            valid: report.is_valid(),
            summary: report.summary(),
            violations: &report.violations,
        }),
        models: (0..M::COUNT)
            .filter_map(|m| u8::try_from(m).ok())
            .map(model_view::<M, D>)
            .collect(),
        robots,
        trajectories,
        obstacles: &file.obstacles,
    }
}

/// The solution's joint paths when they have the problem's shape (one path of `steps`
/// configurations of `D` values per robot); `None` otherwise (the validator says what is
/// wrong, and the page shows that instead of guessing).
fn planned_paths<const D: usize>(
    solution: &SolutionFile,
    robots: usize,
    steps: usize,
) -> Option<Vec<Vec<[f64; D]>>> {
    let paths = solution.joint_paths.as_ref()?;
    if paths.len() != robots || paths.iter().any(|p| p.len() != steps) {
        return None;
    }
    paths
        .iter()
        .map(|p| {
            p.iter()
                .map(|q| <[f64; D]>::try_from(q.as_slice()).ok())
                .collect()
        })
        .collect()
}

/// Per robot, `initial` then the solution's approach, when the solution has an approach of
/// the problem's shape and every robot has `initial`; `None` otherwise.
fn approach_timelines<const D: usize>(
    solution: &SolutionFile,
    problem: &Problem<D>,
) -> Option<Vec<Vec<[f64; D]>>> {
    let approach = solution.approach.as_ref()?;
    let a = approach.first().map_or(0, Vec::len);
    if approach.len() != problem.robots.len() || approach.iter().any(|p| p.len() != a) {
        return None;
    }
    (approach.iter().zip(&problem.robots))
        .map(|(list, robot)| {
            let mut timeline = vec![robot.initial?];
            for q in list {
                timeline.push(<[f64; D]>::try_from(q.as_slice()).ok()?);
            }
            Some(timeline)
        })
        .collect()
}
