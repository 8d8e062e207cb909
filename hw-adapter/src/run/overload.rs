//! A CAN bus that would carry more than its arms may load it ([`BusOverload`]), as the
//! executor refuses it (`ExecError::BusLoad`); `crate::bus` computes the numbers.

use std::fmt;
use std::time::Duration;

/// A CAN bus the arms on it would load over the allowed share, with the ways out: every
/// number a caller needs to choose one, computed for this bus.
#[derive(Clone, Debug, PartialEq)]
pub struct BusOverload {
    /// The bus, as its transport names it (`socketcan:can0`, `slcan:/dev/ttyACM0`).
    pub bus: String,
    /// The arms on it, in the run's order.
    pub arms: Vec<String>,
    /// Its bitrate, bit/s.
    pub bitrate: u32,
    /// The run's control period.
    pub period: Duration,
    /// The arms' traffic at that period, bit/s (worst-case stuffing).
    pub bits_per_second: f64,
    /// The share of the bus allowed (0.7 by default).
    pub max_share: f64,
    /// The shortest control period, in whole milliseconds, at which these arms fit on this
    /// bus (`None`: none does, their heartbeats alone fill it).
    pub fitting_period: Option<Duration>,
    /// The share one arm alone loads such a bus at the run's period.
    pub one_arm_share: f64,
    /// The lowest CiA 301 bitrate at which these arms fit at the run's period (`None`: none
    /// up to 1 Mbit/s).
    pub fitting_bitrate: Option<u32>,
}

impl BusOverload {
    /// The share of the bus's bit time the arms would take (1.0 = all of it).
    pub fn share(&self) -> f64 {
        self.bits_per_second / f64::from(self.bitrate)
    }
}

impl fmt::Display for BusOverload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        write!(
            f,
            "CAN bus {} (arm{} {}) would be loaded {:.1} % ({:.0} kbit/s of {:.0} kbit/s) at a \
             {} ms control period, over the {:.0} % a bus may carry (worst-case bit stuffing); \
             ways out:",
            self.bus,
            if self.arms.len() == 1 { "" } else { "s" },
            self.arms.join(", "),
            self.share() * 100.0,
            self.bits_per_second / 1e3,
            f64::from(self.bitrate) / 1e3,
            ms(self.period),
            self.max_share * 100.0,
        )?;
        match self.fitting_period {
            Some(p) => write!(f, " a control period of {} ms or longer fits", ms(p))?,
            None => write!(f, " no control period fits")?,
        }
        if self.arms.len() > 1 {
            let fits = self.one_arm_share <= self.max_share;
            write!(
                f,
                "; or one bus per arm (one arm alone loads {:.1} %{})",
                self.one_arm_share * 100.0,
                if fits { ", which fits" } else { ": over too" }
            )?;
        }
        match self.fitting_bitrate {
            Some(b) => write!(f, "; or a bitrate of {:.0} kbit/s", f64::from(b) / 1e3),
            None => write!(f, "; no bitrate up to CAN's 1 Mbit/s fits at this period"),
        }
    }
}
