//! Planning a problem file: load and check it, plan with a planner by name (under an
//! assignment rule if one is given), and validate what the planner calls solved before it is
//! reported. A plan that fails validation is never reported as solved.

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
/// the violation in `message`, never as solved.
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
