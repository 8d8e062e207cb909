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
mod sym;
mod transform;

use std::path::Path;

pub use error::Error;

/// Where an input comes from.
#[derive(Clone, Copy, Debug)]
pub enum Input<'a> {
    File(&'a Path),
    /// Text given directly (named `<string>` in messages).
    Text(&'a str),
}

impl Input<'_> {
    /// `(name for messages, contents)`.
    fn read(&self) -> Result<(String, String), Error> {
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
    pub urdf: Input<'a>,
    /// Collision capsules and disabled link pairs; without it the model has no capsules.
    pub collision: Option<Input<'a>>,
}

/// Rust source for `spec`: a unit struct and its `crate::model::Model<D>` impl.
pub fn generate_model(spec: &ModelSpec) -> Result<String, Error> {
    if !is_type_name(spec.type_name) {
        return Err(Error::TypeName(spec.type_name.to_string()));
    }
    let (urdf_source, urdf_text) = spec.urdf.read()?;
    let robot = urdf_rs::read_from_string(&urdf_text).map_err(|e| Error::Urdf {
        source: urdf_source.clone(),
        message: e.to_string(),
    })?;
    let chain = chain::from_urdf(&robot)?;
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
        &geometry,
    ))
}

fn is_type_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}
