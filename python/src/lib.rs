//! The `omcbsa` Python package's native module: the host library's problem and solution
//! files, planners, validator, kinematics, online API and live cell, with NumPy arrays for
//! joint paths and poses. One implementation: everything here converts and calls the host library.

mod bench;
mod cell;
mod cell_state;
mod convert;
mod embodier;
mod episode;
mod kinematics;
mod options;
mod problem;
mod retime;
mod stream;

use std::panic::{catch_unwind, AssertUnwindSafe};

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// Runs `f`, turning a panic (a bug: nothing is meant to panic on any input) into a
/// `RuntimeError` naming the operation instead of unwinding into the interpreter.
pub(crate) fn guard<T>(what: &str, f: impl FnOnce() -> T) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let why = (payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        PyRuntimeError::new_err(format!("internal error in omcbsa {what} (a bug): {why}"))
    })
}

#[pymodule]
fn _omcbsa(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add(
        "InputError",
        m.py().get_type::<convert::exception::InputError>(),
    )?;
    m.add("ChunkError", m.py().get_type::<embodier::ChunkError>())?;
    m.add("CellError", m.py().get_type::<cell::CellError>())?;
    m.add("ArmFault", m.py().get_type::<cell::ArmFault>())?;
    m.add_class::<embodier::Embodier>()?;
    m.add_class::<cell::Cell>()?;
    m.add_class::<problem::Problem>()?;
    m.add_class::<stream::Stream>()?;
    m.add_class::<problem::Solution>()?;
    m.add_class::<problem::Report>()?;
    m.add_class::<problem::Violation>()?;
    m.add_function(wrap_pyfunction!(problem::plan, m)?)?;
    m.add_function(wrap_pyfunction!(problem::validate, m)?)?;
    m.add_function(wrap_pyfunction!(kinematics::fk, m)?)?;
    m.add_function(wrap_pyfunction!(kinematics::ik, m)?)?;
    m.add_function(wrap_pyfunction!(episode::aloha_episode, m)?)?;
    m.add_function(wrap_pyfunction!(retime::retime, m)?)?;
    // Leaving the interpreter stops every arm of every cell still running.
    let stop_all = wrap_pyfunction!(cell::stop_all_cells, m)?;
    m.py()
        .import("atexit")?
        .call_method1("register", (stop_all,))?;
    m.add_function(wrap_pyfunction!(bench::bench_run, m)?)?;
    m.add_function(wrap_pyfunction!(bench::bench_csv_header, m)?)?;
    m.add_function(wrap_pyfunction!(bench::bench_report, m)?)?;
    m.add_function(wrap_pyfunction!(bench::bench_planners, m)?)?;
    Ok(())
}
