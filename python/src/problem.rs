//! `Problem`, `Solution`, `plan` and `validate`: the problem and solution files of
//! docs/FORMATS.md as Python objects, planned and checked by the host library's own code.

use std::path::PathBuf;
use std::sync::Mutex;

use numpy::ndarray::{Array3, ArrayViewD};
use numpy::{AllowTypeChange, IntoPyArray, PyArray3, PyArrayLikeDyn};
use omcbsa::assignment::AssignmentRule;
use omcbsa::error::{FieldError, InputError};
use omcbsa::format::{ProblemFile, SolutionFile, Status, PROBLEM_FORMAT};
use omcbsa::load;
use omcbsa::plan::{load_problem, plan_assigned, InputOrPlanError};
use omcbsa::planners::{self as planners, PlannerKind, Pools};
use omcbsa::validate::validate as check_solution;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use serde_json::{Map, Value};

use crate::convert::{field_error, flat, input_error, number, pose_value, to_json};
use crate::guard;
use crate::options::Options;

/// The keyword options of `Problem.from_arrays`.
const FROM_ARRAYS: &[&str] = &["initial", "tcp", "obstacles", "tolerance", "name", "model"];

pub use omcbsa::models::DOF;
use omcbsa::models::{Fleet, ModelKind};

/// `model=`: one model name for every robot, or a list of one per robot (a mixed fleet);
/// left out, the default model.
#[derive(FromPyObject)]
pub enum ModelArg {
    One(String),
    Each(Vec<String>),
}

impl ModelArg {
    /// The model name of each of `n` robots, or the error naming `model`.
    fn names(py: Python<'_>, arg: Option<&ModelArg>, n: usize) -> PyResult<Vec<String>> {
        match arg {
            None => Ok(vec![ModelKind::default().name().to_string(); n]),
            Some(ModelArg::One(name)) => Ok(vec![name.clone(); n]),
            Some(ModelArg::Each(names)) if names.len() == n => Ok(names.clone()),
            Some(ModelArg::Each(names)) => Err(field_error(
                py,
                "model",
                format!("{} model names, but bases has {n} robots", names.len()),
            )),
        }
    }
}

/// A planning problem (`omcbsa.problem.v1`), checked when made: bad input raises
/// `omcbsa.InputError` (a `ValueError`) naming every bad field as the command line does.
///
/// `Problem(source)` takes a dict in the file's layout, or the path of a problem file.
/// See also `Problem.from_arrays`.
#[pyclass(module = "omcbsa", frozen)]
pub struct Problem {
    pub file: ProblemFile,
}

/// Checks a problem file (every rule a file alone can break, and arms standing clear).
pub fn check(file: ProblemFile) -> Result<ProblemFile, InputError> {
    let problem = load::problem::<Fleet, DOF>(&file)?;
    omcbsa::approach::check_initial::<Fleet, DOF>(&file, &problem)?;
    Ok(file)
}

impl Problem {
    fn from_text(py: Python<'_>, text: &str) -> PyResult<Problem> {
        let file = load::parse_problem(text)
            .and_then(check)
            .map_err(|e| input_error(py, &e))?;
        Ok(Problem { file })
    }
}

/// A JSON document from a dict, or the text of the file at a path.
fn document(source: &Bound<'_, PyAny>) -> PyResult<String> {
    let py = source.py();
    if source.cast::<PyDict>().is_ok() {
        return Ok(to_json(source, "")?.to_string());
    }
    let path: PathBuf = source.extract().map_err(|_| {
        field_error(
            py,
            "",
            format!(
                "expected a dict or the path of a JSON file, got a {}",
                source
                    .get_type()
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_default()
            ),
        )
    })?;
    load::read_text(&path).map_err(|e| input_error(py, &e))
}

/// A JSON value as a Python object (through the json module: dicts, lists, floats, ...).
pub(crate) fn to_python<'py>(
    py: Python<'py>,
    value: &impl serde::Serialize,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

#[pymethods]
impl Problem {
    #[new]
    fn new(source: &Bound<'_, PyAny>) -> PyResult<Problem> {
        Problem::from_text(source.py(), &document(source)?)
    }

    /// A problem from a dict in the file's layout (NumPy arrays are accepted for lists).
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyDict>) -> PyResult<Problem> {
        Problem::from_text(d.py(), &to_json(d, "")?.to_string())
    }

    /// A problem from a JSON file.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Problem> {
        let text = load::read_text(&path).map_err(|e| input_error(py, &e))?;
        Problem::from_text(py, &text)
    }

    /// A problem from JSON text.
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Problem> {
        Problem::from_text(py, text)
    }

    /// A problem from arrays. `bases`: (robots, 7) base poses, position + quaternion xyzw;
    /// `hands`: (hands, H, 7) hand (tool centre point) poses; `dt`: seconds between poses;
    /// `initial`: (robots, 7) joint values; `tcp`: (robots, 7) or (7,) tool centre point in
    /// the tool frame; `obstacles`: dicts in the file's layout; `tolerance`: (metres,
    /// radians); `model`: one model name for all robots or a list of one per robot (robots
    /// of different models mix), the default model (`kinova_gen3`) when left out.
    #[staticmethod]
    #[pyo3(signature = (bases, hands, dt, **options))]
    fn from_arrays(
        py: Python<'_>,
        bases: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        hands: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        dt: f64,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Problem> {
        let o = Options::new("from_arrays", options, FROM_ARRAYS)?;
        let array = "an array of poses";
        let initial = o.get::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>("initial", array)?;
        let tcp = o.get::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>("tcp", array)?;
        let obstacles = o.get::<Bound<'_, PyAny>>("obstacles", "a list of dicts")?;
        let tolerance = o.get::<(f64, f64)>("tolerance", "(metres, radians)")?;
        let name = o.or("name", "a str", "problem".to_string())?;
        let model = o.get::<ModelArg>("model", "a model name or a list of them")?;
        let robots = robots_value(py, &bases, initial.as_ref(), tcp.as_ref(), model.as_ref())?;
        let hands = hands.as_array();
        let h = hands.shape().get(1).copied().unwrap_or(0);
        let hand_rows = pose_rows(py, &hands, 3, "hands", "(hands, H, 7)")?;
        let pose = |row: &[f64], path: String| pose_value(row, &path);
        let mut trajectories = Vec::new();
        for (k, poses) in hand_rows.chunks(h.max(1)).enumerate() {
            let poses = (poses.iter().enumerate())
                .map(|(t, p)| pose(p, format!("hands[{k}][{t}]")))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| fe(py, e))?;
            let mut m = Map::new();
            m.insert("name".into(), Value::from(format!("hand_{k}")));
            m.insert("poses".into(), Value::Array(poses));
            trajectories.push(Value::Object(m));
        }
        let doc = problem_document(
            py,
            &name,
            dt,
            robots,
            trajectories,
            obstacles.as_ref(),
            tolerance,
        )?;
        Problem::from_text(py, &doc.to_string())
    }

    /// The problem in the file's layout.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file)
    }

    /// The problem file's text.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.file).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    #[getter]
    fn name(&self) -> &str {
        &self.file.name
    }

    #[getter]
    fn dt(&self) -> f64 {
        self.file.dt
    }

    /// Number of robots.
    #[getter]
    fn robots(&self) -> usize {
        self.file.robots.len()
    }

    /// Number of hands (trajectories).
    #[getter]
    fn hands(&self) -> usize {
        self.file.trajectories.len()
    }

    /// Poses per trajectory (H).
    #[getter]
    fn horizon(&self) -> usize {
        self.file.trajectories.first().map_or(0, |t| t.poses.len())
    }

    fn __repr__(&self) -> String {
        format!(
            "Problem(name={:?}, robots={}, hands={}, horizon={})",
            self.file.name,
            self.robots(),
            self.hands(),
            self.horizon()
        )
    }
}

/// A problem document of robots and trajectories (`robots_value`, ...), `dt`, `obstacles` (a
/// list of dicts as in the file) and `tolerance` (position m, orientation rad).
pub(crate) fn problem_document(
    py: Python<'_>,
    name: &str,
    dt: f64,
    robots: Vec<Value>,
    trajectories: Vec<Value>,
    obstacles: Option<&Bound<'_, PyAny>>,
    tolerance: Option<(f64, f64)>,
) -> PyResult<Value> {
    let mut doc = Map::new();
    doc.insert("format".into(), Value::from(PROBLEM_FORMAT));
    doc.insert("name".into(), Value::from(name));
    doc.insert("dt".into(), number(dt, "dt").map_err(|e| fe(py, e))?);
    doc.insert("robots".into(), Value::Array(robots));
    doc.insert("trajectories".into(), Value::Array(trajectories));
    if let Some(obstacles) = obstacles {
        doc.insert("obstacles".into(), to_json(obstacles, "obstacles")?);
    }
    if let Some((position_m, orientation_rad)) = tolerance {
        let mut t = Map::new();
        for (key, v, path) in [
            ("position_m", position_m, "tolerance[0]"),
            ("orientation_rad", orientation_rad, "tolerance[1]"),
        ] {
            t.insert(key.into(), number(v, path).map_err(|e| fe(py, e))?);
        }
        doc.insert("tolerance".into(), Value::Object(t));
    }
    Ok(Value::Object(doc))
}

/// The `robots` of a problem document from arrays: `bases` (robots, 7), `initial` (robots, 7),
/// `tcp` (robots, 7) or (7,), of the models `model` names ([`ModelArg`]); robots are named
/// `robot_<i>`.
pub(crate) fn robots_value(
    py: Python<'_>,
    bases: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    initial: Option<&PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    tcp: Option<&PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    model: Option<&ModelArg>,
) -> PyResult<Vec<Value>> {
    let base_rows = pose_rows(py, &bases.as_array(), 2, "bases", "(robots, 7)")?;
    let models = ModelArg::names(py, model, base_rows.len())?;
    let initial_rows = match initial {
        Some(a) => Some(pose_rows(py, &a.as_array(), 2, "initial", "(robots, 7)")?),
        None => None,
    };
    let tcp_rows = match tcp {
        Some(a) if a.as_array().ndim() == 1 => {
            let one = flat(py, &a.as_array(), 7, "tcp", "(7,)")?;
            Some(vec![one; base_rows.len()])
        }
        Some(a) => Some(pose_rows(
            py,
            &a.as_array(),
            2,
            "tcp",
            "(robots, 7) or (7,)",
        )?),
        None => None,
    };
    for (arg, n) in [("initial", &initial_rows), ("tcp", &tcp_rows)] {
        if let Some(r) = n.as_ref().filter(|r| r.len() != base_rows.len()) {
            return Err(field_error(
                py,
                arg,
                format!("{} rows, but bases has {} robots", r.len(), base_rows.len()),
            ));
        }
    }
    let pose = |row: &[f64], path: String| pose_value(row, &path);
    let mut robots = Vec::new();
    for (i, b) in base_rows.iter().enumerate() {
        let mut r = Map::new();
        r.insert("name".into(), Value::from(format!("robot_{i}")));
        r.insert("model".into(), Value::from(models[i].as_str()));
        r.insert(
            "base".into(),
            pose(b, format!("bases[{i}]")).map_err(|e| fe(py, e))?,
        );
        if let Some(q) = &initial_rows {
            let q = (q[i].iter().enumerate())
                .map(|(j, &v)| number(v, &format!("initial[{i}][{j}]")))
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| fe(py, e))?;
            r.insert("initial".into(), Value::Array(q));
        }
        if let Some(t) = &tcp_rows {
            r.insert(
                "tcp".into(),
                pose(&t[i], format!("tcp[{i}]")).map_err(|e| fe(py, e))?,
            );
        }
        robots.push(Value::Object(r));
    }
    Ok(robots)
}

fn fe(py: Python<'_>, e: FieldError) -> PyErr {
    input_error(py, &e.into())
}

/// Rows of 7 of an array that must have `ndim` dimensions.
fn pose_rows(
    py: Python<'_>,
    a: &ArrayViewD<'_, f64>,
    ndim: usize,
    name: &str,
    shape: &str,
) -> PyResult<Vec<Vec<f64>>> {
    if a.ndim() != ndim || a.shape().contains(&0) {
        return Err(field_error(
            py,
            name,
            format!(
                "expected a non-empty array of shape {shape}, got shape {:?}",
                a.shape()
            ),
        ));
    }
    Ok(flat(py, a, 7, name, shape)?
        .chunks_exact(7)
        .map(<[f64]>::to_vec)
        .collect())
}

/// A planner's answer (`omcbsa.solution.v1`): `status`, `assignment`, `joint_paths` (a
/// float64 array of shape (robots, H, 7), or None unless solved), `stats`.
///
/// `Solution(source)` reads a dict in the file's layout or the path of a solution file.
#[pyclass(module = "omcbsa", frozen)]
pub struct Solution {
    pub file: SolutionFile,
}

impl Solution {
    fn from_text(py: Python<'_>, text: &str) -> PyResult<Solution> {
        let file = load::parse_solution(text).map_err(|e| input_error(py, &e))?;
        Ok(Solution { file })
    }
}

#[pymethods]
impl Solution {
    #[new]
    fn new(source: &Bound<'_, PyAny>) -> PyResult<Solution> {
        Solution::from_text(source.py(), &document(source)?)
    }

    /// A solution from a dict in the file's layout.
    #[staticmethod]
    fn from_dict(d: &Bound<'_, PyDict>) -> PyResult<Solution> {
        Solution::from_text(d.py(), &to_json(d, "")?.to_string())
    }

    /// A solution from a JSON file.
    #[staticmethod]
    fn from_file(py: Python<'_>, path: PathBuf) -> PyResult<Solution> {
        let text = load::read_text(&path).map_err(|e| input_error(py, &e))?;
        Solution::from_text(py, &text)
    }

    /// A solution from JSON text.
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Solution> {
        Solution::from_text(py, text)
    }

    /// `solved`, `no_solution`, `timeout`, `out_of_memory` or `invalid_problem`.
    #[getter]
    fn status(&self) -> &'static str {
        self.file.status.as_str()
    }

    /// True when `status` is `solved`.
    #[getter]
    fn solved(&self) -> bool {
        self.file.status == Status::Solved
    }

    /// Why it is not solved (empty when solved).
    #[getter]
    fn message(&self) -> &str {
        &self.file.message
    }

    #[getter]
    fn planner(&self) -> &str {
        &self.file.planner
    }

    /// The name of the problem this solves.
    #[getter]
    fn problem(&self) -> &str {
        &self.file.problem
    }

    /// The planner's own planning time, seconds.
    #[getter]
    fn planning_time_s(&self) -> f64 {
        self.file.planning_time_s
    }

    /// Per robot: the index of the hand it tracks, or None when it holds.
    #[getter]
    fn assignment(&self) -> Vec<Option<usize>> {
        self.file.assignment.clone()
    }

    /// Float64 array of shape (robots, H, 7), or None when not solved.
    #[getter]
    fn joint_paths<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray3<f64>>>> {
        let Some(paths) = &self.file.joint_paths else {
            return Ok(None);
        };
        let (r, h, d) = (
            paths.len(),
            paths.first().map_or(0, Vec::len),
            paths.first().and_then(|p| p.first()).map_or(0, Vec::len),
        );
        let mut flat = Vec::with_capacity(r * h * d);
        for (i, path) in paths.iter().enumerate() {
            if path.len() != h {
                return Err(field_error(
                    py,
                    format!("joint_paths[{i}]"),
                    format!("{} configurations, but joint_paths[0] has {h}", path.len()),
                ));
            }
            for (t, q) in path.iter().enumerate() {
                if q.len() != d {
                    return Err(field_error(
                        py,
                        format!("joint_paths[{i}][{t}]"),
                        format!("{} joint values, but joint_paths[0][0] has {d}", q.len()),
                    ));
                }
                flat.extend_from_slice(q);
            }
        }
        let a = Array3::from_shape_vec((r, h, d), flat)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(Some(a.into_pyarray(py)))
    }

    /// Free-form counters (nodes expanded, conflicts resolved, ...).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file.stats)
    }

    /// The solution in the file's layout.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.file)
    }

    /// The solution file's text (as `omcbsa plan` writes it).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.file).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        format!(
            "Solution(status={:?}, planner={:?}, assignment={:?}, planning_time_s={})",
            self.status(),
            self.file.planner,
            self.file.assignment,
            self.file.planning_time_s
        )
    }
}

/// Plans `problem` with `planner` (omcbsa, pp, pp-single, ik-tracking, descartes,
/// composite-astar, omega-astar) within `timeout` seconds. The GIL is released while
/// planning. A plan the planner calls solved is validated before it is returned; one that
/// fails validation is never returned as solved.
///
/// `assignment` (one entry per robot: the hand it takes, or None to hold still) fixes which
/// arm takes which hand; with `preferred=True` it is only tried first, and the planner
/// chooses freely in the time left when it has no plan.
#[pyfunction]
#[pyo3(signature = (problem, planner=None, timeout=5.0, assignment=None, preferred=false))]
pub fn plan(
    py: Python<'_>,
    problem: &Problem,
    planner: Option<&str>,
    timeout: f64,
    assignment: Option<Vec<Option<usize>>>,
    preferred: bool,
) -> PyResult<Solution> {
    if !(timeout > 0.0 && timeout.is_finite()) {
        return Err(field_error(
            py,
            "timeout",
            format!("must be a positive number of seconds, got {timeout}"),
        ));
    }
    let kind = planner_kind(py, planner)?;
    let file = &problem.file;
    let rule = rule(assignment, preferred);
    match py.detach(|| guard("plan", || plan_with_pools(file, kind, timeout, &rule)))? {
        Ok(file) => Ok(Solution { file }),
        Err(InputOrPlanError::Input(e)) => Err(input_error(py, &e)),
        Err(InputOrPlanError::Plan(e)) => Err(field_error(py, "planner", e)),
    }
}

/// The planner named `name` (the default planner when `None`), or an error at `planner`.
pub fn planner_kind(py: Python<'_>, name: Option<&str>) -> PyResult<PlannerKind> {
    name.map_or(Ok(PlannerKind::DEFAULT), planners::parse)
        .map_err(|e| field_error(py, "planner", e))
}

/// The planner's pools, kept from call to call (see [`Pools`]).
static POOLS: Mutex<Option<Pools>> = Mutex::new(None);

/// Plans in the kept pools; a call made while another thread plans gets pools of its
/// own.
fn plan_with_pools(
    file: &ProblemFile,
    planner: PlannerKind,
    timeout: f64,
    rule: &AssignmentRule,
) -> Result<SolutionFile, InputOrPlanError> {
    let problem = load_problem(file)?;
    let h = problem.horizon();
    let Ok(mut slot) = POOLS.try_lock() else {
        let mut own = Pools::default();
        return plan_assigned(own.for_horizon(h), file, &problem, planner, timeout, rule);
    };
    let storage = slot.get_or_insert_with(Pools::default).for_horizon(h);
    plan_assigned(storage, file, &problem, planner, timeout, rule)
}

/// The assignment rule of `plan`'s and `Embodier`'s arguments.
pub(crate) fn rule(assignment: Option<Vec<Option<usize>>>, preferred: bool) -> AssignmentRule {
    match assignment {
        None => AssignmentRule::Free,
        Some(list) if preferred => AssignmentRule::Preferred(list),
        Some(list) => AssignmentRule::Fixed(list),
    }
}

/// One broken rule of a validation, as `omcbsa validate` reports it: `str(v)` is the
/// command line's line (`rule 4 (collision), robot 0, step 3: ...`).
#[pyclass(module = "omcbsa", frozen, get_all)]
pub struct Violation {
    /// `solution`, `joint_limits`, `tracking`, `velocity`, `collision` or `assignment`.
    pub rule: String,
    pub robot: Option<usize>,
    pub step: Option<usize>,
    /// What `step` counts: `path` (joint_paths) or `approach` (0 = initial).
    pub phase: String,
    pub detail: String,
    text: String,
}

#[pymethods]
impl Violation {
    fn __str__(&self) -> &str {
        &self.text
    }

    fn __repr__(&self) -> String {
        format!("Violation({:?})", self.text)
    }
}

/// The outcome of `validate`: `valid`, `summary` (the command line's first line) and
/// `violations`.
#[pyclass(module = "omcbsa", frozen, get_all)]
pub struct Report {
    pub valid: bool,
    pub summary: String,
    pub violations: Vec<Py<Violation>>,
}

#[pymethods]
impl Report {
    fn __str__(&self) -> &str {
        &self.summary
    }

    fn __repr__(&self) -> String {
        format!("Report({:?})", self.summary)
    }
}

/// Checks `solution` against `problem` (the five rules of docs/FORMATS.md), as
/// `omcbsa validate` does, with the GIL released.
#[pyfunction]
pub fn validate(py: Python<'_>, problem: &Problem, solution: &Solution) -> PyResult<Report> {
    let (file, sol) = (&problem.file, &solution.file);
    let report = py
        .detach(|| {
            guard("validate", || {
                let p = load::problem::<Fleet, DOF>(file)?;
                Ok::<_, InputError>(check_solution::<Fleet, DOF>(file, &p, sol))
            })
        })?
        .map_err(|e| input_error(py, &e))?;
    let violations = (report.violations.iter())
        .map(|v| {
            let rule = serde_json::to_value(v.rule)
                .ok()
                .and_then(|r| r.as_str().map(str::to_string))
                .unwrap_or_default();
            Py::new(
                py,
                Violation {
                    rule,
                    robot: v.robot,
                    step: v.step,
                    phase: serde_json::to_value(v.phase)
                        .ok()
                        .and_then(|p| p.as_str().map(str::to_string))
                        .unwrap_or_default(),
                    detail: v.detail.clone(),
                    text: v.to_string(),
                },
            )
        })
        .collect::<PyResult<_>>()?;
    Ok(Report {
        valid: report.is_valid(),
        summary: report.summary(),
        violations,
    })
}
