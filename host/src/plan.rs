//! Planning a problem file: load and check it, plan with a planner by name (under an
//! assignment rule if one is given), and validate what the planner calls solved before it is
//! reported. A plan that fails validation is never reported as solved.
//!
//! [`plan_file`] allocates its storage for the one call; [`plan_loaded`] plans in a
//! [`Storage`] the caller keeps from run to run (the crate's documentation has an example of
//! [`plan_file`]):
//!
//! ```
//! use omcbsa::format::Status;
//! use omcbsa::load;
//! use omcbsa::plan::plan_loaded;
//! use omcbsa::planners::{Capacities, PlannerKind, Storage};
//!
//! let text = r#"{
//!   "format": "omcbsa.problem.v1", "name": "lift", "dt": 0.1,
//!   "robots": [{"name": "arm", "model": "kinova_gen3",
//!               "base": {"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]},
//!               "initial": [0, 0.26, 3.14, -2.27, 0, 0.96, 1.57]}],
//!   "trajectories": [{"name": "hand", "poses": [
//!     {"position": [0.5, 0, 0.40], "quat_xyzw": [1, 0, 0, 0]},
//!     {"position": [0.5, 0, 0.41], "quat_xyzw": [1, 0, 0, 0]},
//!     {"position": [0.5, 0, 0.42], "quat_xyzw": [1, 0, 0, 0]}]}]
//! }"#;
//! let file = load::parse_problem(text).unwrap();
//! let problem = omcbsa::plan::load_problem(&file).unwrap();
//! // Pools for horizons up to 3 steps, smaller than the defaults.
//! let caps = Capacities {
//!     search_nodes: 1 << 12,
//!     composite_nodes: 1 << 8,
//!     ..Capacities::default()
//! };
//! let mut storage = Storage::new(caps, 3);
//! for kind in [PlannerKind::OmCbsa, PlannerKind::Pp] {
//!     let solution = plan_loaded(&mut storage, &file, &problem, kind, 5.0).unwrap();
//!     assert_eq!(solution.status, Status::Solved, "{kind}: {}", solution.message);
//!     // The arm stands at `initial`: the solution says how it gets to the plan's start.
//!     assert!(solution.approach.is_some());
//! }
//! ```

use omcbsa_core::pace::TooFast;
use omcbsa_core::problem::Problem;

use crate::approach::check_initial;
use crate::assignment::AssignmentRule;
use crate::error::InputError;
use crate::format::{ProblemFile, SolutionFile, Status as FileStatus};
use crate::load;
use crate::models::{Fleet, DOF};
use crate::planners::{Capacities, PlannerKind, Storage};
use crate::time_scale::least_scale;
use crate::validate::validate;
use omcbsa_core::model::Models;

/// Plans a problem file with planner `kind` and returns its solution file. A plan the planner
/// calls solved is validated first; if it fails validation it is reported as not solved, with
/// the violation in `message`, never as solved. A file that breaks the format is an
/// [`InputOrPlanError::Input`] naming the field; a problem that loads but has no plan is a
/// solution file whose status says why (`no_solution`, `timeout`, ...).
///
/// ```
/// use omcbsa::format::Status;
/// use omcbsa::load::parse_problem;
/// use omcbsa::plan::{plan_file, InputOrPlanError};
/// use omcbsa::planners::PlannerKind;
///
/// // A hand 3 m away from the only arm: a proof that nothing can plan it, before searching.
/// let far = r#"{
///   "format": "omcbsa.problem.v1", "name": "far", "dt": 0.1,
///   "robots": [{"name": "arm", "model": "kinova_gen3",
///               "base": {"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]}}],
///   "trajectories": [{"name": "hand", "poses": [
///     {"position": [3, 0, 0.4], "quat_xyzw": [1, 0, 0, 0]}]}]
/// }"#;
/// let solution = plan_file(&parse_problem(far).unwrap(), PlannerKind::DEFAULT, 5.0).unwrap();
/// assert_eq!(solution.status, Status::NoSolution);
/// assert!(solution.message.contains("out of every robot's reach"), "{}", solution.message);
///
/// // A quaternion that is not a unit one: bad input, at its field.
/// let bad = parse_problem(&far.replace("[1, 0, 0, 0]", "[1, 0, 0, 1]")).unwrap();
/// match plan_file(&bad, PlannerKind::DEFAULT, 5.0) {
///     Err(InputOrPlanError::Input(e)) => {
///         assert!(e.has("trajectories[0].poses[0].quat_xyzw", "norm"), "{e}")
///     }
///     other => panic!("{other:?}"),
/// }
/// ```
pub fn plan_file(
    file: &ProblemFile,
    kind: PlannerKind,
    timeout_s: f64,
) -> Result<SolutionFile, InputOrPlanError> {
    let problem = load_problem(file)?;
    let mut storage = Storage::new(Capacities::default(), problem.horizon());
    let (mut solution, too_fast) = plan_outcome(
        &mut storage,
        file,
        &problem,
        kind,
        timeout_s,
        &AssignmentRule::Free,
    )?;
    if let (FileStatus::NoSolution, Some(f)) = (solution.status, too_fast) {
        offer_scaling(
            &mut storage,
            (file, &mut solution),
            &problem,
            kind,
            &f,
            timeout_s,
        )?;
    }
    Ok(solution)
}

/// Adds to a `no_solution` whose search the joints' limits cut where, and the least time
/// scaling found to plan it ([`least_scale`]): `stats.time_scale` (absent when none of the
/// scalings tried planned it), `stats.time_scale_refused_below`, and a sentence in
/// `message`.
fn offer_scaling(
    storage: &mut Storage,
    (file, solution): (&ProblemFile, &mut SolutionFile),
    problem: &Problem<DOF>,
    kind: PlannerKind,
    f: &TooFast,
    timeout_s: f64,
) -> Result<(), InputOrPlanError> {
    let s = least_scale(storage, kind, problem, f, timeout_s).map_err(InputOrPlanError::Plan)?;
    let index = usize::from(f.robot);
    let robot = file.robots.get(index).map_or("?", |r| r.name.as_str());
    let joint = (problem.robots.get(index))
        .and_then(|r| Fleet::joint_names(r.model).get(usize::from(f.joint)))
        .map_or_else(|| f.joint.to_string(), |n| n.to_string());
    let hand = if f.trajectory == u8::MAX {
        String::new()
    } else {
        format!(" following trajectory {}", f.trajectory)
    };
    let scaled = match s.time_scale {
        Some(k) => {
            solution.stats.insert("time_scale".into(), k.into());
            format!(
                "planned with steps {k:.3} times as long (dt {:.4} s)",
                problem.dt * k
            )
        }
        None => format!(
            "not planned at up to {:.3} times as long steps",
            s.refused_below
        ),
    };
    solution
        .stats
        .insert("time_scale_refused_below".into(), s.refused_below.into());
    solution.message = format!(
        "{}; the hands move too fast for robot {robot}{hand}: joint {joint} at step {}; \
         {scaled} ({} plans)",
        solution.message, f.step, s.attempts
    );
    Ok(())
}

/// The checked core problem of a problem file.
pub fn load_problem(file: &ProblemFile) -> Result<Problem<DOF>, InputOrPlanError> {
    let problem = load::problem::<Fleet, DOF>(file).map_err(InputOrPlanError::Input)?;
    check_initial::<Fleet, DOF>(file, &problem).map_err(InputOrPlanError::Input)?;
    Ok(problem)
}

/// [`plan_file`] on a loaded problem with storage the caller keeps from run to run (made for
/// horizons of at least `problem`'s).
pub fn plan_loaded(
    storage: &mut Storage,
    file: &ProblemFile,
    problem: &Problem<DOF>,
    kind: PlannerKind,
    timeout_s: f64,
) -> Result<SolutionFile, InputOrPlanError> {
    plan_assigned(
        storage,
        file,
        problem,
        kind,
        timeout_s,
        &AssignmentRule::Free,
    )
}

/// [`plan_loaded`] under an assignment rule, checked here (errors at `assignment`).
pub fn plan_assigned(
    storage: &mut Storage,
    file: &ProblemFile,
    problem: &Problem<DOF>,
    kind: PlannerKind,
    timeout_s: f64,
    rule: &AssignmentRule,
) -> Result<SolutionFile, InputOrPlanError> {
    plan_outcome(storage, file, problem, kind, timeout_s, rule).map(|(s, _)| s)
}

/// [`plan_assigned`], with where the joints' limits cut the search when it ended
/// `no_solution` ([`omcbsa_core::planner::Stats::too_fast`]).
fn plan_outcome(
    storage: &mut Storage,
    file: &ProblemFile,
    problem: &Problem<DOF>,
    kind: PlannerKind,
    timeout_s: f64,
    rule: &AssignmentRule,
) -> Result<(SolutionFile, Option<TooFast>), InputOrPlanError> {
    rule.check(
        "assignment",
        problem.robots.len(),
        problem.trajectories.len(),
    )
    .map_err(InputOrPlanError::Input)?;
    let outcome = match rule {
        AssignmentRule::Free => storage.solve(kind, problem, timeout_s),
        _ => crate::assignment::solve(
            storage,
            kind,
            &mut Box::new(problem.clone()),
            rule,
            timeout_s,
        ),
    }
    .map_err(InputOrPlanError::Plan)?;
    let mut solution = outcome.to_solution_file(file, kind.name());
    if solution.status == FileStatus::Solved {
        let report = validate::<Fleet, DOF>(file, problem, &solution);
        if !report.is_valid() {
            solution.status = FileStatus::NoSolution;
            solution.message = format!(
                "planner bug: its plan failed validation: {}",
                report.summary()
            );
            solution.joint_paths = None;
        }
    }
    let too_fast = outcome
        .stats
        .too_fast
        .filter(|_| solution.status == FileStatus::NoSolution);
    Ok((solution, too_fast))
}

/// Why [`plan_file`] gave no solution file.
#[derive(Debug)]
pub enum InputOrPlanError {
    /// The problem file breaks the spec.
    Input(InputError),
    /// The request cannot run (storage too small for the horizon, a workspace that cannot be
    /// made).
    Plan(String),
}
