//! `Stream`: the executor's frame generator without arms, for simulating what the executor
//! would command (its time law, its stops) cycle by cycle.

use numpy::ndarray::Array3;
use numpy::{AllowTypeChange, IntoPyArray, PyArray3, PyArrayLikeDyn};
use omcbsa_hw::cia402::counts_to_rad;
use omcbsa_hw::plan::{ArmLimits, JointLimits};
use omcbsa_hw::stream::Generator;
use omcbsa_hw::JOINTS;
use pyo3::prelude::*;

use crate::convert::field_error;

/// Rows of `JOINTS` values, one per arm, or the error naming `name`.
fn rows(
    py: Python<'_>,
    a: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    name: &str,
) -> PyResult<Vec<[f64; JOINTS]>> {
    let a = a.as_array();
    if a.ndim() != 2 || a.shape()[1] != JOINTS {
        return Err(field_error(
            py,
            name,
            format!("expected shape (arms, {JOINTS}), got shape {:?}", a.shape()),
        ));
    }
    Ok(a.outer_iter()
        .map(|r| std::array::from_fn(|j| r[j]))
        .collect())
}

/// The executor's frame generator for simulation. Arms start at rest at ``starts``
/// (arms, 7) rad; ``velocity``, ``acceleration`` and ``jerk`` (arms, 7) are every joint's limits
/// (no position limits); control cycles of ``period`` s; a step lasts at least ``step_time`` s.
#[pyclass(module = "omcbsa")]
pub struct Stream {
    generator: Generator,
}

#[pymethods]
impl Stream {
    #[new]
    #[pyo3(signature = (starts, velocity, acceleration, jerk, period, step_time))]
    fn new(
        py: Python<'_>,
        starts: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        velocity: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        acceleration: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        jerk: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        period: f64,
        step_time: f64,
    ) -> PyResult<Self> {
        let starts = rows(py, &starts, "starts")?;
        let (v, a, j) = (
            rows(py, &velocity, "velocity")?,
            rows(py, &acceleration, "acceleration")?,
            rows(py, &jerk, "jerk")?,
        );
        if [v.len(), a.len(), j.len()] != [starts.len(); 3] {
            return Err(field_error(py, "velocity", "one row of limits per arm"));
        }
        let limits: Vec<ArmLimits> = (0..starts.len())
            .map(|arm| {
                std::array::from_fn(|k| JointLimits {
                    position: None,
                    velocity: v[arm][k],
                    acceleration: a[arm][k],
                    jerk: j[arm][k],
                })
            })
            .collect();
        let generator = Generator::new(&starts, &limits, period, step_time)
            .map_err(|e| field_error(py, "Stream", e))?;
        Ok(Self { generator })
    }

    /// Replaces every arm's waypoints from step ``start`` on by ``waypoints`` (arms, n, 7);
    /// ``InputError`` if the generator refuses it (a limit broken, too short to stop in).
    fn push(
        &mut self,
        py: Python<'_>,
        start: usize,
        waypoints: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    ) -> PyResult<()> {
        let w = waypoints.as_array();
        if w.ndim() != 3 || w.shape()[2] != JOINTS {
            return Err(field_error(
                py,
                "waypoints",
                format!(
                    "expected shape (arms, n, {JOINTS}), got shape {:?}",
                    w.shape()
                ),
            ));
        }
        let lists: Vec<Vec<[f64; JOINTS]>> = w
            .outer_iter()
            .map(|arm| {
                arm.outer_iter()
                    .map(|r| std::array::from_fn(|j| r[j]))
                    .collect()
            })
            .collect();
        let refs: Vec<&[[f64; JOINTS]]> = lists.iter().map(|l| l.as_slice()).collect();
        self.generator
            .push(start, &refs)
            .map_err(|e| field_error(py, "waypoints", e.to_string()))
    }

    /// The commands (cycles, arms, 7), rad, of the next cycles until the arms hold (that
    /// cycle included) or ``max_cycles`` have run.
    fn run<'py>(
        &mut self,
        py: Python<'py>,
        max_cycles: usize,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let arms = self.generator.arms();
        let mut out = vec![[0; JOINTS]; arms];
        let mut rad = Vec::new();
        for _ in 0..max_cycles {
            let tick = (self.generator.next(&mut out))
                .map_err(|e| field_error(py, "Stream", e.to_string()))?;
            rad.extend(out.iter().flatten().map(|&c| counts_to_rad(c)));
            if tick.holding && tick.cycle > 0 {
                break;
            }
        }
        let cycles = rad.len() / (arms * JOINTS);
        let a = Array3::from_shape_vec((cycles, arms, JOINTS), rad)
            .map_err(|e| field_error(py, "Stream", e.to_string()))?;
        Ok(a.into_pyarray(py))
    }
}
