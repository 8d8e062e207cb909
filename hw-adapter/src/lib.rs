//! omcbsa hardware adapter: streams a multi-arm joint-space plan to Kinova Gen3 arms, over CAN
//! (CANopen CiA 301 / CiA 402 cyclic synchronous position, one bus per arm) or over Ethernet
//! with Kinova's Kortex protocol, all arms behind one loop.
//!
//! The layers, each depending only on those below it:
//! - [`run`]: the vocabulary of a run (units, settings, faults, reports); it imports nothing
//!   else of the crate. [`plan`]: the executor's input and the limit check of a command.
//! - [`spline`], [`stream`], [`interpolate`]: waypoints to control-rate commands within joint
//!   limits; the frame generator computes them cycle by cycle from a queue of waypoints that
//!   may be replaced while the arms move.
//! - [`watchdog`]: per-cycle accounting of the answers to each cycle, whatever the transport.
//! - [`link`]: the [`link::ArmLink`] trait, one arm as the loop drives it. Its two
//!   implementations: [`arm`] (CiA 402 drives on a CAN bus: [`transport`], [`canopen`],
//!   [`cia402`]) and [`kortex`] (messages, framing, sessions, the Gen3).
//! - [`live`]: the loop, one thread per arm in lockstep; [`port`]: what a caller hands in per
//!   arm ([`port::ArmUrl`]: where an arm is) and the link made of it; [`executor`]:
//!   [`Executor`], which composes them: validation gate, start-up, streaming, fault handling,
//!   log.
//! - [`cell`]: arms streamed together while a policy runs: start, push chunks, status, stop;
//!   [`connect`]: how a cell reaches each arm ([`connect::Connector`]; [`connect::RealArms`]
//!   for real ones).
//! - No test doubles: the mock arms, simulators, the in-process bus and the test limits are
//!   the crate `omcbsa-mock` (`hw-adapter/mock-arms`), which also connects a cell to mocks.
//! - [`priority`]: real-time scheduling of the arm threads; [`timing`]: whether the machine
//!   holds a control rate (the preflight of every run); [`log`]: the command log.
//!
//! A dry run computes and checks every command of a plan without any arm:
//!
//! ```
//! use omcbsa_hw::{ArmPlan, ExecConfig, Executor, Plan, PlanValidator, JOINTS};
//!
//! struct Accept;
//! impl PlanValidator for Accept {
//!     fn validate(&self, _: &Plan) -> Result<(), String> { Ok(()) }
//! }
//!
//! let path = |to: f64| vec![[0.0; JOINTS], [to; JOINTS], [to; JOINTS]];
//! let plan = Plan {
//!     dt: 0.5,
//!     arms: vec![
//!         ArmPlan { name: "left".into(), joint_path: path(0.02) },
//!         ArmPlan { name: "right".into(), joint_path: path(-0.02) },
//!     ],
//! };
//! let cfg = ExecConfig { dry_run: true, ..ExecConfig::default() };
//! let limits = omcbsa_mock::testing::fleet_limits(2);
//! let no_ports: Vec<(String, omcbsa_hw::ArmPort)> = Vec::new();
//! let report = Executor::new(plan, limits, no_ports, cfg)?.run(&Accept)?;
//! assert_eq!(report.time_scale, 1.0); // within the limits as planned
//! // 1 s of motion at 2 ms, then the hold on the last waypoint.
//! assert_eq!(report.cycles, 501);
//! assert_eq!(report.frames_sent, 2 * 501 * (JOINTS + 1)); // an RPDO per joint and a SYNC
//! # Ok::<(), omcbsa_hw::ExecError>(())
//! ```
#![deny(missing_docs)]

pub mod arm;
pub mod bus;
pub mod canopen;
pub mod cell;
pub mod cia402;
pub mod connect;
pub mod executor;
pub mod frame;
pub mod interpolate;
pub mod kortex;
pub mod link;
pub mod live;
pub mod log;
pub mod plan;
/// The spline every joint follows, shared with the core's retiming.
pub use omcbsa_core::spline;
pub mod port;
pub mod priority;
pub mod run;
pub mod stream;
pub mod timing;
pub mod transport;
pub mod watchdog;

// The unit tests take their joint limits from `omcbsa-mock`'s source: the crate cannot depend
// on it for them (its tests would see two `omcbsa_hw`s), and the file names `omcbsa_hw`.
#[cfg(test)]
extern crate self as omcbsa_hw;
#[cfg(test)]
#[path = "../mock-arms/src/testing.rs"]
mod testing;

pub use executor::Executor;
pub use frame::CanFrame;
pub use live::{Event, StreamHandle, StreamProgress};
pub use plan::{ArmLimits, ArmPlan, JointLimits, Plan, PlanValidator};
pub use port::{ArmPort, ArmPorts};
pub use run::{
    ArmReport, ArmState, ArmStatus, ArmStop, BusOverload, Command, CycleFault, ExecConfig,
    ExecError, Fault, FaultReport, Measured, Progress, Report, Span, WatchSettings, JOINTS,
    STOP_BOUND_PERIODS,
};
pub use stream::PushError;
pub use transport::{Transport, TransportError};
