//! How much of its model's documented joint limits an arm may use: a cell's safety margin.
//!
//! The models carry the vendors' limits ([`crate::model::Model::VELOCITY`],
//! [`crate::model::Model::ACCELERATION`], [`crate::model::Model::JERK`]); a cell may scale the
//! velocity and acceleration limits down (a person nearby, a fragile load). Planners, the
//! validator and the executor all read an arm's limits through its [`LimitScale`], so that
//! what is planned is what is checked and streamed. Jerk is not scaled: it bounds how fast the
//! actuators can change their torque, which a slower cell does not change. Costs nothing: two
//! `f64` per robot.
//!
//! ```
//! use omcbsa_core::limits::{LimitScale, ScaleError};
//! use omcbsa_core::model::{KinovaGen3, Model};
//!
//! let half = LimitScale::new(0.5, 0.25).unwrap();
//! let v = half.velocity::<KinovaGen3, 7>(0);
//! assert_eq!(v[0], 0.5 * KinovaGen3::VELOCITY[0]);
//! assert_eq!(half.acceleration::<KinovaGen3, 7>(0)[6], 0.25 * KinovaGen3::ACCELERATION[6]);
//! assert_eq!(LimitScale::default().velocity::<KinovaGen3, 7>(0), KinovaGen3::VELOCITY);
//!
//! // A scale outside (0, 1] is refused, naming which.
//! assert_eq!(LimitScale::new(1.5, 1.0), Err(ScaleError::Velocity(1.5)));
//! assert!(matches!(LimitScale::new(1.0, f64::NAN), Err(ScaleError::Acceleration(_))));
//! ```

use crate::model::Models;

/// Fractions of the documented velocity and acceleration limits an arm may use, each in
/// (0, 1]; 1 (the hardware's limits) by default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimitScale {
    velocity: f64,
    acceleration: f64,
}

/// A scale outside (0, 1] (or not a number), with the value given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScaleError {
    /// The velocity scale.
    Velocity(f64),
    /// The acceleration scale.
    Acceleration(f64),
}

impl Default for LimitScale {
    fn default() -> Self {
        LimitScale::FULL
    }
}

impl LimitScale {
    /// The documented limits themselves.
    pub const FULL: LimitScale = LimitScale {
        velocity: 1.0,
        acceleration: 1.0,
    };

    /// The scale using `velocity` and `acceleration` of the documented limits; each must be in
    /// (0, 1].
    pub fn new(velocity: f64, acceleration: f64) -> Result<Self, ScaleError> {
        let fraction = |s: f64| s > 0.0 && s <= 1.0;
        if !fraction(velocity) {
            return Err(ScaleError::Velocity(velocity));
        }
        if !fraction(acceleration) {
            return Err(ScaleError::Acceleration(acceleration));
        }
        Ok(LimitScale {
            velocity,
            acceleration,
        })
    }

    /// The fraction of the velocity limits.
    pub fn velocity_scale(&self) -> f64 {
        self.velocity
    }

    /// The fraction of the acceleration limits.
    pub fn acceleration_scale(&self) -> f64 {
        self.acceleration
    }

    /// Model `model`'s velocity limits under this scale, rad/s (m/s).
    pub fn velocity<M: Models<D>, const D: usize>(&self, model: u8) -> [f64; D] {
        M::velocity(model).map(|v| v * self.velocity)
    }

    /// Model `model`'s acceleration limits under this scale, rad/s² (m/s²).
    pub fn acceleration<M: Models<D>, const D: usize>(&self, model: u8) -> [f64; D] {
        M::acceleration(model).map(|a| a * self.acceleration)
    }
}
