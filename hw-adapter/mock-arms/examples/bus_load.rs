//! How many CiA 402 arms fit on one CAN bus at each control period, from the bus model
//! (`omcbsa_hw::bus`: worst-case bit stuffing, the frames the executor sends and the drives
//! answer, heartbeats at the default producer time), under the load the executor allows
//! (`bus::MAX_LOAD`): the markdown tables of docs/HARDWARE.md.
//!
//! cargo run -p omcbsa-mock --example bus_load

use omcbsa_hw::bus::{self, ArmTraffic, MAX_LOAD, PERIODS};
use omcbsa_hw::WatchSettings;
use std::time::Duration;

fn main() {
    let heartbeat = Duration::from_millis(WatchSettings::default().heartbeat_ms.into());
    let arm = ArmTraffic::cia402(heartbeat);
    let ms = |p: Duration| p.as_secs_f64() * 1e3;
    let header = |first: &str| {
        let periods: Vec<String> = PERIODS.iter().map(|&p| format!("{} ms", ms(p))).collect();
        println!("| {first} | {} |", periods.join(" | "));
        println!("|---|{}", "---|".repeat(PERIODS.len()));
    };
    let bitrates = [bus::DEFAULT_BITRATE, 500_000];
    println!(
        "One arm: {} frames, {} bits a cycle (worst-case stuffing), and {} bits of heartbeats \
         every {} ms.\n",
        arm.frames_per_cycle,
        arm.bits_per_cycle,
        arm.heartbeat_bits,
        ms(heartbeat)
    );
    header("one arm loads");
    for bitrate in bitrates {
        let shares: Vec<String> = (PERIODS.iter())
            .map(|&p| {
                let share = arm.bits_per_second(p) / f64::from(bitrate);
                format!("{:.1} %", share * 100.0)
            })
            .collect();
        println!("| {} kbit/s | {} |", bitrate / 1000, shares.join(" | "));
    }
    println!("\nArms per bus within {:.0} % of it:\n", MAX_LOAD * 100.0);
    header("arms per bus");
    for bitrate in bitrates {
        let fit: Vec<String> = (PERIODS.iter())
            .map(|&p| arm.arms_that_fit(bitrate, p, MAX_LOAD).to_string())
            .collect();
        println!("| {} kbit/s | {} |", bitrate / 1000, fit.join(" | "));
    }
}
