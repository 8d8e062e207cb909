//! Readers of published multi-arm problem sets that were not made here (`omcbsa
//! import-problems`): each reads the set from a checkout the user gives and writes a suite
//! directory that `omcbsa bench` runs. Nothing of the sets is kept in this repository.

pub mod cpp;
pub mod error;
pub mod vamp_mr;

pub use error::ImportError;
