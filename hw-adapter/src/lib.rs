//! omcbsa hardware adapter: streams a multi-arm joint-space plan to Kinova Gen3 arms, over CAN
//! (CANopen CiA 301 / CiA 402 cyclic synchronous position, one bus per arm) or over Ethernet
//! with Kinova's Kortex protocol, all arms behind one loop.
//!
//! - [`link`]: [`link::ArmLink`], one arm as the loop drives it, CAN or Kortex.
//! - [`transport`]: the [`Transport`] trait and its SLCAN, SocketCAN and in-process mock buses.
//! - [`canopen`], [`cia402`]: the protocol.
//! - [`kortex`]: Kortex messages, framing, sessions, and the Gen3 as a [`link::ArmLink`].
//! - [`interpolate`]: waypoints to control-rate commands within joint limits.
//! - [`stream`]: the frame generator: commands cycle by cycle from a queue of waypoints that
//!   may be replaced while the arms move.
//! - [`executor`]: [`Executor`]: validation gate, start-up, streaming, fault handling, log.
//! - [`fleet`]: mock arms of either kind, started and checked alike.
//! - [`mock_gen3`]: spawns the Python mock Gen3 on Kortex and reads what it received.
//! - [`mock`]: spawns the Python mock arm (test side, also used by `omcbsa demo`); [`record`]:
//!   what a mock received, checked against the streamed trajectory; [`buslog`]: the mocks' bus
//!   logs (candump), and fault reaction times measured from them.
//! - [`testing`]: joint limits for tests and examples run without the host.
//! - [`priority`]: real-time scheduling of the arm threads.
//! - [`watch`]: the fault-detection settings of a run; [`watchdog`]: per-cycle accounting of the answers to each cycle, independent of the transport.

pub mod arm;
pub mod buslog;
pub mod canopen;
pub mod cia402;
pub mod executor;
pub mod fleet;
pub mod frame;
pub mod interpolate;
pub mod kortex;
pub mod link;
pub mod live;
pub mod log;
pub mod mock;
pub mod mock_gen3;
pub mod plan;
pub mod priority;
pub mod record;
pub mod stream;
pub mod testing;
pub mod transport;
pub mod watch;
pub mod watchdog;

pub use executor::{ExecConfig, ExecError, Executor, Fault, FaultReport, Report};
pub use frame::CanFrame;
pub use live::{Event, StreamHandle, StreamProgress};
pub use plan::{ArmLimits, ArmPlan, JointLimits, Plan, PlanValidator, JOINTS};
pub use stream::PushError;
pub use transport::{Transport, TransportError};
pub use watch::WatchSettings;
