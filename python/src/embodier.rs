//! `omcbsa.Embodier`: the host library's online API (plan policy chunks as they arrive).

use numpy::ndarray::Array3;
use numpy::{AllowTypeChange, IntoPyArray, PyArray3, PyArrayLikeDyn};
use omcbsa::format::Pose;
use omcbsa::online::{ChunkReport, Embodier as HostEmbodier, OnlineError, OnlineOptions, Setup};
use omcbsa::planners::stats_map;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::cell_state::{running, CellRef};
use crate::convert::{field_error, flat, input_error};
use crate::guard;
use crate::options::Options;
use crate::problem::{
    check, planner_kind, problem_document, robots_value, rule, to_python, ModelArg, Problem, DOF,
};
use omcbsa::load;

pyo3::create_exception!(
    omcbsa,
    ChunkError,
    PyRuntimeError,
    "A chunk was not planned (a pose no arm can reach, a missed deadline, no plan within the \
     time, no approach); the plan made before is kept. `kind` says which: `unreachable`, \
     `blocked` (`robot`, `hand` and `step` say where; the message says by what), \
     `deadline_missed`, `not_planned` or `approach`."
);

/// Plans policy chunks as they arrive, from where the arms will be, keeping one plan the arms
/// can be streamed without stopping (the `omcbsa` library's `Embodier`).
///
/// `Embodier(setup, **options)`: `setup` is a `Problem` whose robots all give `initial` (its
/// trajectories are not used), or the keywords `bases`, `initial`, `dt` (`tcp`, `obstacles`,
/// `tolerance`, `model`) give it; the other keywords say how chunks are planned (see the stub,
/// `_omcbsa.pyi`). Timeline index 0 is `initial`; then the approach to the first chunk; then
/// the chunks, one configuration per `dt`.
#[pyclass(module = "omcbsa")]
pub struct Embodier {
    pub(crate) inner: HostEmbodier,
    pub(crate) last: Option<ChunkReport>,
    max_chunk_len: usize,
    /// The cell it plans for, while that runs: the cell pushes its chunks.
    pub(crate) cell: Option<CellRef>,
}

/// The Embodier's keyword options: its setup as arrays, and how chunks are planned.
const OPTIONS: &[&str] = &[
    "bases",
    "initial",
    "dt",
    "tcp",
    "obstacles",
    "tolerance",
    "model",
    "planner",
    "chunk_timeout",
    "max_chunk_len",
    "assignment",
    "preferred",
    "reassign",
    "axis_weight",
    "headroom_weight",
    "reserve_weight",
    "rank_starts",
    "time_scaling",
    "catch_up",
];

pub(crate) fn online_error(py: Python<'_>, e: OnlineError) -> PyErr {
    let (kind, hand, step, robot) = match &e {
        OnlineError::Input(e) => return input_error(py, e),
        OnlineError::Unreachable { hand, step, robot } => {
            ("unreachable", Some(*hand), Some(*step), *robot)
        }
        OnlineError::DeadlineMissed { start_step, .. } => {
            ("deadline_missed", None, Some(*start_step), None)
        }
        OnlineError::Blocked {
            robot_index,
            hand,
            step,
            ..
        } => ("blocked", *hand, Some(*step), Some(*robot_index)),
        OnlineError::NotPlanned { start_step, .. } => {
            ("not_planned", None, Some(*start_step), None)
        }
        OnlineError::Approach(_) => ("approach", None, None, None),
    };
    let err = ChunkError::new_err(e.to_string());
    let value = err.value(py);
    let set = || -> PyResult<()> {
        value.setattr("kind", kind)?;
        value.setattr("hand", hand)?;
        value.setattr("step", step)?;
        value.setattr("robot", robot)
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// `hands` of shape (hands, H, 7), position + quaternion xyzw, as poses per hand.
pub(crate) fn poses_of(
    py: Python<'_>,
    hands: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
) -> PyResult<Vec<Vec<Pose>>> {
    let hands = hands.as_array();
    let shape = hands.shape().to_vec();
    if shape.len() != 3 {
        return Err(field_error(
            py,
            "hands",
            format!("expected an array of shape (hands, H, 7), got shape {shape:?}"),
        ));
    }
    let values = flat(py, &hands, 7, "hands", "(hands, H, 7)")?;
    let h = shape[1].max(1);
    let poses: Vec<Vec<Pose>> = (values.chunks(h * 7))
        .map(|hand| {
            (hand.chunks_exact(7))
                .map(|p| Pose {
                    position: [p[0], p[1], p[2]],
                    quat_xyzw: [p[3], p[4], p[5], p[6]],
                })
                .collect()
        })
        .collect();
    Ok(poses)
}

/// A chunk's report as a dict (`Embodier.last_report`, `Cell.push`).
pub(crate) fn report_dict<'py>(py: Python<'py>, r: &ChunkReport) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("start_step", r.start_step)?;
    d.set_item("index", r.index)?;
    d.set_item("dropped", r.dropped)?;
    d.set_item("recovery", r.recovery.map(|r| r.name()))?;
    d.set_item("blocked", r.blocked.as_deref())?;
    d.set_item("end", r.end)?;
    d.set_item("planning_time_s", r.planning_time_s)?;
    d.set_item("stats", to_python(py, &stats_map(&r.stats))?)?;
    d.set_item("time_factor", r.time_factor)?;
    d.set_item("lag_s", r.lag_s)?;
    d.set_item("total_lag_s", r.total_lag_s)?;
    Ok(d)
}

impl Embodier {
    /// Chunks go through the cell while one runs on this Embodier.
    pub(crate) fn check_free(&self) -> PyResult<()> {
        match &self.cell {
            Some(cell) if running(cell) => Err(PyRuntimeError::new_err(
                "this Embodier plans for a running Cell: push chunks with cell.push (the \
                 cell commits what the arms execute)",
            )),
            _ => Ok(()),
        }
    }

    /// Robots' configurations from timeline index `from` to the plan's end, (robots, n, 7).
    fn segment<'py>(&self, py: Python<'py>, from: usize) -> PyResult<Bound<'py, PyArray3<f64>>> {
        self.range(py, from, self.inner.end().saturating_sub(from))
    }

    /// Robots' configurations at timeline indices `from..from + len`, (robots, len, 7).
    fn range<'py>(
        &self,
        py: Python<'py>,
        from: usize,
        len: usize,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = self.inner.robot_names().len();
        let mut values = Vec::with_capacity(n * len * DOF);
        for i in 0..n {
            let path = self.inner.planned(i, from);
            let Some(path) = path.get(..len) else {
                return Err(PyRuntimeError::new_err(format!(
                    "timeline index {from} of robot {i} is no longer kept (committed)"
                )));
            };
            path.iter().for_each(|q| values.extend_from_slice(q));
        }
        Array3::from_shape_vec((n, len, DOF), values)
            .map(|a| a.into_pyarray(py))
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }
}

#[pymethods]
impl Embodier {
    #[new]
    #[pyo3(signature = (setup=None, **options))]
    fn new(
        py: Python<'_>,
        setup: Option<&Problem>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Embodier> {
        let o = Options::new("Embodier", options, OPTIONS)?;
        let d = OnlineOptions::default();
        let planner = o.get::<Option<String>>("planner", "a planner name, or None")?;
        let assignment =
            o.get::<Option<Vec<Option<usize>>>>("assignment", "a list of hand indices or None")?;
        let options = OnlineOptions {
            planner: planner_kind(py, planner.flatten().as_deref())?,
            chunk_timeout_s: o.or("chunk_timeout", "a number of seconds", d.chunk_timeout_s)?,
            max_chunk_len: o.or("max_chunk_len", "an int", d.max_chunk_len)?,
            assignment: rule(assignment.flatten(), o.or("preferred", "a bool", false)?),
            reassign: o.or("reassign", "a bool", d.reassign)?,
            axis_weight: o.or("axis_weight", "a number", d.axis_weight)?,
            headroom_weight: o.or("headroom_weight", "a number", d.headroom_weight)?,
            reserve_weight: o.or("reserve_weight", "a number", d.reserve_weight)?,
            rank_starts: o.or("rank_starts", "a bool", d.rank_starts)?,
            time_scaling: o.or("time_scaling", "a bool", d.time_scaling)?,
            catch_up: o.or("catch_up", "a bool", d.catch_up)?,
            ..d
        };
        let max_chunk_len = options.max_chunk_len;
        let array = "an array of poses";
        let bases = o.get::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>("bases", array)?;
        let initial = o.get::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>("initial", array)?;
        let dt = o.get::<f64>("dt", "a number of seconds")?;
        let tcp = o.get::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>("tcp", array)?;
        let obstacles = o.get::<Bound<'_, PyAny>>("obstacles", "a list of dicts")?;
        let tolerance = o.get::<(f64, f64)>("tolerance", "(metres, radians)")?;
        let model = o.get::<ModelArg>("model", "a model name or a list of them")?;
        let setup = match (setup, bases, initial, dt) {
            (Some(problem), None, None, None) => Setup::of_problem(&problem.file),
            (None, Some(bases), Some(initial), Some(dt)) => {
                let robots =
                    robots_value(py, &bases, Some(&initial), tcp.as_ref(), model.as_ref())?;
                // The loader checks the setup as a problem's; one hand stands in for the
                // chunks to come.
                let hand = serde_json::json!({"name": "hand", "poses": [{
                    "position": [0.0, 0.0, 0.0], "quat_xyzw": [0.0, 0.0, 0.0, 1.0]}]});
                let doc = problem_document(
                    py,
                    "online",
                    dt,
                    robots,
                    vec![hand],
                    obstacles.as_ref(),
                    tolerance,
                )?;
                let file = load::parse_problem(&doc.to_string())
                    .and_then(check)
                    .map_err(|e| input_error(py, &e))?;
                Setup::of_problem(&file)
            }
            _ => {
                return Err(field_error(
                    py,
                    "setup",
                    "give a Problem (its trajectories are not used), or bases, initial and dt \
                     (with tcp, obstacles and tolerance if needed), not both",
                ))
            }
        };
        let inner = py
            .detach(|| guard("Embodier", || HostEmbodier::new(&setup, options)))?
            .map_err(|e| online_error(py, e))?;
        Ok(Embodier {
            inner,
            last: None,
            max_chunk_len,
            cell: None,
        })
    }

    /// Plans a chunk: `hands[j][k]` (shape (hands, H, 7), position + quaternion xyzw) is hand
    /// j's pose at policy step `start_step + k`. Returns the new joint segment, shape
    /// (robots, n, 7): every robot's configurations from the chunk's first pose (timeline
    /// index `last_index`) to the plan's end. The first chunk chooses the assignment and the
    /// approach from `initial` (`approach`); later chunks keep the assignment and replace the
    /// plan from `start_step` on. The GIL is released while planning. Bad input raises
    /// `InputError` (`hands[1][4].quat_xyzw: ...`); a chunk that cannot be planned raises
    /// `ChunkError` and leaves the plan as it was.
    fn push_chunk<'py>(
        &mut self,
        py: Python<'py>,
        start_step: u64,
        hands: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        self.check_free()?;
        let poses = poses_of(py, &hands)?;
        let inner = &mut self.inner;
        let report = py
            .detach(|| guard("push_chunk", || inner.push_chunk(start_step, &poses)))?
            .map_err(|e| online_error(py, e))?;
        let index = report.index;
        self.last = Some(report);
        self.segment(py, index)
    }

    /// Embodies a whole episode on a fresh Embodier, however long (no splitting by hand):
    /// `hands` (hands, T, 7) is every hand's pose at policy steps 0..T. It is planned in chunks
    /// of `chunk_len` poses (default `max_chunk_len`), each from where the one before left
    /// the arms, as a policy would send them. Returns every robot's timeline, shape
    /// (robots, 1 + approach_len + T, 7): `initial`, the approach, then one configuration
    /// per step. A chunk that cannot be planned raises `ChunkError` naming where.
    #[pyo3(signature = (hands, chunk_len=None))]
    fn embody<'py>(
        &mut self,
        py: Python<'py>,
        hands: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        chunk_len: Option<usize>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        self.check_free()?;
        let poses = poses_of(py, &hands)?;
        let chunk_len = chunk_len.unwrap_or(self.max_chunk_len);
        let inner = &mut self.inner;
        let embodied = py
            .detach(|| guard("embody", || inner.embody(&poses, chunk_len)))?
            .map_err(|e| online_error(py, e))?;
        let timeline = embodied.timeline;
        self.last = Some(embodied.last);
        let (n, len) = (timeline.len(), timeline.first().map_or(0, Vec::len));
        let values: Vec<f64> = timeline.iter().flatten().flatten().copied().collect();
        Array3::from_shape_vec((n, len, DOF), values)
            .map(|a| a.into_pyarray(py))
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    /// Robots' planned configurations from timeline index `start` to the plan's end, shape
    /// (robots, n, 7).
    fn planned<'py>(&self, py: Python<'py>, start: usize) -> PyResult<Bound<'py, PyArray3<f64>>> {
        self.segment(py, start)
    }

    /// The approach from `initial` to the first chunk, shape (robots, approach_len, 7)
    /// (timeline indices 1 to approach_len).
    #[getter]
    fn approach<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        self.range(py, 1, self.inner.approach_len())
    }

    /// The arms were sent the plan up to (not including) timeline index `index`: later chunks
    /// may no longer replace it, and it is forgotten (memory stays bounded).
    fn commit_until(&mut self, index: usize) -> PyResult<()> {
        self.check_free()?;
        self.inner.commit_until(index);
        Ok(())
    }

    /// The timeline index of policy step `step` (None before the first chunk).
    fn timeline_index(&self, step: u64) -> Option<usize> {
        self.inner.timeline_index(step)
    }

    /// Per robot, the hand it holds (None: it holds still); None before the first chunk.
    #[getter]
    fn assignment(&self) -> Option<Vec<Option<usize>>> {
        self.inner.assignment().map(<[_]>::to_vec)
    }

    #[getter]
    fn approach_len(&self) -> usize {
        self.inner.approach_len()
    }

    /// Timeline index one past the plan's last configuration.
    #[getter]
    fn end(&self) -> usize {
        self.inner.end()
    }

    /// Timeline index of the last chunk's first pose (None before the first chunk).
    #[getter]
    fn last_index(&self) -> Option<usize> {
        self.last.as_ref().map(|r| r.index)
    }

    /// The last chunk's planning report: start_step, index, dropped, recovery (None, or how a
    /// dead end was recovered), blocked (why it needed one), end, planning_time_s,
    /// time_factor (timeline steps per policy step: above 1 when time-scaled), lag_s (how far
    /// the arms fell behind the policy with this chunk), total_lag_s (how far behind they
    /// are at its last pose), stats.
    #[getter]
    fn last_report<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.last.as_ref().map(|r| report_dict(py, r)).transpose()
    }

    /// Robot names, in the setup's order.
    #[getter]
    fn robot_names(&self) -> Vec<String> {
        self.inner.robot_names().to_vec()
    }
}
