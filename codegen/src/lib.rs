//! # omcbsa-codegen
//!
//! Build-time generator: reads a serial-chain URDF (and optionally the collision capsules the
//! fitting tool wrote for it) and emits fixed-size Rust implementing
//! `omcbsa_core::model::Model<D>`: limits, collision data, and unrolled forward kinematics,
//! link frames and Jacobian with every fixed transform folded into literal constants.
//! `core/build.rs` calls [`generate_model`] once per compiled-in model; [`fit`] makes the
//! collision file.

mod chain;
mod collision;
mod emit;
mod error;
pub mod fit;
mod fleet;
pub mod manifest;
mod sym;
mod transform;

use std::path::Path;

pub use chain::Ends;
pub use error::{Error, NotSerial};
pub use fleet::fleet as generate_fleet;

/// Where an input comes from.
#[derive(Clone, Copy, Debug)]
pub enum Input<'a> {
    /// A file, read when the model is generated.
    File(&'a Path),
    /// Text given directly (named `<string>` in messages).
    Text(&'a str),
}

impl Input<'_> {
    /// `(name for messages, contents)`.
    pub(crate) fn read(&self) -> Result<(String, String), Error> {
        match self {
            Input::File(path) => std::fs::read_to_string(path)
                .map(|text| (path.display().to_string(), text))
                .map_err(|source| Error::Read {
                    path: path.to_path_buf(),
                    source,
                }),
            Input::Text(text) => Ok(("<string>".to_string(), text.to_string())),
        }
    }
}

/// One model to generate.
#[derive(Clone, Copy, Debug)]
pub struct ModelSpec<'a> {
    /// Name of the generated Rust type, e.g. `KinovaGen3`.
    pub type_name: &'a str,
    /// `Model::NAME`, the name problem files use, e.g. `kinova_gen3`; the collision file's
    /// `model` field must match it.
    pub name: &'a str,
    /// The URDF.
    pub urdf: Input<'a>,
    /// Collision capsules and disabled link pairs; without it the model has no capsules.
    pub collision: Option<Input<'a>>,
    /// Where the chain starts and ends; without them the whole URDF must be one serial chain
    /// whose last link is the tool frame.
    pub ends: Option<Ends<'a>>,
    /// The vendor's limits; without them the URDF's velocity limits and no acceleration limit
    /// (`f64::INFINITY`).
    pub limits: Option<Limits<'a>>,
}

/// Joint limits given beside the URDF, one value per actuated joint in chain order.
#[derive(Clone, Copy, Debug)]
pub struct Limits<'a> {
    /// Velocity limits, rad/s (m/s for a prismatic joint).
    pub velocity: &'a [f64],
    /// Acceleration limits, rad/s² (m/s²).
    pub acceleration: &'a [f64],
    /// Where the numbers come from (written into the generated type's documentation).
    pub source: &'a str,
}

/// Rust source for `spec`: a unit struct and its `crate::model::Model<D>` impl. Anything
/// the generated code could not stand behind (a URDF that is no serial chain, a joint type
/// that is not supported, limits that are not numbers, ...) is an [`Error`] naming the link,
/// joint or file; nothing is guessed.
///
/// ```
/// use omcbsa_codegen::{generate_model, Error, Input, ModelSpec};
///
/// // A two-joint arm: a shoulder about z, an elbow about y, a 0.3 m forearm.
/// let urdf = r#"<robot name="two_link">
///   <link name="base"/> <link name="upper"/> <link name="fore"/> <link name="tool"/>
///   <joint name="shoulder" type="revolute">
///     <parent link="base"/> <child link="upper"/> <origin xyz="0 0 0.1"/> <axis xyz="0 0 1"/>
///     <limit lower="-3" upper="3" effort="1" velocity="1.5"/>
///   </joint>
///   <joint name="elbow" type="revolute">
///     <parent link="upper"/> <child link="fore"/> <origin xyz="0 0 0.4"/> <axis xyz="0 1 0"/>
///     <limit lower="-2" upper="2" effort="1" velocity="2.0"/>
///   </joint>
///   <joint name="flange" type="fixed">
///     <parent link="fore"/> <child link="tool"/> <origin xyz="0.3 0 0"/>
///   </joint>
/// </robot>"#;
/// let spec = ModelSpec {
///     type_name: "TwoLink",
///     name: "two_link",
///     urdf: Input::Text(urdf),
///     collision: None,
///     ends: None,
///     limits: None,
/// };
/// let source = generate_model(&spec).unwrap();
/// assert!(source.contains("pub struct TwoLink;"));
/// assert!(source.contains("impl crate::model::Model<2> for TwoLink"));
/// assert!(source.contains(r#"JOINT_NAMES: [&'static str; 2] = ["shoulder", "elbow"];"#));
/// // Without the vendor's limits: the URDF's velocities and no acceleration limit.
/// assert!(source.contains("const VELOCITY: [f64; 2] = [1.5, 2.0];"));
/// assert!(source.contains("ACCELERATION: [f64; 2] = [f64::INFINITY, f64::INFINITY];"));
///
/// // A joint type the generator does not support is named, with the joint.
/// let floating = urdf.replace(r#""elbow" type="revolute""#, r#""elbow" type="floating""#);
/// let err = generate_model(&ModelSpec { urdf: Input::Text(&floating), ..spec }).unwrap_err();
/// let named = matches!(&err, Error::UnsupportedJoint { joint, kind: "floating" } if joint == "elbow");
/// assert!(named, "{err}");
/// // So is a type name that is no Rust identifier.
/// let spaced = ModelSpec { type_name: "two link", ..spec };
/// assert!(matches!(generate_model(&spaced), Err(Error::TypeName(_))));
/// ```
pub fn generate_model(spec: &ModelSpec) -> Result<String, Error> {
    if !is_type_name(spec.type_name) {
        return Err(Error::TypeName(spec.type_name.to_string()));
    }
    let (urdf_source, urdf_text) = spec.urdf.read()?;
    let robot = urdf_rs::read_from_string(&urdf_text).map_err(|e| Error::Urdf {
        source: urdf_source.clone(),
        message: e.to_string(),
    })?;
    let mut chain = chain::from_urdf(&robot, spec.ends)?;
    let acceleration = match spec.limits {
        Some(limits) => apply_limits(&mut chain, &limits)?,
        None => vec![f64::INFINITY; chain.actuated().count()],
    };
    let collision = spec.collision.map(|c| c.read()).transpose()?;
    let file = collision
        .as_ref()
        .map(|(source, text)| (source.as_str(), text.as_str()));
    let geometry = collision::geometry(&chain, spec.name, file)?;
    let source = Path::new(&urdf_source)
        .file_name()
        .map_or(urdf_source.clone(), |f| f.to_string_lossy().into_owned());
    Ok(emit::model(
        spec.type_name,
        spec.name,
        &source,
        &chain,
        &acceleration,
        spec.limits.map(|l| l.source),
        &geometry,
    ))
}

/// Replaces the chain's velocity limits with `limits.velocity` and returns the accelerations,
/// after checking both have one positive finite value per actuated joint.
fn apply_limits(chain: &mut chain::Chain, limits: &Limits) -> Result<Vec<f64>, Error> {
    let dof = chain.actuated().count();
    for (what, values) in [
        ("velocity", limits.velocity),
        ("acceleration", limits.acceleration),
    ] {
        if values.len() != dof {
            return Err(Error::BadLimit {
                what,
                message: format!("{} values for {dof} actuated joints", values.len()),
            });
        }
        if let Some(i) = values.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(Error::BadLimit {
                what,
                message: format!("value {i} ({}) is not a positive number", values[i]),
            });
        }
    }
    let moving = chain
        .joints
        .iter_mut()
        .filter(|j| j.motion != chain::Motion::Fixed);
    for (joint, &v) in moving.zip(limits.velocity) {
        joint.velocity = v;
    }
    Ok(limits.acceleration.to_vec())
}

fn is_type_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}
