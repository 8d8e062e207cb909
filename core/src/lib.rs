//! # omcbsa-core
//!
//! The planning core of omcbsa: `#![no_std]`, no `alloc`. Every piece of storage it uses is
//! handed in by the caller (see [`search::Workspace`]), so memory use is fixed at compile time
//! and a search that runs out of room says so ([`planner::Status::OutOfMemory`], naming the
//! pool) instead of allocating. Bad input is an error or a status that says what is wrong,
//! never a panic; the same input gives the same output.
//!
//! Units: metres, radians, seconds. Configurations are `[f64; D]`, poses [`model::Frame`]s.
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
//! - [`tool`]: the capsules of what a robot carries.
//! - [`collision`]: arm-level checks on link capsules, at a configuration and along a motion.
//! - [`motion`]: the motion checks every planner shares.
//! - [`problem`]: the fixed-capacity problem: robots, hand trajectories, obstacles.
//! - [`reach`]: proofs, before searching, that a trajectory is out of every robot's reach.
//! - [`tracking`]: following a trajectory by IK.
//! - [`search`]: Ω-A*, one robot's search on its pose manifolds, and the validity checker.
//! - [`planner`]: the interface every multi-robot planner implements, and the request.
//! - [`cbs`]: Ω-CBSA; [`pp`] and [`assign`]: prioritised planning; [`baselines`]: IK
//!   tracking, PP-Descartes and composite A*.
//! - [`spline`]: the cubic Hermite spline the executor moves every joint along; [`retime`]:
//!   its time-optimal parameterisation under velocity and acceleration limits (TOPP-RA).
//! - [`approach`]: from where the arms stand to where a plan begins; [`embody`]: a planner
//!   and the approach as one search.
//!
//! Every module has a runnable example; [`planner`]'s is the shortest plan.
#![no_std]
#![deny(missing_docs)]
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
pub mod retime;
pub mod rng;
pub mod search;
pub mod spline;
pub mod tool;
pub mod tracking;
pub mod trig;

pub use nalgebra;
