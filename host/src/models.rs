//! The robot models compiled into this program, by the names files and the command line use.
//!
//! Everything the host plans, validates, views and executes goes through [`Fleet`], the type
//! codegen generates over every compiled model of [`DOF`] joints (`core/build.rs`): a robot's
//! model is an index into it ([`ModelKind`], [`omcbsa_core::problem::Robot::model`]), so a
//! problem may mix models. Adding a model is its folder under `robots/` and a line in
//! `core/build.rs`; nothing here names one except the aliases.

use std::fmt;

use omcbsa_core::model::Models;

/// The models the host plans for: every compiled-in model of [`DOF`] joints.
pub type Fleet = omcbsa_core::model::Fleet7;

/// Joints of every arm the host plans for.
pub const DOF: usize = 7;

/// One of [`Fleet`]'s models, by its index there. The default is the first compiled in
/// (`kinova_gen3`, the arm of the demo and of the benchmark families that name none).
///
/// ```
/// use omcbsa::models::ModelKind;
///
/// assert_eq!(ModelKind::default().name(), "kinova_gen3");
/// assert_eq!(ModelKind::parse("panda").unwrap().name(), "franka_panda");
/// let err = ModelKind::parse("ur5").unwrap_err();
/// assert!(err.contains("compiled in: kinova_gen3, franka_panda"), "{err}");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ModelKind(u8);

impl ModelKind {
    /// Short names accepted besides [`ModelKind::name`] (Franka's own short name).
    const ALIASES: [(&'static str, &'static str); 1] = [("panda", "franka_panda")];

    /// Every model, in index order.
    pub fn all() -> impl Iterator<Item = ModelKind> {
        (0..Fleet::COUNT).filter_map(|i| u8::try_from(i).ok().map(ModelKind))
    }

    /// The index into [`Fleet`] (what [`omcbsa_core::problem::Robot::model`] holds).
    pub fn id(self) -> u8 {
        self.0
    }

    /// The name problem files use.
    pub fn name(self) -> &'static str {
        Fleet::name(self.0)
    }

    /// The model named `name` (or one of its aliases).
    pub fn from_name(name: &str) -> Option<ModelKind> {
        let name = (Self::ALIASES.iter())
            .find_map(|&(alias, full)| (alias == name).then_some(full))
            .unwrap_or(name);
        Fleet::find(name).map(ModelKind)
    }

    /// Like [`ModelKind::from_name`], with an error that lists the models compiled in.
    pub fn parse(name: &str) -> Result<ModelKind, String> {
        Self::from_name(name).ok_or_else(|| {
            let known: Vec<&str> = Self::all().map(|m| m.name()).collect();
            let aliases: Vec<String> = (Self::ALIASES.iter())
                .map(|(a, m)| format!("{a} for {m}"))
                .collect();
            format!(
                "unknown model {name:?} (compiled in: {}; aliases: {})",
                known.join(", "),
                aliases.join(", ")
            )
        })
    }
}

impl fmt::Display for ModelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_aliases_parse() {
        for m in ModelKind::all() {
            assert_eq!(ModelKind::parse(m.name()), Ok(m));
        }
        let panda = ModelKind::parse("panda").unwrap();
        assert_eq!(panda.name(), "franka_panda");
        assert_ne!(panda, ModelKind::default());
        assert_eq!(ModelKind::default().name(), "kinova_gen3");
        let e = ModelKind::parse("ur5").unwrap_err();
        assert!(
            e.contains("kinova_gen3, franka_panda") && e.contains("ur5"),
            "{e}"
        );
    }
}
