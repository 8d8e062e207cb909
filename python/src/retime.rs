//! `retime`: the core's time-optimal law along the executor's spline (TOPP-RA), for the
//! path and limits given, as arrays over its grid.

use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArrayLikeDyn};
use omcbsa_core::retime::{grid_len, retime as solve, GridPoint, JointPath, Limits, Options};
use pyo3::prelude::*;

use crate::convert::field_error;
use crate::guard;

/// The law's grid: path parameter (waypoints), path speed (waypoints/s), time (s).
type Law<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// A 1-D array of `dof` values, or the error naming `name`.
fn row(
    py: Python<'_>,
    a: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    dof: usize,
    name: &str,
) -> PyResult<Vec<f64>> {
    let a = a.as_array();
    if a.shape() != [dof] {
        return Err(field_error(
            py,
            name,
            format!("expected shape ({dof},), got shape {:?}", a.shape()),
        ));
    }
    Ok(a.iter().copied().collect())
}

#[pyfunction]
#[pyo3(signature = (waypoints, velocity, acceleration, per_segment=20, max_speed=f64::INFINITY, start=0.0, start_speed=0.0))]
#[allow(clippy::too_many_arguments)] // the Python signature: keyword arguments with defaults
pub fn retime<'py>(
    py: Python<'py>,
    waypoints: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    velocity: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    acceleration: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    per_segment: usize,
    max_speed: f64,
    start: f64,
    start_speed: f64,
) -> PyResult<Law<'py>> {
    let w = waypoints.as_array();
    let [_, dof] = *w.shape() else {
        return Err(field_error(
            py,
            "waypoints",
            format!("expected shape (n, dof), got shape {:?}", w.shape()),
        ));
    };
    let points: Vec<f64> = w.iter().copied().collect();
    let velocity = row(py, velocity, dof, "velocity")?;
    let acceleration = row(py, acceleration, dof, "acceleration")?;
    let options = Options {
        per_segment,
        max_speed,
        start,
        start_speed,
    };
    let law = guard("retime", || {
        let path = JointPath::new(&points, dof)?;
        let limits = Limits {
            velocity: &velocity,
            acceleration: &acceleration,
        };
        let mut grid = vec![GridPoint::default(); grid_len(&path, &options).max(1)];
        let law = solve(&path, &limits, &options, &mut grid)?;
        let n = law.points().len();
        Ok::<_, omcbsa_core::retime::RetimeError>(grid[..n].to_vec())
    })?
    .map_err(|e| field_error(py, "retime", e.to_string()))?;
    let s: Vec<f64> = law.iter().map(|p| p.s).collect();
    let speed: Vec<f64> = law.iter().map(|p| p.x.sqrt()).collect();
    let t: Vec<f64> = law.iter().map(|p| p.t).collect();
    Ok((
        s.into_pyarray(py),
        speed.into_pyarray(py),
        t.into_pyarray(py),
    ))
}
