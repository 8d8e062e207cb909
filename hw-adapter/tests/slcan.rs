//! The SLCAN transport against a scripted adapter on a pseudo-terminal.

use nix::pty::openpty;
use omcbsa_hw::transport::slcan::{SlcanTransport, DEFAULT_BITRATE};
use omcbsa_hw::{CanFrame, Transport, TransportError};
use std::fs::File;
use std::io::{Read, Write};
use std::time::Duration;

#[test]
fn opens_sends_and_receives_over_a_pty() {
    let pty = openpty(None, None).unwrap();
    let path = nix::unistd::ttyname(&pty.slave).unwrap();
    let mut master = File::from(pty.master);
    // The adapter: acknowledge C (bell: already closed), S6 and O, then record what comes.
    let adapter = std::thread::spawn(move || {
        let mut seen = Vec::new();
        let mut buf = [0u8; 256];
        while !seen.ends_with(b"O\r") {
            let n = master.read(&mut buf).unwrap();
            for &b in &buf[..n] {
                seen.push(b);
                if b == b'\r' {
                    let reply: &[u8] = if seen.ends_with(b"C\r") {
                        b"\x07"
                    } else {
                        b"\r"
                    };
                    master.write_all(reply).unwrap();
                }
            }
        }
        // a transmit ack, a frame with a timestamp, a heartbeat, then a bell
        master
            .write_all(b"z\rt18560102030405061234\rt701105\r\x07")
            .unwrap();
        while !seen.ends_with(b"t0800\r") {
            let n = master.read(&mut buf).unwrap();
            seen.extend_from_slice(&buf[..n]);
        }
        (master, String::from_utf8(seen).unwrap())
    });
    let mut t = SlcanTransport::open(path.to_str().unwrap(), DEFAULT_BITRATE).unwrap();
    let tpdo = t.recv(Duration::from_secs(1)).unwrap().unwrap();
    assert_eq!(tpdo, CanFrame::new(0x185, &[1, 2, 3, 4, 5, 6]).unwrap());
    assert_eq!(
        t.recv(Duration::from_secs(1)).unwrap().unwrap(),
        CanFrame::new(0x701, &[5]).unwrap()
    );
    // the bell after them: the adapter reports an error
    assert!(matches!(
        t.recv(Duration::from_secs(1)),
        Err(TransportError::Io { .. })
    ));
    t.send(
        &CanFrame::new(0x080, &[]).unwrap(),
        Duration::from_millis(100),
    )
    .unwrap();
    let (_master, seen) = adapter.join().unwrap();
    assert_eq!(seen, "C\rS6\rO\rt0800\r");
}
