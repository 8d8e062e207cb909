//! The robot models compiled into this program, by the names files and the command line use.
//!
//! Code that depends on the model is generic over `M: Model<D>`; callers pick `M` by matching
//! on [`ModelKind`], so adding a model is one variant here and one arm per match.

use std::fmt;

use omcbsa_core::model::{KinovaGen3, Model};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    KinovaGen3,
}

impl ModelKind {
    pub const ALL: [ModelKind; 1] = [ModelKind::KinovaGen3];

    /// The name problem files use.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::KinovaGen3 => <KinovaGen3 as Model<7>>::NAME,
        }
    }

    pub fn from_name(name: &str) -> Option<ModelKind> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// Like [`ModelKind::from_name`], with an error that lists the models compiled in.
    pub fn parse(name: &str) -> Result<ModelKind, String> {
        Self::from_name(name).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|m| m.name()).collect();
            format!("unknown model {name:?} (compiled in: {})", known.join(", "))
        })
    }
}

impl fmt::Display for ModelKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
