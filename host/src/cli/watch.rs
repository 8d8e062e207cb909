//! The watchdog options shared by `execute`, `demo` and `online`: one set of fault-detection
//! settings, their defaults those of [`WatchSettings::default`] (which the fault matrix test
//! and the README's fault table use too), printed by each command at start.

use std::time::Duration;

use omcbsa_hw::WatchSettings;

#[derive(clap::Args, Clone, Debug)]
pub struct WatchArgs {
    /// Per-cycle accounting: a drive that has not answered SYNC k when SYNC k+M is due (or
    /// answers more than M periods late) stops every arm.
    #[arg(long, value_name = "M", default_value_t = WatchSettings::default().missed_cycles)]
    missed_cycles: u32,
    /// Heartbeat producer time written into every drive (0x1017), ms.
    #[arg(long, value_name = "MS", default_value_t = WatchSettings::default().heartbeat_ms)]
    heartbeat_ms: u16,
    /// Heartbeat consumer time as a multiple of the producer time (CiA 301 practice: 1.5-2).
    #[arg(long, value_name = "X", default_value_t = WatchSettings::default().heartbeat_factor)]
    heartbeat_factor: f64,
    /// Following error time-out written into every drive (0x6066), ms.
    #[arg(long, value_name = "MS",
          default_value_t = WatchSettings::default().following_error_timeout_ms)]
    following_error_timeout_ms: u16,
    /// How long a drive's position trails its target in normal motion, ms: each drive's
    /// following error window (0x6065) is its joint's peak speed x 2 x (lag + period).
    #[arg(long, value_name = "MS",
          default_value_t = WatchSettings::default().drive_lag.as_millis() as u64)]
    drive_lag_ms: u64,
    /// The executor's own following error check (second line), rad.
    #[arg(long, value_name = "RAD",
          default_value_t = WatchSettings::default().following_error_bound)]
    following_error_bound: f64,
    /// Backstop on the wall clock: an answer missing this long, or an arm this far behind the
    /// common schedule, stops every arm, ms.
    #[arg(long, value_name = "MS",
          default_value_t = WatchSettings::default().feedback_timeout.as_millis() as u64)]
    feedback_timeout_ms: u64,
}

impl WatchArgs {
    /// The settings, checked; an error names the option.
    pub fn settings(&self) -> Result<WatchSettings, String> {
        let settings = WatchSettings {
            missed_cycles: self.missed_cycles,
            heartbeat_ms: self.heartbeat_ms,
            heartbeat_factor: self.heartbeat_factor,
            following_error_timeout_ms: self.following_error_timeout_ms,
            drive_lag: Duration::from_millis(self.drive_lag_ms),
            following_error_bound: self.following_error_bound,
            feedback_timeout: Duration::from_millis(self.feedback_timeout_ms),
        };
        settings
            .check()
            .map_err(|e| format!("watchdog options: {e}"))?;
        Ok(settings)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        watch: WatchArgs,
    }

    #[test]
    fn defaults_are_the_libraries_and_options_are_checked() {
        let cli = Cli::try_parse_from(["x"]).unwrap();
        assert_eq!(cli.watch.settings().unwrap(), WatchSettings::default());
        let cli = Cli::try_parse_from(["x", "--missed-cycles", "3", "--drive-lag-ms", "4"]);
        let s = cli.unwrap().watch.settings().unwrap();
        assert_eq!(
            (s.missed_cycles, s.drive_lag),
            (3, Duration::from_millis(4))
        );
        let bad = Cli::try_parse_from(["x", "--heartbeat-factor", "0.5"]).unwrap();
        assert!(bad
            .watch
            .settings()
            .unwrap_err()
            .contains("heartbeat factor"));
        assert!(Cli::try_parse_from(["x", "--missed-cycles", "-1"]).is_err());
    }
}
