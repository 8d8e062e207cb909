//! # omcbsa (host)
//!
//! The std side of omcbsa: the problem and solution file formats ([`format`](mod@format)), reading and
//! checking them into the core's fixed-capacity problem ([`load`]), planning them with any
//! planner by name in storage allocated here ([`plan`], [`planners`]), checking a solution
//! against its problem ([`validate`]), and planning a policy's chunks as they arrive
//! ([`online`]). The `omcbsa` binary is a thin command line over these.
//!
//! Bad input is an [`error::InputError`] that lists every broken rule with the path of the
//! field (`robots[0].initial: ...`), never a panic; a plan that fails validation is never
//! reported as solved.
//!
//! A problem file, planned with Ω-CBSA and validated:
//!
//! ```
//! use omcbsa::format::Status;
//! use omcbsa::models::{Fleet, DOF};
//! use omcbsa::planners::PlannerKind;
//! use omcbsa::{load, plan, validate};
//!
//! // One Gen3; its hand, pointing down, slides 1 cm a step along y.
//! let text = r#"{
//!   "format": "omcbsa.problem.v1",
//!   "name": "slide",
//!   "dt": 0.1,
//!   "robots": [{"name": "arm", "model": "kinova_gen3",
//!               "base": {"position": [0, 0, 0], "quat_xyzw": [0, 0, 0, 1]}}],
//!   "trajectories": [{"name": "hand", "poses": [
//!     {"position": [0.5, 0.00, 0.4], "quat_xyzw": [1, 0, 0, 0]},
//!     {"position": [0.5, 0.01, 0.4], "quat_xyzw": [1, 0, 0, 0]},
//!     {"position": [0.5, 0.02, 0.4], "quat_xyzw": [1, 0, 0, 0]}]}]
//! }"#;
//! let file = load::parse_problem(text).unwrap();
//! let solution = plan::plan_file(&file, PlannerKind::DEFAULT, 5.0).unwrap();
//! assert_eq!(solution.status, Status::Solved, "{}", solution.message);
//! assert_eq!(solution.assignment, [Some(0)]);
//!
//! // The validator checks the five rules of the format on its own.
//! let problem = load::problem::<Fleet, DOF>(&file).unwrap();
//! let report = validate::validate::<Fleet, DOF>(&file, &problem, &solution);
//! assert!(report.is_valid(), "{}", report.summary());
//! ```

pub mod approach;
pub mod assignment;
pub mod bench;
pub mod demo;
pub mod error;
pub mod execute;
pub mod format;
pub mod ik;
pub mod import;
pub mod live;
pub mod load;
pub mod models;
pub mod online;
pub mod plan;
pub mod planners;
pub mod pose;
pub mod suite;
pub mod validate;
pub mod view;
