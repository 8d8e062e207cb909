//! # omcbsa-core
//!
//! The planning core of omcbsa: `#![no_std]`, no `alloc`. Every piece of storage it uses is
//! handed in by the caller (see [`search::Workspace`]), so memory use is fixed at compile time
//! and a search that runs out of room says so instead of allocating.
//!
//! Layers, bottom up:
//! - [`model`]: the [`model::Model`] trait and the robot models generated at build time from
//!   URDF files (forward kinematics, Jacobian, limits, collision primitives).
//! - [`lanes`]: the numbers the kinematics and the batched checks compute with: one, or a
//!   batch of [`lanes::LANES`] (SIMD).
//! - [`kinematics`]: pose errors and the null-space basis of the Jacobian.
//! - [`ik`]: damped-least-squares IK projection and seeded multi-start IK.
//! - [`rng`]: a small deterministic random generator.
//! - [`geometry`]: shapes and closed-form distance queries.
//! - [`collision`]: arm-level checks on link capsules, at a configuration and along a motion.
#![no_std]
#![forbid(unsafe_code)]

pub mod approach;
pub mod assign;
pub mod baselines;
pub mod cbs;
pub mod collision;
pub mod embody;
pub mod geometry;
pub mod ik;
pub mod kinematics;
pub mod lanes;
pub mod model;
pub mod motion;
pub mod planner;
pub mod pp;
pub mod problem;
pub mod reach;
pub mod rng;
pub mod search;
pub mod tool;
pub mod tracking;
mod trig;

pub use nalgebra;
