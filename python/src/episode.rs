//! `omcbsa.aloha_episode`: a recorded episode of the project's aloha-sim family
//! (`data/aloha_sim`) placed on a cell of Gen3s, for trying the Embodier and the Cell on a
//! real policy's motion.

use std::path::PathBuf;

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3};
use omcbsa::format::{ProblemFile, TrajectorySpec, PROBLEM_FORMAT};
use omcbsa::online::aloha::{self, FleetKind, Layout};
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

use crate::convert::field_error;
use crate::guard;
use crate::problem::{check, Problem};

/// Reads the episode at `path` (`<task>_<seed>.json.gz`, beside its family's index.json) and
/// places it on `arms` Kinova Gen3s standing by `layout` (`corners` or `rows`), each at its
/// retract posture, around the family's table. Returns `(setup, hands)`: `setup` a Problem of
/// the cell (its one-step trajectories are every hand's first pose; give it to `Embodier`),
/// `hands` (hands, T, 7) every hand's pose at each of the episode's steps, `setup.dt` apart.
#[pyfunction]
#[pyo3(signature = (path, arms=2, layout="corners"))]
pub fn aloha_episode<'py>(
    py: Python<'py>,
    path: PathBuf,
    arms: usize,
    layout: &str,
) -> PyResult<(Problem, Bound<'py, PyArray3<f64>>)> {
    let layout = Layout::parse(layout).map_err(|e| field_error(py, "layout", e))?;
    let max = omcbsa::online::bimanual::MAX_ARMS;
    if !(1..=max).contains(&arms) {
        return Err(field_error(py, "arms", format!("{arms}: 1 to {max}")));
    }
    let family = (py.detach(|| guard("aloha_episode", || aloha::read_episode(&path))))?
        .map_err(|e| field_error(py, "path", e))?;
    let cell = aloha::Cell {
        layout,
        fleet: FleetKind::Gen3,
        arms,
    };
    let episode = family.episode(0, &cell);
    let setup = &episode.setup;
    let file = ProblemFile {
        format: PROBLEM_FORMAT.to_string(),
        name: episode.name.clone(),
        dt: setup.dt,
        robots: setup.robots.clone(),
        trajectories: (episode.hands.iter().enumerate())
            .map(|(j, poses)| TrajectorySpec {
                name: format!("hand_{j}"),
                poses: poses.iter().take(1).copied().collect(),
            })
            .collect(),
        obstacles: setup.obstacles.clone(),
        tolerance: setup.tolerance,
    };
    let file = check(file).map_err(|e| crate::convert::input_error(py, &e))?;
    let (h, t) = (
        episode.hands.len(),
        episode.hands.first().map_or(0, Vec::len),
    );
    let values: Vec<f64> = (episode.hands.iter().flatten())
        .flat_map(|p| p.position.into_iter().chain(p.quat_xyzw))
        .collect();
    let hands = Array3::from_shape_vec((h, t, 7), values)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok((Problem { file }, hands.into_pyarray(py)))
}
