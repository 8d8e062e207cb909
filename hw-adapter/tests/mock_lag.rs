//! The Python mocks' joints follow their last command with a first-order lag in time (a time
//! constant), between commands too, as a real arm's do: with a time constant of 100 ms, the
//! feedback a while after a command shows the joint nearer its target than the feedback right
//! after it, with no command in between.

use omcbsa_hw::arm::ArmBus;
use omcbsa_hw::cia402::{rad_to_counts, CW_ENABLE_OPERATION};
use omcbsa_hw::kortex::channel::Channel;
use omcbsa_hw::kortex::header::uid;
use omcbsa_hw::kortex::proto::{self, base, base_cyclic};
use omcbsa_hw::link::ArmLink;
use omcbsa_hw::{Command, JOINTS};
use omcbsa_mock::mock::{exec_config, script_path, venv_python, MockArm, MockArmOptions};
use omcbsa_mock::mock_gen3::{self, MockGen3};
use prost::Message;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

const T: Duration = Duration::from_secs(2);

fn record(tag: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("omcbsa-lag-{tag}-{}.jsonl", std::process::id()))
}

/// Fraction of the way from 0 to the commanded step joint 1 is at, per feedback.
fn kortex_fraction(udp: &mut Channel, step: f32) -> f64 {
    let (_, p) = udp.call(uid::REFRESH_FEEDBACK, &[], T).unwrap();
    let f = base_cyclic::Feedback::decode(p.as_slice()).unwrap();
    f64::from(f.actuators[0].position) / f64::from(step)
}

#[test]
fn the_mock_gen3_keeps_moving_toward_its_command_between_commands() {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let extra = ["--tau-ms=100".to_string()];
    let period = Duration::from_millis(100);
    let mock = MockGen3::spawn(
        &python,
        "lag",
        &[0.0; JOINTS],
        period,
        &record("kortex"),
        &extra,
    )
    .unwrap();
    let mut tcp = Channel::tcp(([127, 0, 0, 1], mock.tcp_port).into()).unwrap();
    let mut udp = Channel::udp(([127, 0, 0, 1], mock.udp_port).into()).unwrap();
    let c = mock_gen3::credentials();
    let login = proto::CreateSessionInfo {
        username: c.username,
        password: c.password,
        session_inactivity_timeout: 60000,
        connection_inactivity_timeout: 5000,
    };
    for link in [&mut tcp, &mut udp] {
        let (h, _) = link
            .call(uid::CREATE_SESSION, &login.encode_to_vec(), T)
            .unwrap();
        link.session = h.session_id;
    }
    let mode = base::ServoingModeInformation {
        servoing_mode: base::ServoingMode::LowLevelServoing as i32,
    };
    tcp.call(uid::SET_SERVOING_MODE, &mode.encode_to_vec(), T)
        .unwrap();
    let refresh = |frame_id: u32, joint1: f32| base_cyclic::Command {
        frame_id,
        actuators: (0..JOINTS)
            .map(|j| base_cyclic::ActuatorCommand {
                command_id: frame_id,
                position: if j == 0 { joint1 } else { 0.0 },
                ..Default::default()
            })
            .collect(),
    };
    udp.call(uid::REFRESH, &refresh(1, 0.0).encode_to_vec(), T)
        .unwrap();
    // 2 degrees in 100 ms: within the Gen3's 50 degrees/s.
    let step = 2.0;
    udp.call(uid::REFRESH, &refresh(2, step).encode_to_vec(), T)
        .unwrap();
    let sent = Instant::now();
    let at_once = kortex_fraction(&mut udp, step);
    let quick = sent.elapsed();
    std::thread::sleep(Duration::from_millis(150));
    let later = kortex_fraction(&mut udp, step);
    std::thread::sleep(Duration::from_millis(450));
    let settled = kortex_fraction(&mut udp, step);
    println!(
        "after {quick:?}: {at_once:.3}, after ~150 ms: {later:.3}, after ~600 ms: {settled:.3}"
    );
    // 1 - exp(-t / 100 ms): a few percent at once, 78 % at 150 ms, all of it at 600 ms.
    assert!(at_once < 0.5, "{at_once}");
    assert!((0.7..0.95).contains(&later), "{later}");
    assert!(settled > 0.99, "{settled}");
    drop((tcp, udp));
    mock.finish().unwrap();
}

#[test]
fn the_mock_drives_keep_moving_toward_their_target_between_syncs() {
    let python = venv_python().unwrap_or_else(|e| panic!("{e}"));
    let opts = MockArmOptions {
        initial: [0.0; JOINTS],
        record: None,
        bus_log: None,
        extra_args: vec!["--tau=0.1".into()],
    };
    let mock = MockArm::spawn(&python, &script_path(), "lag", &opts).unwrap();
    let cfg = exec_config();
    let bus = mock.open_bus().unwrap();
    let mut arm = ArmBus::new("lag".into(), bus, Instant::now(), &cfg, None);
    let rest: Command = [0; JOINTS];
    let span = [(-1_000_000, 1_000_000); JOINTS];
    let speed = [0.5; JOINTS];
    ArmBus::configure(
        &mut arm,
        &cfg,
        &omcbsa_hw::link::StartPlan {
            first: rest,
            span,
            speed,
        },
        &AtomicBool::new(false),
    )
    .unwrap();
    ArmBus::enable(&mut arm, &cfg).unwrap();
    // Joint 5 (10 rad/s², 10 ms a cycle): 0.9 mrad from rest is within its limits.
    let mut target = rest;
    let step = rad_to_counts(0.9e-3).unwrap();
    target[4] = step;
    let fraction = |arm: &mut ArmBus| {
        let deadline = Instant::now() + T;
        let before = arm.measured().and_then(|m| m.cycle);
        loop {
            arm.poll().unwrap();
            let m = arm.measured().unwrap();
            if m.cycle != before {
                return m.positions[4] / 0.9e-3;
            }
            assert!(Instant::now() < deadline, "no TPDO");
            std::thread::sleep(Duration::from_millis(1));
        }
    };
    // The SYNC that applies the target: its TPDO reports where the joint was (at rest).
    arm.send_cycle(&target, CW_ENABLE_OPERATION).unwrap();
    let at_sync = fraction(&mut arm);
    // 150 ms with no SYNC, then one holding the same target.
    std::thread::sleep(Duration::from_millis(150));
    arm.send_cycle(&target, CW_ENABLE_OPERATION).unwrap();
    let later = fraction(&mut arm);
    println!("at the target's SYNC: {at_sync:.3}, 150 ms later: {later:.3}");
    assert!(at_sync < 0.2, "{at_sync}");
    // 1 - exp(-150 ms / 100 ms) = 78 %: the joint moved between the SYNCs.
    assert!((0.7..0.95).contains(&later), "{later}");
    ArmBus::finish(&mut arm, &target).unwrap();
    drop(arm);
    mock.finish().unwrap();
}
