//! SocketCAN on a virtual interface. Skips (with a message) when no vcan interface exists and
//! none can be created (needs root and the vcan kernel module).
#![cfg(all(feature = "socketcan", target_os = "linux"))]

use omcbsa_hw::transport::socketcan::SocketCanTransport;
use omcbsa_hw::{CanFrame, Transport};
use std::process::{Command, Stdio};
use std::time::Duration;

fn vcan() -> Option<&'static str> {
    let iface = "vcan0";
    let exists = || std::path::Path::new("/sys/class/net").join(iface).exists();
    if !exists() && nix::unistd::Uid::effective().is_root() {
        let _ = Command::new("ip")
            .args(["link", "add", "dev", iface, "type", "vcan"])
            .stderr(Stdio::null())
            .status();
        let _ = Command::new("ip")
            .args(["link", "set", "up", iface])
            .stderr(Stdio::null())
            .status();
    }
    exists().then_some(iface)
}

#[test]
fn frames_round_trip_on_vcan() {
    let Some(iface) = vcan() else {
        eprintln!("SKIPPED: no vcan0 interface and none could be created (needs root and the vcan module)");
        return;
    };
    let mut a = SocketCanTransport::open(iface).unwrap();
    let mut b = SocketCanTransport::open(iface).unwrap();
    let f = CanFrame::new(0x203, &[1, 2, 3, 4, 0x0F, 0]).unwrap();
    a.send(&f, Duration::from_millis(10)).unwrap();
    assert_eq!(b.recv(Duration::from_millis(100)).unwrap(), Some(f));
    assert_eq!(b.recv(Duration::ZERO).unwrap(), None);
}

#[test]
fn missing_interface_is_a_clear_error() {
    let e = SocketCanTransport::open("nocan7")
        .err()
        .unwrap()
        .to_string();
    assert!(e.starts_with("cannot open CAN bus socketcan:nocan7"), "{e}");
}
