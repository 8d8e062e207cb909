//! # omcbsa (host)
//!
//! The std side of omcbsa: the problem and solution file formats ([`format`]), reading and
//! checking them into the core's fixed-capacity problem ([`load`]), and checking a solution
//! against its problem ([`validate`]). The `omcbsa` binary is a thin command line over these.

pub mod approach;
pub mod assignment;
pub mod bench;
pub mod demo;
pub mod error;
pub mod execute;
pub mod format;
pub mod ik;
pub mod import;
pub mod load;
pub mod models;
pub mod online;
pub mod plan;
pub mod planners;
pub mod pose;
pub mod suite;
pub mod validate;
pub mod view;
