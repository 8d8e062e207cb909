//! How a cell ([`crate::cell::Cell`]) reaches its arms: a [`Connector`] turns each
//! [`CellArm`] into the port the executor drives it through ([`ArmPort`]), with whatever must
//! live as long as the cell ([`ArmGuard`]: a stand-in arm's process, say, and what it
//! records). [`RealArms`] reaches real arms by their URLs ([`ArmUrl`]); the crate
//! `omcbsa-mock` has a connector that also starts mock arms.

use crate::kortex::Credentials;
use crate::plan::ArmLimits;
use crate::port::{ArmPort, ArmUrl, OpenError};
use crate::run::{ExecConfig, JOINTS};
use serde_json::Value;
use std::fmt;
use std::time::Duration;

/// One arm of a cell, at a URL of type `U` (its connector's [`Connector::Url`]).
#[derive(Clone, Debug)]
pub struct CellArm<U = ArmUrl> {
    /// The arm's name.
    pub name: String,
    /// Where it is.
    pub url: U,
    /// Where it stands, rad: the cell's first waypoint (a real arm must be within
    /// [`ExecConfig::start_tolerance`] of it; a stand-in arm is started there).
    pub start: [f64; JOINTS],
    /// Its joint limits.
    pub limits: ArmLimits,
}

/// Why an arm's guard could not say what the arm recorded.
pub type GuardError = Box<dyn std::error::Error + Send + Sync>;

/// What must live as long as the cell that an arm is in (a stand-in arm's process); dropped, it
/// ends what it holds at once.
pub trait ArmGuard: Send {
    /// Waits for what it holds to end once the cell has closed the arm's port: what the arm
    /// recorded (it received, for a stand-in arm).
    fn finish(self: Box<Self>) -> Result<Vec<Value>, GuardError>;
}

/// An arm reached: its port, and what must live as long as the cell (`None` for a real arm).
pub struct Connected {
    /// The arm's port, open.
    pub port: ArmPort,
    /// Ended after the run; its record is returned with the cell's end.
    pub guard: Option<Box<dyn ArmGuard>>,
}

impl From<ArmPort> for Connected {
    fn from(port: ArmPort) -> Self {
        Connected { port, guard: None }
    }
}

/// Why an arm could not be reached.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// A Kortex arm, and the connector has no credentials to reach it with.
    #[error("a Kortex arm needs credentials")]
    NoCredentials,
    /// The arm's port could not be opened: why (boxed: the rest are small).
    #[error(transparent)]
    Open(Box<OpenError>),
    /// The arm cannot keep up with the cell's period.
    #[error(
        "{what} runs at a period of {fastest:?} at the fastest; the cell's period is {period:?}"
    )]
    TooFast {
        /// What the arm is.
        what: &'static str,
        /// Its shortest period.
        fastest: Duration,
        /// The cell's.
        period: Duration,
    },
    /// A stand-in arm could not be started: why.
    #[error("{0}")]
    Start(String),
}

/// Turns the arms of a cell into ports: see the module.
pub trait Connector {
    /// Where an arm is, as this connector reads it.
    type Url: Clone + fmt::Debug + fmt::Display;

    /// The control period an arm at `url` runs at by default.
    fn default_period(&self, url: &Self::Url) -> Duration;

    /// Whether `arm` can run with `config`: checked for every arm before any is connected.
    fn check(&self, arm: &CellArm<Self::Url>, config: &ExecConfig) -> Result<(), ConnectError> {
        let _ = (arm, config);
        Ok(())
    }

    /// Reaches `arm` for a run with `config`.
    fn connect(
        &self,
        arm: &CellArm<Self::Url>,
        config: &ExecConfig,
    ) -> Result<Connected, ConnectError>;
}

/// Real arms, by their URLs: a Kortex arm is reached with [`RealArms::credentials`].
#[derive(Clone, Debug, Default)]
pub struct RealArms {
    /// Who Kortex arms are reached as.
    pub credentials: Option<Credentials>,
}

impl Connector for RealArms {
    type Url = ArmUrl;

    fn default_period(&self, url: &ArmUrl) -> Duration {
        url.default_period()
    }

    fn connect(&self, arm: &CellArm, _: &ExecConfig) -> Result<Connected, ConnectError> {
        let none = Credentials {
            username: String::new(),
            password: String::new(),
        };
        let credentials = match (&arm.url, &self.credentials) {
            (ArmUrl::Kortex(_), None) => return Err(ConnectError::NoCredentials),
            (_, c) => c.as_ref().unwrap_or(&none),
        };
        let port = arm
            .url
            .open(credentials)
            .map_err(|e| ConnectError::Open(Box::new(e)))?;
        Ok(port.into())
    }
}
