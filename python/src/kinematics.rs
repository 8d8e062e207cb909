//! `fk` and `ik`, vectorised over the leading dimensions of their arrays, answering as
//! `omcbsa fk` and `omcbsa ik` answer one line.

use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{AllowTypeChange, IntoPyArray, PyArrayDyn, PyArrayLikeDyn};
use omcbsa::error::{Errors, InputError};
use omcbsa::format::Pose;
use omcbsa::ik::solve as solve_ik;
use omcbsa::models::{Fleet, ModelKind};
use omcbsa::{load, pose};
use omcbsa_core::model::{Frame, Models};
use pyo3::prelude::*;

use crate::convert::{field_error, flat, index_path, input_error};
use crate::guard;
use crate::problem::DOF;

/// The compiled-in model named `name`.
fn model(py: Python<'_>, name: &str) -> PyResult<ModelKind> {
    ModelKind::parse(name).map_err(|e| field_error(py, "model", e))
}

/// Row `k` of `values` as a configuration of model `model` (finite, within limits), or the
/// error naming `name[i][j]`.
fn configuration(
    model: u8,
    row: &[f64],
    name: &str,
    lead: &[usize],
    k: usize,
) -> Result<[f64; DOF], InputError> {
    let mut errors = Errors::default();
    let q = load::joint_values::<Fleet, DOF>(model, row, "", &mut errors);
    errors.finish().map_err(|e| InputError {
        errors: (e.errors.into_iter())
            .map(|f| f.within(&index_path(name, lead, k)))
            .collect(),
    })?;
    Ok(q.unwrap_or([0.0; DOF]))
}

/// An optional pose argument (shape (7,): position + quaternion xyzw) as a frame; the
/// identity when left out.
fn frame_arg(
    py: Python<'_>,
    arg: Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    name: &str,
) -> PyResult<Frame> {
    let Some(arg) = arg else {
        return Ok(Frame::IDENTITY);
    };
    let a = arg.as_array();
    if a.shape() != [7] {
        return Err(field_error(
            py,
            name,
            format!("expected a pose of shape (7,), got shape {:?}", a.shape()),
        ));
    }
    let v = flat(py, &a, 7, name, "(7,)")?;
    let p = Pose {
        position: [v[0], v[1], v[2]],
        quat_xyzw: [v[3], v[4], v[5], v[6]],
    };
    pose::to_frame(&p).map_err(|e| input_error(py, &InputError::from(e.within(name))))
}

/// Forward kinematics: `q` of shape (..., 7) joint values -> poses of shape (..., 7),
/// position + quaternion xyzw (w >= 0) of the tool frame in the model's base frame; with
/// `base` (the robot's pose in the world) and `tcp` (the tool centre point in the tool
/// frame), each pose (7,), of the tool centre point in the world: `base * fk(q) * tcp`. A
/// value outside the joint limits raises `ValueError` naming it (`q[2][5]`).
#[pyfunction]
#[pyo3(signature = (model_name, q, base=None, tcp=None))]
pub fn fk<'py>(
    py: Python<'py>,
    model_name: &str,
    q: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    base: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    tcp: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let kind = model(py, model_name)?;
    let (base, tcp) = (frame_arg(py, base, "base")?, frame_arg(py, tcp, "tcp")?);
    let q = q.as_array();
    let shape = q.shape().to_vec();
    let values = flat(py, &q, DOF, "q", "(..., 7)")?;
    let lead = &shape[..shape.len() - 1];
    let out = py
        .detach(|| {
            guard("fk", || {
                FkRows {
                    values: &values,
                    lead,
                    base: &base,
                    tcp: &tcp,
                }
                .run(kind.id())
            })
        })?
        .map_err(|e| input_error(py, &e))?;
    array(py, shape, out)
}

/// Joint values (..., 7) and success flags (...).
type IkAnswer<'py> = (Bound<'py, PyArrayDyn<f64>>, Bound<'py, PyArrayDyn<bool>>);

/// Inverse kinematics: `poses` of shape (..., 7), position + quaternion xyzw of the tool
/// frame in the model's base frame -> (`q` of shape (..., 7), `ok` of shape (...)). Each pose
/// is solved from its seed (`seeds`: None, one configuration (7,), or one per pose) and then
/// from random starts drawn from `seed`, as `omcbsa ik` does; a pose with no solution gets
/// `ok` False and NaN joint values. With `base` and `tcp` (as for `fk`), the poses are of the
/// tool centre point in the world. A bad pose or seed raises `ValueError` naming it.
#[pyfunction]
#[pyo3(signature = (model_name, poses, seeds=None, seed=0, base=None, tcp=None))]
pub fn ik<'py>(
    py: Python<'py>,
    model_name: &str,
    poses: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    seeds: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    seed: u64,
    base: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
    tcp: Option<PyArrayLikeDyn<'py, f64, AllowTypeChange>>,
) -> PyResult<IkAnswer<'py>> {
    let kind = model(py, model_name)?;
    let (base_inv, tcp_inv) = (
        frame_arg(py, base, "base")?.inverse(),
        frame_arg(py, tcp, "tcp")?.inverse(),
    );
    let poses = poses.as_array();
    let shape = poses.shape().to_vec();
    let values = flat(py, &poses, 7, "poses", "(..., 7)")?;
    let lead = shape[..shape.len() - 1].to_vec();
    let seeds = match &seeds {
        None => None,
        Some(s) => {
            let s = s.as_array();
            let ok = s.shape() == [DOF] || s.shape() == shape.as_slice();
            if !ok {
                return Err(field_error(
                    py,
                    "seeds",
                    format!(
                        "expected shape (7,) or the shape of poses {shape:?}, got {:?}",
                        s.shape()
                    ),
                ));
            }
            Some(flat(py, &s, DOF, "seeds", "(..., 7)")?)
        }
    };
    let (q, ok) = py
        .detach(|| {
            guard("ik", || {
                IkRows {
                    values: &values,
                    seeds: seeds.as_deref(),
                    lead: &lead,
                    seed,
                    base_inv: &base_inv,
                    tcp_inv: &tcp_inv,
                }
                .run(kind.id())
            })
        })?
        .map_err(|e| input_error(py, &e))?;
    let mut q_shape = lead.clone();
    q_shape.push(DOF);
    let ok = ArrayD::from_shape_vec(IxDyn(&lead), ok)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    Ok((array(py, q_shape, q)?, ok.into_pyarray(py)))
}

/// The poses of `values` (rows of `D` joint values), position + quaternion per row.
struct FkRows<'a> {
    values: &'a [f64],
    lead: &'a [usize],
    /// The robot's base in the world and its tool centre point in the tool frame.
    base: &'a Frame,
    tcp: &'a Frame,
}

impl FkRows<'_> {
    /// The poses for model `model`.
    fn run(self, model: u8) -> Result<Vec<f64>, InputError> {
        let mut out = Vec::with_capacity(self.values.len());
        for (k, row) in self.values.chunks_exact(DOF).enumerate() {
            let q = configuration(model, row, "q", self.lead, k)?;
            let p = pose::from_frame(&self.base.compose(&Fleet::fk(model, &q)).compose(self.tcp));
            out.extend_from_slice(&p.position);
            out.extend_from_slice(&p.quat_xyzw);
        }
        Ok(out)
    }
}

/// IK of every pose of `values` (rows of 7): joint values (NaN where none) and success flags.
struct IkRows<'a> {
    values: &'a [f64],
    /// One configuration for all poses, or one per pose.
    seeds: Option<&'a [f64]>,
    lead: &'a [usize],
    seed: u64,
    /// Inverses of the robot's base and of its tool centre point (see [`FkRows`]).
    base_inv: &'a Frame,
    tcp_inv: &'a Frame,
}

impl IkRows<'_> {
    /// The answers for model `model`.
    fn run(self, model: u8) -> Result<(Vec<f64>, Vec<bool>), InputError> {
        const D: usize = DOF;
        let n = self.values.len() / 7;
        let mut q = Vec::with_capacity(n * D);
        let mut ok = Vec::with_capacity(n);
        for (k, row) in self.values.chunks_exact(7).enumerate() {
            let p = Pose {
                position: [row[0], row[1], row[2]],
                quat_xyzw: [row[3], row[4], row[5], row[6]],
            };
            let target = pose::to_frame(&p)
                .map_err(|e| InputError::from(e.within(&index_path("poses", self.lead, k))))?;
            let target = self.base_inv.compose(&target).compose(self.tcp_inv);
            let start = match self.seeds {
                Some(s) if s.len() == D => Some(configuration(model, s, "seeds", &[], 0)?),
                Some(s) => Some(configuration(
                    model,
                    &s[k * D..(k + 1) * D],
                    "seeds",
                    self.lead,
                    k,
                )?),
                None => None,
            };
            match solve_ik::<Fleet, D>(model, &target, start.as_ref(), self.seed) {
                Ok(sol) => {
                    q.extend_from_slice(&sol);
                    ok.push(true);
                }
                Err(_) => {
                    q.extend_from_slice(&[f64::NAN; D]);
                    ok.push(false);
                }
            }
        }
        Ok((q, ok))
    }
}

fn array(
    py: Python<'_>,
    shape: Vec<usize>,
    values: Vec<f64>,
) -> PyResult<Bound<'_, PyArrayDyn<f64>>> {
    ArrayD::from_shape_vec(IxDyn(&shape), values)
        .map(|a| a.into_pyarray(py))
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}
