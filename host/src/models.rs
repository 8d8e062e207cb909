//! The robot models compiled into this program, by the names files and the command line use.
//!
//! Code that depends on the model is generic over `M: Model<D>`; [`ModelKind::visit`] is the
//! one place that turns a model's name into its type, so adding a model (a folder under
//! `robots/` and a line in `core/build.rs`) is one variant and one arm here.

use std::fmt;

use omcbsa_core::model::{FrankaPanda, KinovaGen3, Model};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    KinovaGen3,
    FrankaPanda,
}

/// Code generic over the model, run by [`ModelKind::visit`] with the model's type (closures
/// cannot be generic, so the generic code is a method).
pub trait ModelVisitor {
    type Output;
    fn visit<M: Model<D>, const D: usize>(self) -> Self::Output;
}

impl ModelKind {
    pub const ALL: [ModelKind; 2] = [ModelKind::KinovaGen3, ModelKind::FrankaPanda];

    /// Short names accepted besides [`ModelKind::name`] (the and Franka's own).
    const ALIASES: [(&'static str, ModelKind); 1] = [("panda", ModelKind::FrankaPanda)];

    /// Runs `visitor` with this model's type.
    pub fn visit<V: ModelVisitor>(self, visitor: V) -> V::Output {
        match self {
            ModelKind::KinovaGen3 => visitor.visit::<KinovaGen3, 7>(),
            ModelKind::FrankaPanda => visitor.visit::<FrankaPanda, 7>(),
        }
    }

    /// The name problem files use.
    pub fn name(self) -> &'static str {
        struct Name;
        impl ModelVisitor for Name {
            type Output = &'static str;
            fn visit<M: Model<D>, const D: usize>(self) -> &'static str {
                M::NAME
            }
        }
        self.visit(Name)
    }

    /// The model named `name` (or one of its aliases).
    pub fn from_name(name: &str) -> Option<ModelKind> {
        (Self::ALL.into_iter().find(|m| m.name() == name))
            .or_else(|| (Self::ALIASES.iter()).find_map(|&(a, m)| (a == name).then_some(m)))
    }

    /// Like [`ModelKind::from_name`], with an error that lists the models compiled in.
    pub fn parse(name: &str) -> Result<ModelKind, String> {
        Self::from_name(name).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
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
        for m in ModelKind::ALL {
            assert_eq!(ModelKind::parse(m.name()), Ok(m));
        }
        assert_eq!(ModelKind::parse("panda"), Ok(ModelKind::FrankaPanda));
        let e = ModelKind::parse("ur5").unwrap_err();
        assert!(
            e.contains("kinova_gen3, franka_panda") && e.contains("ur5"),
            "{e}"
        );
    }
}
