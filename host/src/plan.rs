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

use omcbsa_core::problem::Problem;

use crate::approach::check_initial;
use crate::assignment::AssignmentRule;
use crate::error::InputError;
use crate::format::{ProblemFile, SolutionFile, Status as FileStatus};
use crate::load;
use crate::models::{Fleet, DOF};
use crate::planners::{Capacities, PlannerKind, Storage};
use crate::validate::validate;

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
    plan_loaded(&mut storage, file, &problem, kind, timeout_s)
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
    Ok(solution)
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
