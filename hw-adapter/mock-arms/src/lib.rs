//! omcbsa's stand-in arms, for tests, the demo and measurements: nothing of it is needed to
//! drive real arms, and `omcbsa-hw`'s own API has none of it.
//!
//! - [`mock`] and [`mock_gen3`] start the Python mock arms (`hw-adapter/mock/`: CiA 402 drives
//!   behind an SLCAN adapter, a Gen3 on Kortex); [`arms`] starts either kind alike
//!   ([`arms::MockArms`]); [`record`] and [`buslog`] check what they received.
//! - [`connect`]: the cell's connector ([`omcbsa_hw::connect::Connector`]) that also understands
//!   the mock URLs `mock-can` and `mock-kortex` ([`connect::ArmOrMockUrl`]), starting a mock for
//!   each and returning its record when the cell ends; real arms are left to
//!   [`omcbsa_hw::connect::RealArms`].
//! - [`sim`]: simulated arms in process at the frame level, at the default rates, and the
//!   fault matrix; [`transport`]: the in-process CAN bus they answer on.
//! - [`testing`]: joint limits for tests and examples run without the host.
#![deny(missing_docs)]

pub mod arms;
pub mod buslog;
pub mod connect;
pub mod mock;
pub mod mock_gen3;
pub mod record;
pub mod sim;
pub mod testing;
pub mod transport;
