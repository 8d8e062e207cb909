//! `omcbsa.Cell`: an Embodier's arms, streamed while a policy runs (the host library's
//! `LiveCell`): `push` plans a chunk with the GIL released and hands it to the executor,
//! whose threads stream it; `status` says where every arm is; a fault stops every arm and the
//! next call raises `ArmFault`. Leaving the cell stops every arm: the `with` block's end, an
//! exception, Ctrl-C (a `KeyboardInterrupt` that leaves the block or the program), SIGTERM
//! (a `SystemExit`, when the program has no handler of its own), the interpreter's exit
//! (atexit), the object's collection.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use numpy::{AllowTypeChange, PyArray1, PyArrayLikeDyn};
use omcbsa::live::{LiveCell, LiveError, LiveOptions, LivePush, LiveStatus};
use omcbsa::online::OnlineError;
use omcbsa_hw::cell::CellEnd;
use omcbsa_hw::kortex::Credentials;
use omcbsa_hw::port::ArmUrl;
use omcbsa_hw::{ArmState, Event, ExecConfig, FaultReport, WatchSettings};
use omcbsa_mock::connect::ArmOrMockUrl;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::cell_state::{lock, CellRef, State};
use crate::convert::{field_error, input_error};
use crate::embodier::{online_error, poses_of, report_dict, Embodier};
use crate::guard;
use crate::options::Options;

pyo3::create_exception!(
    omcbsa,
    CellError,
    PyRuntimeError,
    "The cell did not do what it was asked: `kind` says why: `start` (an arm did not start; \
     none moved), `invalid` (the chunk's plan failed its check), `refused` (the executor \
     refused the chunk's plan), `ended` (the cell has ended). A refused chunk is not sent: \
     the arms go on with the plan they have."
);

pyo3::create_exception!(
    omcbsa,
    ArmFault,
    CellError,
    "A fault stopped every arm (the watchdog's quick stop). `arm` is where it was seen, `fault` \
     what it was, `cycle` when, `bound_s` the bound on every arm's stop, `stops` how and when \
     each arm was stopped (dicts: arm, cycles_sent, latency_s, error, unanswered); str(e) is \
     the whole report. The cell has ended."
);

type Slot = Arc<Mutex<State>>;

/// Every cell of the process, stopped when the interpreter exits.
static CELLS: Mutex<Vec<CellRef>> = Mutex::new(Vec::new());

/// Ends the cell in `slot` if it runs: every arm stopped (`stop`) or finished; its end.
fn end(slot: &Mutex<State>, why: &str, finish: bool) -> Option<Result<CellEnd, LiveError>> {
    let mut state = lock(slot);
    match std::mem::replace(&mut *state, State::Ended(why.to_string())) {
        State::Running(cell) => Some(if finish { cell.finish() } else { cell.stop() }),
        ended => {
            *state = ended;
            None
        }
    }
}

/// Stops every cell that still runs: registered with atexit.
#[pyfunction]
pub fn stop_all_cells(py: Python<'_>) {
    let cells: Vec<Slot> = (CELLS.lock().unwrap_or_else(|p| p.into_inner()).drain(..))
        .filter_map(|w| w.upgrade())
        .collect();
    py.detach(|| {
        for slot in cells {
            let _ = end(&slot, "the interpreter exited", false);
        }
    });
}

/// Makes SIGTERM leave the program as an exception does (`SystemExit(143)`: the `with` block's
/// end and atexit stop the arms) when the program has left it at its default, which ends the
/// process at once with the arms still commanded. A handler of the program's own is kept.
/// Python runs signal handlers on the main thread only, so a cell started elsewhere leaves it.
fn exit_on_sigterm(py: Python<'_>) -> PyResult<()> {
    let threading = py.import("threading")?;
    let main = threading.call_method0("main_thread")?;
    if !threading.call_method0("current_thread")?.is(&main) {
        return Ok(());
    }
    let signal = py.import("signal")?;
    let term = signal.getattr("SIGTERM")?;
    if signal
        .call_method1("getsignal", (&term,))?
        .is(&signal.getattr("SIG_DFL")?)
    {
        let handler = wrap_pyfunction!(sigterm_exit, py)?;
        signal.call_method1("signal", (term, handler))?;
    }
    Ok(())
}

/// The SIGTERM handler of [`exit_on_sigterm`]: exit status 128 + the signal's number, as the
/// default's.
#[pyfunction]
fn sigterm_exit(signum: i32, _frame: Bound<'_, PyAny>) -> PyResult<()> {
    Err(pyo3::exceptions::PySystemExit::new_err(128 + signum))
}

/// The arms an Embodier plans for, streamed while a policy runs.
///
/// `Cell(embodier, arms, **options)`: `arms` maps every robot name of the Embodier (which has
/// planned no chunk yet) to its arm's URL: `kortex://HOST`, `socketcan://IFACE`,
/// `slcan:///dev/ttyX`, or `mock-kortex` / `mock-can` (the project's mock arms, started for
/// the cell). Returns once every arm holds where its robot's `initial` says. See the stub
/// (`_omcbsa.pyi`) for the options and docs/HARDWARE.md ("Running a policy on arms") for a
/// policy loop.
#[pyclass(module = "omcbsa")]
pub struct Cell {
    slot: Slot,
    embodier: Py<Embodier>,
    names: Vec<String>,
    time_scale: f64,
    period: Duration,
    step_time: f64,
    records: PathBuf,
}

/// The cell's keyword options.
const OPTIONS: &[&str] = &[
    "time_scale",
    "rate",
    "records",
    "kortex_user",
    "kortex_password",
    "rt_priority",
    "missed_cycles",
    "heartbeat_ms",
    "heartbeat_factor",
    "following_error_timeout_ms",
    "drive_lag_ms",
    "following_error_bound",
    "feedback_timeout_ms",
    "sdo_timeout_ms",
];

/// The host library's options from the keywords; `kortex`: some arm is a real Gen3.
fn live_options(py: Python<'_>, o: &Options<'_>, kortex: bool) -> PyResult<LiveOptions> {
    let d = ExecConfig::default();
    let w = WatchSettings::default();
    let ms = |key: &str, default: Duration| -> PyResult<Duration> {
        Ok(o.get::<u64>(key, "a whole number of milliseconds")?
            .map_or(default, Duration::from_millis))
    };
    let watch = WatchSettings {
        missed_cycles: o.or("missed_cycles", "an int", w.missed_cycles)?,
        heartbeat_ms: o.or("heartbeat_ms", "an int", w.heartbeat_ms)?,
        heartbeat_factor: o.or("heartbeat_factor", "a number", w.heartbeat_factor)?,
        following_error_timeout_ms: o.or(
            "following_error_timeout_ms",
            "an int",
            w.following_error_timeout_ms,
        )?,
        drive_lag: ms("drive_lag_ms", w.drive_lag)?,
        following_error_bound: o.or(
            "following_error_bound",
            "a number",
            w.following_error_bound,
        )?,
        feedback_timeout: ms("feedback_timeout_ms", w.feedback_timeout)?,
    };
    watch
        .check()
        .map_err(|e| field_error(py, "watchdog", e.to_string()))?;
    let rate = o.get::<f64>("rate", "a number of Hz")?;
    if let Some(r) = rate.filter(|r| !(100.0..=1000.0).contains(r)) {
        return Err(field_error(
            py,
            "rate",
            format!("{r} Hz: must be 100 to 1000"),
        ));
    }
    let priority = o.get::<Option<u8>>("rt_priority", "an int from 1 to 99, or None")?;
    if let Some(p) = priority.flatten().filter(|p| !(1..=99).contains(p)) {
        return Err(field_error(
            py,
            "rt_priority",
            format!("{p}: must be 1 to 99, or None"),
        ));
    }
    let credentials = match kortex {
        false => None,
        true => Some(
            Credentials::resolve(
                o.get("kortex_user", "a str")?,
                o.get("kortex_password", "a str")?,
                |k| std::env::var(k).ok(),
            )
            .map_err(|e| field_error(py, "kortex_user", e.to_string()))?,
        ),
    };
    Ok(LiveOptions {
        time_scale: o
            .get::<Option<f64>>("time_scale", "a number, or None")?
            .flatten(),
        period: rate.map(|r| Duration::from_secs_f64(1.0 / r)),
        config: ExecConfig {
            watch,
            sdo_timeout: ms("sdo_timeout_ms", d.sdo_timeout)?,
            realtime_priority: priority.unwrap_or(d.realtime_priority),
            ..d
        },
        credentials,
        records: o
            .get::<Option<PathBuf>>("records", "a path, or None")?
            .flatten(),
    })
}

/// A Python error for a cell's error. A fault or the cell's end has also ended `slot`.
fn cell_error(py: Python<'_>, e: LiveError) -> PyErr {
    let (kind, message) = match e {
        LiveError::Setup(s) => return field_error(py, "arms", s),
        LiveError::Chunk(OnlineError::Input(e)) => return input_error(py, &e),
        LiveError::Chunk(e) => return online_error(py, e),
        LiveError::Fault(report) => return arm_fault(py, &report),
        e @ LiveError::Start(_) => ("start", e.to_string()),
        e @ LiveError::Invalid(_) => ("invalid", e.to_string()),
        e @ LiveError::Refused(_) => ("refused", e.to_string()),
        e @ LiveError::Ended(_) => ("ended", e.to_string()),
    };
    let err = CellError::new_err(message);
    match err.value(py).setattr("kind", kind) {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// `ArmFault` carrying the report.
fn arm_fault(py: Python<'_>, report: &FaultReport) -> PyErr {
    let err = ArmFault::new_err(report.to_string());
    let set = || -> PyResult<()> {
        let value = err.value(py);
        let stops = PyList::empty(py);
        for s in &report.stops {
            let d = PyDict::new(py);
            d.set_item("arm", &s.arm)?;
            d.set_item("cycles_sent", s.cycles_sent)?;
            d.set_item("latency_s", s.latency.as_secs_f64())?;
            d.set_item("error", s.error.as_ref().map(ToString::to_string))?;
            d.set_item("unanswered", &s.unanswered)?;
            stops.append(d)?;
        }
        value.setattr("kind", "fault")?;
        value.setattr("arm", &report.arm)?;
        value.setattr("fault", report.fault.to_string())?;
        value.setattr("cycle", report.cycle)?;
        value.setattr("bound_s", report.bound.as_secs_f64())?;
        value.setattr("stops", stops)
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

fn state_name(s: ArmState) -> &'static str {
    match s {
        ArmState::Starting => "starting",
        ArmState::Moving => "moving",
        ArmState::Holding => "holding",
        ArmState::Stopped => "stopped",
        ArmState::Finished => "finished",
    }
}

fn status_dict<'py>(py: Python<'py>, s: &LiveStatus) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let p = &s.cell.progress;
    d.set_item("cycle", p.cycle)?;
    d.set_item("step", p.step)?;
    d.set_item("fixed", p.fixed)?;
    d.set_item("holding", p.holding)?;
    d.set_item("policy_step", s.policy_step)?;
    d.set_item("lag_s", s.lag_s)?;
    let events = PyList::empty(py);
    for e in &s.cell.events {
        let (kind, cycle, step) = match *e {
            Event::QueueDry { cycle, step } => ("queue_dry", cycle, step),
            Event::Resumed { cycle, step } => ("resumed", cycle, step),
        };
        let ev = PyDict::new(py);
        ev.set_item("kind", kind)?;
        ev.set_item("cycle", cycle)?;
        ev.set_item("step", step)?;
        events.append(ev)?;
    }
    d.set_item("events", events)?;
    let arms = PyDict::new(py);
    for a in &s.cell.arms {
        let arm = PyDict::new(py);
        arm.set_item("state", state_name(a.state))?;
        arm.set_item("commanded", PyArray1::from_slice(py, &a.commanded))?;
        let measured = a.measured.map(|m| PyArray1::from_slice(py, &m.positions));
        arm.set_item("measured", measured)?;
        arm.set_item("measured_cycle", a.measured.and_then(|m| m.cycle))?;
        arm.set_item("following_error", a.following_error)?;
        arm.set_item("queue_depth", a.queue_depth)?;
        arm.set_item("lag_s", a.lag.map(|l| l.as_secs_f64()))?;
        arms.set_item(&a.name, arm)?;
    }
    d.set_item("arms", arms)?;
    Ok(d)
}

fn push_dict<'py>(py: Python<'py>, p: &LivePush) -> PyResult<Bound<'py, PyDict>> {
    let d = report_dict(py, &p.report)?;
    d.set_item("late", p.late)?;
    d.set_item("from", p.from)?;
    d.set_item("cycle", p.cycle)?;
    d.set_item("attempts", p.attempts)?;
    Ok(d)
}

fn end_dict<'py>(
    py: Python<'py>,
    end: &CellEnd,
    records: &PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let r = &end.report;
    d.set_item("cycles", r.cycles)?;
    d.set_item("holds", r.holds)?;
    d.set_item("halted", r.halted)?;
    d.set_item("report", r.to_string())?;
    d.set_item("records", records)?;
    Ok(d)
}

impl Cell {
    /// Runs `f` on the running cell with the GIL released. A fault (or the run's end) ends
    /// the cell: its mocks exit and write their records before the error is raised.
    fn with_cell<T: Send>(
        &self,
        py: Python<'_>,
        f: impl FnOnce(&mut LiveCell) -> Result<T, LiveError> + Send,
    ) -> PyResult<T> {
        let slot = &self.slot;
        let result = py.detach(|| {
            guard("Cell", || {
                let mut state = lock(slot);
                let result = match &mut *state {
                    State::Running(cell) => f(cell),
                    State::Ended(why) => {
                        return Err(LiveError::Ended(format!("the cell has ended: {why}")))
                    }
                };
                if let Err(e @ (LiveError::Fault(_) | LiveError::Ended(_))) = &result {
                    let why = match e {
                        LiveError::Fault(r) => format!("stopped by a fault on arm {:?}", r.arm),
                        e => e.to_string(),
                    };
                    // Dropping the cell waits for its threads and mocks (their records).
                    drop(std::mem::replace(&mut *state, State::Ended(why)));
                }
                result
            })
        })?;
        result.map_err(|e| cell_error(py, e))
    }

    /// Ends the cell: finished (the queue run out) or stopped.
    fn end<'py>(&self, py: Python<'py>, finish: bool) -> PyResult<Option<Bound<'py, PyDict>>> {
        let slot = &self.slot;
        let why = if finish { "finished" } else { "stopped" };
        match py.detach(|| guard("Cell", || end(slot, why, finish)))? {
            None => Ok(None),
            Some(Ok(e)) => end_dict(py, &e, &self.records).map(Some),
            Some(Err(e)) => Err(cell_error(py, e)),
        }
    }
}

#[pymethods]
impl Cell {
    #[new]
    #[pyo3(signature = (embodier, arms, **options))]
    fn new(
        py: Python<'_>,
        embodier: Py<Embodier>,
        arms: HashMap<String, String>,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Cell> {
        let o = Options::new("Cell", options, OPTIONS)?;
        exit_on_sigterm(py)?;
        let mut urls = Vec::with_capacity(arms.len());
        for (name, url) in &arms {
            let parsed = ArmOrMockUrl::parse(url)
                .map_err(|e| field_error(py, format!("arms[{name:?}]"), e))?;
            urls.push((name.clone(), parsed));
        }
        // In the Embodier's order, for stable messages.
        let names = embodier.bind(py).borrow().inner.robot_names().to_vec();
        urls.sort_by_key(|(n, _)| names.iter().position(|m| m == n).unwrap_or(usize::MAX));
        let kortex = urls
            .iter()
            .any(|(_, u)| matches!(u, ArmOrMockUrl::Arm(ArmUrl::Kortex(_))));
        let options = live_options(py, &o, kortex)?;
        let mut e = embodier.bind(py).try_borrow_mut()?;
        e.check_free()?;
        let inner = &e.inner;
        let started = py.detach(|| guard("Cell", || LiveCell::start(inner, &urls, options)))?;
        let live = started.map_err(|err| cell_error(py, err))?;
        let cell = Cell {
            names: live.names().to_vec(),
            time_scale: live.time_scale(),
            period: live.period(),
            step_time: live.step_time(),
            records: live.records().to_path_buf(),
            slot: Arc::new(Mutex::new(State::Running(Box::new(live)))),
            embodier: embodier.clone_ref(py),
        };
        e.cell = Some(Arc::downgrade(&cell.slot));
        let mut cells = CELLS.lock().unwrap_or_else(|p| p.into_inner());
        cells.retain(|w| w.strong_count() > 0);
        cells.push(Arc::downgrade(&cell.slot));
        Ok(cell)
    }

    /// Plans a chunk with the Embodier (the GIL released) and hands it to the executor;
    /// returns at once, the arms moving on their own. `hands` (hands, H, 7): hand j's poses at
    /// policy steps `start_step..start_step + H`. Poses at steps the arms have passed are
    /// dropped (`late`). Returns the chunk's report (as `Embodier.last_report`) with `late`,
    /// `from` (the waypoint, a timeline index, it streams from), `cycle` and `attempts`.
    /// Raises InputError (bad hands), ChunkError (not planned), CellError (not sent: the arms
    /// go on with the plan they have) or ArmFault.
    fn push<'py>(
        &self,
        py: Python<'py>,
        start_step: u64,
        hands: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let poses = poses_of(py, &hands)?;
        let mut e = self.embodier.bind(py).try_borrow_mut()?;
        let inner = &mut e.inner;
        let pushed = self.with_cell(py, |cell| cell.push(inner, start_step, &poses))?;
        e.last = Some(pushed.report.clone());
        push_dict(py, &pushed)
    }

    /// Where the stream and every arm are: `step` (the waypoint being executed), `fixed`,
    /// `holding`, `cycle`, `policy_step` (the policy step the arms are at, or None), `lag_s`
    /// (the Embodier's lag behind the policy), `events` (queue_dry, resumed, since the last
    /// call) and `arms`: per name, `state`, `commanded` and `measured` joints, `following_error`,
    /// `queue_depth`, `lag_s`. Raises ArmFault once after a fault.
    fn status<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.with_cell(py, |cell| cell.status())?;
        status_dict(py, &s)
    }

    /// Waits for the queue to run out (Ctrl-C still stops the arms), holds for the settle
    /// cycles, disables the drives: `cycles`, `holds`, `halted`, `report`, `records`. None if
    /// the cell had ended.
    fn finish<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        loop {
            py.check_signals()?;
            let done = self.with_cell(py, |cell| {
                let s = cell.status()?;
                Ok(s.cell.progress.holding && s.cell.arms.iter().all(|a| a.queue_depth == 0))
            });
            match done {
                Ok(true) => break,
                Ok(false) => py.detach(|| std::thread::sleep(Duration::from_millis(10))),
                Err(e) if e.is_instance_of::<ArmFault>(py) => return Err(e),
                Err(_) => return Ok(None),
            }
        }
        self.end(py, true)
    }

    /// Stops every arm now (a quick stop, as for a fault): as `finish`.
    fn stop<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.end(py, false)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// Leaving the block stops every arm (call `finish()` in it to let the queue run out);
    /// a fault not yet reported is raised unless another exception is leaving the block.
    fn __exit__(
        &self,
        py: Python<'_>,
        exc_type: Option<&Bound<'_, PyAny>>,
        _exc: Option<&Bound<'_, PyAny>>,
        _tb: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<bool> {
        match self.end(py, false) {
            Err(e) if exc_type.is_none() => Err(e),
            _ => Ok(false),
        }
    }

    /// The arms' names, in the Embodier's order.
    #[getter]
    fn robot_names(&self) -> Vec<String> {
        self.names.clone()
    }

    /// How many times slower than the policy's rate the arms move.
    #[getter]
    fn time_scale(&self) -> f64 {
        self.time_scale
    }

    /// The control period, s.
    #[getter]
    fn period(&self) -> f64 {
        self.period.as_secs_f64()
    }

    /// Seconds per waypoint as streamed (dt times time_scale).
    #[getter]
    fn step_time(&self) -> f64 {
        self.step_time
    }

    /// Where mock arms write their records (NAME.jsonl; a CAN mock's bus log NAME.log), once
    /// the cell has ended.
    #[getter]
    fn records(&self) -> PathBuf {
        self.records.clone()
    }

    /// The cell still runs.
    #[getter]
    fn running(&self, py: Python<'_>) -> bool {
        let slot = &self.slot;
        py.detach(|| matches!(*lock(slot), State::Running(_)))
    }
}

impl Drop for Cell {
    /// Stops every arm (the object was collected without leaving the cell).
    fn drop(&mut self) {
        let slot = self.slot.clone();
        Python::attach(|py| py.detach(|| end(&slot, "the Cell was collected", false)));
    }
}
