//! The executor refuses a CAN bus its arms would load over `bus::MAX_LOAD`, before any arm is
//! set up, and accepts one arm per bus at the default CAN period.

use omcbsa_hw::bus::CAN_PERIOD;
use omcbsa_hw::{ArmPlan, ExecConfig, ExecError, Executor, Plan, PlanValidator, Transport, JOINTS};
use omcbsa_mock::sim::can::{CanSim, CanSimOptions};
use omcbsa_mock::transport::MockTransport;
use std::time::Duration;

const ARMS: [&str; 3] = ["left", "right", "middle"];

struct Accept;
impl PlanValidator for Accept {
    fn validate(&self, _: &Plan) -> Result<(), String> {
        Ok(())
    }
}

fn plan() -> Plan {
    Plan {
        dt: 0.25,
        arms: ARMS
            .map(|name| ArmPlan {
                name: name.into(),
                joint_path: vec![[0.0; JOINTS], [0.01; JOINTS], [0.01; JOINTS]],
            })
            .into(),
    }
}

fn config() -> ExecConfig {
    ExecConfig {
        period: CAN_PERIOD,
        ..ExecConfig::default()
    }
}

#[test]
fn three_arms_on_one_bus_are_refused_before_any_is_set_up() {
    // Three ends named alike: one bus (as three arms on `socketcan://can0` would be).
    let (hosts, mut devices): (Vec<_>, Vec<_>) =
        ARMS.iter().map(|_| MockTransport::pair("can0")).unzip();
    let arms: Vec<(String, Box<dyn Transport>)> = (ARMS.iter().zip(hosts))
        .map(|(n, h)| (n.to_string(), Box::new(h) as Box<dyn Transport>))
        .collect();
    let limits = omcbsa_mock::testing::fleet_limits(ARMS.len());
    let e = Executor::new(plan(), limits, arms, config())
        .unwrap()
        .run(&Accept)
        .unwrap_err();
    let ExecError::BusLoad(overload) = &e else {
        panic!("not refused for its load: {e}")
    };
    assert_eq!(overload.bus, "mock:can0");
    assert_eq!(overload.arms, ARMS);
    assert!(
        (overload.share() - 1.262).abs() < 1e-3,
        "{}",
        overload.share()
    );
    assert_eq!(overload.fitting_period, Some(Duration::from_millis(8)));
    let text = e.to_string();
    for part in [
        "refusing to start: CAN bus mock:can0 (arms left, right, middle) would be loaded 126.2 % \
         (1262 kbit/s of 1000 kbit/s) at a 4 ms control period, over the 70 %",
        "a control period of 8 ms or longer fits",
        "one bus per arm (one arm alone loads 42.1 %, which fits)",
    ] {
        assert!(text.contains(part), "{text}");
    }
    std::thread::sleep(Duration::from_millis(20));
    for d in &mut devices {
        assert!(d.drain().is_empty(), "a frame reached an arm");
    }

    // Online alike.
    let (hosts, _devices): (Vec<_>, Vec<_>) =
        ARMS.iter().map(|_| MockTransport::pair("can0")).unzip();
    let arms = (ARMS.iter().zip(hosts))
        .map(|(n, h)| {
            (
                n.to_string(),
                [0.0; JOINTS],
                Box::new(h) as Box<dyn Transport>,
            )
        })
        .collect();
    let limits = omcbsa_mock::testing::fleet_limits(ARMS.len());
    let e = Executor::online(arms, 0.25, 1.0, &limits, config()).err();
    assert!(matches!(e, Some(ExecError::BusLoad(_))), "{e:?}");
}

#[test]
fn one_arm_per_bus_at_the_default_period_is_accepted() {
    // 42.1 % of each 1 Mbit/s bus.
    let (sims, arms): (Vec<CanSim>, Vec<_>) = ARMS
        .iter()
        .map(|n| {
            let (sim, bus) = CanSim::spawn(CanSimOptions::at([0.0; JOINTS]));
            (sim, (n.to_string(), bus))
        })
        .unzip();
    let limits = omcbsa_mock::testing::fleet_limits(ARMS.len());
    let report = Executor::new(plan(), limits, arms, config())
        .unwrap()
        .run(&Accept)
        .unwrap();
    assert_eq!(report.period, CAN_PERIOD);
    for sim in sims {
        let seen = sim.finish();
        assert_eq!(seen.commands.last(), Some(&[100_000; JOINTS]));
    }
}
