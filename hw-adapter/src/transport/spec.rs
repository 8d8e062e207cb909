//! A bus spec (`slcan:PATH`, `socketcan:IFACE`, the command line's `--arm NAME=SPEC`) checked,
//! and the bus it names opened.

#[cfg(all(feature = "socketcan", target_os = "linux"))]
use super::socketcan::SocketCanTransport;
use super::{slcan, Transport, TransportError};

/// A bus spec, checked: what [`open`] opens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BusSpec<'a> {
    /// A serial-line CAN adapter at this device path.
    Slcan(&'a str),
    /// A SocketCAN interface.
    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    SocketCan(&'a str),
}

impl<'a> BusSpec<'a> {
    /// Parses `slcan:PATH` or `socketcan:IFACE` (the `--arm NAME=SPEC` syntax), refusing what
    /// no live run could open: an empty path, a path with a NUL byte, an interface name Linux
    /// would not accept (1 to 15 bytes, no `/`, `:`, whitespace, not `.` or `..`), SocketCAN
    /// in a build without it. A dry run checks its buses with this.
    pub fn parse(spec: &'a str) -> Result<Self, TransportError> {
        let bad = |reason: &str| TransportError::Open {
            bus: spec.to_string(),
            reason: reason.to_string(),
        };
        match spec.split_once(':') {
            Some(("slcan", "")) => Err(bad("the serial device path is empty")),
            Some(("slcan", path)) if path.contains('\0') => {
                Err(bad("the serial device path contains a NUL byte"))
            }
            Some(("slcan", path)) => Ok(BusSpec::Slcan(path)),
            #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
            Some(("socketcan", _)) => Err(bad(
                "SocketCAN support is not built in (Linux with the `socketcan` feature only)",
            )),
            #[cfg(all(feature = "socketcan", target_os = "linux"))]
            Some(("socketcan", iface)) => {
                let valid = (1..=15).contains(&iface.len())
                    && iface != "."
                    && iface != ".."
                    && !iface
                        .chars()
                        .any(|c| c == '/' || c == ':' || c == '\0' || c.is_whitespace());
                if valid {
                    Ok(BusSpec::SocketCan(iface))
                } else {
                    Err(bad(
                        "not a network interface name (1 to 15 bytes, no '/', ':' or spaces)",
                    ))
                }
            }
            _ => Err(bad(
                "expected `slcan:/dev/ttyXXX` or `socketcan:IFACE` (e.g. socketcan:can0)",
            )),
        }
    }
}

/// Opens a bus from a spec `slcan:PATH` or `socketcan:IFACE` ([`BusSpec::parse`]).
pub fn open(spec: &str) -> Result<Box<dyn Transport>, TransportError> {
    match BusSpec::parse(spec)? {
        BusSpec::Slcan(path) => Ok(Box::new(slcan::SlcanTransport::open(
            path,
            slcan::DEFAULT_BITRATE,
        )?)),
        #[cfg(all(feature = "socketcan", target_os = "linux"))]
        BusSpec::SocketCan(iface) => Ok(Box::new(SocketCanTransport::open(iface)?)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bus_specs_a_live_run_could_never_open_are_refused() {
        assert_eq!(
            BusSpec::parse("slcan:/dev/ttyACM0").unwrap(),
            BusSpec::Slcan("/dev/ttyACM0")
        );
        for bad in [
            "mock",
            "slcan:",
            "slcan:a\0b",
            "can0",
            "tcp:host",
            "socketcan:",
        ] {
            let e = BusSpec::parse(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("cannot open CAN bus {bad}:")), "{e}");
        }
        #[cfg(all(feature = "socketcan", target_os = "linux"))]
        {
            assert_eq!(
                BusSpec::parse("socketcan:can0").unwrap(),
                BusSpec::SocketCan("can0")
            );
            for bad in [
                "socketcan:a/b",
                "socketcan:..",
                "socketcan:can 0",
                "socketcan:abcdefghijklmnop",
            ] {
                assert!(BusSpec::parse(bad).is_err(), "{bad}");
            }
        }
    }
}
