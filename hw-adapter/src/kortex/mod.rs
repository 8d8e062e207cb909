//! Kinova Gen3 arms over Ethernet with Kinova's Kortex protocol (API 2.6): the messages
//! ([`proto`], compiled from `hw-adapter/proto`), their framing ([`header`], [`codec`]), one
//! link with its session ([`channel`]), and the arm as the executor drives it ([`KortexArm`]).
//!
//! `--arm NAME=kortex:HOST` reaches the arm at HOST on TCP 10000 and UDP 10001;
//! `kortex:HOST:TCP_PORT:UDP_PORT` names other ports (the tests' mocks).

pub mod arm;
pub mod channel;
pub mod codec;
pub mod header;
pub mod proto;

pub use arm::KortexArm;

use std::fmt;
use std::net::{SocketAddr, ToSocketAddrs};

/// The Gen3's TCP port (configuration rpcs).
pub const DEFAULT_TCP_PORT: u16 = 10000;
/// The Gen3's UDP port (the cyclic rpcs).
pub const DEFAULT_UDP_PORT: u16 = 10001;
/// Environment variable read for the user name when no option gives it.
pub const USER_ENV: &str = "OMCBSA_KORTEX_USER";
/// Environment variable read for the password when no option gives it.
pub const PASSWORD_ENV: &str = "OMCBSA_KORTEX_PASSWORD";

/// `kortex:HOST[:TCP_PORT:UDP_PORT]`, checked.
///
/// ```
/// use omcbsa_hw::kortex::KortexSpec;
///
/// let s = KortexSpec::parse("kortex:192.168.1.10")?;
/// assert_eq!((s.host.as_str(), s.tcp_port, s.udp_port), ("192.168.1.10", 10000, 10001));
/// let e = KortexSpec::parse("kortex:host:4000").unwrap_err();
/// assert!(e.contains("give both ports or neither"));
/// # Ok::<(), String>(())
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KortexSpec {
    /// Host name or address (IPv6 in brackets in the spec).
    pub host: String,
    /// TCP port (configuration).
    pub tcp_port: u16,
    /// UDP port (cyclic).
    pub udp_port: u16,
}

impl KortexSpec {
    /// Parses a spec; the error names the spec and what is wrong with it.
    pub fn parse(spec: &str) -> Result<Self, String> {
        let bad = |why: &str| {
            format!("cannot reach arm {spec}: {why} (expected kortex:HOST or kortex:HOST:TCP_PORT:UDP_PORT)")
        };
        let rest = spec
            .strip_prefix("kortex:")
            .ok_or_else(|| bad("not a kortex spec"))?;
        // An IPv6 address is written in brackets: kortex:[fe80::1]:10000:10001.
        let (host, ports) = match rest.strip_prefix('[') {
            Some(r) => {
                let (h, p) = r.split_once(']').ok_or_else(|| bad("a '[' without ']'"))?;
                (h, p.strip_prefix(':'))
            }
            None => match rest.split_once(':') {
                Some((h, p)) => (h, Some(p)),
                None => (rest, None),
            },
        };
        if host.is_empty() || host.chars().any(|c| c.is_whitespace() || c == '\0') {
            return Err(bad("the host is empty or contains spaces"));
        }
        let (tcp_port, udp_port) = match ports {
            None | Some("") if !rest.ends_with(':') => (DEFAULT_TCP_PORT, DEFAULT_UDP_PORT),
            Some(p) => {
                let port = |s: &str, which: &str| {
                    s.parse::<u16>().ok().filter(|&p| p != 0).ok_or_else(|| {
                        bad(&format!(
                            "{which} port {s:?} is not a number from 1 to 65535"
                        ))
                    })
                };
                match p.split_once(':') {
                    Some((t, u)) => (port(t, "the TCP")?, port(u, "the UDP")?),
                    None => return Err(bad("give both ports or neither")),
                }
            }
            None => return Err(bad("give both ports or neither")),
        };
        Ok(Self {
            host: host.to_string(),
            tcp_port,
            udp_port,
        })
    }

    fn resolve(&self, port: u16) -> Result<SocketAddr, String> {
        (self.host.as_str(), port)
            .to_socket_addrs()
            .map_err(|e| format!("cannot resolve {}: {e}", self.host))?
            .next()
            .ok_or_else(|| format!("{} has no address", self.host))
    }
}

impl fmt::Display for KortexSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "kortex:{}:{}:{}",
            self.host, self.tcp_port, self.udp_port
        )
    }
}

/// The user and password of a Kortex session. Never printed: `Debug` withholds the password.
#[derive(Clone, PartialEq, Eq)]
pub struct Credentials {
    /// The user name.
    pub username: String,
    /// The password (never logged).
    pub password: String,
}

impl fmt::Debug for Credentials {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Credentials {{ username: {:?}, password: <withheld> }}",
            self.username
        )
    }
}

impl Credentials {
    /// The credentials from the options given (`None`: not given), else from
    /// [`USER_ENV`] / [`PASSWORD_ENV`]; `lookup` reads the environment.
    pub fn resolve(
        username: Option<String>,
        password: Option<String>,
        lookup: impl Fn(&str) -> Option<String>,
    ) -> Result<Self, String> {
        let username = username
            .or_else(|| lookup(USER_ENV))
            .filter(|u| !u.is_empty());
        let password = password.or_else(|| lookup(PASSWORD_ENV));
        match (username, password) {
            (Some(username), Some(password)) => Ok(Self { username, password }),
            (None, _) => Err(format!(
                "no Kortex user name: give --kortex-user or set {USER_ENV}"
            )),
            (_, None) => Err(format!(
                "no Kortex password: give --kortex-password-file or set {PASSWORD_ENV}"
            )),
        }
    }
}

/// An arm's two links, open but without sessions yet ([`KortexArm`] creates them at start-up).
pub struct Connection {
    /// Where the arm is.
    pub spec: KortexSpec,
    /// The TCP link (configuration rpcs).
    pub tcp: channel::Channel,
    /// The UDP link (the cyclic rpcs).
    pub udp: channel::Channel,
    /// Who the sessions log in as.
    pub credentials: Credentials,
}

impl Connection {
    /// Connects TCP and opens the UDP socket (no frame is sent); the error names the arm.
    pub fn open(spec: &KortexSpec, credentials: &Credentials) -> Result<Self, String> {
        let fail = |e: String| format!("cannot reach arm {spec}: {e}");
        let tcp =
            channel::Channel::tcp(spec.resolve(spec.tcp_port).map_err(fail)?).map_err(fail)?;
        let udp =
            channel::Channel::udp(spec.resolve(spec.udp_port).map_err(fail)?).map_err(fail)?;
        Ok(Self {
            spec: spec.clone(),
            tcp,
            udp,
            credentials: credentials.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_default_to_ports_10000_and_10001_and_bad_ones_are_refused() {
        let s = KortexSpec::parse("kortex:192.168.1.10").unwrap();
        assert_eq!(
            (s.host.as_str(), s.tcp_port, s.udp_port),
            ("192.168.1.10", 10000, 10001)
        );
        let s = KortexSpec::parse("kortex:127.0.0.1:4000:4001").unwrap();
        assert_eq!((s.tcp_port, s.udp_port), (4000, 4001));
        let s = KortexSpec::parse("kortex:[::1]:4000:4001").unwrap();
        assert_eq!((s.host.as_str(), s.tcp_port), ("::1", 4000));
        for bad in [
            "kortex:",
            "kortex:host:4000",
            "kortex:host:0:1",
            "kortex:host:x:1",
            "kortex:host:",
            "kortex:ho st",
            "kortex:[::1",
        ] {
            let e = KortexSpec::parse(bad).unwrap_err();
            assert!(e.starts_with(&format!("cannot reach arm {bad}:")), "{e}");
        }
    }

    #[test]
    fn credentials_come_from_options_else_the_environment_and_the_password_is_never_shown() {
        let env = |k: &str| match k {
            USER_ENV => Some("operator".to_string()),
            PASSWORD_ENV => Some("s3cret".to_string()),
            _ => None,
        };
        let c = Credentials::resolve(None, None, env).unwrap();
        assert_eq!(
            (c.username.as_str(), c.password.as_str()),
            ("operator", "s3cret")
        );
        let c = Credentials::resolve(Some("admin".into()), Some("pw".into()), env).unwrap();
        assert_eq!((c.username.as_str(), c.password.as_str()), ("admin", "pw"));
        assert!(!format!("{c:?}").contains("pw\""));
        let none = |_: &str| None;
        let e = Credentials::resolve(None, Some("x".into()), none).unwrap_err();
        assert!(e.contains(USER_ENV), "{e}");
        let e = Credentials::resolve(Some("a".into()), None, none).unwrap_err();
        assert!(e.contains(PASSWORD_ENV), "{e}");
    }
}
