//! Checks a solution against its problem: the five rules of docs/FORMATS.md ("What makes a
//! solution valid"), with the project's collision model, reporting every violation with its
//! rule, robot, step and what failed.

use std::fmt;

use omcbsa_core::collision::{ArmPose, Sweep};
use omcbsa_core::model::{Frame, Models};
use omcbsa_core::nalgebra::Vector3;
use omcbsa_core::problem::Problem;
use serde::Serialize;

use crate::error::quoted;
use crate::format::{ProblemFile, SolutionFile, Status};
use crate::load::joint_range;
use crate::pose::short;

/// How far a holding robot may be from `initial`, per joint (only float noise).
pub const HOLD_TOLERANCE: f64 = 1e-9;
/// Slack on the velocity rule, for the rounding of `v_max * dt`.
pub const VELOCITY_SLACK: f64 = 1e-9;
/// Largest displacement of any point of a link between two checked configurations of a motion
/// (metres).
pub const MOTION_CHECK_SPACING: f64 = 0.002;

/// The rule a violation breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Rule {
    /// Not a solved solution of this problem.
    Solution,
    /// Rule 1: a joint outside its limits.
    JointLimits,
    /// Rule 2: a tool centre point off its pose.
    Tracking,
    /// Rule 3: a joint faster than its velocity limit.
    Velocity,
    /// Rule 4: a collision, at a step or between two.
    Collision,
    /// Rule 5: an assignment that is not one robot per trajectory.
    Assignment,
}

impl Rule {
    /// The rule's number in the spec (none for [`Rule::Solution`]).
    pub fn number(self) -> Option<u8> {
        match self {
            Rule::Solution => None,
            Rule::JointLimits => Some(1),
            Rule::Tracking => Some(2),
            Rule::Velocity => Some(3),
            Rule::Collision => Some(4),
            Rule::Assignment => Some(5),
        }
    }

    fn title(self) -> &'static str {
        match self {
            Rule::Solution => "solution",
            Rule::JointLimits => "joint limits",
            Rule::Tracking => "tracking",
            Rule::Velocity => "velocity",
            Rule::Collision => "collision",
            Rule::Assignment => "assignment",
        }
    }
}

/// Which part of a robot's timeline a step number counts in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Phase {
    /// The joint paths: step `t` is `joint_paths[i][t]`.
    #[default]
    Path,
    /// The approach: step 0 is `initial`, step `k` is `approach[i][k - 1]`, step `A + 1` is
    /// `joint_paths[i][0]`.
    Approach,
}

/// One broken rule.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Violation {
    /// The rule broken.
    pub rule: Rule,
    /// The robot (index into `robots`) the violation is about, if one.
    pub robot: Option<usize>,
    /// The step (0-based) in `phase`, or for a motion the step it starts from.
    pub step: Option<usize>,
    /// What `step` counts.
    pub phase: Phase,
    /// What failed, naming joints, links, obstacles and trajectories.
    pub detail: String,
    /// For a collision, the links in contact as `(robot, link)` with `link` an index into
    /// `Model::LINK_NAMES` (so a viewer can mark them); empty otherwise.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub links: Vec<(usize, usize)>,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.rule.number() {
            Some(n) => write!(f, "rule {n} ({})", self.rule.title())?,
            None => f.write_str(self.rule.title())?,
        }
        if let Some(r) = self.robot {
            write!(f, ", robot {r}")?;
        }
        match (self.step, self.phase) {
            (Some(t), Phase::Path) => write!(f, ", step {t}")?,
            (Some(t), Phase::Approach) => write!(f, ", approach step {t}")?,
            (None, Phase::Approach) => write!(f, ", approach")?,
            (None, Phase::Path) => {}
        }
        write!(f, ": {}", self.detail)
    }
}

/// Violations kept in a report; beyond, they are only counted, so that a report stays small
/// however large the solution (22 million malformed configurations are one line each
/// otherwise).
pub const MAX_VIOLATIONS: usize = 1000;

/// The outcome of a validation: valid when there are no violations.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Report {
    /// The first [`MAX_VIOLATIONS`] violations.
    pub violations: Vec<Violation>,
    /// How many more there are.
    pub omitted: usize,
}

impl Report {
    /// Whether no rule is broken.
    pub fn is_valid(&self) -> bool {
        self.violations.is_empty()
    }

    /// A one-line human answer: `valid`, or the first violation and how many there are.
    pub fn summary(&self) -> String {
        match self.violations.as_slice() {
            [] => "valid".to_string(),
            [only] => format!("invalid: {only}"),
            [first, rest @ ..] => {
                format!("invalid: {first} (and {} more)", rest.len() + self.omitted)
            }
        }
    }

    /// Violations found so far, listed or not.
    pub fn count(&self) -> usize {
        self.violations.len() + self.omitted
    }

    fn add(&mut self, rule: Rule, robot: Option<usize>, step: Option<usize>, detail: String) {
        if self.violations.len() == MAX_VIOLATIONS {
            self.omitted += 1;
            return;
        }
        self.violations.push(Violation {
            rule,
            robot,
            step,
            phase: Phase::Path,
            detail,
            links: Vec::new(),
        });
    }

    fn add_contact<M: Models<D>, const D: usize>(
        &mut self,
        problem: &Problem<D>,
        contact: &Contact,
        step: usize,
        detail: String,
    ) {
        self.violations.push(Violation {
            rule: Rule::Collision,
            robot: Some(contact.robot()),
            step: Some(step),
            phase: Phase::Path,
            detail,
            links: contact.links::<M, D>(problem),
        });
    }
}

/// Checks `solution` against `problem` (the checked file and its converted form) for robots of
/// model `M`. Every violation is listed (up to [`MAX_VIOLATIONS`], then counted) with its
/// rule, robot and step; the validator shares no code path with the planners' search.
///
/// ```
/// use omcbsa::format::{Pose, ProblemFile, RobotSpec, SolutionFile, Status, TrajectorySpec};
/// use omcbsa::format::{PROBLEM_FORMAT, SOLUTION_FORMAT};
/// use omcbsa::models::{Fleet, DOF};
/// use omcbsa::validate::{validate, Rule};
/// use omcbsa::{load, pose};
/// use omcbsa_core::model::{KinovaGen3, Model};
///
/// // A Gen3 whose hand must stay where it is for three steps.
/// let q = [0.0, 0.5, 0.0, 1.5, 0.0, 1.0, 0.0];
/// let hand = pose::from_frame(&KinovaGen3::fk(&q));
/// let file = ProblemFile {
///     format: PROBLEM_FORMAT.to_string(),
///     name: "still".to_string(),
///     dt: 0.1,
///     robots: vec![RobotSpec {
///         name: "arm".to_string(),
///         model: "kinova_gen3".to_string(),
///         base: Pose::IDENTITY,
///         initial: None,
///         tcp: None,
///         tool: None,
///     }],
///     trajectories: vec![TrajectorySpec { name: "hand".to_string(), poses: vec![hand; 3] }],
///     obstacles: Vec::new(),
///     tolerance: Default::default(),
/// };
/// let problem = load::problem::<Fleet, DOF>(&file).unwrap();
/// let mut solution = SolutionFile {
///     format: SOLUTION_FORMAT.to_string(),
///     problem: "still".to_string(),
///     planner: "by hand".to_string(),
///     status: Status::Solved,
///     message: String::new(),
///     planning_time_s: 0.0,
///     assignment: vec![Some(0)],
///     joint_paths: Some(vec![vec![q.to_vec(); 3]]),
///     approach: None,
///     stats: Default::default(),
/// };
/// assert!(validate::<Fleet, DOF>(&file, &problem, &solution).is_valid());
///
/// // Joint 2 jumps 0.5 rad at step 1: too fast (rule 3), and the hand leaves its pose (2).
/// solution.joint_paths.as_mut().unwrap()[0][1][1] += 0.5;
/// let report = validate::<Fleet, DOF>(&file, &problem, &solution);
/// let broke = |rule, step| {
///     (report.violations.iter()).any(|v| v.rule == rule && v.step == Some(step))
/// };
/// assert!(broke(Rule::Velocity, 0) && broke(Rule::Velocity, 1) && broke(Rule::Tracking, 1));
/// assert!(!report.is_valid() && report.summary().starts_with("invalid: "));
/// ```
pub fn validate<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    problem: &Problem<D>,
    solution: &SolutionFile,
) -> Report {
    let mut report = Report::default();
    if solution.problem != file.name {
        report.add(
            Rule::Solution,
            None,
            None,
            format!(
                "the solution is for problem {}, not {}",
                quoted(&solution.problem),
                quoted(&file.name)
            ),
        );
    }
    if solution.status != Status::Solved {
        // Without paths there is nothing else to check.
        report.add(
            Rule::Solution,
            None,
            None,
            format!("status is {}, not solved", solution.status.as_str()),
        );
        return report;
    }
    check_assignment(file, solution, &mut report);
    let Some(paths) = joint_paths::<M, D>(problem, solution, &mut report) else {
        return report;
    };
    check_limits::<M, D>(problem, &paths, &mut report);
    check_tracking::<M, D>(file, problem, &solution.assignment, &paths, &mut report);
    check_velocity::<M, D>(problem, &paths, &mut report);
    check_collisions::<M, D>(file, problem, &paths, &mut report);
    check_approach::<M, D>(file, problem, solution, &paths, &mut report);
    report
}

/// The optional approach: its shape, then rules 1, 3 and 4 on every robot's timeline from
/// `initial` through the approach to `joint_paths[i][0]`. Violations name the approach's step
/// (0 = `initial`, A + 1 = `joint_paths[i][0]`).
fn check_approach<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    problem: &Problem<D>,
    solution: &SolutionFile,
    paths: &[Vec<[f64; D]>],
    report: &mut Report,
) {
    let Some(approach) = &solution.approach else {
        return;
    };
    let before = report.violations.len();
    let a = approach.first().map_or(0, Vec::len);
    if approach.len() != problem.robots.len() {
        report.add(
            Rule::Assignment,
            None,
            None,
            format!(
                "approach has {} lists for {} robots",
                approach.len(),
                problem.robots.len()
            ),
        );
    }
    let mut timelines = Vec::with_capacity(approach.len());
    for (i, (list, robot)) in approach.iter().zip(&problem.robots).enumerate() {
        let Some(initial) = robot.initial else {
            report.add(
                Rule::Assignment,
                Some(i),
                None,
                "approach given, but the problem gives the robot no initial configuration"
                    .to_string(),
            );
            continue;
        };
        if list.len() != a {
            report.add(
                Rule::Assignment,
                Some(i),
                None,
                format!(
                    "approach[{i}] has {} configurations, approach[0] has {a}: every robot's \
                     approach has the same length",
                    list.len()
                ),
            );
        }
        let mut timeline = vec![initial];
        for (k, q) in list.iter().enumerate() {
            match <[f64; D]>::try_from(q.as_slice()) {
                Ok(q) => timeline.push(q),
                Err(_) => report.add(
                    Rule::Assignment,
                    Some(i),
                    None,
                    format!(
                        "approach[{i}][{k}] has {} joint values, model {} has {D}",
                        q.len(),
                        M::name(robot.model)
                    ),
                ),
            }
        }
        timeline.extend(paths.get(i).and_then(|p| p.first()));
        timelines.push(timeline);
    }
    if report.violations.len() != before {
        return;
    }
    let mut sub = Report::default();
    check_limits::<M, D>(problem, &timelines, &mut sub);
    check_velocity::<M, D>(problem, &timelines, &mut sub);
    check_collisions::<M, D>(file, problem, &timelines, &mut sub);
    for v in sub.violations {
        if report.violations.len() == MAX_VIOLATIONS {
            report.omitted += 1;
            continue;
        }
        report.violations.push(Violation {
            phase: Phase::Approach,
            detail: format!("(0 = initial, {} = joint_paths[0]) {}", a + 1, v.detail),
            ..v
        });
    }
    report.omitted += sub.omitted;
}

/// Rule 5, the assignment: one entry per robot, existing trajectories, each exactly once.
fn check_assignment(file: &ProblemFile, solution: &SolutionFile, report: &mut Report) {
    let assignment = &solution.assignment;
    let (n_robots, n_traj) = (file.robots.len(), file.trajectories.len());
    if assignment.len() != n_robots {
        report.add(
            Rule::Assignment,
            None,
            None,
            format!(
                "assignment has {} entries for {n_robots} robots",
                assignment.len()
            ),
        );
    }
    let mut tracker: Vec<Option<usize>> = vec![None; n_traj];
    for (i, a) in assignment.iter().enumerate() {
        match *a {
            Some(j) if j >= n_traj => report.add(
                Rule::Assignment,
                Some(i),
                None,
                format!("assignment[{i}] = {j}, but there are only {n_traj} trajectories"),
            ),
            Some(j) => match tracker[j] {
                Some(k) => report.add(
                    Rule::Assignment,
                    Some(i),
                    None,
                    format!(
                        "trajectory {j} ({}) is also assigned to robot {k}",
                        quoted(&file.trajectories[j].name)
                    ),
                ),
                None => tracker[j] = Some(i),
            },
            None if file.robots.get(i).is_some_and(|r| r.initial.is_none()) => report.add(
                Rule::Assignment,
                Some(i),
                None,
                "holds (assignment null), but the problem gives it no initial configuration"
                    .to_string(),
            ),
            None => {}
        }
    }
    for (j, t) in tracker.iter().enumerate() {
        if t.is_none() {
            report.add(
                Rule::Assignment,
                None,
                None,
                format!(
                    "trajectory {j} ({}) is tracked by no robot",
                    quoted(&file.trajectories[j].name)
                ),
            );
        }
    }
}

/// Rule 5, the paths: one path per robot of H configurations of D joints. `None` (reported)
/// if their shape is wrong, since the other rules cannot be checked then.
fn joint_paths<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    solution: &SolutionFile,
    report: &mut Report,
) -> Option<Vec<Vec<[f64; D]>>> {
    let before = report.count();
    let Some(paths) = &solution.joint_paths else {
        report.add(
            Rule::Assignment,
            None,
            None,
            "joint_paths is missing".to_string(),
        );
        return None;
    };
    let (n_robots, horizon) = (problem.robots.len(), problem.horizon());
    if paths.len() != n_robots {
        report.add(
            Rule::Assignment,
            None,
            None,
            format!(
                "joint_paths has {} paths for {n_robots} robots",
                paths.len()
            ),
        );
    }
    let mut out = Vec::with_capacity(paths.len());
    for (i, (path, robot)) in paths.iter().zip(&problem.robots).enumerate() {
        if path.len() != horizon {
            report.add(
                Rule::Assignment,
                Some(i),
                None,
                format!(
                    "joint_paths[{i}] has {} configurations, expected H = {horizon}",
                    path.len()
                ),
            );
        }
        let mut configurations = Vec::with_capacity(path.len());
        for (t, q) in path.iter().enumerate() {
            match <[f64; D]>::try_from(q.as_slice()) {
                Ok(q) => configurations.push(q),
                Err(_) => report.add(
                    Rule::Assignment,
                    Some(i),
                    Some(t),
                    format!(
                        "joint_paths[{i}][{t}] has {} joint values, model {} has {D}",
                        q.len(),
                        M::name(robot.model)
                    ),
                ),
            }
        }
        out.push(configurations);
    }
    (report.count() == before).then_some(out)
}

/// Rule 1, with the range of [`joint_range`] (joint limits, and the bus's range for the
/// continuous joints).
fn check_limits<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    paths: &[Vec<[f64; D]>],
    report: &mut Report,
) {
    for (i, (path, robot)) in paths.iter().zip(&problem.robots).enumerate() {
        for (t, q) in path.iter().enumerate() {
            for (j, &v) in q.iter().enumerate() {
                let (lower, upper) = joint_range::<M, D>(robot.model, j);
                if !(lower <= v && v <= upper) {
                    report.add(
                        Rule::JointLimits,
                        Some(i),
                        Some(t),
                        format!(
                            "joint {} = {} is outside its limits [{}, {}]",
                            M::joint_names(robot.model)[j],
                            short(v),
                            short(lower),
                            short(upper)
                        ),
                    );
                }
            }
        }
    }
}

/// Rule 2: tracking robots' tool centre points on their trajectory, holding robots still.
fn check_tracking<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    problem: &Problem<D>,
    assignment: &[Option<usize>],
    paths: &[Vec<[f64; D]>],
    report: &mut Report,
) {
    let tol = &problem.tolerance;
    for (i, (path, robot)) in paths.iter().zip(&problem.robots).enumerate() {
        match assignment.get(i).copied().flatten() {
            Some(j) => {
                // A trajectory index out of range is a rule 5 violation, reported already.
                let Some(trajectory) = problem.trajectories.get(j) else {
                    continue;
                };
                let name = quoted(&file.trajectories[j].name);
                for (t, (q, target)) in path.iter().zip(trajectory).enumerate() {
                    let tcp = robot
                        .base
                        .compose(&M::fk(robot.model, q))
                        .compose(&robot.tcp);
                    let dp = (tcp.pos - target.pos).norm();
                    let angle = rotation_angle(&tcp, target);
                    if dp > tol.position {
                        report.add(
                            Rule::Tracking,
                            Some(i),
                            Some(t),
                            format!(
                                "the TCP is {} m from pose {t} of trajectory {j} ({name}); \
                                 tolerance {} m",
                                short(dp),
                                short(tol.position)
                            ),
                        );
                    }
                    if angle > tol.orientation {
                        report.add(
                            Rule::Tracking,
                            Some(i),
                            Some(t),
                            format!(
                                "the TCP is rotated {} rad from pose {t} of trajectory {j} \
                                 ({name}); tolerance {} rad",
                                short(angle),
                                short(tol.orientation)
                            ),
                        );
                    }
                }
            }
            None => {
                // A holding robot without `initial` is a rule 5 violation, reported already.
                let Some(initial) = &robot.initial else {
                    continue;
                };
                for (t, q) in path.iter().enumerate() {
                    if let Some(j) = (0..D).find(|&j| (q[j] - initial[j]).abs() > HOLD_TOLERANCE) {
                        report.add(
                            Rule::Tracking,
                            Some(i),
                            Some(t),
                            format!(
                                "holds, but joint {} = {} differs from its initial {}",
                                M::joint_names(robot.model)[j],
                                short(q[j]),
                                short(initial[j])
                            ),
                        );
                    }
                }
            }
        }
    }
}

/// Angle of the rotation taking `a`'s orientation to `b`'s, from the trace (with the sine
/// from the skew part, so it is accurate near 0 and near pi).
fn rotation_angle(a: &Frame, b: &Frame) -> f64 {
    let r = a.rot.tr_mul(&b.rot);
    let cos = 0.5 * (r.trace() - 1.0);
    let sin = 0.5
        * Vector3::new(
            r[(2, 1)] - r[(1, 2)],
            r[(0, 2)] - r[(2, 0)],
            r[(1, 0)] - r[(0, 1)],
        )
        .norm();
    sin.atan2(cos)
}

/// Rule 3.
fn check_velocity<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    paths: &[Vec<[f64; D]>],
    report: &mut Report,
) {
    let dt = problem.dt;
    for (i, (path, robot)) in paths.iter().zip(&problem.robots).enumerate() {
        let (names, velocity) = (M::joint_names(robot.model), M::velocity(robot.model));
        for (t, pair) in path.windows(2).enumerate() {
            for (j, (a, b)) in pair[0].iter().zip(&pair[1]).enumerate() {
                let dq = (b - a).abs();
                let max = velocity[j] * dt;
                if dq > max + VELOCITY_SLACK {
                    report.add(
                        Rule::Velocity,
                        Some(i),
                        Some(t),
                        format!(
                            "joint {} moves {} between steps {t} and {}, more than its velocity \
                             limit {} * dt {} = {}",
                            names[j],
                            short(dq),
                            t + 1,
                            short(velocity[j]),
                            short(dt),
                            short(max)
                        ),
                    );
                }
            }
        }
    }
}

/// What a robot's links and tool hit, by capsule index (into `Model::CAPSULES`, then into the
/// robot's tool capsules).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Contact {
    Obstacle {
        robot: usize,
        capsule: usize,
        obstacle: usize,
    },
    Robot {
        robot: usize,
        capsule: usize,
        other: usize,
        other_capsule: usize,
    },
    SelfLinks {
        robot: usize,
        capsule: usize,
        other_capsule: usize,
    },
}

impl Contact {
    fn robot(&self) -> usize {
        match *self {
            Contact::Obstacle { robot, .. }
            | Contact::Robot { robot, .. }
            | Contact::SelfLinks { robot, .. } => robot,
        }
    }

    /// `(robot, link)` of every link in contact (an obstacle is not a link).
    fn links<M: Models<D>, const D: usize>(&self, problem: &Problem<D>) -> Vec<(usize, usize)> {
        let model = |robot: usize| problem.robots.get(robot).map_or(0, |r| r.model);
        // The link a capsule index is on (`usize::MAX` for none).
        let link = |robot: usize, capsule: usize| {
            (M::capsules(model(robot)).get(capsule)).map_or(usize::MAX, |c| usize::from(c.link))
        };
        let links = match *self {
            Contact::Obstacle { robot, capsule, .. } => vec![(robot, link(robot, capsule))],
            Contact::Robot {
                robot,
                capsule,
                other,
                other_capsule,
            } => vec![
                (robot, link(robot, capsule)),
                (other, link(other, other_capsule)),
            ],
            Contact::SelfLinks {
                robot,
                capsule,
                other_capsule,
            } => vec![
                (robot, link(robot, capsule)),
                (robot, link(robot, other_capsule)),
            ],
        };
        links
            .into_iter()
            .filter(|&(r, l)| l < M::link_names(model(r)).len())
            .collect()
    }

    fn describe<M: Models<D>, const D: usize>(
        &self,
        file: &ProblemFile,
        problem: &Problem<D>,
    ) -> String {
        // `link forearm_link`, or `tool "gripper" (capsule 1)` past the link capsules.
        let part = |robot: usize, capsule: usize| {
            let model = problem.robots.get(robot).map_or(0, |r| r.model);
            let capsules = M::capsules(model);
            if let Some(c) = capsules.get(capsule) {
                let link = M::link_names(model).get(usize::from(c.link));
                return format!("link {}", link.copied().unwrap_or("?"));
            }
            let k = capsule - capsules.len();
            match file.robots[robot].tool.as_ref() {
                Some(tool) if k < tool.capsules.len() => {
                    format!("tool {} (capsule {k})", quoted(&tool.name))
                }
                _ => "a link".to_string(),
            }
        };
        match *self {
            Contact::Obstacle {
                robot,
                capsule,
                obstacle,
            } => format!(
                "{} hits obstacle {obstacle} ({})",
                part(robot, capsule),
                quoted(&file.obstacles[obstacle].name)
            ),
            Contact::Robot {
                robot,
                capsule,
                other,
                other_capsule,
            } => format!(
                "{} hits {} of robot {other} ({})",
                part(robot, capsule),
                part(other, other_capsule),
                quoted(&file.robots[other].name)
            ),
            Contact::SelfLinks {
                robot,
                capsule,
                other_capsule,
            } => {
                format!(
                    "{} hits its own {}",
                    part(robot, capsule),
                    part(robot, other_capsule)
                )
            }
        }
    }
}

/// Rule 4, at every step and along every motion between steps.
fn check_collisions<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    problem: &Problem<D>,
    paths: &[Vec<[f64; D]>],
    report: &mut Report,
) {
    let horizon = paths.iter().map(Vec::len).min().unwrap_or(0);
    let mut step_collides = vec![false; horizon];
    for (t, collides) in step_collides.iter_mut().enumerate() {
        let contacts = contacts(
            problem,
            &arms_at::<M, D>(problem, paths.iter().map(|p| p[t])),
        );
        *collides = !contacts.is_empty();
        for c in contacts {
            report.add_contact::<M, D>(problem, &c, t, c.describe::<M, D>(file, problem));
        }
    }
    for t in 0..horizon.saturating_sub(1) {
        // The step's own violation says enough.
        if step_collides[t] || step_collides[t + 1] {
            continue;
        }
        let (from, to): (Vec<_>, Vec<_>) = paths.iter().map(|p| (p[t], p[t + 1])).unzip();
        let sweeps = together::<M, D>(problem, &from, &to);
        let count = sweeps.first().map_or(0, Sweep::count);
        for k in 0..count {
            let contacts = contacts(
                problem,
                &arms_at::<M, D>(problem, sweeps.iter().map(|s| s.config(k))),
            );
            for c in &contacts {
                let detail = format!(
                    "moving from step {t} to {}, at {:.1} % of the way: {}",
                    t + 1,
                    100.0 * (k as f64 + 0.5) / count as f64,
                    c.describe::<M, D>(file, problem)
                );
                report.add_contact::<M, D>(problem, c, t, detail);
            }
            if !contacts.is_empty() {
                break;
            }
        }
    }
}

/// The robots of `problem` placed at `configurations` (one per robot, in order).
fn arms_at<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    configurations: impl Iterator<Item = [f64; D]>,
) -> Vec<ArmPose> {
    (problem.robots.iter().zip(configurations))
        .map(|(robot, q)| ArmPose::new::<M, D>(robot.model, &robot.base, &robot.tool, &q))
        .collect()
}

/// The robots moving together straight from `from` to `to` (one configuration each), checked
/// at the same instants: as many as the robot whose points move farthest needs for no point
/// to move more than [`MOTION_CHECK_SPACING`] between two.
fn together<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    from: &[[f64; D]],
    to: &[[f64; D]],
) -> Vec<Sweep<M, D>> {
    let sweeps: Vec<Sweep<M, D>> = (problem.robots.iter().zip(from.iter().zip(to)))
        .map(|(r, (a, b))| Sweep::new(r.model, &r.tool, a, b, MOTION_CHECK_SPACING))
        .collect();
    let count = sweeps.iter().map(|s| s.count()).max().unwrap_or(1);
    sweeps.into_iter().map(|s| s.with_count(count)).collect()
}

/// Whether the robots standing at `configurations` (one per robot) overlap nothing, by rule
/// 4's check of a step.
pub fn placing_is_clear<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    configurations: &[[f64; D]],
) -> bool {
    contacts(
        problem,
        &arms_at::<M, D>(problem, configurations.iter().copied()),
    )
    .is_empty()
}

/// Whether the robots moving together straight from `from` to `to` (one configuration each)
/// overlap nothing at any instant rule 4 checks between two steps (the ends are
/// [`placing_is_clear`]'s). The instants are those of a validation, visited coarse to fine so
/// that a motion that collides is found out early.
pub fn motion_is_clear<M: Models<D>, const D: usize>(
    problem: &Problem<D>,
    from: &[[f64; D]],
    to: &[[f64; D]],
) -> bool {
    let sweeps = together::<M, D>(problem, from, to);
    let count = sweeps.first().map_or(0, Sweep::count);
    // Placed in the same storage each time; a robot that stays put, once.
    let mut arms = arms_at::<M, D>(problem, from.iter().copied());
    let moving: Vec<usize> = (0..arms.len()).filter(|&r| from[r] != to[r]).collect();
    coarse_to_fine(count).all(|k| {
        for &r in &moving {
            let robot = &problem.robots[r];
            arms[r].place::<M, D>(robot.model, &robot.base, &robot.tool, &sweeps[r].config(k));
        }
        contacts(problem, &arms).is_empty()
    })
}

/// `0..count`, every index once: first those on the coarsest power-of-two grid, then each
/// finer grid's new ones.
fn coarse_to_fine(count: usize) -> impl Iterator<Item = usize> {
    let top = count.max(1).next_power_of_two();
    std::iter::successors(Some(top), |&s| (s > 1).then_some(s / 2)).flat_map(move |stride| {
        (0..count)
            .step_by(stride)
            .filter(move |k| stride == top || k % (2 * stride) != 0)
    })
}

/// What the arms standing at their `initial` configurations overlap, in the validator's words:
/// empty when they stand clear; `None` when some robot gives no `initial`.
pub fn initial_contacts<M: Models<D>, const D: usize>(
    file: &ProblemFile,
    problem: &Problem<D>,
) -> Option<Vec<String>> {
    let standing = (problem.robots.iter())
        .map(|r| Some(ArmPose::new::<M, D>(r.model, &r.base, &r.tool, &r.initial?)))
        .collect::<Option<Vec<_>>>()?;
    Some(
        contacts(problem, &standing)
            .iter()
            .map(|c| c.describe::<M, D>(file, problem))
            .collect(),
    )
}

/// What overlaps with the arms at `arms` (touching is not overlapping): every obstacle each
/// arm hits, the first pair of its own links, the first pair of links with each other arm.
fn contacts<const D: usize>(problem: &Problem<D>, arms: &[ArmPose]) -> Vec<Contact> {
    let obstacles = problem.obstacles.as_slice();
    let mut found = Vec::new();
    for (robot, arm) in arms.iter().enumerate() {
        let mut from = 0;
        while let Some(k) = arm.obstacle_hit(&obstacles[from..], 0.0) {
            let obstacle = from + k;
            // `obstacle_hit` names the obstacle; the link is found for the message.
            let capsule = (arm.capsules().iter().enumerate())
                .position(|(i, w)| !arm.on_base(i) && obstacles[obstacle].hits_capsule(w, 0.0))
                .unwrap_or(usize::MAX);
            found.push(Contact::Obstacle {
                robot,
                capsule,
                obstacle,
            });
            from = obstacle + 1;
        }
        if let Some((capsule, other_capsule)) = arm.self_hit(0.0) {
            found.push(Contact::SelfLinks {
                robot,
                capsule,
                other_capsule,
            });
        }
        for (other, other_arm) in arms.iter().enumerate().skip(robot + 1) {
            if let Some((capsule, other_capsule)) = arm.arm_hit(other_arm, 0.0) {
                found.push(Contact::Robot {
                    robot,
                    capsule,
                    other,
                    other_capsule,
                });
            }
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::coarse_to_fine;

    #[test]
    fn coarse_to_fine_visits_every_instant_once() {
        for count in 0..70 {
            let mut seen: Vec<usize> = coarse_to_fine(count).collect();
            seen.sort_unstable();
            assert_eq!(seen, (0..count).collect::<Vec<_>>(), "count {count}");
        }
        assert_eq!(coarse_to_fine(5).collect::<Vec<_>>(), [0, 4, 2, 1, 3]);
    }
}
